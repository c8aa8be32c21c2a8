"""The physically consistent fit (cosim/identification/consistent.py) on small synthetic cases
whose optimum is checked without the solver: a closed form (the nearest positive semidefinite
matrix in the Frobenius norm: the eigenvalues clipped at zero) and the Karush-Kuhn-Tucker
conditions of the convex program, the multipliers computed here from the gradient alone."""
import numpy as np
import pytest

from cosim.identification.consistent import FLOOR, consistent_fit, is_consistent, pseudo_inertia

# vec(J) = T phi for one link's ten standard parameters (J row by row)
T = np.array([pseudo_inertia(e).ravel() for e in np.eye(10)]).T
DRIVE = ("rotor_inertia", "viscous", "coulomb", "offset")


def _names(nlinks, njoints):
    return ([f"link[{i}].p{k}" for i in range(1, nlinks + 1) for k in range(10)]
            + [f"joint[{j}].{n}" for j in range(1, njoints + 1) for n in DRIVE])


def _body(rng, m):
    """A rigid body's ten standard parameters: mass m in eight points about a random centre
    (J = sum of m_k [x_k; 1] [x_k; 1]')."""
    x = np.hstack([rng.normal(0, 0.2, 3) + rng.normal(0, 0.1, (8, 3)), np.ones((8, 1))])
    return _phi(m / 8 * x.T @ x)


def _phi(J):
    return np.linalg.solve(T.T @ T, T.T @ J.ravel())


def test_a_link_the_data_make_non_rigid_comes_back_as_the_nearest_rigid_one():
    """P = 1 and L with |L (phi - beta)| = |J(phi) - J(beta)|_F per link: the optimum is beta's J
    with its negative eigenvalues set to zero (up to the margin and the pull, 1e-6 relative)."""
    rng = np.random.default_rng(3)
    good, bad = _body(rng, 5.0), _body(rng, 2.0)
    Jb = pseudo_inertia(bad)
    lam, V = np.linalg.eigh(Jb)
    lam[0] = -0.3 * lam[-1]  # one negative eigenvalue: no rigid body's
    bad = _phi(V @ np.diag(lam) @ V.T)
    drive = np.array([0.2, -0.5, 1.5, -0.7])  # a negative viscous friction: clipped; a negative offset: kept
    beta = np.concatenate([good, bad, drive])
    assert is_consistent(good) and not is_consistent(bad)
    Lk = np.linalg.cholesky(T.T @ T).T
    L = np.zeros((24, 24))
    L[:10, :10] = L[10:20, 10:20] = Lk
    L[20:, 20:] = np.eye(4)
    phi0 = np.concatenate([_body(rng, 4.0), _body(rng, 3.0), [0.1, 0.1, 0.1, 0.0]])
    phi, cost = consistent_fit(np.eye(24), L, beta, phi0, _names(2, 1), 2)
    lam_c = np.maximum(lam, 0.0)
    want = np.concatenate([good, _phi(V @ np.diag(lam_c) @ V.T),
                           [0.2, 0.0, 1.5, -0.7]])
    assert is_consistent(phi[:10]) and is_consistent(phi[10:20])
    assert np.max(np.abs(phi - want)) < 1e-4 * np.max(np.abs(beta)), np.abs(phi - want)
    # the cost is the squared distance removed: the negative eigenvalue and the viscous term
    assert cost == pytest.approx(lam[0] ** 2 + 0.5 ** 2, rel=1e-4)


def _duality_gap(phi, A, b, w, phi0, names, nlinks):
    """f(phi) less a lower bound of the optimum of min f = |A phi - b|^2 + |w (phi - phi0)|^2,
    every link's J >= 0, the drive terms in NONNEG >= 0: the Lagrange dual function at the
    multipliers read off the gradient at phi (link i's Lambda_i with T' vec(Lambda_i) = the
    gradient's block, unique) made feasible (Lambda_i's negative eigenvalues and negative
    multipliers of the drive terms set to zero).  Zero at the optimum, >= f(phi) - optimum."""
    G, q = A.T @ A + np.diag(w ** 2), A.T @ b + w ** 2 * phi0
    f = np.sum((A @ phi - b) ** 2) + np.sum((w * (phi - phi0)) ** 2)
    s = 2 * (G @ phi - q)  # the gradient: at the optimum, the constraints' multipliers
    for i in range(nlinks):
        lam, V = np.linalg.eigh((T @ np.linalg.solve(T.T @ T, s[10 * i:10 * i + 10])).reshape(4, 4))
        s[10 * i:10 * i + 10] = T.T @ (V @ np.diag(np.maximum(lam, 0.0)) @ V.T).ravel()
    for k, n in enumerate(names[10 * nlinks:]):
        s[10 * nlinks + k] = max(s[10 * nlinks + k], 0.0) if n.rsplit(".", 1)[1] != "offset" else 0.0
    # min over phi of f(phi) - s' phi (the Lagrangian): phi' G phi - (2 q + s)' phi + |b|^2 + |w phi0|^2
    v = q + s / 2
    return f - (b @ b + np.sum((w * phi0) ** 2) - v @ np.linalg.solve(G, v)), f


