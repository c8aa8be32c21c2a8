"""Gear stiffness and backlash from a motor and a link encoder, against a two-mass drive simulated
by scipy's solve_ivp, not by the core (tests/oracles/two_mass.py): a motor inertia Jm with viscous
friction bm, driven by a torque u(t), joined to a link inertia Jl with viscous friction bl by a
spring of stiffness k with a dead band of total width b.  The recorded effort is the motor's, u;
the fit takes the model's rotor inertia and motor friction off it (effort="motor")."""
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model
from cosim.errors import InputError
from cosim.identification.encoders import drive_elasticity

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "oracles"))
from two_mass import two_mass_drive  # noqa: E402

JM, BM, JL, BL = 0.8, 2.0, 3.0, 5.0  # kg m2, N m s/rad
K, GAP = 2.0e4, 4e-4  # N m/rad, rad


def _u(t):
    return 60 * np.sin(2 * np.pi * 0.7 * t) + 25 * np.sin(2 * np.pi * 2.3 * t + 1.0)


def _simulate():
    d = two_mass_drive(_u, jm=JM, bm=BM, jl=JL, bl=BL, k=K, gap=GAP)
    return d.t, d.motor, d.link, d.motor_rate, d.u, d.transmitted


def test_stiffness_and_backlash_recovered_from_the_two_encoders():
    t, th, q, thd, u, ts = _simulate()
    assert np.mean(np.abs(th - q) < GAP / 2) > 0.005  # the motion crosses the dead band
    m = Model("pendulum", params={"axis[1].rotor_inertia": JM, "axis[1].viscous": BM})  # a single R axis
    col = lambda a: a[:, None]  # noqa: E731
    est = drive_elasticity(m, t, col(th), col(q), col(thd), col(u), effort="motor")[0]
    assert est["effort_side"] == "link"
    assert abs(est["stiffness"] / K - 1) < 0.02, est
    assert abs(est["backlash"] / GAP - 1) < 0.1, est
    # the motor's effort taken as the transmitted one (the rotor's share left in) misses the stiffness
    raw = drive_elasticity(m, t, col(th), col(q), col(thd), col(u), effort="transmitted")[0]
    assert abs(raw["stiffness"] / K - 1) > 0.05, raw


def test_bad_input_is_named():
    m = Model("pendulum")
    t = np.arange(10) * 0.01
    x = np.zeros((10, 1))
    bad = x.copy()
    bad[3, 0] = np.nan
    with pytest.raises(InputError, match="q_link row 4, joint 1"):
        drive_elasticity(m, t, x, bad, x, x)
    with pytest.raises(InputError, match="joint 2"):
        drive_elasticity(m, t, x, x, x, x, joints=[2])
