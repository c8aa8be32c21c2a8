"""The closed loop (cosim.closed_loop.ClosedLoop) against expectations computed here from
its definition: the readings' delay, the actuator delay under a compliance, the noise
draws, running in pieces and stopping; and its two back ends (the core's compiled loop,
the stepwise loop) on the same runs and failures."""
import numpy as np
import pytest

import cosim.closed_loop as cl
from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.closed_loop import ClosedLoop
from cosim.core import Model
from cosim.master import CoreDrive, CorePlant, MasterError, make_reference, run

H = 1e-3


def _reference(m, dz, duration=0.6):
    h = m.home()
    d = np.zeros(m.ndof)
    d[2] = dz
    return make_reference(m, tr.waypoints([h, h + d, h], move_time=0.25), step=H, duration=duration)


def _both(m, ref, **kw):
    """The same run on both back ends: {compiled: record, stepwise: record}."""
    out = {}
    for compiled in (True, False):
        c = ctl.pd_gravity(m, kp=300.0, kd=30.0)
        rec = ClosedLoop(CorePlant(m), c, drive=CoreDrive(m), compiled=compiled, **kw).run(ref)
        assert rec.loop == ("compiled" if compiled else "python")
        assert np.ptp(rec.x[:, 2]) > 0.004  # it moved
        out[compiled] = rec
    return out


def test_readings_are_the_joints_of_whole_samples_earlier_plus_the_encoder_offset():
    # sensor.delay = 3 samples: q[k] = q_true[k - 3] + offset (q_true[0] before), qd likewise
    m = Model("6pus", params={"sensor.delay": 3 * H, "rail[2].encoder_offset": 1e-4})
    offset = np.array([0, 1e-4, 0, 0, 0, 0])
    for rec in _both(m, _reference(m, 0.008)).values():
        past = np.vstack([np.repeat(rec.q_true[:1], 3, axis=0), rec.q_true[:-3]])
        np.testing.assert_allclose(rec.q, past + offset, rtol=0, atol=1e-15)
        past_d = np.vstack([np.repeat(rec.qd_true[:1], 3, axis=0), rec.qd_true[:-3]])
        np.testing.assert_allclose(rec.qd, past_d, rtol=0, atol=1e-15)


def test_a_fractional_sensor_delay_interpolates_between_the_samples_around_it():
    m = Model("6pus", params={"sensor.delay": 2.5 * H})
    for rec in _both(m, _reference(m, 0.008)).values():
        k = np.arange(3, len(rec.time))
        np.testing.assert_allclose(rec.q[k], 0.5 * (rec.q_true[k - 3] + rec.q_true[k - 2]), rtol=0, atol=1e-15)


@pytest.mark.parametrize("delay_samples", [0, 3])
def test_the_compliance_reads_under_the_effort_the_core_applies_after_the_actuator_delay(delay_samples):
    # No friction, no rotor inertia: the transmission carries the applied effort, so the
    # reading of rail 3 is q + compliance tau_acting.  tau_acting at sample k is the command
    # of sample k - 1 without delay, of sample k - d with a delay of d samples (zero before).
    c3 = 1e-4
    m = Model("6pus", params={"rail[3].compliance": c3, "actuator.delay": delay_samples * H})
    for rec in _both(m, _reference(m, 0.008)).values():
        lag = max(delay_samples, 1)
        acting = np.vstack([np.zeros((lag, 6)), rec.tau_applied[:-lag]])
        np.testing.assert_allclose(rec.q[:, 2] - rec.q_true[:, 2], c3 * acting[:, 2], rtol=1e-12, atol=1e-16)
        other = np.vstack([np.zeros((lag + 1, 6)), rec.tau_applied[:-lag - 1]])  # one sample off: a different answer
        assert np.max(np.abs(c3 * (other[:, 2] - acting[:, 2]))) > 1e-8


def test_the_noise_is_drawn_once_in_the_order_q_qd_tau_pose():
    m = Model("6pus", params={"rail[2].encoder_offset": 1e-4})
    sig = {"q": 1e-6, "qd": 1e-5, "tau": 0.01, "pose": 2e-6}
    offset = np.array([0, 1e-4, 0, 0, 0, 0])
    for rec in _both(m, _reference(m, 0.008), noise=sig, seed=11).values():
        z = np.random.default_rng(11).normal(size=(len(rec.time), 24))
        np.testing.assert_allclose(rec.q - rec.q_true - offset, sig["q"] * z[:, 0:6], rtol=0, atol=1e-16)
        np.testing.assert_allclose(rec.qd - rec.qd_true, sig["qd"] * z[:, 6:12], rtol=0, atol=1e-15)
        np.testing.assert_allclose(rec.tau_logged - rec.tau_cmd, sig["tau"] * z[:, 12:18], rtol=0, atol=1e-13)
        np.testing.assert_allclose(rec.pose - rec.x, sig["pose"] * z[:, 18:24], rtol=0, atol=1e-16)


