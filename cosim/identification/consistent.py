"""Physically consistent standard parameters whose base parameters fit given ones.

A link's ten standard parameters are a rigid body's (positive mass, inertia about the centre
positive definite with the triangle inequalities) exactly when its pseudo-inertia matrix

    J = [[S, h], [h', m]],   S = tr(I_o) / 2 * 1 - I_o    (I_o: inertia about the frame origin)

is positive definite (Wensing, Kim & Slotine 2018, sec. III).  J is linear in the parameters,
so the fit is a convex semidefinite program (sec. IV): it minimises ``|L (P phi - beta)|^2``
(L' L: the base parameters' information matrix), the weighted least-squares cost of the
recording itself, plus a small pull towards the starting standard parameters that fixes the
directions no recording sees (and makes the optimum unique), subject to every link's
``J >= eps I`` (eps: :data:`MARGIN` of the largest eigenvalue of the link's starting J) and
rotor inertia, viscous and Coulomb friction >= 0.  cvxpy states it, the interior-point solver
Clarabel solves it to its tolerances.
"""
from __future__ import annotations

import warnings

import numpy as np

NONNEG = ("rotor_inertia", "viscous", "coulomb")
MARGIN = 1e-6  # each link's J >= MARGIN * (largest eigenvalue of its starting J) * 1
SOLVER = "CLARABEL"
# the duality gap's tolerances (Clarabel's default 1e-8): on the KUKA KR300's recording (an information
# matrix of condition about 1e9) the gap stalls at 3e-8 in double precision, which 1e-8 would call inaccurate
TOLERANCES = {"tol_gap_abs": 1e-7, "tol_gap_rel": 1e-7}
# the pull's weight on a parameter is prior * (its own information, at least FLOOR of the largest):
# what no recording sees (a first link's mass) is held by a curvature the solver resolves
FLOOR = 1e-3


def pseudo_inertia(phi) -> np.ndarray:
    """J (4, 4) of one link's standard parameters (m, mx, my, mz, XX, XY, XZ, YY, YZ, ZZ)."""
    m, hx, hy, hz, XX, XY, XZ, YY, YZ, ZZ = phi
    Io = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    J = np.empty((4, 4))
    J[:3, :3] = 0.5 * np.trace(Io) * np.eye(3) - Io
    J[:3, 3] = J[3, :3] = (hx, hy, hz)
    J[3, 3] = m
    return J


def from_pseudo_inertia(J) -> np.ndarray:
    """The ten standard parameters of a pseudo-inertia J (inverse of :func:`pseudo_inertia`)."""
    S = J[:3, :3]
    Io = np.trace(S) * np.eye(3) - S
    return np.array([J[3, 3], *J[:3, 3], Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2]])


def is_consistent(phi, margin: float = 0.0) -> bool:
    """True if one link's standard parameters are a rigid body's (J positive definite)."""
    return bool(np.linalg.eigvalsh(pseudo_inertia(phi))[0] > margin)


# standard parameters of one link = _M vec(J) (linear; vec row by row, J symmetric)
_M = np.array([from_pseudo_inertia(e.reshape(4, 4)) for e in np.eye(16)]).T


def _problem(R, c, phi0, names, nlinks):
    """The program min |R phi - c|^2 over phi, every link's J >= eps I, the drive terms >= 0.

    Each link's unknown is X (4, 4) positive semidefinite, J = D X D + eps 1 with D the square
    roots of the starting J's diagonal (X of order one whatever the link's size)."""
    import cvxpy as cp

    parts, cons = [], []
    for i in range(nlinks):
        J0 = pseudo_inertia(phi0[10 * i:10 * i + 10])
        dg = np.sqrt(np.maximum(np.diag(J0), 1e-12 * np.abs(J0).max()))
        eps = MARGIN * np.linalg.eigvalsh(J0)[-1]
        X = cp.Variable((4, 4), PSD=True, name=f"link{i + 1}")
        J = cp.multiply(np.outer(dg, dg), X) + eps * np.eye(4)
        parts.append(_M @ cp.vec(J, order="C"))
    nd = len(phi0) - 10 * nlinks
    if nd:
        scale = np.maximum(np.abs(phi0[10 * nlinks:]), 1.0 / np.maximum(np.linalg.norm(R[:, 10 * nlinks:], axis=0),
                                                                        1e-300))
        y = cp.Variable(nd, name="drive")
        parts.append(cp.multiply(scale, y))
        low = [k for k, n in enumerate(names[10 * nlinks:]) if n.rsplit(".", 1)[1] in NONNEG]
        if low:
            cons.append(y[low] >= 0)
    phi = cp.hstack(parts)
    return cp.Problem(cp.Minimize(cp.sum_squares(R @ phi - c)), cons), phi


