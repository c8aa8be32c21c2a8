"""A drive's command-to-effort map (``pkm_effort_map``): what a torque sensor or a motor
current reads against the commanded effort: a gain, an offset, a limit and a first-order
lag (docs/recording.md, "Two effort channels").
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, ptr, raise_for


def effort_map(u, dt: float, *, gain: float = 1.0, offset: float = 0.0, lag: float = 0.0,
               limit: float = np.inf, y0: float = 0.0) -> np.ndarray:
    """The effort a drive delivers for the commanded efforts ``u`` (``pkm_effort_map``).

    The command ``u[k]`` is held over one sample; the drive makes
    ``e_k = clip(gain u[k], +-limit) + offset`` and the delivered effort follows it with a
    first-order lag: ``y[k] = a y[k-1] + (1 - a) e_k``, ``a = exp(-dt / lag)``, the effort
    at the end of sample k's hold (exact for the held ``e``); ``y[-1] = y0``.  The effort
    read at sample k is ``y[k-1]``.

    Parameters
    ----------
    u : array_like, shape (n,)
        Commanded effort [N or N m].
    dt : float
        Sample period [s].
    gain, offset : float
        Delivered per commanded effort [-], and a constant [N or N m].
    lag : float
        Time constant [s] (0: none).
    limit : float
        Largest delivered ``|gain u|`` [N or N m] (inf: none).
    y0 : float
        Delivered effort before the first sample.

    Returns
    -------
    numpy.ndarray, shape (n,)

    Example
    -------
    >>> import numpy as np
    >>> y = effort_map(np.ones(3), 1e-3, gain=0.5, lag=1e-3)
    >>> np.round(y, 4)
    array([0.3161, 0.4323, 0.4751])
    """
    u = np.ascontiguousarray(np.asarray(u, dtype=float).ravel())
    y = np.empty_like(u)
    err = C.create_string_buffer(512)
    lim = 0.0 if not np.isfinite(limit) and limit > 0 else float(limit)
    st = lib.pkm_effort_map(u.size, float(dt), ptr(u), float(gain), float(offset), float(lag), lim, float(y0),
                            ptr(y), err, len(err))
    raise_for(st, err.value.decode())
    return y
