"""The Quattro the core serves from robots/quattro.toml against the hand-written Quattro kept
as a test oracle (c_core/tests/oracles/, robot "quattro_hand" of libpkm_oracle.so): two
implementations written apart, the description's kinematics and dynamics compiled from the
file, the hand-written ones from the source's equations (Virzi 2010).

Run by tests/core/test_described.py and tests/quattro/test_described_facts.py with PKM_LIB
pointing at libpkm_oracle.so (the hand-written model exists in no library the package ships):
``python oracle_quattro.py CHECK [CASE]`` prints "ok" or exits non-zero with the failed
assertion.  The parameter names differ (the description is per arm and leg, the hand-written
model lumped: docs/robots.md), so each side gets its own names for the same machine; with a
payload the hand-written payload.J (about the tool axis, turned tool.ratio = 4 times per
articulation radian) is the description's platform.Izz = 4^2 payload.J."""
import sys

import numpy as np

from cosim.core import Model

from described_checks import rel, samples

CASES = {
    "default": (None, {}, {}),
    "appendix_a": ("appendix_a", {}, {}),
    "payload": (None, {"payload.m": 0.6, "payload.J": 2e-3}, {"payload.m": 0.6, "platform.Izz": 16 * 2e-3}),
}


def pair(case):
    st, pa, pb = CASES[case]
    return Model("quattro_hand", param_set=st, params=pa), Model("quattro", param_set=st, params=pb)


def workspace_poses(n=400, seed=4):
    """Poses over the whole workspace grid of the thesis' maps, unreachable ones included."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.6, 0.6, n), rng.uniform(-0.6, 0.6, n), rng.uniform(-1.3, -0.7, n),
                            rng.uniform(-0.8, 0.8, n)])


def motion(case):
    """IK, Jacobians, both dynamics, mass matrix, joint accelerations, energy and singularity
    measures at 1000 random states near home to 1e-10."""
    a, b = pair(case)
    X, XD, XDD = samples(a, 1000, seed=11)
    assert rel(a.ik(X), b.ik(X)) < 1e-10
    assert rel(a.jacobian(X), b.jacobian(X)) < 1e-10
    T = a.inverse_dynamics(X, XD, XDD)
    assert rel(T, b.inverse_dynamics(X, XD, XDD)) < 1e-10
    assert rel(a.forward_dynamics(X, XD, T), b.forward_dynamics(X, XD, T)) < 1e-10
    for x, xd, xdd in zip(X[::10], XD[::10], XDD[::10]):
        Jx_a, Jq_a, J_a = a.jacobians(x)
        Jx_b, Jq_b, J_b = b.jacobians(x)
        # the hand-written closure is |C - B|^2 - c^2, the description's half of it
        assert rel(Jx_a, 2 * Jx_b) < 1e-10 and rel(Jq_a, 2 * Jq_b) < 1e-10 and rel(J_a, J_b) < 1e-10
        assert rel(a.jacobian_dot(x, xd), b.jacobian_dot(x, xd)) < 1e-10
        assert rel(a.mass_matrix(x), b.mass_matrix(x)) < 1e-10
        assert rel(a.joint_acceleration(x, xd, xdd), b.joint_acceleration(x, xd, xdd)) < 1e-10
        assert rel(np.array(a.energy(x, xd)), np.array(b.energy(x, xd))) < 1e-10
        assert rel(a.singularity(x), b.singularity(x)) < 1e-10
    xq = a.home() + np.array([0.03, -0.02, 0.05, 0.1])
    np.testing.assert_allclose(a.chain_points(xq), b.chain_points(xq), rtol=0, atol=1e-15)


def differs(_case):
    """The comparison can fail: one parameter of the description moved by 1 % shows."""
    a = Model("quattro_hand")
    X, XD, XDD = samples(a, 200, seed=3)
    for params in ({"arm[2].com_angle": -0.0745 * 1.01}, {"platform.ends": 0.075 * 1.01}):
        b = Model("quattro", params=params)
        assert rel(a.inverse_dynamics(X, XD, XDD), b.inverse_dynamics(X, XD, XDD)) > 1e-6


def facts(case):
    """The 22 indices, the GIMRE and the joint points over the workspace, the same status."""
    a, b = pair(case)
    assert b.has("quattro_indices") and b.has("quattro_gimre") and b.has("quattro_points")
    X = workspace_poses()
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


def constants(case):
    """The constants cosim.quattro reads (torque limit, Adept origin, link length) and a
    time-optimal cycle of Virzi 2010 ch. 6 (cosim.quattro.cycle_time) on either model."""
    from cosim.quattro import cycle_time as ct

    a, b = pair(case)
    ca, cb = a.quattro_constants(), b.quattro_constants()
    assert ca.keys() == cb.keys() and all(abs(ca[k] - cb[k]) < 1e-15 * abs(ca[k]) for k in ca)
    assert ca["base_height"] == a.param("base.h") and ca["link_length"] == a.param("arm.b_r")
    assert ca["tau_arm_max"] == a.param("gear.ratio") * a.param("motor.tau_nominal")
    ta, tb = ct.cycle_time(a, z=-1.0, n=100), ct.cycle_time(b, z=-1.0, n=100)
    assert abs(ta - tb) < 1e-9 * ta


def workspace_motion(case):
    """IK, Jacobian and inverse dynamics within 1e-12, forward dynamics within 1e-10, at the
    reachable poses of the workspace: measured 1e-13 (ID), 3e-11 (FD, whose solve of M and J
    amplifies the rounding near the workspace's edge)."""
    a, b = pair(case)
    X = workspace_poses()
    X = X[a.quattro_indices(X)[1] == 0]
    rng = np.random.default_rng(7)
    XD, XDD = rng.uniform(-2, 2, X.shape), rng.uniform(-20, 20, X.shape)
    assert rel(a.ik(X), b.ik(X)) < 1e-12 and rel(a.jacobian(X), b.jacobian(X)) < 1e-12
    T = a.inverse_dynamics(X, XD, XDD)
    assert rel(T, b.inverse_dynamics(X, XD, XDD)) < 1e-12
    assert rel(a.forward_dynamics(X, XD, T), b.forward_dynamics(X, XD, T)) < 1e-10


CHECKS = {f.__name__: f for f in (motion, differs, facts, constants, workspace_motion)}

if __name__ == "__main__":
    CHECKS[sys.argv[1]](sys.argv[2] if len(sys.argv) > 2 else "default")
    print("ok")
