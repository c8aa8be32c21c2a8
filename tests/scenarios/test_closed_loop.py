"""The compiled closed loop (pkm_closed_loop) against the Python master loop, sample by sample.

Both loops step the same core plant with the same controller law; the compiled one
runs inside the core.  They must give the same samples (to the rounding of the
controller's arithmetic), the same noise, the same errors and partial results."""
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.core import Model
from cosim.master import CoreDrive, CorePlant, MasterError, make_reference, run

FIELDS = ("x", "xd", "q", "qd", "q_true", "tau_cmd", "tau", "x_meas")


def _reference(m, dz, duration=0.6):
    h = m.home()
    d = np.zeros(m.ndof)
    d[2] = dz
    return make_reference(m, tr.waypoints([h, h + d], move_time=0.3), duration=duration)


def _controllers(m, robot):
    joint = "m" if robot == "6pus" else "rad"
    kp = 300.0 if robot == "6pus" else 200.0
    return [ctl.pd(ndof=m.ndof, kp=kp, kd=30.0, joint=joint, saturation=25.0),
            ctl.pd_gravity(m, kp=kp, kd=30.0), ctl.pd_gravity(m, kp=kp, kd=30.0, gravity="reference"),
            ctl.computed_torque(m, kp=400.0, kd=40.0)]


@pytest.mark.parametrize("robot,dz", [("6pus", 0.01), ("quattro", -0.02)])
def test_compiled_loop_equals_the_python_loop(robot, dz):
    m = Model(robot)
    ref = _reference(m, dz)
    for c in _controllers(m, robot):
        for noise in (0.0, 2e-6):
            kw = dict(q_noise=noise, qd_noise=noise, pose_noise=noise, seed=3, drive=CoreDrive(m))
            slow = run(CorePlant(m), c, ref, compiled=False, **kw)
            fast = run(CorePlant(m), c, ref, **kw)
            assert slow.loop == "python" and fast.loop == "compiled", (slow.loop_note, fast.loop_note)
            assert len(fast) == len(slow) == len(ref.time)
            for f in FIELDS:
                scale = 1e-12 if f.startswith("tau") else 1e-14
                np.testing.assert_allclose(fast[f], slow[f], rtol=0, atol=scale, err_msg=f"{robot} {c.kind} {f}")
            assert fast.saturated == slow.saturated
            # the loop moved the robot (not two runs that both did nothing)
            assert np.ptp(fast["x"][:, 2]) > 0.5 * abs(dz)


def test_compiled_loop_with_an_encoder_model_and_chunks():
    # encoder offset and compliance: the readings go through pkm_measure_joints with the
    # effort applied before each sample, also across the chunks of the compiled loop
    m = Model("6pus", params={"rail[2].encoder_offset": 1e-4, "rail[4].compliance": 1e-5})
    ref = _reference(m, 0.01, duration=5.0)  # 5001 samples: three C calls of 2000
    c = ctl.pd_gravity(m, kp=300.0, kd=30.0)
    slow = run(CorePlant(m), c, ref, compiled=False, drive=CoreDrive(m))
    fast = run(CorePlant(m), c, ref, drive=CoreDrive(m))
    assert fast.loop == "compiled"
    for f in FIELDS:
        np.testing.assert_allclose(fast[f], slow[f], rtol=0, atol=1e-12, err_msg=f)
    assert np.any(fast["q"][:, 1] != fast["q_true"][:, 1])


def test_a_python_callable_runs_in_the_python_loop_and_says_why():
    m = Model("6pus")
    ref = _reference(m, 0.005, duration=0.05)
    g = ctl.pd_gravity(m, kp=300.0, kd=30.0)

    def my_controller(t, q, qd, r):
        return g(t, q, qd, r) * 1.0

    res = run(CorePlant(m), my_controller, ref)
    assert res.loop == "python"
    assert "Python callable" in res.loop_note
    with pytest.raises(MasterError, match="cannot run compiled"):
        run(CorePlant(m), my_controller, ref, compiled=True)


def test_a_failure_stops_both_loops_at_the_same_sample_with_the_same_rows():
    # a PD far too weak to hold the platform: it falls until the sim stops it
    m = Model("6pus")
    ref = _reference(m, 0.0, duration=1.0)
    c = ctl.pd(ndof=6, kp=1.0, kd=0.1)
    errs = {}
    for compiled in (False, None):
        with pytest.raises(MasterError) as ei:
            run(CorePlant(m), c, ref, compiled=compiled)
        errs[compiled] = ei.value
    slow, fast = errs[False], errs[None]
    assert fast.partial.loop == "compiled"
    assert len(fast.partial) == len(slow.partial) > 10
    np.testing.assert_allclose(fast.partial["x"], slow.partial["x"], rtol=0, atol=1e-14)
    head = str(slow).split(":")[0]
    assert str(fast).startswith(head), (str(fast), str(slow))
    assert "singularity" in str(fast) and "singularity" in str(slow)
