"""Controllers and the master loop on a plant whose sampled response is known exactly.

The toy plant (conftest) is a double integrator per joint integrated in closed form
with the effort held over each step, so the master + the core's controller laws must
reproduce python-control's zero-order-hold closed loop to round-off: this pins the
sampling, the hold, the sign conventions and the laws (PD, PD + gravity, computed torque)
against python-control and closed forms written here.
"""
import control
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.errors import InputError
from cosim.master import MasterError, make_reference, run


def _forced(sys, t, u, x0):
    return control.forced_response(sys, T=t, U=u, X0=x0).outputs


def test_pd_run_equals_python_control_sampled_loop(toy):
    j, mass, load, m, plant = toy
    kp, kd, dt = (40.0, 25.0)[j], (6.0, 3.0)[j], 2e-3
    x0, x1 = (0.01, -0.02)[j], (0.03, 0.0)[j]
    ref = make_reference(m, tr.step([x0], [x1], t_step=0.1), step=dt, duration=1.0)
    res = run(plant, ctl.pd(ndof=1, kp=kp, kd=kd), ref)
    cl = ctl.closed_loop(mass, kp, kd, dt)
    u = np.vstack([ref.q[:, 0], np.full(len(ref.time), load)])
    y = _forced(cl, ref.time, u, [x0, 0.0])
    np.testing.assert_allclose(res["q"][:, 0], y[0], rtol=0, atol=1e-13)
    np.testing.assert_allclose(res["qref"][:, 0] - res["q"][:, 0], y[1], rtol=0, atol=1e-13)


def test_pd_settles_at_predicted_error_and_pdg_removes_it(toy):
    j, mass, load, m, plant = toy
    kp, kd, dt = 50.0, 8.0, 1e-3
    ref = make_reference(m, tr.step([0.0], [0.01]), step=dt, duration=3.0)
    res = run(plant, ctl.pd(ndof=1, kp=kp, kd=kd), ref, x0=[0.0])
    assert abs(res["q"][-1, 0] - res["q"][0, 0]) > 0.009   # it did move
    e_sim = res["qref"][-1] - res["q"][-1]
    np.testing.assert_allclose(e_sim, [load / kp], rtol=1e-6)   # independent: g / kp by hand
    np.testing.assert_allclose(ctl.predicted_steady_state_error(m, ref.x[-1], kp), [load / kp], rtol=1e-12)
    assert ctl.analyse_pd(mass=mass, kp=kp, kd=kd, dt=dt)["gravity_compliance"] == pytest.approx(1 / kp, rel=1e-9)
    res = run(plant, ctl.pd_gravity(m, kp=kp, kd=kd), ref, x0=[0.0])
    assert np.max(np.abs(res["qref"][-1] - res["q"][-1])) < 1e-9


def test_computed_torque_cancels_mass_and_gravity(toy):
    """With an exact model each joint error follows the unit-mass loop, whatever M and g."""
    j, mass, load, m, plant = toy
    kp, kd, dt = 400.0, 40.0, 1e-3
    ref = make_reference(m, tr.step([0.0], [(0.02, -0.01)[j]]), step=dt, duration=0.5)
    res = run(plant, ctl.computed_torque(m, kp=kp, kd=kd), ref, x0=[0.0])
    cl = ctl.closed_loop(1.0, kp, kd, dt)
    y = _forced(cl, ref.time, np.vstack([ref.q[:, 0], np.zeros(len(ref.time))]), [0.0, 0.0])
    np.testing.assert_allclose(res["q"][:, 0], y[0], atol=1e-13)


def test_computed_torque_tracks_a_blend_with_small_error(toy):
    j, mass, load, m, plant = toy
    traj = tr.waypoints([[0.0], [(0.02, 0.01)[j]], [(0.0, 0.03)[j]]], move_time=0.3, hold_time=0.1)
    ref = make_reference(m, traj, step=1e-3, duration=traj.duration)
    res = run(plant, ctl.computed_torque(m, kp=(2 * np.pi * 20) ** 2, kd=2 * 2 * np.pi * 20), ref)
    err = np.abs(res["qref"] - res["q"]).max()
    # The held effort lags the feed-forward by half a step: error ~ jerk h / (2 wn^2), well below 1e-5 m.
    assert 0 < err < 2e-6
    # without feedback the hold alone would leave a larger drift
    res_ff = run(plant, ctl.computed_torque(m, kp=0.0, kd=0.0), ref)
    assert np.abs(res_ff["qref"] - res_ff["q"]).max() > 3 * err


def test_design_places_the_continuous_poles():
    d = ctl.design_pd(mass=0.3, bandwidth_hz=5.0, damping=0.7, dt=None)
    wn = 2 * np.pi * 5.0
    assert d.kp == pytest.approx(0.3 * wn**2) and d.kd == pytest.approx(2 * 0.7 * wn * 0.3)
    want = np.roots([1, 2 * 0.7 * wn, wn**2])
    np.testing.assert_allclose(np.sort_complex(d.poles), np.sort_complex(want), rtol=1e-9)
    # 0.7 damping: overshoot exp(-pi z / sqrt(1 - z^2)) = 4.6 %
    assert d.step_info["Overshoot"] == pytest.approx(100 * np.exp(-np.pi * 0.7 / np.sqrt(1 - 0.49)), rel=2e-2)
    ds = ctl.design_pd(mass=0.3, bandwidth_hz=5.0, damping=0.7, dt=1e-3)
    assert ds.stable and np.all(np.abs(ds.poles) < 1)
    assert ds.step_info["RiseTime"] == pytest.approx(d.step_info["RiseTime"], rel=0.03)
    # far too slow a sampling for that bandwidth: python-control says unstable
    assert not ctl.design_pd(mass=0.3, bandwidth_hz=200.0, damping=0.7, dt=5e-3).stable


