"""The compiled closed loop: plant, sampled controller and reference table in one C call.

:func:`cosim.master.run` steps a plant and a Python controller sample by sample.  When
the plant is the core (:class:`~cosim.master.CorePlant`) and the controller is one the
core implements (``pkm_ctrl``: PD, PD + gravity, computed torque, PID, discrete LTI),
the same loop runs inside the core (``pkm_closed_loop``) with no Python call per
sample; ``run`` takes that path by itself and says so (``RunResult.loop``).  The
sequence of operations is the master's, so both paths give the same samples (to the
last bits of the controller's arithmetic).

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl, trajectories as tr
>>> from cosim.master import CorePlant, make_reference, run
>>> m = Model("6pus")
>>> ref = make_reference(m, tr.step(m.home(), m.home() + [0, 0, 0.01, 0, 0, 0]), duration=2.0)
>>> res = run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), ref)
>>> res.loop
'compiled'
"""
from __future__ import annotations

import numpy as np

from ._native import STATUS, raise_for
# The controller's handle and the loop's C call live in the binding (cosim.core owns every
# foreign call); this module chains the calls and reports.
from .core import KINDS, LOOP_FIELDS, CompiledController, closed_loop_call

__all__ = ["CompiledController", "compile_controller", "run_compiled", "KINDS"]


def compile_controller(controller, *, model, dt: float):
    """``(CompiledController, "")`` for a controller the core implements, else ``(None, reason)``."""
    kind = getattr(controller, "kind", None)
    if kind not in KINDS:
        return None, (f"the controller ({type(controller).__name__}) is a Python callable the core does not "
                      f"implement (compiled kinds: {', '.join(KINDS)})")
    try:
        return CompiledController(controller, model=model, dt=dt), ""
    except ValueError as e:
        return None, str(e)


def run_compiled(sim, ctrl: CompiledController, *, time, dt: float, qref, qdref, qddref=None, xref=None,
                 q_noise=None, qd_noise=None, measure: bool = False, chunk: int | None = None,
                 on_chunk=None) -> tuple[dict, int, int, str]:
    """Run ``pkm_closed_loop`` over the samples ``time`` from the simulator's current state.

    Parameters
    ----------
    sim : cosim.simulate.Simulator
        The plant, at its start state.
    ctrl : CompiledController
        Reset before the call (``ctrl.reset(x0)``).
    time : array_like, shape (n,)
        Sample times [s]; the plant advances from ``time[k]`` to ``time[k] + dt``.
    qref, qdref, qddref, xref : array_like, shape (n, nd)
        Reference rows (``qddref``, ``xref`` optional).
    q_noise, qd_noise : array_like, shape (n, nd), optional
        Noise added to the joint readings the controller sees.
    measure : bool
        Read the joints through the plant's sensor model (``pkm_measure_joints``).
    chunk : int, optional
        Samples per C call (the loop goes on exactly across calls); ``on_chunk(k)`` is
        called after each with the samples done, e.g. for a progress bar.

    Returns
    -------
    (rows, n_done, status, message)
        ``rows`` maps ``q, qd, q_true, qd_true, x, xd, tau_cmd, tau`` to (n, nd) arrays
        of which the first ``n_done`` rows are filled; ``status`` is 0 or the core's
        status of the failure, ``message`` its text (naming the time).
    """
    t = np.ascontiguousarray(time, dtype=float)
    n, nd = t.size, ctrl.ndof
    arrs = {k: (None if v is None else np.ascontiguousarray(v, dtype=float).reshape(n, nd))
            for k, v in (("q", qref), ("qd", qdref), ("qdd", qddref), ("x", xref), ("qn", q_noise),
                         ("qdn", qd_noise))}
    rows = {f: np.full((n, nd), np.nan) for f in LOOP_FIELDS}
    step = n if not chunk else max(1, int(chunk))
    k0 = 0
    while k0 < n:
        k1 = min(n, k0 + step)
        # A chunk ends one sample into the next (the plant advances after each sample but
        # the last of a call): each call's last sample is the next call's first, redone.
        before = None if k0 == 0 else rows["tau"][k0 - 1]
        st, done, message = closed_loop_call(sim, ctrl, t=t, dt=dt, ref=arrs, rows=rows, k0=k0, k1=k1,
                                             tau_before=before, q_noise=arrs["qn"], qd_noise=arrs["qdn"],
                                             measure=measure)
        if st != 0:
            return rows, k0 + done, st, message
        if k1 == n:
            return rows, n, 0, ""
        # The last sample of this call was recorded but not advanced: advance it with the
        # command it produced, then the next call starts at its successor.
        sim.set_input(rows["tau_cmd"][k1 - 1])
        try:
            sim.advance(float(t[k1 - 1]) + float(dt))
        except Exception as e:  # noqa: BLE001 - reported as the loop's failure at this sample
            status = getattr(e, "status", "PKM_ERR_INTERNAL")
            code = next((c for c, (name, _) in STATUS.items() if name == status), -9)
            return rows, k1 - 1, code, (f"closed loop stopped at sample {k1 - 1} (t = {t[k1 - 1]:.6g} s): {e}")
        k0 = k1
        if on_chunk is not None:
            on_chunk(k0)
    return rows, n, 0, ""


def raise_status(status: int, message: str) -> None:
    """Raise the core's exception class for a loop failure."""
    raise_for(status, message)
