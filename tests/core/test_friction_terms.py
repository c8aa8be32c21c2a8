"""The drive layer's friction and the generic joint force's Coulomb levels, term by term, against
their closed forms (numpy): the core evaluates a smooth sign or a Stribeck exponential only on a
joint whose coefficient is nonzero, so joints with and without each term are mixed here, and a
joint without any friction must add exactly nothing but its viscous and offset terms."""
import numpy as np

from cosim.core import Model


def _joints(m, n=200, seed=3):
    rng = np.random.default_rng(seed)
    q = m.ik(m.home()) + rng.normal(0, 1e-3, (n, m.ndof))
    qd = rng.normal(0, 5e-3, (n, m.ndof))
    qd[:5] = 0.0  # at rest: every smooth sign is zero
    return q, qd, np.zeros((n, m.ndof))


def test_friction_terms_on_some_joints_match_their_closed_form():
    m = Model("6pus")
    j = m.facts.joint_prefix
    p = {f"{j}[1].coulomb": 0.3, f"{j}[2].stribeck": 0.2, f"{j}[2].stribeck_v": 0.004, f"{j}[3].coulomb": 0.5,
         f"{j}[3].coulomb_v": 0.002, f"{j}[3].stribeck": 0.1, f"{j}[4].viscous": 2.0, f"{j}[5].offset": -0.4}
    m.set_params(p)
    q, qd, qdd = _joints(m)
    f = m.add_drive_efforts(q, qd, qdd, np.zeros_like(q))
    v_eps = m.param("drive.v_eps")
    want = np.zeros_like(q)
    for i in range(m.ndof):
        g = {k: m.param(f"{j}[{i + 1}].{k}") for k in ("coulomb", "coulomb_v", "stribeck", "stribeck_v", "viscous",
                                                        "offset")}
        vc = g["coulomb_v"] if g["coulomb_v"] > 0 else v_eps
        v = qd[:, i]
        want[:, i] = (g["coulomb"] * np.tanh(v / vc) + g["stribeck"] * np.exp(-(v / g["stribeck_v"]) ** 2)
                      * np.tanh(v / v_eps) + g["viscous"] * v + g["offset"])
    assert np.allclose(f, want, rtol=1e-12, atol=1e-15)
    assert np.all(f[:, 5] == 0.0)  # no friction on joint 6
    assert np.all(f[:5, :3] == 0.0)  # at rest the Coulomb and Stribeck terms vanish
    assert np.array_equal(f[:, 3], 2.0 * qd[:, 3]) and np.all(f[:, 4] == -0.4)


def test_joint_force_coulomb_levels_on_one_joint_match_their_closed_form():
    m = Model("6pus")
    j = m.facts.joint_prefix
    m.set_params({f"{j}[2].force_cpos": 0.3, f"{j}[2].force_cneg": 0.1, f"{j}[2].force_cv": 0.003,
                  f"{j}[4].force_k1": 50.0, f"{j}[4].force_qc": 0.05, f"{j}[5].force_v2": 4.0})
    q, qd, qdd = _joints(m)
    f = m.add_drive_efforts(q, qd, qdd, np.zeros_like(q))
    s = np.tanh(qd[:, 1] / 0.003)
    assert np.allclose(f[:, 1], 0.3 * np.maximum(s, 0) + 0.1 * np.minimum(s, 0), rtol=1e-12, atol=1e-15)
    assert np.allclose(f[:, 3], 50.0 * (q[:, 3] - 0.05), rtol=1e-12)
    assert np.allclose(f[:, 4], 4.0 * qd[:, 4] * np.abs(qd[:, 4]), rtol=1e-12)
    assert np.all(f[:, [0, 2, 5]] == 0.0)
