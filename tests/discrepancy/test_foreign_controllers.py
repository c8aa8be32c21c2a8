"""Recordings made under a PID (integral, filtered derivative, output limits) or a
discrete LTI controller from python-control: the sidecar describes them, the engine
rebuilds them and replays the held-out part in closed loop."""
import control
import numpy as np
import pytest

from cosim import controllers as ctl, trajectories as tr
from cosim.core import Model
from cosim.discrepancy import diagnose
from cosim.discrepancy.runs import controller_from
from cosim.master import CorePlant, make_reference, run
from cosim.recording import write_recording
from cosim.ssp import lti_controller

DT = 1e-3


def _record(tmp_path, controller, name):
    m = Model("6pus")
    x0 = m.home()
    rng = np.random.default_rng(7)
    poses = x0 + rng.uniform(-1, 1, (10, 6)) * [0.004, 0.004, 0.004, 0.03, 0.03, 0.03]
    traj = tr.pose_set(poses, move_time=0.3, hold_time=0.1)
    ref = make_reference(m, traj, duration=float(traj.times[-1]) + 0.2, step=DT)
    res = run(CorePlant(m), controller, ref)
    csv, _ = write_recording(tmp_path / f"{name}.csv", res.to_recording())
    return csv, res


def _pid(m):
    return ctl.pid(m, kp=3000, ki=6000, kd=40, dt=DT, deriv_filter=2e-3, saturation=200, gravity_feedforward=True)


def _lti(m):
    s = control.tf("s")
    c = control.c2d(control.ss(3000 + 40 * s / (1 + 2e-3 * s) + 6000 / s), DT)
    return lti_controller(c, ndof=m.ndof, model=m, gravity_feedforward=True, saturation=200)


@pytest.mark.parametrize("make", [_pid, _lti], ids=["pid", "lti"])
def test_the_sidecar_controller_is_rebuilt_and_replayed(tmp_path, make):
    m = Model("6pus")
    csv, res = _record(tmp_path, make(m), make.__name__)
    assert res.controller["type"] in ("pid", "lti")
    rebuilt, why = controller_from(res.controller, m)
    assert rebuilt is not None, why
    assert rebuilt.describe() == res.controller  # every gain, filter, limit and flag carried over
    d = diagnose(csv, figures=False, replay=True)
    assert "skipped" not in d.replay, d.replay
    nominal = d.replay["runs"]["nominal"]
    assert "error" not in nominal, nominal
    # The recorded motion is the nominal plant under this controller: the replay follows
    # it (1e-4 of the stroke here; the integral starts from zero at the replay's start).
    stroke = np.ptp(res["q"], axis=0)
    assert np.all(np.asarray(nominal["rms_q"]) < 1e-3 * stroke), (nominal["rms_q"], stroke)


def test_a_bad_description_says_what_is_missing():
    m = Model("6pus")
    c, why = controller_from({"type": "pid", "kp": 1, "kd": 1}, m)
    assert c is None and "ki" in why
    c, why = controller_from({"type": "lti", "dt": DT, "A": [[1]], "B": [[1, 0]], "C": [[1]], "D": [[0]]}, m)
    assert c is None and "shapes" in why
