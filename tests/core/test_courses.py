"""Time courses of named parameters in the core's integrator (pkm_param_set_course).

Oracles, none from the code under test: the EMPS axis (one carriage of mass M on a horizontal
rail, q = x) pushed by a constant force F while it moves forward (qd >> drive.v_eps, so the
smoothed Coulomb sign is 1 to the last bit) obeys M x'' = F - c(t), whose solution is a
polynomial in t written out below: for a trend c(t) = c0 + r t,
    x(t) = v0 t + ((F - c0) t^2 / 2 - r t^3 / 6) / M,
and for a step of the friction or of the mass at t_s two parabolas joined at t_s with the
state continuous.  The constant model's answer differs from these by millimetres, the
tolerance is 1e-8 m, so a course not evaluated inside the integrator fails.
"""
import numpy as np
import pytest

from cosim.core import Model, Simulator
from cosim.errors import ArgumentError, ParameterError

M, F, C0, V0 = 90.0, 30.0, 20.0, 0.05  # kg, N, N, m/s


def _axis(**params):
    return Model("emps", params={"rail[1].coulomb": C0, **params})


def _run(m, T, method="erk"):
    sim = Simulator(m, method=method, rtol=1e-10, atol=1e-12)
    sim.reset(0.0, [0.0], [V0])
    sim.set_input([F])
    sim.advance(T)
    t, x, xd = sim.state
    return float(x[0]), float(xd[0])


@pytest.mark.parametrize("method", ["erk", "bdf"])
def test_a_coulomb_trend_follows_the_closed_form(method):
    r, T = -4.0, 1.5  # N/s: the friction falls from 20 N to 14 N
    m = _axis()
    m.set_course("rail[1].coulomb", "trend", rate=r, t0=0.0)
    x, v = _run(m, T, method)
    assert abs(x - (V0 * T + ((F - C0) * T**2 / 2 - r * T**3 / 6) / M)) < 1e-8
    assert abs(v - (V0 + ((F - C0) * T - r * T**2 / 2) / M)) < 1e-8
    # the model's own value stays the parameter's (t0's); the course is read where asked
    assert m.param("rail[1].coulomb") == C0
    assert m.value_at("rail[1].coulomb", T) == pytest.approx(C0 + r * T, abs=1e-12)


def test_a_trend_around_a_later_reference_time():
    r, t0, T = 2.0, 1.0, 1.5  # c(t) = C0 + r (t - t0): 18 N at t = 0, 21 N at t = 1.5 s
    m = _axis()
    m.set_course("rail[1].coulomb", "trend", rate=r, t0=t0)
    x, _ = _run(m, T)
    c_start = C0 - r * t0
    assert abs(x - (V0 * T + ((F - c_start) * T**2 / 2 - r * T**3 / 6) / M)) < 1e-8


def _two_parabolas(ts, T, a1, a2):
    x1, v1 = V0 * ts + a1 * ts**2 / 2, V0 + a1 * ts
    return x1 + v1 * (T - ts) + a2 * (T - ts) ** 2 / 2, v1 + a2 * (T - ts)


@pytest.mark.parametrize("name, size, accel_after", [
    ("rail[1].coulomb", -6.0, (F - C0 + 6.0) / M),       # the friction drops by 6 N at t_s
    ("platform.m", 30.0, (F - C0) / (M + 30.0)),         # a payload of 30 kg put on at t_s
])
def test_a_step_joins_two_parabolas_at_its_time(name, size, accel_after):
    ts, T = 0.37, 1.0
    m = _axis()
    m.set_course(name, "step", size=size, t0=ts)
    x, v = _run(m, T)
    xw, vw = _two_parabolas(ts, T, (F - C0) / M, accel_after)
    assert abs(x - xw) < 1e-8 and abs(v - vw) < 1e-8


def test_a_step_inside_one_advance_and_across_several_agree():
    ts = 0.37
    m = _axis()
    m.set_course("platform.m", "step", size=30.0, t0=ts)
    one = _run(m, 1.0)
    sim = Simulator(m, rtol=1e-10, atol=1e-12)
    sim.reset(0.0, [0.0], [V0])
    sim.set_input([F])
    for t in np.arange(1, 101) * 0.01:  # a 10 ms loop, the step between two of its samples
        sim.advance(float(t))
    _, x, xd = sim.state
    assert abs(x[0] - one[0]) < 1e-9 and abs(xd[0] - one[1]) < 1e-9


