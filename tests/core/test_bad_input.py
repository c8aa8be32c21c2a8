"""Finite but absurd inputs: the core names what is too large instead of returning an
infinity or a NaN, or blaming the pose (the 6-PUS once called tau = 1e308 a singular
mass matrix at a good pose)."""
import numpy as np
import pytest

from cosim.errors import ArgumentError
from cosim.core import Model
from cosim.simulate import Simulator


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_overflowing_efforts_and_rates_are_named(robot):
    m = Model(robot)
    x, z = m.home(), np.zeros(m.ndof)
    with pytest.raises(ArgumentError, match=r"too large .*largest \|tau\| = 1e\+308"):
        m.forward_dynamics(x, z, np.full(m.ndof, 1e308))
    with pytest.raises(ArgumentError, match=r"energy is not finite .*largest \|xd\| = 1e\+200"):
        m.energy(x, np.full(m.ndof, 1e200))
    sim = Simulator(m)
    with pytest.raises(ArgumentError, match=r"reset: the energy is not finite"):
        sim.reset(0.0, x, np.full(m.ndof, 1e200))
    sim.set_input(np.full(m.ndof, 1e308))
    with pytest.raises(ArgumentError, match=r"too large"):
        sim.advance(1e-3)


def test_a_denormal_or_tiny_advance_is_a_zero_step():
    m = Model("6pus")
    sim = Simulator(m)
    sim.set_input(m.gravity_load(m.home()))
    sim.advance(5e-324)
    sim.advance(1e-16)
    t, x, xd = sim.state
    assert t == 1e-16 and np.array_equal(x, m.home())
    sim.advance(1e-3)  # and it goes on normally
    assert sim.state[0] == 1e-3