def test_step_metrics_of_a_first_order_response():
    tau, dt = 0.05, 1e-4
    t = np.arange(0, 1.0, dt)
    y = 2.0 + 0.3 * (1 - np.exp(-t / tau))
    info = ctl.step_metrics(t, y, y0=2.0, yfinal=2.3)
    assert info["RiseTime"] == pytest.approx(tau * np.log(9), abs=2 * dt)
    assert info["SettlingTime"] == pytest.approx(tau * np.log(50), abs=2 * dt)
    assert info["Overshoot"] == 0 and info["Amplitude"] == pytest.approx(0.3)
    with pytest.raises(ctl.ControllerError, match="zero amplitude"):
        ctl.step_metrics(t, np.ones_like(t))


def test_saturation_clips_and_counts(toy):
    j, mass, load, m, plant = toy
    ref = make_reference(m, tr.step([0.0], [0.5]), step=1e-3, duration=0.2)
    limit = (3.0, 2.0)[j]
    c = ctl.pd(ndof=1, kp=1000.0, kd=10.0, saturation=limit)
    res = run(plant, c, ref, x0=[0.0])
    assert np.all(np.abs(res["tau_applied"]) <= limit)
    np.testing.assert_allclose(res["tau_applied"][0], [limit])
    # clipped while kp e + kd ed > limit: counted against the samples that exceed it, recomputed here
    raw = 1000.0 * (res["qref"][:, 0] - res["q"][:, 0]) + 10.0 * (res["qdref"][:, 0] - res["qd"][:, 0])
    assert res.saturated == np.count_nonzero(np.abs(raw) > limit) > 10
    assert c.describe()["saturation"] == limit


def test_bad_gains_and_measurements_are_named(make_axis):
    with pytest.raises(ctl.ControllerError, match="kp of joint 2 is negative"):
        ctl.pd(ndof=3, kp=[1.0, -2.0, 1.0], kd=1.0)
    with pytest.raises(ctl.ControllerError, match="kd has 2 entries, expected 3"):
        ctl.pd(ndof=3, kp=1.0, kd=[1.0, 2.0])
    with pytest.raises(ctl.ControllerError, match="saturation of joint 1"):
        ctl.pd(ndof=2, kp=1.0, kd=1.0, saturation=0.0)
    ref = ctl.Reference(np.zeros(1), np.zeros(1), np.zeros(1))
    with pytest.raises(ctl.ControllerError, match="runs on a model"):
        ctl.pd(ndof=1, kp=1.0, kd=1.0)(0.25, np.array([0.0]), np.zeros(1), ref)
    c = ctl.pd(ndof=1, kp=1.0, kd=1.0, model=make_axis(0.5, 1.5))
    with pytest.raises(InputError, match=r"pd at t = 0.25 s: q of joint 1 is nan"):
        c(0.25, np.array([np.nan]), np.zeros(1), ref)
    with pytest.raises(InputError, match=r"pd at t = 0.25 s: qd has shape \(2,\), expected \(1,\)"):
        c(0.25, np.zeros(1), np.zeros(2), ref)
    with pytest.raises(ctl.ControllerError, match="exactly one of"):
        ctl.design_pd(mass=1.0, damping=1.0)


def test_master_failure_names_time_and_keeps_samples(failing_toy_plant):
    m = failing_toy_plant.model
    ref = make_reference(m, tr.step([0.0], [0.01]), step=1e-3, duration=0.2)
    with pytest.raises(MasterError, match=r"stopped in the step from t = 0.05 s to 0.051 s: toy plant: leg 1") as e:
        run(failing_toy_plant, ctl.pd(ndof=1, kp=10.0, kd=1.0), ref, x0=[0.0])
    assert len(e.value.partial) == 50
    with pytest.raises(MasterError, match="not a whole number of steps"):
        make_reference(m, tr.step([0.0], [0.01]), step=1e-3, duration=0.2005)


def test_sensor_and_tracker_noise(toy):
    j, mass, load, m, plant = toy
    ref = make_reference(m, tr.step([0.0], [0.0]), step=1e-3, duration=2.0)
    kw = dict(q_noise=1e-5, pose_noise=2e-5, seed=3)
    res = run(plant, ctl.pd_gravity(m, kp=100.0, kd=10.0), ref, **kw)
    assert np.std(res["q"][:, 0] - res["q_true"][:, 0]) == pytest.approx(1e-5, rel=0.1)
    assert np.std(res["pose"][:, 0] - res["x"][:, 0]) == pytest.approx(2e-5, rel=0.1)
    again = run(plant, ctl.pd_gravity(m, kp=100.0, kd=10.0), ref, **kw)
    np.testing.assert_array_equal(again["q"], res["q"])
    quiet = run(plant, ctl.pd_gravity(m, kp=100.0, kd=10.0), ref, q_noise=1e-5, seed=3)
    np.testing.assert_array_equal(quiet["pose"], quiet["x"])
    with pytest.raises(MasterError, match="pose_noise must be standard deviations >= 0"):
        run(plant, ctl.pd(ndof=1, kp=1.0, kd=1.0), ref, pose_noise=-1.0)
