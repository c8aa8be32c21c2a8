"""The identifiable (base) parameters of a regressor: QR with column pivoting.

Of the standard parameters, some never change the efforts (a link's moments about its own
joint axis that the chain never moves) and others only in fixed combinations (a link's
mass with its outer neighbours'): the regressor W has rank r < p.  The base parameters
(Gautier 1990; Khalil & Dombre 2002, sec. 12.4) are r independent columns B of W, chosen
by a QR decomposition with column pivoting, each with the dependent columns D regrouped on
it: ``beta = phi_B + K phi_D``, ``K = R_BB^-1 R_BD``, so that ``W phi = W_B beta`` for every
phi.  The rank is the number of diagonal entries of R above ``tol`` times the largest (the
columns first scaled to unit norm, so that the tolerance does not depend on the units).

Example
-------
>>> import numpy as np
>>> from cosim.identification.base import base_parameters
>>> W = np.array([[1.0, 2.0, 0.0], [3.0, 6.0, 0.0], [0.0, 0.0, 1.0]])
>>> b = base_parameters(W, ["a", "b", "c"])
>>> b.names, b.combination(0)
(['a', 'c'], 'a + 2 b')
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..errors import InputError


@dataclass
class BaseParameters:
    """The base parameters of a regressor.

    ``independent`` (r,) and ``dependent`` (p - r,) are column indices of the standard
    parameters, ``K`` (r, p - r) the regrouping, ``names`` the independent columns' names,
    ``standard`` all standard names; :meth:`project` maps standard parameters to base ones.
    """

    independent: np.ndarray
    dependent: np.ndarray
    K: np.ndarray
    names: list
    standard: list

    @property
    def matrix(self) -> np.ndarray:
        """P (r, p) with ``beta = P phi``."""
        P = np.zeros((len(self.independent), len(self.standard)))
        P[np.arange(len(self.independent)), self.independent] = 1.0
        P[:, self.dependent] = self.K
        return P

    def project(self, phi) -> np.ndarray:
        """Base parameters of standard parameters ``phi`` (p,) or (n, p)."""
        return np.asarray(phi) @ self.matrix.T

    def combination(self, j: int, digits: int = 6) -> str:
        """Base parameter ``j`` written out: ``link[3].ZZ + 0.5 link[4].m + ...``."""
        terms = [self.standard[self.independent[j]]]
        for k, d in enumerate(self.dependent):
            c = self.K[j, k]
            if c != 0.0:
                terms.append(f"{'-' if c < 0 else '+'} {abs(c):.{digits}g} {self.standard[d]}")
        return " ".join(terms)


def base_parameters(W, names, tol: float = 1e-8) -> BaseParameters:
    """The base parameters of regressor ``W`` (m, p) with column names ``names``.

    Parameters
    ----------
    W : array_like, shape (m, p)
        A regressor over a motion that excites the arm (rows: samples x joints); a column
        whose norm is below 1e-11 of the largest is rounding (a parameter the motion does
        not move) and counts as zero.
    names : sequence of str
        The p columns' names (the standard parameters).
    tol : float
        Relative rank tolerance on the pivoted R's diagonal, columns scaled to unit norm [1].

    Returns
    -------
    BaseParameters
        Entries of K below 1e-8 (relative to the column scales) are set to zero: they are
        rounding, not a regrouping.
    """
    W = np.asarray(W, dtype=float)
    if W.ndim != 2 or W.shape[1] != len(names):
        raise InputError(f"regressor of shape {W.shape} does not have one column per name ({len(names)})")
    if not np.all(np.isfinite(W)):
        raise InputError("regressor holds a NaN or an infinite value")
    scale = np.linalg.norm(W, axis=0)
    live = scale > 1e-11 * scale.max()  # below: rounding of a column the motion does not move
    Ws = W[:, live] / scale[live]
    _, R, piv = scipy.linalg.qr(Ws, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    if d.size == 0 or d[0] == 0:
        raise InputError("the motion moves no parameter: the regressor is zero")
    r = int(np.sum(d > tol * d[0]))
    cols = np.flatnonzero(live)
    ind, dep_live = cols[piv[:r]], cols[piv[r:]]
    Ks = scipy.linalg.solve_triangular(R[:r, :r], R[:r, r:])
    K_live = Ks * scale[dep_live][None, :] / scale[ind][:, None]
    K_live[np.abs(Ks) < 1e-8] = 0.0
    dead = np.flatnonzero(~live)
    dep = np.concatenate([dep_live, dead]).astype(int)
    K = np.concatenate([K_live, np.zeros((r, dead.size))], axis=1)
    order = np.argsort(ind)  # the independent columns in the standard order
    return BaseParameters(ind[order], dep, K[order], [names[i] for i in ind[order]], list(names))
