"""Bad input never crashes the host: each case returns an error status with a log line
that says what and where, and the process can instantiate the FMU again."""
import numpy as np
import pytest

from cosim import fmu

H = 1e-3


def _fresh_instance_works(fmu_file, hold):
    with fmu.FMUInstance(fmu_file, name="after") as f:
        for _ in range(5):
            f.step(H, tau=hold)
        assert np.all(np.isfinite(f.vector("x")))
        assert not [line for line in f.log if not line.startswith("OK")]


@pytest.mark.parametrize("name, value, words", [
    ("leg[1].L", -0.116, ["leg[1].L", "-0.116"]),
    ("platform.Izz", 9e-4, ["platform.Izz", "no rigid body"]),  # > Ixx + Iyy
    ("leg[3].L", float("nan"), ["leg[3].L", "nan"]),
    ("solver.rtol", -1.0, ["solver.rtol", "-1"]),
    ("z0", 0.5, ["initial pose", "leg"]),
    ("sensor.delay", 0.002, ["sensor.delay = 0.002 s", "does not delay"]),  # refused, not ignored
    # an unknown integrator: the message lists the core's method table (pkm_sim_method)
    ("solver.method", 7, ["solver.method = 7", "2 (explicit Runge-Kutta 5(4))", "or 3 (explicit Runge-Kutta 3(2))"]),
])
def test_bad_start_value_fails_initialization(fmu_file, hold, name, value, words):
    f = fmu.FMUInstance(fmu_file, params={name: value}, initialize=False)
    with pytest.raises(fmu.FMUError) as e:
        f.initialize()
    line = f.log[-1]
    assert line.startswith("Error [logStatusError] fmi2ExitInitializationMode:"), line
    for w in words:
        assert w in line, line
    assert e.value.log == f.log
    # Nothing else works on a failed instance until a reset: the state machine says so.
    with pytest.raises(fmu.FMUError):
        f.step(H)
    assert "not allowed in state 'error'" in f.log[-1]
    f.close()
    _fresh_instance_works(fmu_file, hold)


def test_reset_after_a_bad_parameter(fmu_file, hold):
    f = fmu.FMUInstance(fmu_file, params={"platform.Izz": 9e-4}, initialize=False)
    with pytest.raises(fmu.FMUError):
        f.initialize()
    f.fmu.reset()  # back to instantiated, with every start value restored
    assert f.get("platform.Izz") == 7.5e-4
    f.initialize()
    f.step(H, tau=hold)
    f.close()


def test_nan_input(fmu_file, hold):
    with fmu.FMUInstance(fmu_file) as f:
        f.step(H, tau=hold)
        bad = hold.copy()
        bad[2] = np.nan
        with pytest.raises(fmu.FMUError):
            f.step(H, tau=bad)
        line = f.log[-1]
        assert "tau[3]" in line and "nan" in line and "t = 0.001 s" in line and "not finite" in line, line
    _fresh_instance_works(fmu_file, hold)


def test_parameter_is_fixed_after_initialization(fmu_file):
    with fmu.FMUInstance(fmu_file) as f:
        with pytest.raises(fmu.FMUError):
            f.set("leg[1].L", 0.12)
        assert "leg[1].L is fixed" in f.log[-1]


def test_wrong_guid_is_refused(fmu_file):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(fmu_file))
    d = extract(str(fmu_file))
    s = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=d,
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    with pytest.raises(Exception, match="instantiate"):
        s.instantiate()


def _discarded_step(fmu_file, tau):
    f = fmu.FMUInstance(fmu_file)
    with pytest.raises(fmu.FMUError) as e:
        for _ in range(1000):
            f.step(H, tau=tau)
    return f, e.value


