"""Bounded work per fmi2DoStep: no setting or input makes one call run away.

Without the bounds each case takes far longer than a host can wait for a 1 ms step (the slider
crank under 1e6 N m with solver.maxSteps = 2147483647: > 40 s for one step; the planar 3-RRR
with arm[2].coulomb = 1e4 on the explicit method alone: 0.6-3.5 s per 1 ms step).  The wall
time of every call is measured here; the bound (2 s) is generous to a loaded machine and well
below those.
"""
import re
import time

import numpy as np
import pytest

from cosim import fmu

BOUND = 2.0  # s, per call


def _timed(fn, *args):
    t0 = time.perf_counter()
    try:
        fn(*args)
        err = None
    except fmu.FMUError as e:
        err = e
    return time.perf_counter() - t0, err


def test_max_steps_above_the_cap_is_refused_naming_it():
    f = fmu.FMUInstance(fmu.fmu_path("slider_crank"), params={"solver.maxSteps": 2147483647}, initialize=False)
    try:
        with pytest.raises(fmu.FMUError, match=r"solver.maxSteps = 2147483647 must be in \[1, 1000000\]"):
            f.initialize()
    finally:
        f.close()


@pytest.mark.parametrize("method", [2, 0])  # explicit Runge-Kutta 5(4) (default), CVODE BDF
def test_a_violent_input_at_the_largest_budget_is_discarded_within_the_bound(method):
    # tau = 1e6 N m on the crank drives it into its dead centre, where no step size is small
    # enough; with the largest step budget allowed the call still returns in bounded time,
    # Discarded at the last accepted state, which stays finite and readable.
    with fmu.FMUInstance(fmu.fmu_path("slider_crank"),
                         params={"solver.maxSteps": 1_000_000, "solver.method": method}) as f:
        f.set_vector("tau", [1e6])
        wall, err = _timed(f.step, 1e-3)
        assert wall < BOUND, f"one 1 ms doStep took {wall:.2f} s"
        assert err is not None
        line = f.log[-1]
        assert line.startswith("Discard [logStatusDiscard] fmi2DoStep"), line
        m = re.search(r"step budget exceeded at t = ([0-9.e+-]+) s", line)
        assert m, line
        assert ("use solver.method = BDF" if method == 2 else "too fast to resolve") in line, line
        assert f.last_successful_time() == pytest.approx(float(m.group(1)), rel=1e-9)
        assert 0 < f.last_successful_time() < 1e-3
        assert np.all(np.isfinite(f.vector("x"))) and np.all(np.isfinite(f.vector("xd")))


def _three_rrr(method=None):
    params = {"arm[2].coulomb": 1e4}
    if method is not None:
        params["solver.method"] = method
    return fmu.FMUInstance(fmu.fmu_path("planar_3rrr"), params=params)


def test_stiff_friction_on_the_explicit_default_returns_within_the_bound_and_equals_bdf():
    tau = [0.2, -0.1, 0.15]  # N m: the platform moves, arm 2 works against 1e4 N m of friction
    walls = []
    with _three_rrr() as f:
        x0 = f.vector("x")
        for _ in range(5):
            wall, err = _timed(f.step, 1e-3, tau)
            assert err is None, f.log[-3:]
            walls.append(wall)
        x_erk = f.vector("x")
    with _three_rrr(method=0) as g:
        for _ in range(5):
            g.step(1e-3, tau)
        x_bdf = g.vector("x")
    assert max(walls) < BOUND, walls
    # the explicit default handed the stiff stretch to BDF: the same motion to the tolerances
    np.testing.assert_allclose(x_erk, x_bdf, rtol=0, atol=1e-7)
    assert np.max(np.abs(x_erk - x0)) > 1e-6  # it moved
