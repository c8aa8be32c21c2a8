"""A measured external force per joint (Recording.f_ext) is a known input: the plant adds it
to the actuator effort in both back ends of the closed loop, the replay passes it, and the
effort residual accounts for it instead of leaving it for the engine to explain."""
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.core import Model
from cosim.discrepancy.runs import closed_loop
from cosim.discrepancy.residuals import Pipeline
from cosim.master import CoreDrive, CorePlant, make_reference, run

H = 1e-3


def _reference(m, duration=2.0):
    h = m.home()
    d = np.zeros(6)
    d[0], d[2] = 0.004, 0.006
    return make_reference(m, tr.waypoints([h, h + d, h - d, h], move_time=0.4), step=H, duration=duration)


def _force(t):
    """A known force: a 3 N pulse on joint 1 from 0.5 s to 1.2 s, a 1.5 N sine on joint 3 [N]."""
    f = np.zeros((len(t), 6))
    f[(t >= 0.5) & (t < 1.2), 0] = 3.0
    f[:, 2] = 1.5 * np.sin(2 * np.pi * 2.0 * t)
    return f


@pytest.mark.parametrize("compiled", [True, False])
def test_the_force_acts_like_that_much_more_command(compiled):
    # Without saturation, dead zone or delay, f_ext is the same as adding it to the command.
    m = Model("6pus")
    ref = _reference(m, 1.0)
    f = _force(ref.time)
    g = ctl.pd_gravity(m, kp=300.0, kd=30.0)
    a = run(CorePlant(m), ctl.pd_gravity(m, kp=300.0, kd=30.0), ref, f_ext=f, compiled=compiled)
    pushed = iter(f)
    b = run(CorePlant(m), lambda t, q, qd, r: g(t, q, qd, r) + next(pushed), ref)
    assert a.loop == ("compiled" if compiled else "python")
    np.testing.assert_allclose(a["x"], b["x"], rtol=0, atol=1e-12)
    c = run(CorePlant(m), ctl.pd_gravity(m, kp=300.0, kd=30.0), ref)
    assert np.max(np.abs(c["x"] - a["x"])) > 1e-4  # the force moved it


def _recording(m, plant, ref, f, k0=500):
    ctrl = ctl.pd_gravity(m, kp=300.0, kd=30.0)
    res = closed_loop(plant, ctrl, ref, f_ext=f)
    rec = res.to_recording(effort="logged", start=k0, qref=ref.q, controller=ctrl.describe())
    rec.f_ext = f[k0:]
    return rec, res


def test_the_replay_reproduces_a_recording_with_a_known_force_only_with_it():
    m = Model("6pus")
    plant = m.copy()
    plant.set_params({"actuator.delay": 2e-3, "rail[2].compliance": 5e-5})  # it must not delay the force
    ref = _reference(m)
    f = _force(ref.time)
    _, res = _recording(m, plant, ref, f)
    replay = closed_loop(plant, ctl.pd_gravity(m, kp=300.0, kd=30.0), ref, f_ext=f)
    blind = closed_loop(plant, ctl.pd_gravity(m, kp=300.0, kd=30.0), ref)
    assert np.max(np.abs(replay.x - res.x)) < 1e-12
    assert np.max(np.abs(blind.x - res.x)) > 1e-4
    np.testing.assert_allclose(replay.tau_logged, res.tau_logged, rtol=0, atol=1e-9)


def test_the_effort_residual_accounts_for_the_force():
    # The plant is the model (no hidden effect): with f_ext the residual is only smoothing
    # and differentiation error; without it the residual is the force itself.
    m = Model("6pus")
    ref = _reference(m)
    f = _force(ref.time)
    rec, _ = _recording(m, m.copy(), ref, f)
    known = Pipeline(rec, m).evaluate().eff
    rec.f_ext = None
    missing = Pipeline(rec, m).evaluate().eff
    pos = Pipeline(rec, m).idx
    rms = np.sqrt(np.mean(known ** 2, axis=0))
    assert np.all(rms < 0.03), rms
    # without it the residual is minus the (smoothed) force on joints 1 and 3
    np.testing.assert_allclose(missing[:, 2], -1.5 * np.sin(2 * np.pi * 2.0 * rec.time[pos]), rtol=0, atol=0.05)
    assert np.sqrt(np.mean(missing[:, 0] ** 2)) > 1.0
