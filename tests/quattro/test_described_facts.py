"""The Quattro's own functions (the 22 indices of Virzi 2010, the GIMRE, the joint points, the
constants) and its motion on the described Quattro (c_core/src/robots/quattro_facts.cpp over
robots/quattro_described.toml) against the hand-written model (c_core/src/robots/quattro.cpp):
two implementations written apart, the description's kinematics and dynamics compiled from the
file, the hand-written ones from the source's equations.  Poses over the whole workspace grid
of the thesis' maps, unreachable and out-of-range ones included (the same status expected)."""
import numpy as np
import pytest

from cosim.core import Model

# Hand-written payload.J (about the tool axis, turned tool.ratio = 4 times per articulation
# radian) is the description's platform.Izz = 4^2 payload.J (tests/core/test_described.py).
CASES = {
    "default": (None, {}, {}),
    "appendix_a": ("appendix_a", {}, {}),
    "payload": (None, {"payload.m": 0.6, "payload.J": 2e-3}, {"payload.m": 0.6, "platform.Izz": 16 * 2e-3}),
}


def poses(n=400, seed=4):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.6, 0.6, n), rng.uniform(-0.6, 0.6, n), rng.uniform(-1.3, -0.7, n),
                            rng.uniform(-0.8, 0.8, n)])


@pytest.mark.parametrize("case", sorted(CASES))
def test_described_quattro_facts_equal_the_hand_written_ones(case):
    st, pa, pb = CASES[case]
    a, b = Model("quattro", param_set=st, params=pa), Model("quattro_described", param_set=st, params=pb)
    assert b.has("quattro_indices") and b.has("quattro_gimre") and b.has("quattro_points")
    X = poses()
    Ia, sa = a.quattro_indices(X)
    Ib, sb = b.quattro_indices(X)
    ok = sa == 0
    assert np.array_equal(sa != 0, sb != 0) and 100 < ok.sum() < len(X)  # both reachable and not
    scale = np.abs(Ia[ok]).max(axis=0)
    assert (np.abs(Ia[ok] - Ib[ok]).max(axis=0) / scale).max() < 1e-12
    for x in X[ok][::10]:
        Na, Nb = a.quattro_gimre(x), b.quattro_gimre(x)
        assert np.abs(Na - Nb).max() < 1e-12 * np.abs(Na).max()
        pa_, pb_ = a.quattro_points(x), b.quattro_points(x)
        for k in "ABC":
            assert np.abs(pa_[k] - pb_[k]).max() < 1e-14


def test_described_quattro_facts_follow_the_description():
    """The comparison can fail: a forearm 1 % longer, an arm 1 % heavier on one side only move
    the indices that read them (the kinematic ones, the dynamic ones)."""
    X = poses(60, seed=9)
    a = Model("quattro_described")
    Ia, sa = a.quattro_indices(X)
    ok = sa == 0
    rods = {f"leg[{i}].L": 0.825 * 1.01 for i in range(1, 5)}
    Ib, _ = Model("quattro_described", params=rods).quattro_indices(X[ok])
    assert np.abs(Ib[:, 0] - Ia[ok, 0]).max() > 1e-4 * np.abs(Ia[ok, 0]).max()   # mu_T
    Ic, _ = Model("quattro_described", params={"arm[1].mass": 1.45 * 1.01}).quattro_indices(X[ok])
    assert np.array_equal(Ic[:, :7], Ia[ok, :7])                                     # kinematic: unchanged
    assert np.abs(Ic[:, 12] - Ia[ok, 12]).max() > 1e-6 * np.abs(Ia[ok, 12]).max()   # kat


def test_described_quattro_constants_and_cycle_time_equal_the_hand_written_ones():
    """The constants cosim.quattro reads (torque limit, Adept origin, link length) and a
    time-optimal cycle of Virzi 2010 ch. 6 (cosim.quattro.cycle_time) on either model."""
    from cosim.quattro import cycle_time as ct

    for st in ("default", "appendix_a"):
        a, b = Model("quattro", param_set=st), Model("quattro_described", param_set=st)
        ca, cb = a.quattro_constants(), b.quattro_constants()
        assert ca.keys() == cb.keys() and all(abs(ca[k] - cb[k]) < 1e-15 * abs(ca[k]) for k in ca)
        assert ca["base_height"] == a.param("base.h") and ca["link_length"] == a.param("arm.b_r")
    ta, tb = ct.cycle_time(a, z=-1.0, n=100), ct.cycle_time(b, z=-1.0, n=100)
    assert abs(ta - tb) < 1e-9 * ta


@pytest.mark.parametrize("st", ["default", "appendix_a"])
def test_described_quattro_motion_equals_the_hand_written_one_over_the_workspace(st):
    """Inverse kinematics, Jacobian and inverse dynamics within 1e-12, forward dynamics within
    1e-10, at the reachable poses of the workspace (tests/core/test_described.py: near home,
    1e-10): measured 1e-13 (ID), 3e-11 (FD, whose solve of M and J amplifies the rounding
    near the workspace's edge)."""
    a, b = Model("quattro", param_set=st), Model("quattro_described", param_set=st)
    X = poses()
    X = X[a.quattro_indices(X)[1] == 0]
    rng = np.random.default_rng(7)
    XD, XDD = rng.uniform(-2, 2, X.shape), rng.uniform(-20, 20, X.shape)

    def rel(p, q):
        return np.abs(p - q).max() / np.abs(p).max()
    assert rel(a.ik(X), b.ik(X)) < 1e-12 and rel(a.jacobian(X), b.jacobian(X)) < 1e-12
    T = a.inverse_dynamics(X, XD, XDD)
    assert rel(T, b.inverse_dynamics(X, XD, XDD)) < 1e-12
    assert rel(a.forward_dynamics(X, XD, T), b.forward_dynamics(X, XD, T)) < 1e-10
