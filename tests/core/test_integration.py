"""cosim.simulate: the Python face of the core's simulator (pkm_sim: explicit Runge-Kutta
5(4) by default, CVODE BDF or Adams on request).

The physics is checked in c_core/tests/integration_test.cpp; here: the binding (shapes,
inputs, errors as exceptions with the stop state attached), bit-for-bit rollback from
Python, and a step response against an independent integrator (scipy's DOP853 on the
core's forward dynamics, same zero-order-hold input).
"""
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from cosim.errors import ArgumentError, JointLimitError, SingularError
from cosim.core import Model
from cosim.simulate import SimResult, Simulator, default_options, simulate


@pytest.fixture(scope="module")
def model():
    return Model("6pus")


def test_default_options_are_the_cores(model):
    assert default_options() == {"method": "erk", "rtol": 1e-8, "atol": 1e-10, "max_step": 0.0,
                                 "max_steps": 100000, "sing_min": 1e-4}


def test_the_method_list_is_the_cores_and_each_method_integrates(model):
    """One list of integrators (pkm_sim_method): the names, codes and titles every layer
    reads; each named method runs, and the pkm.h codes are the enum's (PKM_BDF 0 ...)."""
    from cosim.cli.scenario import INTEGRATORS
    from cosim.core.simulator import METHOD_CODES, METHODS

    assert METHOD_CODES == {"bdf": 0, "adams": 1, "erk": 2, "erk23": 3}   # pkm.h pkm_lmm
    assert INTEGRATORS == {k: v[1] for k, v in METHODS.items()}
    assert INTEGRATORS["erk"] == "explicit Runge-Kutta 5(4)" and INTEGRATORS["bdf"] == "CVODE BDF"
    for name in METHODS:
        sim = Simulator(model, method=name)
        sim.set_input(model.gravity_load(model.home()))
        sim.advance(0.01)
        assert sim.state[0] == 0.01
    with pytest.raises(ArgumentError, match=r"method must be one of \['adams', 'bdf', 'erk', 'erk23'\]"):
        Simulator(model, method="rk4")


@pytest.mark.parametrize("method", ["erk", "bdf"])
def test_simulator_holds_the_robot_with_its_gravity_load(model, method):
    x0 = model.home()
    sim = Simulator(model, method=method)
    t, x, xd = sim.state
    assert t == 0.0 and np.array_equal(x, x0) and np.array_equal(xd, np.zeros(6))
    sim.set_input(model.gravity_load(x0))
    sim.advance(0.1)
    t, x, xd = sim.state
    assert t == 0.1
    np.testing.assert_allclose(x, x0, atol=1e-8)
    np.testing.assert_allclose(xd, 0.0, atol=1e-7)
    st = sim.stats
    assert set(st) == {"steps", "rhs_evals", "jac_evals", "error_test_fails", "nonlin_conv_fails"}
    assert st["steps"] > 0 and st["rhs_evals"] >= st["steps"]
    # BDF builds difference-quotient Jacobians; the explicit method needs none.
    assert st["jac_evals"] >= 1 if method == "bdf" else st["jac_evals"] == 0


def test_bad_arguments_raise_argument_errors(model):
    with pytest.raises(ArgumentError, match="method"):
        Simulator(model, method="rk4")
    with pytest.raises(ArgumentError, match="rtol"):
        Simulator(model, rtol=-1.0)
    with pytest.raises(ArgumentError, match="sing_min"):
        Simulator(model, sing_min=2.0)
    sim = Simulator(model)
    with pytest.raises(ArgumentError, match=r"tau\[1\]"):
        sim.set_input([0, np.nan, 0, 0, 0, 0])
    with pytest.raises(ArgumentError, match="shape"):
        sim.set_input(np.zeros(5))
    with pytest.raises(ArgumentError, match=r"x\[0\]"):
        sim.reset(0.0, [np.inf, 0, 0.085, 0, 0, 0])
    sim.advance(0.01)
    with pytest.raises(ArgumentError, match="before the current time"):
        sim.advance(0.005)
    with pytest.raises(ArgumentError, match="dt"):
        simulate(model, model.home(), dt=0.0)
    with pytest.raises(ArgumentError, match="tau must be"):
        simulate(model, model.home(), t_end=0.01, dt=1e-3, tau=np.zeros((3, 6)))


def test_rollback_is_bit_for_bit(model):
    x0 = model.home()
    g = model.gravity_load(x0)
    sim = Simulator(model)
    sim.reset(0.0, x0, [0.01, -0.02, 0.0, 0.05, 0.0, -0.03])
    sim.set_input(g)
    sim.advance(0.01)
    saved = sim.state
    taus = [g + 0.1 * k for k in range(10)]
    first = []
    for k, tau in enumerate(taus):
        sim.set_input(tau)
        sim.advance(0.01 + 1e-3 * (k + 1))
        first.append(sim.state)
    sim.reset(*saved)
    for k, tau in enumerate(taus):
        sim.set_input(tau)
        sim.advance(0.01 + 1e-3 * (k + 1))
        t, x, xd = sim.state
        assert t == first[k][0]
        assert x.tobytes() == first[k][1].tobytes() and xd.tobytes() == first[k][2].tobytes()