def test_stroke_limit_during_a_step(fmu_file, model, hold):
    tau = model.gravity_load(model.home())
    tau[0] -= 5.0  # drive slider 1 to its lower stop
    f, err = _discarded_step(fmu_file, tau)
    line = f.log[-1]
    assert line.startswith("Discard [logStatusDiscard] fmi2DoStep"), line
    assert "leg 1" in line and "rail[1].qmin" in line and "t = 0.07" in line, line
    # The state stays at the event: readable, consistent, at the reported time.
    t_event = f.last_successful_time()
    assert f.time < t_event < f.time + H  # inside the step that was discarded
    assert abs(f.get("q[1]")) < 1e-9
    # A step failed: the importer must roll back or stop, it cannot go on.
    with pytest.raises(fmu.FMUError):
        f.step(H, tau=tau)
    assert "not allowed in state 'step failed'" in f.log[-1]
    f.close()
    _fresh_instance_works(fmu_file, hold)


def test_pose_goes_singular_during_a_step(fmu_file, model, hold):
    tau = model.gravity_load(model.home()) + np.array([0.3, -0.2, 0.1, 0.25, -0.15, 0.05])
    f, err = _discarded_step(fmu_file, tau)
    line = f.log[-1]
    assert line.startswith("Discard [logStatusDiscard] fmi2DoStep"), line
    assert "singularity" in line and "t = 0.2" in line, line
    assert f.get("singularity.direct") == pytest.approx(f.get("solver.singMin"), rel=1e-3)
    f.close()
    _fresh_instance_works(fmu_file, hold)


def test_model_exchange_stops_at_the_stroke_limit(fmu_file, model, hold):
    # ME: fmpy's solver locates the state event; the FMU asks it to stop there, saying why.
    tau = model.gravity_load(model.home())
    tau[0] -= 5.0
    log = []
    r = fmu.simulate(fmu_file, fmi_type="ModelExchange", stop_time=0.3, step=H, tau=tau, rtol=1e-10,
                     outputs=["q[1]"], logger=lambda *a: log.append(a))
    lines = [a[4].decode() for a in log]
    assert any("stopping the simulation" in s and "leg 1" in s for s in lines), lines
    # Stopped at the stroke limit, at the time Co-Simulation finds it.
    f, _ = _discarded_step(fmu_file, tau)
    assert r["time"][-1] < 0.3
    assert r["q[1]"][-1] < 2e-3
    assert f.last_successful_time() > r["time"][-1]
    f.close()


def test_model_exchange_singular_pose_is_an_error_not_a_crash(fmu_file, model, hold):
    """Model Exchange stepped by the test itself (explicit Euler, h = 0.1 ms: no host solver
    whose reaction to a refused derivative is undefined): the FMU asks to stop where the pose
    leaves leg 1's reach, with a warning naming the leg, at the time the Co-Simulation FMU's
    own integrator finds the singularity; one step further, the derivatives are refused with
    Discard naming leg 1 and the time, never a crash or a value that is not finite."""
    tau = model.gravity_load(model.home()) + np.array([0.3, -0.2, 0.1, 0.25, -0.15, 0.05])
    cs, _ = _discarded_step(fmu_file, tau)
    t_cs = cs.last_successful_time()
    cs.close()
    me = fmu.FMUInstance(fmu_file, kind="ModelExchange")
    me.set_vector("tau", tau)
    h, t, x, stop = 1e-4, 0.0, me.continuous_states(), False
    while t < 0.3 and not stop:
        dx = me.derivatives()
        assert np.all(np.isfinite(dx)), t
        x, t = x + h * dx, t + h
        me.fmu.setTime(t)
        me.set_continuous_states(x)
        _, stop = me.fmu.completedIntegratorStep()
    assert stop, "Model Exchange never asked to stop"
    line = me.log[-1]
    assert line.startswith("Warning [logStatusWarning] fmi2CompletedIntegratorStep: stopping the simulation"), line
    assert "leg 1" in line and f"t = {t:.3f} s" in line, line
    assert abs(t - t_cs) < 1e-3, (t, t_cs)  # Euler's drift from the adaptive RK 5(4) over 0.24 s
    me.fmu.setTime(t + h)
    me.set_continuous_states(x + h * dx)
    with pytest.raises(fmu.FMUError):
        me.derivatives()
    line = me.log[-1]
    assert line.startswith("Discard [logStatusDiscard] fmi2GetDerivatives: forward dynamics at t = ") and "leg 1" in line, line
    me.close()
    _fresh_instance_works(fmu_file, hold)