def test_copies_carry_the_course_and_clearing_it_restores_the_constant():
    m = _axis()
    m.set_course("rail[1].coulomb", "trend", rate=-4.0, t0=0.0)
    assert m.copy().course("rail[1].coulomb") == {"kind": "trend", "rate": -4.0, "t0": 0.0}
    m.set_course("rail[1].coulomb", None)
    assert m.courses() == {}
    x, _ = _run(m, 1.0)
    assert abs(x - (V0 + (F - C0) / 2 / M)) < 1e-8


def test_a_trend_leaving_the_range_stops_the_sim_naming_parameter_and_time():
    m = _axis()
    m.set_course("rail[1].coulomb", "trend", rate=-40.0, t0=0.0)  # below 0 N after 0.5 s
    sim = Simulator(m)
    sim.reset(0.0, [0.0], [V0])
    sim.set_input([F])
    with pytest.raises(ParameterError, match=r"rail\[1\]\.coulomb reaches the end of its valid range \[0, .*at t = 0\.5 s"):
        sim.advance(1.0)


@pytest.mark.parametrize("name, kind, kw, error, match", [
    ("rail[9].coulomb", "trend", {"rate": 1.0}, ParameterError, r"no parameter named 'rail\[9\]"),
    ("rail[1].coulomb", "trend", {"rate": float("nan")}, ArgumentError, "rate nan is not finite"),
    ("rail[1].coulomb", "step", {"size": float("inf")}, ArgumentError, "step size inf is not finite"),
    ("rail[1].coulomb", "trend", {"rate": 1.0, "t0": -1.0}, ArgumentError, "t0 = -1 s must be finite and >= 0"),
    ("rail[1].coulomb", "ramp", {}, ArgumentError, "unknown kind 'ramp'"),
    ("platform.m", "trend", {"rate": 1.0}, ParameterError, "belongs to the mechanism.*give it a step"),
    ("rail[1].qmax", "step", {"size": 0.1}, ParameterError, "is a joint limit"),
    ("actuator.delay", "step", {"size": 0.01, "t0": 1.0}, ParameterError, "read when a sim is created"),
    ("rail[1].coulomb", "step", {"size": -30.0, "t0": 1.0}, ParameterError,
     r"rail\[1\]\.coulomb = -10 N at t = 1 s .* outside its valid range"),
])
def test_bad_courses_are_refused_with_what_and_where(name, kind, kw, error, match):
    m = _axis()
    with pytest.raises(error, match=match):
        m.set_course(name, kind, **kw)
    assert m.courses() == {}


def test_the_sim_stops_where_the_trend_leaves_the_range():
    m = _axis()
    m.set_course("rail[1].coulomb", "trend", rate=-40.0, t0=0.0)
    sim = Simulator(m, rtol=1e-10, atol=1e-12)
    sim.reset(0.0, [0.0], [V0])
    sim.set_input([F])
    with pytest.raises(ParameterError):
        sim.advance(1.0)
    t, x, _ = sim.state
    assert t == 0.5 and abs(x[0] - (V0 * t + ((F - C0) * t**2 / 2 + 40.0 * t**3 / 6) / M)) < 1e-8


def test_a_rollback_across_a_step_repeats_the_run_bit_for_bit():
    m = _axis()
    m.set_course("platform.m", "step", size=30.0, t0=0.37)
    m.set_course("rail[1].coulomb", "trend", rate=-4.0, t0=0.0)
    sim = Simulator(m, rtol=1e-10, atol=1e-12)
    sim.reset(0.0, [0.0], [V0])
    sim.set_input([F])
    sim.advance(0.3)
    saved = sim.save_state()
    sim.advance(1.0)
    first = sim.state
    sim.load_state(saved)  # back before the step: the mass is the one before it again
    sim.advance(1.0)
    again = sim.state
    assert first[0] == again[0] and np.array_equal(first[1], again[1]) and np.array_equal(first[2], again[2])