def test_the_input_forms_are_equivalent(model):
    x0 = model.home()
    g = model.gravity_load(x0) + np.array([0.2, 0, -0.1, 0, 0.1, 0])
    n = 20
    a = simulate(model, x0, t_end=0.02, dt=1e-3, tau=g)
    b = simulate(model, x0, t_end=0.02, dt=1e-3, tau=np.tile(g, (n, 1)))
    c = simulate(model, x0, t_end=0.02, dt=1e-3, tau=lambda t, x, xd: g)
    assert isinstance(a, SimResult) and a.error is None
    assert a.t.shape == (n + 1,) and a.x.shape == a.xd.shape == a.q.shape == a.qd.shape == a.tau.shape == (n + 1, 6)
    assert a.t[-1] == 0.02
    np.testing.assert_allclose(np.diff(a.t), 1e-3, rtol=1e-9)
    for r in (b, c):
        assert np.array_equal(a.x, r.x) and np.array_equal(a.xd, r.xd) and np.array_equal(a.tau, r.tau)
    # q and qd are the core's kinematics of the sampled states.
    np.testing.assert_array_equal(a.q, model.ik(a.x))
    # No input at all: the platform sinks.
    free = simulate(model, x0, t_end=0.02, dt=1e-3)
    assert free.x[-1, 2] < x0[2] - 1e-4
    assert np.all(free.tau == 0)


def test_a_fall_stops_at_a_stroke_limit_naming_leg_and_time():
    m = Model("6pus", params={f"rail[{i}].qmax": 0.08 for i in range(1, 7)})
    with pytest.raises(JointLimitError) as info:
        simulate(m, m.home(), t_end=1.0, dt=1e-3)
    msg = str(info.value)
    mt = re.search(r"leg (\d) reached its stroke limit rail\[(\d)\]\.qmax = 0\.08 m at t = ([0-9.eE+-]+) s", msg)
    assert mt, msg
    assert mt.group(1) == mt.group(2)
    leg = int(mt.group(1)) - 1
    res = info.value.result
    assert isinstance(res, SimResult) and res.error is info.value
    assert res.t[-1] == pytest.approx(float(mt.group(3)), abs=1e-9)
    assert 0 < res.t[-1] < 1.0 and res.t[-2] < res.t[-1]
    assert res.q[-1, leg] == pytest.approx(0.08, abs=1e-9)
    assert np.all(np.isfinite(res.x)) and np.all(res.q <= 0.08)


def test_a_free_fall_from_home_stops_at_the_direct_singularity(model):
    with pytest.raises(SingularError, match=r"direct \(type 2\) singularity.* at t = 0\.178"):
        simulate(model, model.home(), t_end=1.0, dt=1e-2)


def _pd(model, q_ref, kp=2000.0, kd=30.0):
    """PD + gravity compensation in joint space (a controller, not physics)."""

    def tau(t, x, xd):
        return model.gravity_load(x) + kp * (q_ref - model.ik(x)) - kd * model.joint_velocity(x, xd)

    return tau


def test_step_response_matches_an_independent_integrator(model):
    """Leg 1 reference steps by +2 mm at t = 0 under PD + gravity compensation at 1 kHz.

    The reference integrates the same equations, the core's forward dynamics, with
    scipy's DOP853 at tight tolerances, the input held over each 1 ms interval and
    computed from scipy's own state: agreement to 1e-6 checks the simulator's state
    handling, input hold and integration accuracy (the default RK 5(4)).
    """
    x0 = model.home()
    q_ref = model.ik(x0) + np.array([2e-3, 0, 0, 0, 0, 0])
    ctl = _pd(model, q_ref)
    dt, n = 1e-3, 100
    res = simulate(model, x0, t_end=n * dt, dt=dt, tau=ctl, rtol=1e-10, atol=1e-12)

    y = np.concatenate([x0, np.zeros(6)])
    ref = [y.copy()]
    for k in range(n):
        tau = ctl(k * dt, y[:6], y[6:])

        def f(t, s, tau=tau):
            return np.concatenate([s[6:], model.forward_dynamics(s[:6], s[6:], tau)])

        sol = solve_ivp(f, (k * dt, (k + 1) * dt), y, method="DOP853", rtol=1e-12, atol=1e-14)
        assert sol.success, sol.message
        y = sol.y[:, -1]
        ref.append(y.copy())
    ref = np.array(ref)
    err_x = np.abs(res.x - ref[:, :6]).max()
    err_xd = np.abs(res.xd - ref[:, 6:]).max()
    print(f"step response vs solve_ivp: max |dx| = {err_x:.2e}, max |dxd| = {err_xd:.2e}")
    assert err_x < 1e-6 and err_xd < 1e-6
    # The step did move the robot (the comparison is not between two robots at rest).
    assert res.q[-1, 0] - res.q[0, 0] > 1e-3


def test_core_bench_reports_every_target_row():
    """`cosim bench core` is a command, not a test; this only checks that its C++ part runs
    and reports each performance-target quantity with a finite value and a verdict."""
    from cosim.cli.benchmark import _run_cpp, core_table

    rows = _run_cpp(quick=True)
    assert {"ik_ns", "fk_us", "id_ns", "fd_ns", "sim_bdf_1ms", "sim_adams_1ms"} <= set(rows)
    for r in rows.values():
        assert np.isfinite(r["value"]) and r["value"] > 0, r
        assert r["pass"] == (r["value"] >= r["target"] if r["higher_is_better"] else r["value"] <= r["target"])
    assert "0 failed" in rows["fk_us"]["note"]
    table = core_table(rows, {"ik_ns": {"python": 1.0, "baseline": 2.0, "baseline_what": "loop"}})
    for r in rows.values():  # each row's line carries the verdict its own figures give
        line = next(ln for ln in table.splitlines() if r["label"] in ln)
        assert ("PASS" if r["pass"] else "MISS") in line, line