def consistent_fit(P, L, beta, phi0, names, nlinks: int, prior: float = 1e-6):
    """Standard parameters phi, every link a rigid body, nearest to base parameters ``beta``.

    Parameters
    ----------
    P : ndarray (r, p)
        Base parameters of standard ones: ``beta = P phi``.
    L : ndarray (r, r)
        Square root of the base parameters' information matrix (the weighted regressor's R).
    beta : ndarray (r,)
        The unconstrained least-squares base parameters.
    phi0 : ndarray (p,)
        Start: consistent standard parameters (every link's J positive definite).
    names : list of str
        The standard parameters' names (the drive terms' bounds go by name).
    nlinks : int
        Links first in phi, ten parameters each.
    prior : float
        Weight of the pull to ``phi0``, relative to the information's scale [1].

    Returns
    -------
    phi : ndarray (p,)
        Every link's J positive definite (:func:`is_consistent`), rotor inertia, viscous and
        Coulomb friction >= 0.
    cost_increase : float
        ``|L (P phi - beta)|^2``: the increase of the weighted sum of squared residuals over
        the unconstrained fit, in units of the residuals' variance (chi-square with about as
        many degrees of freedom as the constraints that bind).

    Raises
    ------
    RuntimeError
        The solver ends without an optimum, or with one in which a link is not a rigid body.
    """
    phi0 = np.asarray(phi0, float)
    A = L @ P
    d = np.sum(A ** 2, axis=0)  # each standard parameter's own information
    w = np.sqrt(prior * np.maximum(d, FLOOR * d.max()))
    # |A phi - L beta|^2 + |w (phi - phi0)|^2 = |R phi - c|^2 + a constant
    Q, R = np.linalg.qr(np.vstack([A, np.diag(w)]))
    c = Q.T @ np.concatenate([L @ beta, w * phi0])
    from cvxpy.error import SolverError

    prob, expr = _problem(R, c, phi0, names, nlinks)
    try:
        prob.solve(solver=SOLVER, **TOLERANCES)
    except SolverError as e:  # the solver stopped on a numerical failure
        raise RuntimeError(f"the consistent fit's semidefinite program failed in {SOLVER}: {e}") from e
    phi = None if expr.value is None else np.array(expr.value, float)
    bad = [] if phi is None else [(i + 1, np.linalg.eigvalsh(pseudo_inertia(phi[10 * i:10 * i + 10]))[0])
                                  for i in range(nlinks) if not is_consistent(phi[10 * i:10 * i + 10])]
    if prob.status not in ("optimal", "optimal_inaccurate") or phi is None or bad:
        where = ("no parameters returned" if phi is None else
                 "; ".join(f"link {i}: pseudo-inertia's least eigenvalue {v:.3g}" for i, v in bad)
                 or "every link a rigid body")
        raise RuntimeError(f"the consistent fit's semidefinite program ended '{prob.status}' in {SOLVER} ({where})")
    if prob.status == "optimal_inaccurate":
        warnings.warn(f"the consistent fit's semidefinite program is solved to reduced accuracy ({SOLVER})",
                      RuntimeWarning, stacklevel=2)
    for k, n in enumerate(names[10 * nlinks:]):
        if n.rsplit(".", 1)[1] in NONNEG:  # >= 0 up to the solver's tolerance: exactly
            phi[10 * nlinks + k] = max(phi[10 * nlinks + k], 0.0)
    return phi, float(np.sum((L @ (P @ phi - beta)) ** 2))
