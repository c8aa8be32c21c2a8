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

import ctypes as C

import numpy as np

from ._native import lib, pkm_ctrl_spec, pkm_loop_record, pkm_loop_reference, ptr, raise_for

__all__ = ["CompiledController", "compile_controller", "run_compiled", "KINDS"]

#: controller kinds the core implements (pkm.h pkm_ctrl_kind)
KINDS = {"pd": 0, "pd_gravity": 1, "computed_torque": 2, "pid": 3, "lti": 4}


def _mat(a, shape):
    if a is None:
        return None
    m = np.ascontiguousarray(np.asarray(a, dtype=float).reshape(shape))
    return m


class CompiledController:
    """A controller of :mod:`cosim.controllers` as a core ``pkm_ctrl``.

    Parameters
    ----------
    controller : cosim.controllers.JointController
        PD, PD + gravity, computed torque (or a PID / LTI controller with the
        attributes ``ki``, ``deriv_filter``, ``A``, ``B``, ``C``, ``D``).
    model : cosim.core.Model
        The model the controller believes in, when the controller has none of its own
        (PD needs none: the plant's model is given).
    dt : float
        Sample period [s].
    """

    def __init__(self, controller, *, model, dt: float):
        kind = getattr(controller, "kind", None)
        if kind not in KINDS:
            raise ValueError(f"controller kind {kind!r} is not one the core implements ({sorted(KINDS)})")
        self.kind = kind
        own_dt = getattr(controller, "dt", None)
        if own_dt is not None and abs(float(own_dt) - float(dt)) > 1e-9 * float(dt):
            raise ValueError(f"the {kind} controller was designed for a sample period of {own_dt:g} s; the loop "
                             f"runs at {dt:g} s")
        self.model = getattr(controller, "model", None) or model
        nd = self.model.ndof
        self.ndof = nd
        keep = {}

        def arr(name, shape):
            a = _mat(getattr(controller, name, None), shape)
            keep[name] = a
            return ptr(a)

        spec = pkm_ctrl_spec()
        spec.kind = KINDS[kind]
        spec.dt = float(dt)
        spec.kp = arr("kp", (nd, nd))
        spec.kd = arr("kd", (nd, nd))
        spec.ki = arr("ki", (nd, nd))
        spec.deriv_filter = float(getattr(controller, "deriv_filter", 0.0) or 0.0)
        sat = getattr(controller, "saturation", None)
        if sat is not None:
            sat = np.ascontiguousarray(np.broadcast_to(np.asarray(sat, float), (nd, nd)).diagonal()
                                       if np.ndim(sat) == 2 else np.broadcast_to(np.asarray(sat, float), (nd,)))
        keep["saturation"] = sat
        spec.saturation = ptr(sat)
        spec.gravity_at_reference = int(getattr(controller, "gravity", "measured") == "reference")
        spec.gravity_feedforward = int(bool(getattr(controller, "gravity_feedforward", False)))
        if kind == "lti":
            A = np.asarray(controller.A, float)
            spec.nx = A.shape[0]
            spec.A = arr("A", (spec.nx, spec.nx))
            spec.B = arr("B", (spec.nx, nd))
            spec.C = arr("C", (nd, spec.nx))
            spec.D = arr("D", (nd, nd))
        self._keep = keep
        err = C.create_string_buffer(1024)
        h = lib.pkm_ctrl_create(self.model._m, C.byref(spec), err, len(err))
        if not h:
            raise ValueError(f"{kind} controller: {err.value.decode()}")
        self._c = C.c_void_p(h)

    def __del__(self):
        try:
            if getattr(self, "_c", None):
                lib.pkm_ctrl_destroy(self._c)
                self._c = None
        except Exception:  # interpreter shutdown
            pass

    def reset(self, x0=None) -> None:
        """Clear the controller's states; ``x0`` seeds the forward kinematics [m, rad]."""
        x = None if x0 is None else np.ascontiguousarray(x0, dtype=float)
        self._check(lib.pkm_ctrl_reset(self._c, ptr(x)))

    def __call__(self, t, q, qd, ref) -> np.ndarray:
        """One sample, as the Python controllers: ``tau`` [N or N m] from readings and reference."""
        a = [np.ascontiguousarray(v, dtype=float) if v is not None else None
             for v in (q, qd, ref.q, ref.qd, ref.qdd, ref.x)]
        tau = np.empty(self.ndof)
        self._check(lib.pkm_ctrl_update(self._c, float(t), *[ptr(v) for v in a], ptr(tau)))
        return tau

    @property
    def saturated(self) -> int:
        """Samples at which the saturation clipped an effort since the last reset."""
        return int(lib.pkm_ctrl_saturated(self._c))

    def _check(self, status):
        if status != 0:
            raise_for(status, lib.pkm_ctrl_error(self._c).decode())


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


_FIELDS = ("q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd", "tau")


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
    rows = {f: np.full((n, nd), np.nan) for f in _FIELDS}
    step = n if not chunk else max(1, int(chunk))
    done = C.c_size_t(0)
    k0 = 0
    while k0 < n:
        k1 = min(n, k0 + step)
        # A chunk ends one sample into the next (the plant advances after each sample but
        # the last of a call): each call's last sample is the next call's first, redone.
        m = k1 - k0

        def at(a):
            return None if a is None else ptr(a[k0:k1]) if a.ndim == 1 else a[k0:k1].ctypes.data_as(
                C.POINTER(C.c_double))

        before = None if k0 == 0 else np.ascontiguousarray(rows["tau"][k0 - 1])
        ref = pkm_loop_reference(m, float(t[k0]), float(dt), at(t), at(arrs["q"]), at(arrs["qd"]), at(arrs["qdd"]),
                                 at(arrs["x"]), ptr(before))
        rec = pkm_loop_record(*[at(rows[f]) for f in _FIELDS])
        st = lib.pkm_closed_loop(sim._s, ctrl._c, C.byref(ref), at(arrs["qn"]), at(arrs["qdn"]), int(bool(measure)),
                                 C.byref(rec), C.byref(done))
        if st != 0:
            return rows, k0 + int(done.value), st, lib.pkm_sim_error(sim._s).decode()
        if k1 == n:
            return rows, n, 0, ""
        # The last sample of this call was recorded but not advanced: advance it with the
        # command it produced, then the next call starts at its successor.
        sim.set_input(rows["tau_cmd"][k1 - 1])
        try:
            sim.advance(float(t[k1 - 1]) + float(dt))
        except Exception as e:  # noqa: BLE001 - reported as the loop's failure at this sample
            status = getattr(e, "status", "PKM_ERR_INTERNAL")
            from ._native import STATUS

            code = next((c for c, (name, _) in STATUS.items() if name == status), -9)
            return rows, k1 - 1, code, (f"closed loop stopped at sample {k1 - 1} (t = {t[k1 - 1]:.6g} s): {e}")
        k0 = k1
        if on_chunk is not None:
            on_chunk(k0)
    return rows, n, 0, ""


def raise_status(status: int, message: str) -> None:
    """Raise the core's exception class for a loop failure."""
    raise_for(status, message)
