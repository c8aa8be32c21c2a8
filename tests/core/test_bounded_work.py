"""Bounded work per pkm_sim_advance: the step budget, its cap, and the explicit method's
stiffness detection handing a stiff stretch to BDF.

The stiff case is the planar 3-RRR with 1e4 N m of Coulomb friction on arm 2 (smooth sign
over drive.v_eps: a slope of 1e8 N m s/rad), where the explicit method alone needed
0.6-2 s per 1 ms advance.  Wall times are measured here; the bound (2 s per call) is
generous to a loaded machine and well below the old behaviour.
"""
import time

import numpy as np
import pytest

from cosim._native import ArgumentError, IntegrationError
from cosim.core import Model
from cosim.simulate import Simulator

BOUND = 2.0  # s, per call
TAU = np.array([0.2, -0.1, 0.15])  # N m


@pytest.fixture(scope="module")
def stiff():
    return Model("planar_3rrr", params={"arm[2].coulomb": 1e4})


def _run(model, method, steps=5, **options):
    sim = Simulator(model, method=method, **options)
    sim.set_input(TAU)
    walls = []
    for k in range(1, steps + 1):
        t0 = time.perf_counter()
        sim.advance(k * 1e-3)
        walls.append(time.perf_counter() - t0)
    return sim, walls


def test_max_steps_is_capped_naming_the_cap():
    with pytest.raises(ArgumentError, match=r"max_steps = 2147483647 must be in \[1, 1000000\]"):
        Simulator(Model("planar_3rrr"), max_steps=2147483647)
    Simulator(Model("planar_3rrr"), max_steps=1_000_000)  # the cap itself is allowed


@pytest.mark.parametrize("method", ["erk", "erk23"])
def test_explicit_methods_hand_stiff_friction_to_bdf_and_agree_with_it(stiff, method):
    sim, walls = _run(stiff, method)
    ref, _ = _run(stiff, "bdf", rtol=1e-10, atol=1e-12)
    assert max(walls) < BOUND, walls
    # Without the hand-over the explicit method stays at its stability limit (~1e-8 s steps):
    # tens of thousands of steps per millisecond.  With it, a few hundred at most.
    assert sim.stats["steps"] < 5 * 2000, sim.stats
    _, x, xd = sim.state
    _, xr, xdr = ref.state
    np.testing.assert_allclose(x, xr, rtol=0, atol=1e-7)
    assert np.max(np.abs(x - stiff.home())) > 1e-6  # it moved


def test_the_hand_over_replays_bit_for_bit_after_a_rollback(stiff):
    sim = Simulator(stiff)
    sim.set_input(TAU)
    sim.advance(1e-3)
    saved = sim.save_state()
    sim.advance(2e-3)
    first = sim.state
    sim.load_state(saved)
    sim.advance(2e-3)
    again = sim.state
    assert first[0] == again[0]
    assert np.array_equal(first[1], again[1]) and np.array_equal(first[2], again[2])


def test_the_budget_stops_the_advance_naming_the_time_and_the_remedy(stiff):
    # A budget far too small for the friction: the advance stops where it ran out.
    sim = Simulator(stiff, max_steps=10)
    sim.set_input(TAU)
    t0 = time.perf_counter()
    with pytest.raises(IntegrationError, match=r"step budget exceeded at t = [0-9.e+-]+ s: max_steps = 10 ") as e:
        sim.advance(1e-3)
    assert time.perf_counter() - t0 < BOUND
    assert e.value.status == "PKM_ERR_STEP_BUDGET"
    assert "use solver.method = BDF" in str(e.value)
    t, x, xd = sim.state
    assert 0 <= t < 1e-3 and np.all(np.isfinite(x)) and np.all(np.isfinite(xd))