def test_the_compiled_loop_goes_on_exactly_in_pieces_and_stops_when_asked(monkeypatch):
    m = Model("6pus", params={"rail[2].encoder_offset": 1e-4, "rail[4].compliance": 1e-5,
                              "actuator.delay": 2 * H, "sensor.delay": 1.5 * H})
    ref = _reference(m, 0.008, duration=1.0)

    def go(**kw):
        return ClosedLoop(CorePlant(m), ctl.pd_gravity(m, kp=300.0, kd=30.0), drive=CoreDrive(m),
                          noise={"q": 1e-6}, seed=2).run(ref, **kw)

    monkeypatch.setattr(cl, "PIECE_SECONDS", 1e3)
    whole = go()
    monkeypatch.setattr(cl, "PIECE_SECONDS", 1e-9)  # pieces of 16 samples
    seen = []
    pieces = go(progress=seen.append)
    assert len(seen) > 50 and whole.n == pieces.n == len(ref.time)
    for f in ("q", "qd", "x", "xd", "tau_cmd", "tau_applied"):
        np.testing.assert_array_equal(getattr(pieces, f), getattr(whole, f), err_msg=f)
    asked = []
    stopped = go(should_stop=lambda: asked.append(1) or len(asked) == 3)
    assert stopped.stopped and stopped.n == 64 + 2 * 16
    np.testing.assert_array_equal(stopped.x, whole.x[:stopped.n])


@pytest.mark.parametrize("robot,dz", [("6pus", 0.01), ("quattro", -0.02)])
def test_the_two_back_ends_give_the_same_samples(robot, dz):
    m = Model(robot)
    ref = _reference(m, dz)
    kp = 300.0 if robot == "6pus" else 200.0
    for c in (ctl.pd(ndof=m.ndof, kp=kp, kd=30.0, joint="m" if robot == "6pus" else "rad", saturation=25.0),
              ctl.pd_gravity(m, kp=kp, kd=30.0, gravity="reference"), ctl.computed_torque(m, kp=400.0, kd=40.0)):
        kw = dict(q_noise=2e-6, qd_noise=2e-6, pose_noise=2e-6, seed=3, drive=CoreDrive(m))
        slow = run(CorePlant(m), c, ref, compiled=False, **kw)
        fast = run(CorePlant(m), c, ref, **kw)
        assert slow.loop == "python" and fast.loop == "compiled", (slow.loop_note, fast.loop_note)
        for f in ("x", "xd", "q", "qd", "q_true", "tau_cmd", "tau_applied", "pose"):
            np.testing.assert_allclose(fast[f], slow[f], rtol=0, atol=1e-12, err_msg=f"{robot} {c.kind} {f}")
        assert fast.saturated == slow.saturated
        assert np.ptp(fast["x"][:, 2]) > 0.5 * abs(dz)


def test_a_python_callable_runs_stepwise_and_says_why():
    m = Model("6pus")
    ref = _reference(m, 0.005, duration=0.05)
    g = ctl.pd_gravity(m, kp=300.0, kd=30.0)
    res = run(CorePlant(m), lambda t, q, qd, r: g(t, q, qd, r), ref)
    assert res.loop == "python" and "Python callable" in res.loop_note
    with pytest.raises(MasterError, match="cannot run compiled"):
        run(CorePlant(m), lambda t, q, qd, r: g(t, q, qd, r), ref, compiled=True)


def test_a_failure_stops_both_back_ends_at_the_same_sample_with_the_same_rows():
    # a PD far too weak to hold the platform: it falls until the sim stops it
    m = Model("6pus")
    ref = _reference(m, 0.0, duration=1.0)
    errs = {}
    for compiled in (False, None):
        with pytest.raises(MasterError) as ei:
            run(CorePlant(m), ctl.pd(ndof=6, kp=1.0, kd=0.1), ref, compiled=compiled)
        errs[compiled] = ei.value
    slow, fast = errs[False], errs[None]
    assert fast.partial.loop == "compiled"
    assert len(fast.partial) == len(slow.partial) > 10
    np.testing.assert_allclose(fast.partial["x"], slow.partial["x"], rtol=0, atol=1e-14)
    assert str(fast).split(":")[0] == str(slow).split(":")[0]
    assert "singularity" in str(fast) and "singularity" in str(slow)



def test_a_run_after_its_history_starts_where_the_whole_run_was_on_both_back_ends():
    """history: a PID controller (integral, filtered derivative) fed the readings of the
    samples before ``start`` continues as in the run that went through them: from the whole
    run's state at ``start``, its efforts are the whole run's (both back ends); started at
    rest they are not."""
    m = Model("6pus")
    ref = _reference(m, 0.01)

    def pid():
        return ctl.pid(m, kp=300.0, ki=200.0, kd=30.0, dt=H, deriv_filter=0.002)

    whole = ClosedLoop(CorePlant(m), pid(), drive=CoreDrive(m)).run(ref)
    k0 = 200
    for compiled in (True, False):
        part = ClosedLoop(CorePlant(m), pid(), drive=CoreDrive(m), compiled=compiled).run(
            ref, start=k0, x0=whole.x[k0], xd0=whole.xd[k0], history=(whole.q[:k0], whole.qd[:k0]))
        np.testing.assert_allclose(part.tau_applied[:50], whole.tau_applied[k0:k0 + 50], atol=1e-6 * np.abs(whole.tau_applied).max())
    cold = ClosedLoop(CorePlant(m), pid(), drive=CoreDrive(m)).run(ref, start=k0, x0=whole.x[k0], xd0=whole.xd[k0])
    assert np.abs(cold.tau_applied[0] - whole.tau_applied[k0]).max() > 1e-3 * np.abs(whole.tau_applied).max()
    with pytest.raises(ValueError, match="history"):
        ClosedLoop(CorePlant(m), pid(), drive=CoreDrive(m)).run(ref, start=k0, history=(whole.q[:k0 + 1],
                                                                                        whole.qd[:k0 + 1]))
