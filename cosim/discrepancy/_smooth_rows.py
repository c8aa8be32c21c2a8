"""The pipeline's smoothing (:meth:`.residuals.Pipeline.S_inner`) at a few rows only.

An evaluation of the residual reads its smoothed efforts at the decimated samples alone, a
fifth of a window apart: smoothing every row (``scipy.ndimage.convolve1d``) computes five to
ten times the values read.  :func:`smoothed_rows` computes those rows only, with the
operations scipy's correlation makes for a symmetric filter, in its order, so that each value
is the one ``convolve1d`` gives, bit for bit (``tests/discrepancy/test_smooth_rows.py``).

scipy (``NI_Correlate1D``, ``ni_filters.c``) correlates with the reversed weights ``fw``
(``convolve1d`` reverses them); an odd filter whose weights mirror each other within
``DBL_EPSILON`` is taken as symmetric, and each output is then
``x[i] fw[h] + (x[i-h] + x[i+h]) fw[0] + ... + (x[i-1] + x[i+1]) fw[h-1]``, the sums made from
the farthest pair inwards, the left weight for both.  Any other filter, or rows not evenly
spaced, is smoothed whole and indexed (the same values).
"""
from __future__ import annotations

import numpy as np
from scipy.ndimage import convolve1d

DBL_EPSILON = float(np.finfo(float).eps)


def symmetric(weights) -> bool:
    """Does scipy's correlation take the convolution weights ``weights`` as a symmetric filter
    (an odd number of them, each pair within ``DBL_EPSILON``)?"""
    w = np.asarray(weights, float)
    h = len(w) // 2
    return len(w) % 2 == 1 and all(abs(w[h + i] - w[h - i]) <= DBL_EPSILON for i in range(1, h + 1))


def smoothed_rows(a, weights, rows) -> np.ndarray:
    """``convolve1d(a, weights, axis=0, mode="constant")[rows]``, bit for bit, computed at
    ``rows`` alone where ``weights`` is a symmetric filter and ``rows`` an evenly spaced
    sequence whose windows lie inside ``a`` (else the whole convolution, indexed).

    Parameters
    ----------
    a : array (n, ...) of float
        The signals, rows in time.
    weights : array (w,)
        The convolution weights (``Pipeline._coeffs``).
    rows : array (m,) of int
        The rows wanted.

    Example
    -------
    >>> from scipy.signal import savgol_coeffs
    >>> a, w = np.random.default_rng(0).normal(size=(300, 2)), savgol_coeffs(21, 3)
    >>> rows = np.arange(20, 280, 5)
    >>> np.array_equal(smoothed_rows(a, w, rows), convolve1d(a, w, axis=0, mode="constant")[rows])
    True
    """
    a = np.asarray(a, float)
    rows = np.asarray(rows)
    h = len(weights) // 2
    step = int(rows[1] - rows[0]) if len(rows) > 1 else 1
    even = (len(rows) > 1 and rows.dtype.kind in "iu" and step > 0
            and np.array_equal(rows, np.arange(rows[0], rows[0] + step * len(rows), step)))
    if not (even and rows[0] - h >= 0 and rows[-1] + h < len(a) and symmetric(weights)):
        return convolve1d(a, weights, axis=0, mode="constant")[rows]
    fw = np.asarray(weights, float)[::-1]  # the correlation's weights
    lo, hi = int(rows[0]), int(rows[-1]) + 1
    out = a[lo:hi:step] * fw[h]
    for j in range(h, 0, -1):
        out += (a[lo - j:hi - j:step] + a[lo + j:hi + j:step]) * fw[h - j]
    return out
