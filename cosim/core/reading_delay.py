"""The readings' delay line of a closed loop (``pkm_reading_delay``, drive parameter
``sensor.delay``): the line the core's compiled loop keeps in its sim, for the stepwise
loop of :mod:`cosim.closed_loop` around any plant.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, ptr, raise_for
from ..errors import ArgumentError
from ._handles import _errbuf, _release


class ReadingDelay:
    """The delay line of the joint readings of ``model`` (its ``sensor.delay`` now).

    Parameters
    ----------
    model : cosim.core.Model
        The plant's model; its drive parameter ``sensor.delay`` [s] is read at creation.

    Example
    -------
    >>> from cosim.core import Model
    >>> m = Model("6pus", params={"sensor.delay": 2e-3})
    >>> line = ReadingDelay(m)
    >>> q, qd = line.read(0.0, m.ik(m.home()), [0.0] * 6)     # the first sample's reading
    """

    def __init__(self, model):
        self.ndof = model.ndof
        err = _errbuf()
        h = lib.pkm_reading_delay_create(model._m, err, len(err))
        if not h:
            raise_for(-2 if "validate" in err.value.decode() else -1, err.value.decode())
        self._r = C.c_void_p(h)

    def __del__(self):
        _release(self, "_r", "pkm_reading_delay_destroy")

    def read(self, t: float, q, qd) -> tuple[np.ndarray, np.ndarray]:
        """Record the sample ``(t, q, qd)`` [s, m or rad, per s]; return the reading and rate
        of ``t - sensor.delay`` (interpolated linearly between the samples around it, the
        first sample's before it), or ``q, qd`` without a delay."""
        out = []
        for name, v in (("q", q), ("qd", qd)):
            a = np.array(v, dtype=float)  # a copy: the core writes the delayed value into it
            if a.shape != (self.ndof,):
                raise ArgumentError(f"reading delay: {name} has shape {a.shape}, expected ({self.ndof},)",
                                    "PKM_ERR_ARGUMENT")
            out.append(a)
        st = lib.pkm_reading_delay_read(self._r, float(t), ptr(out[0]), ptr(out[1]))
        if st != 0:
            raise_for(st, lib.pkm_reading_delay_error(self._r).decode())
        return out[0], out[1]

    def reset(self) -> None:
        """Forget every sample (a new run)."""
        lib.pkm_reading_delay_reset(self._r)
