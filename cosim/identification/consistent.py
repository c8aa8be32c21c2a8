"""Physically consistent standard parameters whose base parameters fit given ones.

A link's ten standard parameters are a rigid body's (positive mass, inertia about the centre
positive definite with the triangle inequalities) exactly when its pseudo-inertia matrix

    J = [[S, h], [h', m]],   S = tr(I_o) / 2 * 1 - I_o    (I_o: inertia about the frame origin)

is positive definite (Wensing, Kim & Slotine 2018, sec. III).  Writing J = U U' with U upper
triangular (ten numbers) makes every value of the unknowns a
rigid body; rotor inertia, viscous and Coulomb friction are kept >= 0 by bounds.  The fit
minimises ``|L (P phi(theta) - beta)|^2`` (L' L: the base parameters' information matrix),
the weighted least-squares cost of the recording itself, plus a small pull towards the
starting standard parameters that fixes the directions no recording sees.
"""
from __future__ import annotations

import numpy as np
import scipy.optimize

_TRIU = np.triu_indices(4)
NONNEG = ("rotor_inertia", "viscous", "coulomb")


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


def _upper_from_J(J) -> np.ndarray:
    # J = U U' with U upper triangular: the Cholesky factor of the flipped matrix, flipped back
    return np.linalg.cholesky(J[::-1, ::-1])[::-1, ::-1][_TRIU].copy()


def _basis():
    """M (10, 16): standard parameters = M vec(J) (linear), and E_k, the unknowns' unit matrices."""
    M = np.array([from_pseudo_inertia(e.reshape(4, 4)) for e in np.eye(16)]).T
    E = []
    for i, j in zip(*_TRIU):
        e = np.zeros((4, 4))
        e[i, j] = 1.0
        E.append(e)
    return M, E


_M, _E = _basis()


def _link(t):
    """One link's standard parameters and their derivatives (10, 10) by its unknowns t."""
    U = np.zeros((4, 4))
    U[_TRIU] = t
    phi = _M @ (U @ U.T).ravel()
    D = np.stack([_M @ (e @ U.T + U @ e.T).ravel() for e in _E], axis=1)
    return phi, D


def _unpack(theta, nlinks, ndrive):
    parts = [_link(theta[10 * i:10 * i + 10]) for i in range(nlinks)]
    phi = np.concatenate([p for p, _ in parts] + [theta[10 * nlinks:10 * nlinks + ndrive]])
    D = np.zeros((phi.size, theta.size))
    for i, (_, Di) in enumerate(parts):
        D[10 * i:10 * i + 10, 10 * i:10 * i + 10] = Di
    D[10 * nlinks:, 10 * nlinks:] = np.eye(ndrive)
    return phi, D


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
    cost_increase : float
        ``|L (P phi - beta)|^2``: the increase of the weighted sum of squared residuals over
        the unconstrained fit, in units of the residuals' variance (chi-square with about as
        many degrees of freedom as the constraints that bind).
    """
    ndrive = len(phi0) - 10 * nlinks
    theta0 = np.concatenate([_upper_from_J(pseudo_inertia(phi0[10 * i:10 * i + 10])) for i in range(nlinks)]
                            + [phi0[10 * nlinks:]])
    lo = np.full(theta0.size, -np.inf)
    for k, n in enumerate(names[10 * nlinks:]):
        if n.rsplit(".", 1)[1] in NONNEG:
            lo[10 * nlinks + k] = 0.0
            theta0[10 * nlinks + k] = max(theta0[10 * nlinks + k], 1e-9)
    d = np.sum((L @ P) ** 2, axis=0)  # each standard parameter's own information
    w = np.sqrt(prior * np.maximum(d, 1e-9 * d.max()))

    A = L @ P

    def res(theta):
        phi = _unpack(theta, nlinks, ndrive)[0]
        return np.concatenate([A @ phi - L @ beta, w * (phi - phi0)])

    def jac(theta):
        D = _unpack(theta, nlinks, ndrive)[1]
        return np.concatenate([A @ D, w[:, None] * D])

    sol = scipy.optimize.least_squares(res, theta0, jac=jac, bounds=(lo, np.full(theta0.size, np.inf)),
                                       method="trf", x_scale="jac", xtol=1e-10, ftol=1e-10, gtol=1e-8,
                                       max_nfev=300)
    phi = _unpack(sol.x, nlinks, ndrive)[0]
    return phi, float(np.sum((L @ (P @ phi - beta)) ** 2))
