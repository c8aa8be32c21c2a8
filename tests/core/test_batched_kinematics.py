"""Batched velocity and acceleration kinematics (``pkm_pose_velocity_batch``,
``pkm_pose_acceleration_batch``): one C call over many poses gives the per-pose calls'
results bit for bit, and a bad row is named (with its time when given)."""
import numpy as np
import pytest

from cosim.core import Model, PkmError


@pytest.mark.parametrize("robot", ["6pus", "quattro", "fourbar"])
def test_batched_pose_rates_equal_the_per_pose_calls(robot):
    m = Model(robot)
    rng = np.random.default_rng(3)
    n = 300
    x = m.home() + rng.normal(0, 1e-3, (n, m.ndof))
    qd, qdd = rng.normal(0, 1e-2, (n, m.ndof)), rng.normal(0, 1e-1, (n, m.ndof))
    xd = m.pose_velocity(x, qd)
    xdd = m.pose_acceleration(x, xd, qdd)
    assert np.array_equal(xd, np.array([m.pose_velocity(a, b) for a, b in zip(x, qd)]))
    assert np.array_equal(xdd, np.array([m.pose_acceleration(a, b, c) for a, b, c in zip(x, xd, qdd)]))
    # the inverse map closes: J xd = qd
    assert np.allclose(m.joint_velocity(x, xd), qd, rtol=1e-9, atol=1e-15)


def test_a_bad_row_of_a_batch_is_named_with_its_time():
    m = Model("6pus")
    x = np.tile(m.home(), (50, 1))
    qd = np.zeros((50, 6))
    qd[31, 2] = np.inf
    with pytest.raises(PkmError, match=r"sample 31 \(t = 0\.031 s\): joint velocity qd\[2\] is not finite"):
        m.pose_velocity(x, qd, times=np.arange(50) * 1e-3, what="sample")
