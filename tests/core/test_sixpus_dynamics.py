"""6-PUS dynamics through the Python binding: forward(inverse) on batches, mass matrix
and kinetic energy, power balance and gravity load checked against the energy, and the
rail reaction forces that keep a platform with vertical-ish legs from "falling"."""
import numpy as np
import pytest

from cosim.errors import UnreachableError
from cosim.core import Model

DEG = np.pi / 180


def states(m, n, rng):
    x = np.column_stack([rng.uniform(-0.04, 0.04, (n, 2)), rng.uniform(0.03, 0.1, n),
                         rng.uniform(-5, 5, (n, 3)) * DEG])
    _, st = m.ik(x, errors="status")
    x = x[st == 0]
    k = len(x)
    xd = np.column_stack([rng.uniform(-0.3, 0.3, (k, 3)), rng.uniform(-2, 2, (k, 3))])
    xdd = np.column_stack([rng.uniform(-5, 5, (k, 3)), rng.uniform(-50, 50, (k, 3))])
    return x, xd, xdd


@pytest.fixture()
def m():
    return Model("6pus", params={"payload.m": 0.2, "payload.x": 0.01, "payload.y": -0.02, "payload.z": 0.03})


def test_forward_of_inverse_on_a_batch(m):
    m.set_params({f"rail[{i}].coulomb": 2.0 for i in range(1, 7)} | {f"rail[{i}].viscous": 5.0 for i in range(1, 7)})
    x, xd, xdd = states(m, 3000, np.random.default_rng(1))
    tau = m.inverse_dynamics(x, xd, xdd)
    back = m.forward_dynamics(x, xd, tau)
    err = np.abs(back - xdd).max(axis=1) / np.abs(xdd).max(axis=1)
    assert err.max() < 1e-9


def test_mass_matrix_and_kinetic_energy(m):
    x, xd, _ = states(m, 100, np.random.default_rng(2))
    M = m.mass_matrix(x)
    np.testing.assert_allclose(M, np.swapaxes(M, -1, -2), rtol=0, atol=1e-15 * np.abs(M).max())
    assert (np.linalg.eigvalsh(M) > 0).all()
    ke, _ = m.energy(x, xd)
    np.testing.assert_allclose(ke, 0.5 * np.einsum("ni,nij,nj->n", xd, M, xd), rtol=1e-12)


def test_power_balance_and_gravity_load_from_the_energy(m):
    rng = np.random.default_rng(3)
    x, xd, xdd = states(m, 30, rng)
    h = 1e-6
    for xi, vi, ai in zip(x, xd, xdd):
        tau = m.inverse_dynamics(xi, vi, ai)
        qd = m.joint_velocity(xi, vi)

        def E(s):
            k, p = m.energy(xi + s * vi + 0.5 * s * s * ai, vi + s * ai)
            return k + p

        d1, d2 = (E(h) - E(-h)) / (2 * h), (E(2 * h) - E(-2 * h)) / (4 * h)
        assert (4 * d1 - d2) / 3 == pytest.approx(tau @ qd, abs=1e-6 * np.abs(tau * qd).max())
        # Virtual work: J^T g = dPE/dx.
        g = m.gravity_load(xi)
        dPE = [(m.energy(xi + h * e, 0 * vi)[1] - m.energy(xi - h * e, 0 * vi)[1]) / (2 * h) for e in np.eye(6)]
        np.testing.assert_allclose(m.jacobian(xi).T @ g, dPE, rtol=0, atol=1e-6 * np.abs(dPE).max())


def test_a_leg_perpendicular_to_its_rail_hands_its_load_to_the_rail():
    # Zavala-Yoe et al. 2015 sec. 5: a model with leg-axis forces only loses its hold on the platform
    # as a leg turns perpendicular to its rail (s.w -> 0) and the platform "falls".  With
    # the rail reactions in the model, that actuator's holding effort goes to zero with
    # s.w (the rail carries the load), the others stay finite, and the platform stays put.
    m = Model("6pus", params={"leg[1].L": 0.086})     # leg 1 turns perpendicular below the others' reach
    zs = np.sqrt(0.086**2 - 0.008**2)
    x = m.home().copy()
    ratios, g1 = [], []
    for dz in (1e-3, 1e-5, 1e-7):
        x[2] = zs - dz
        g = m.gravity_load(x)
        c1 = np.sqrt(0.086**2 - 0.008**2 - x[2] ** 2)      # s.w of leg 1
        assert np.isfinite(g).all() and np.abs(g).max() < 100
        ratios.append(g[0] / c1)
        g1.append(abs(g[0]))
        assert np.abs(m.forward_dynamics(x, np.zeros(6), g)).max() < 1e-6
    assert abs(ratios[-1] / ratios[0] - 1) < 0.15          # tau_1 = O(s.w) -> 0
    assert g1[-1] < 2e-2 * g1[0]
