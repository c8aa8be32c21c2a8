"""fmi2GetFMUstate / SetFMUstate / serialisation: rolling back and re-stepping reproduces
the trajectory bit for bit, also in another instance and across a Discarded step."""
import numpy as np
import pytest

from cosim import fmu

H = 1e-3


def _inputs(hold, n):
    t = np.arange(n) * H
    return hold + 0.05 * np.outer(np.sin(2 * np.pi * 7 * t), [1, -1, 0.5, 0.3, -0.2, 0.8])


def _run(f, taus, record=("x", "xd", "q")):
    out = []
    for tau in taus:
        f.step(H, tau=tau)
        out.append(np.concatenate([f.vector(k) for k in record]))
    return np.array(out)


def test_rollback_reproduces_bit_for_bit(fmu_file, hold):
    taus = _inputs(hold, 40)
    with fmu.FMUInstance(fmu_file) as f:
        _run(f, taus[:20])
        t_mid = f.time
        s = f.get_state()
        first = _run(f, taus[20:])
        f.set_state(s, time=t_mid)
        again = _run(f, taus[20:])
        f.free_state(s)
    assert np.array_equal(first, again)
    assert np.max(np.abs(first[-1] - first[0])) > 1e-6  # it moved


def _continue_in_a_new_instance(fmu_file, params, taus, split, check=None):
    """Run ``taus[:split]`` on an instance with ``params``, serialize its state, then run the
    rest there and, from the serialized bytes, on a default instance: both trajectories."""
    with fmu.FMUInstance(fmu_file, name="a", params=params) as a:
        _run(a, taus[:split])
        t_mid = a.time
        s = a.get_state()
        blob = a.serialize(s)
        a.free_state(s)
        ref = _run(a, taus[split:])
    with fmu.FMUInstance(fmu_file, name="b") as b:
        s = b.deserialize(blob)
        b.set_state(s, time=t_mid)
        b.free_state(s)
        if check:
            check(b)
        got = _run(b, taus[split:])
    return ref, got


def test_serialized_state_continues_in_a_new_instance(fmu_file, hold):
    # A default-parameter instance takes the state, parameters included.
    def takes_the_parameters(b):
        assert b.get("platform.m") == 0.42

    ref, got = _continue_in_a_new_instance(fmu_file, {"platform.m": 0.42}, _inputs(hold, 30), 10,
                                           takes_the_parameters)
    assert np.array_equal(ref, got)


@pytest.mark.parametrize("method", [2, 0])  # explicit Runge-Kutta (default), CVODE BDF
def test_serialized_state_carries_the_actuator_delay_line_and_the_step_size(fmu_file, hold, method):
    # With a 5 ms actuator delay the commands of the last 5 ms act after the rollback
    # point: a fresh instance given only the serialized state must replay them.
    ref, got = _continue_in_a_new_instance(fmu_file, {"actuator.delay": 0.005, "solver.method": method},
                                           _inputs(hold, 30), 12)
    assert np.array_equal(ref, got)


def test_rollback_after_a_discarded_step(fmu_file, model):
    # Push leg 1 to its lower stroke limit: the step is discarded at the event; rolling
    # back and stepping with a gentler effort goes on, and equals a run that never failed.
    g = model.gravity_load(model.home())
    hard, soft = g.copy(), g.copy()
    hard[0] -= 5.0
    soft[0] -= 0.5
    with fmu.FMUInstance(fmu_file) as f:
        _run(f, [g] * 5)
        t_mid = f.time
        s = f.get_state()
        with pytest.raises(fmu.FMUError, match="stroke limit"):
            _run(f, [hard] * 200)
        f.set_state(s, time=t_mid)
        got = _run(f, [soft] * 20)
    with fmu.FMUInstance(fmu_file) as ref:
        _run(ref, [g] * 5)
        want = _run(ref, [soft] * 20)
    assert np.array_equal(got, want)


def test_model_exchange_state_round_trip(fmu_file, hold):
    with fmu.FMUInstance(fmu_file, kind="ModelExchange") as f:
        f.set_vector("tau", hold)
        x = f.continuous_states()
        dx = f.derivatives()
        s = f.get_state()
        blob = f.serialize(s)
        f.set_continuous_states(x + 1e-4)
        assert not np.array_equal(f.derivatives(), dx)
        f.set_state(f.deserialize(blob))
        np.testing.assert_array_equal(f.continuous_states(), x)
        np.testing.assert_array_equal(f.derivatives(), dx)
        f.free_state(s)


def test_foreign_state_is_refused(fmu_file):
    with fmu.FMUInstance(fmu_file, name="cs") as cs, fmu.FMUInstance(fmu_file, kind="ModelExchange", name="me") as me:
        s = me.get_state()
        blob = me.serialize(s)
        with pytest.raises(fmu.FMUError):
            cs.deserialize(blob)
        assert "another model, interface or layout" in cs.log[-1]
        with pytest.raises(fmu.FMUError):
            cs.deserialize(b"\x00" * len(blob))
        assert "not an FMU state" in cs.log[-1]
        with pytest.raises(fmu.FMUError):
            cs.deserialize(blob[:20])
        assert "too few" in cs.log[-1]
        me.free_state(s)
