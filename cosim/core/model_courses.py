"""Time courses of a model's named parameters (a mixin of :class:`cosim.core.Model`): a
parameter that drifts during a simulation, as a trend or a step in time (core
``pkm_param_set_course``).  The course acts in the core's integrator only (:class:`Simulator`,
the closed loops); every other function uses the parameter's own value.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, raise_for
from ..errors import ArgumentError
from ._handles import _errbuf

#: course kinds by name, as the core numbers them (pkm_course_kind)
KINDS = {"none": 0, "trend": 1, "step": 2}


class CourseMethods:
    """The time-course methods of :class:`cosim.core.Model` (which holds the core handle
    ``_m`` and ``_index``)."""

    def set_course(self, name: str, kind: str | None, *, rate: float = 0.0, size: float = 0.0,
                   t0: float = 0.0) -> None:
        """Give parameter ``name`` a course in time, inside the core's integrator.

        Parameters
        ----------
        name : str
            A parameter (:meth:`param_names`), e.g. ``"rail[2].coulomb"`` or ``"payload.m"``.
        kind : {"trend", "step", None}
            ``"trend"``: p(t) = p + rate (t - t0), a drive-layer parameter only (friction,
            offsets, joint forces, rotor inertia); ``"step"``: p(t) = p before t0, p + size from
            t0 on, any parameter but the joint limits and the delays; None (or ``"none"``):
            no course.  p is the parameter's value (:meth:`param`).
        rate : float
            The trend's rate [the parameter's unit per s].
        size : float
            The step's size [the parameter's unit].
        t0 : float
            The trend's reference time (where it is p) or the step's time [s, the
            simulation's time, >= 0].

        Raises
        ------
        ParameterError
            An unknown parameter, a trend on a mechanism parameter, a parameter that cannot
            change with time, a step beyond the parameter's range.
        ArgumentError
            An unknown kind, a non-finite rate or size, a negative or non-finite t0.

        Example
        -------
        >>> m = Model("6pus", params={"rail[2].coulomb": 0.12})
        >>> m.set_course("rail[2].coulomb", "trend", rate=-0.01, t0=0.0)   # N/s
        >>> round(m.value_at("rail[2].coulomb", 4.0), 6)
        0.08
        """
        key = "none" if kind is None else kind
        if key not in KINDS:
            raise ArgumentError(f"course of {name}: unknown kind {kind!r} (trend, step or None)", "PKM_ERR_ARGUMENT")
        change = rate if key == "trend" else size if key == "step" else 0.0
        err = _errbuf()
        s = lib.pkm_param_set_course(self._m, self._index(name), KINDS[key], float(change), float(t0), err, len(err))
        raise_for(s, err.value.decode())
        names = self.__dict__.setdefault("_coursed", set())  # what courses() and copy() look at
        (names.discard if key == "none" else names.add)(name)

    def course(self, name: str) -> dict | None:
        """The course of ``name``: ``{"kind", "rate" or "size", "t0"}``, or None."""
        k, change, t0 = C.c_int(), C.c_double(), C.c_double()
        raise_for(lib.pkm_param_course(self._m, self._index(name), C.byref(k), C.byref(change), C.byref(t0)), name)
        kind = {v: n for n, v in KINDS.items()}[k.value]
        if kind == "none":
            return None
        return {"kind": kind, "rate" if kind == "trend" else "size": change.value, "t0": t0.value}

    def courses(self) -> dict:
        """Every parameter's course: {name: :meth:`course`}, the parameters without one left out."""
        names = self.__dict__.get("_coursed", ())
        return {n: c for n in sorted(names) if (c := self.course(n)) is not None}

    def value_at(self, name: str, t):
        """The value of ``name`` at time(s) ``t`` [s] under its course [its unit]; a float for
        a scalar ``t``, else an array of ``t``'s shape."""
        i = self._index(name)
        tt = np.asarray(t, dtype=float)
        out = np.empty(tt.shape)
        v = C.c_double()
        for k, ti in np.ndenumerate(tt):
            raise_for(lib.pkm_param_value_at(self._m, i, float(ti), C.byref(v)), f"{name} at t = {ti} s")
            out[k] = v.value
        return float(out) if out.ndim == 0 else out
