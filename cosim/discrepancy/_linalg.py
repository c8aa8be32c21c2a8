"""Least squares of the small systems a stepwise selection solves by the thousand.

``numpy.linalg.lstsq`` spends most of the time of a 2 x 2 to 10 x 10 solve checking and
converting its arguments (about 60 us against 20 us for LAPACK's ``gelsd`` itself, measured
on the engine's Gram matrices).  :func:`small_lstsq` calls the same LAPACK routine through
the same numpy kernel, with the same cut-off of small singular values, so its solution is
numpy's bit for bit (``tests/discrepancy/test_small_lstsq.py``), for float64 arrays only; where
LAPACK fails (a NaN in the system) it raises numpy's ``LinAlgError`` too, after numpy's
floating-point warning.
"""
from __future__ import annotations

import math

import numpy as np

try:  # numpy's own kernel behind numpy.linalg.lstsq
    from numpy.linalg import _umath_linalg
except ImportError:  # pragma: no cover - a numpy that moved it: the public function
    _umath_linalg = None

_EPS = float(np.finfo(np.float64).eps)


def _kernel_agrees() -> bool:
    """numpy's kernel is called as numpy calls it (a numpy whose private kernel changed its
    signature or result falls back to the public function)."""
    a, b = np.array([[4.0, 1.0], [1.0, 3.0], [0.5, 0.25]]), np.array([1.0, 2.0, 0.5])
    try:
        x = _umath_linalg.lstsq(a, b[:, None], _EPS * 3, signature="ddd->ddid")[0][:, 0]
    except Exception:  # noqa: BLE001 - any failure: the public function
        return False
    return np.array_equal(x, np.linalg.lstsq(a, b, rcond=None)[0])


if _umath_linalg is not None and not _kernel_agrees():  # pragma: no cover - another numpy
    _umath_linalg = None


def small_lstsq(a, b):
    """The least-squares solution x of ``a x = b``, as ``numpy.linalg.lstsq(a, b, rcond=None)[0]``.

    Parameters
    ----------
    a : ndarray, (m, n) float64
    b : ndarray, (m,) float64

    Returns
    -------
    ndarray, (n,)

    Example
    -------
    >>> small_lstsq(np.array([[2.0, 0.0], [0.0, 4.0]]), np.array([1.0, 1.0]))
    array([0.5 , 0.25])
    """
    m, n = a.shape
    if _umath_linalg is None or a.dtype != np.float64 or b.dtype != np.float64 or m == 0 or n == 0:
        return np.linalg.lstsq(a, b, rcond=None)[0]
    x = _umath_linalg.lstsq(a, b[:, None], _EPS * max(m, n), signature="ddd->ddid")[0][:, 0]
    if not math.isfinite(x @ x):  # LAPACK failed (a non-finite input): numpy's path and its LinAlgError
        return np.linalg.lstsq(a, b, rcond=None)[0]
    return x


def small_lstsq_many(a, b):
    """:func:`small_lstsq` of a stack of systems of one size, each solution bit for bit the one of
    its own call: numpy's kernel loops over the stack with the same LAPACK routine, workspace
    and cut-off (one call instead of one per system).

    Parameters
    ----------
    a : ndarray, (k, m, n) float64
    b : ndarray, (k, m) float64

    Returns
    -------
    ndarray, (k, n)

    Example
    -------
    >>> small_lstsq_many(np.array([[[2.0, 0.0], [0.0, 4.0]], [[1.0, 0.0], [0.0, 1.0]]]), np.ones((2, 2)))
    array([[0.5 , 0.25],
           [1.  , 1.  ]])
    """
    k, m, n = a.shape
    if _umath_linalg is None or a.dtype != np.float64 or b.dtype != np.float64 or k == 0 or m == 0 or n == 0:
        return np.array([small_lstsq(a[i], b[i]) for i in range(k)]).reshape(k, n)
    with np.errstate(invalid="ignore"):  # a system LAPACK fails on is solved again alone, as small_lstsq does
        x = _umath_linalg.lstsq(a, b[:, :, None], _EPS * max(m, n), signature="ddd->ddid")[0][:, :, 0]
    bad = ~np.isfinite(np.einsum("ij,ij->i", x, x))
    for i in np.flatnonzero(bad):
        x[i] = small_lstsq(a[i], b[i])
    return x