def test_the_optimum_of_a_nearly_free_problem_satisfies_the_kkt_conditions():
    """Three links and six drive terms seen through 28 combinations of their 42 standard
    parameters, the information spread over eight decades (a weak excitation), the data made
    by a link of negative mass.  The fit's result is a KKT point of the convex program: its
    global optimum."""
    rng = np.random.default_rng(7)
    nl, nj = 3, 3
    p = 10 * nl + 4 * nj
    truth = np.concatenate([_body(rng, 8.0), -_body(rng, 1.5), _body(rng, 3.0), np.tile([0.3, 2.0, 1.0, 0.0], nj)])
    r = p - 14
    P = np.linalg.qr(rng.normal(size=(p, r)))[0].T
    U = np.linalg.qr(rng.normal(size=(r, r)))[0]
    L = U @ np.diag(np.logspace(2, -6, r)) @ np.linalg.qr(rng.normal(size=(r, r)))[0]
    beta = P @ truth + np.linalg.solve(L, rng.normal(size=r))
    phi0 = np.concatenate([_body(rng, 6.0), _body(rng, 2.0), _body(rng, 2.5), np.tile([0.1, 1.0, 1.0, 0.0], nj)])
    names = _names(nl, nj)
    phi, cost = consistent_fit(P, L, beta, phi0, names, nl)
    A = L @ P
    d = np.sum(A ** 2, axis=0)
    w = np.sqrt(1e-6 * np.maximum(d, FLOOR * d.max()))  # the pull of consistent_fit
    gap, f = _duality_gap(phi, A, L @ beta, w, phi0, names, nl)
    assert gap < 1e-6 * f, (gap, f)  # measured 4.3e-8 f
    assert all(is_consistent(phi[10 * i:10 * i + 10]) for i in range(nl))
    assert cost == pytest.approx(np.sum((L @ (P @ phi - beta)) ** 2))


def test_what_no_recording_sees_stays_at_its_start():
    """Only ZZ, mx and my of a 400 kg link are seen, ZZ at four times the start's: the link's
    XX + YY must grow with it (J's corner S_zz = (XX + YY - ZZ) / 2 >= 0); the mass, which no
    datum and no constraint asks to move, stays at the start (measured 400.28 kg; with the pull's
    floor at 1e-9 of the largest information in place of FLOOR, 270 kg: an interior-point
    solver's barrier, not the pull, then places it)."""
    rng = np.random.default_rng(1)
    phi0 = _body(rng, 400.0)
    seen = [9, 1, 2]  # ZZ, mx, my
    beta = phi0[seen] * [4.0, 1.0, 1.0]
    phi, cost = consistent_fit(np.eye(10)[seen], np.eye(3), beta, phi0, [f"link[1].p{k}" for k in range(10)], 1)
    assert phi[9] == pytest.approx(beta[0], rel=1e-5) and cost < 1e-6
    assert phi[0] == pytest.approx(400.0, rel=1e-2), phi[0]
    assert is_consistent(phi)


@pytest.mark.filterwarnings("ignore:Solution may be inaccurate")  # cvxpy's, for the stopped solver
def test_a_solver_that_stops_short_is_an_error_naming_its_status_and_links(monkeypatch):
    """Clarabel stopped after one iteration (link 1 not yet a rigid body) or three (every link
    one, the optimum not reached): no parameters, a RuntimeError."""
    import cosim.identification.consistent as consistent

    rng = np.random.default_rng(3)
    phi0, beta = _body(rng, 5.0), -_body(rng, 2.0)
    names = [f"link[1].p{k}" for k in range(10)]
    for iters, where in ((1, r"link 1: pseudo-inertia's least eigenvalue -"), (3, "every link a rigid body")):
        monkeypatch.setattr(consistent, "TOLERANCES", {**consistent.TOLERANCES, "max_iter": iters})
        with pytest.raises(RuntimeError, match=rf"program ended 'user_limit' in CLARABEL \({where}"):
            consistent_fit(np.eye(10), np.eye(10), beta, phi0, names, 1)
