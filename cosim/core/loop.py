"""One call of the core's closed loop (``pkm_closed_loop``: plant, controller and reference
table in C); :mod:`cosim.closed_loop` chains the calls.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, pkm_loop_record, pkm_loop_reference, ptr
from .simulator import Simulator
from .controller import CompiledController


#: the recorded channels of ``pkm_closed_loop`` (pkm_loop_record), in its order, named as the
#: fields of :class:`cosim.run_record.RunRecord` (``tau_applied``: the record's ``tau``)
LOOP_FIELDS = ("q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd", "tau_applied", "tau_inj")


def closed_loop_call(sim: Simulator, ctrl: CompiledController, *, t, dt: float, ref: dict, rows: dict,
                     k0: int, k1: int, tau_before=None, q_noise=None, qd_noise=None,
                     measure: bool = False, f_ext=None, inject=None, inject_point: int = 0
                     ) -> tuple[int, int, str]:
    """One ``pkm_closed_loop`` call over samples ``k0:k1`` (see
    :func:`cosim.closed_loop.run_compiled`, which chains calls).

    ``ref`` maps ``q, qd, qdd, x`` to C-contiguous (n, nd) arrays (``qdd``, ``x`` may be
    None); ``rows`` maps :data:`LOOP_FIELDS` to (n, nd) arrays that receive the samples
    (a missing one is not recorded).  ``inject`` (n, nd) is a signal injected at
    ``inject_point`` (``pkm_inject_point``, :data:`cosim.core.controller.INJECT_POINTS`).
    Returns ``(status, samples done in this call, message)``.
    """
    m = k1 - k0

    def at(a):
        return None if a is None else ptr(a[k0:k1])

    before = None if tau_before is None else np.ascontiguousarray(tau_before, dtype=float)
    spec = pkm_loop_reference(m, float(t[k0]), float(dt), at(t), at(ref["q"]), at(ref["qd"]), at(ref.get("qdd")),
                              at(ref.get("x")), ptr(before), at(f_ext), int(inject_point if inject is not None else 0),
                              at(inject))
    rec = pkm_loop_record(*[at(rows.get(f)) for f in LOOP_FIELDS])
    done = C.c_size_t(0)
    st = lib.pkm_closed_loop(sim._s, ctrl._c, C.byref(spec), at(q_noise), at(qd_noise), int(bool(measure)),
                             C.byref(rec), C.byref(done))
    return st, int(done.value), (lib.pkm_sim_error(sim._s).decode() if st else "")
