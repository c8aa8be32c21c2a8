"""The inverse dynamics in its two layers (``pkm_mechanism_inverse_dynamics_batch``,
``pkm_add_drive_inverse_dynamics_batch``, ``pkm_add_drive_efforts_batch``, ``pkm_param_in_drive_layer``): the drive layer added
to the mechanism's efforts is the whole inverse dynamics bit for bit, no drive-layer parameter
moves the mechanism's part, and the drive layer's part of a viscous friction is b qd."""
import numpy as np
import pytest

from cosim.core import Model, PkmError
from cosim.errors import ArgumentError


def _motion(m, n=40, seed=5):
    rng = np.random.default_rng(seed)
    x = m.home() + rng.normal(0, 1e-3, (n, m.ndof))
    xd = m.pose_velocity(x, rng.normal(0, 5e-2, (n, m.ndof)))
    xdd = m.pose_acceleration(x, xd, rng.normal(0, 0.5, (n, m.ndof)))
    return x, xd, xdd


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_drive_layer_on_the_mechanism_is_the_inverse_dynamics_bit_for_bit(robot):
    m = Model(robot)
    j = m.facts.joint_prefix
    k = 2
    m.set_params({f"{j}[1].coulomb": 0.3, f"{j}[{k}].viscous": 2.0, f"{j}[1].rotor_inertia": 0.05,
                  f"{j}[{k}].offset": -0.4, f"{j}[1].force_v2": 3.0, f"{j}[{k}].stribeck": 0.2,
                  f"{j}[{k}].stribeck_v": 0.01})
    x, xd, xdd = _motion(m)
    mech = m.mechanism_inverse_dynamics(x, xd, xdd)
    assert np.array_equal(m.add_drive_inverse_dynamics(x, xd, xdd, mech), m.inverse_dynamics(x, xd, xdd))
    joints = m.ik(x), m.joint_velocity(x, xd), m.joint_acceleration(x, xd, xdd)
    assert np.array_equal(m.add_drive_efforts(*joints, mech), m.inverse_dynamics(x, xd, xdd))
    assert not np.array_equal(mech, m.inverse_dynamics(x, xd, xdd))


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_no_drive_layer_parameter_moves_the_mechanism_and_the_others_are_the_mechanism(robot):
    m = Model(robot)
    x, xd, xdd = _motion(m)
    mech = m.mechanism_inverse_dynamics(x, xd, xdd)
    drive = m.drive_layer_params()
    j = m.facts.joint_prefix
    assert {f"{j}[1].coulomb", f"{j}[3].rotor_inertia", f"{j}[2].force_k1", "actuator.delay",
            "sensor.delay", f"{j}[1].backlash"} <= drive
    assert not {"platform.m", "payload.m", "gravity.z"} & drive
    moved = 0
    k = m.copy()
    for name, v in m.params().items():
        try:
            k.set_params_unchecked({name: v * 1.1 + 1e-3})
            after = k.mechanism_inverse_dynamics(x, xd, xdd)
        except PkmError:
            after = None  # outside its range, an inconsistent set, a pose the moved geometry cannot hold
        k.set_params_unchecked({name: v})
        if after is None:
            continue
        if name in drive:
            assert np.array_equal(after, mech), name
        moved += not np.array_equal(after, mech)
    assert moved > 5  # masses, inertias, gravity, geometry do move it
    for name in ("platform.m", "gravity.z"):
        k = m.copy()
        k.set_params({name: m.param(name) * 1.1 + 1e-3})
        assert not np.array_equal(k.mechanism_inverse_dynamics(x, xd, xdd), mech), name


def test_the_drive_part_of_a_viscous_friction_is_b_times_the_joint_rate():
    m = Model("6pus")
    m.set_params({"rail[3].viscous": 2.5})
    x, xd, xdd = _motion(m)
    part = m.add_drive_inverse_dynamics(x, xd, xdd, np.zeros((len(x), 6)))
    want = np.zeros_like(part)
    want[:, 2] = 2.5 * m.joint_velocity(x, xd)[:, 2]  # the rail's rate from the pose's
    assert np.allclose(part, want, rtol=1e-12, atol=1e-15)


def test_bad_inputs_of_the_drive_layer_are_named():
    m = Model("6pus")
    x, xd, xdd = _motion(m, n=10)
    with pytest.raises(ArgumentError, match="same number of rows"):
        m.add_drive_inverse_dynamics(x, xd, xdd, np.zeros((9, 6)))
    with pytest.raises(PkmError, match=r"item 2: joint velocity qd\[0\] is not finite"):
        m.add_drive_efforts(m.ik(x), np.where(np.arange(10)[:, None] == 2, np.inf, xd), xdd, np.zeros((10, 6)))
    mech = np.zeros((10, 6))
    mech[4, 1] = np.nan
    with pytest.raises(PkmError, match=r"item 4: mechanism effort tau\[1\] is not finite"):
        m.add_drive_inverse_dynamics(x, xd, xdd, mech)
