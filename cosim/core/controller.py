"""The core's sampled joint-space controllers (``pkm_ctrl``): a controller of
:mod:`cosim.controllers` compiled into the core (docs/scenarios.md), the one place its law
runs, whichever loop calls it.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, pkm_ctrl_spec, ptr, raise_for
from ..errors import ArgumentError, InputError
from ._handles import _release


#: controller kinds the core implements (pkm.h pkm_ctrl_kind)
KINDS = {"pd": 0, "pd_gravity": 1, "computed_torque": 2, "pid": 3, "lti": 4, "discrete": 5}
#: laws of the discrete controller (pkm.h PKM_LAW_*)
DISCRETE_LAWS = {"cascade_pp": 0, "pid": 1}


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
            raise InputError(f"controller kind {kind!r} is not one the core implements ({sorted(KINDS)})")
        self.kind = kind
        own_dt = getattr(controller, "dt", None)
        if own_dt is not None and abs(float(own_dt) - float(dt)) > 1e-9 * float(dt):
            raise InputError(f"the {kind} controller was designed for a sample period of {own_dt:g} s; the loop "
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
        if kind == "discrete":
            spec.law = DISCRETE_LAWS[controller.law]
            spec.kv = arr("kv", (nd, nd))
            for side in ("pos", "vel"):
                filt = controller.position_filter if side == "pos" else controller.velocity_filter
                if filt is not None:
                    b = np.ascontiguousarray(filt["b"], dtype=float)
                    a = np.ascontiguousarray(filt["a"], dtype=float)
                    keep[side] = (b, a)
                    setattr(spec, f"{side}_nb", b.size)
                    setattr(spec, f"{side}_na", a.size)
                    setattr(spec, f"{side}_b", ptr(b))
                    setattr(spec, f"{side}_a", ptr(a))
            spec.velocity_source = int(controller.velocity == "measured")
            if controller.limits is not None:
                lo, hi = (np.ascontiguousarray(v, dtype=float) for v in controller.limits)
                keep["limits"] = (lo, hi)
                spec.u_min, spec.u_max = ptr(lo), ptr(hi)
            g = np.ascontiguousarray(controller.output_gain, dtype=float)
            keep["output_gain"] = g
            spec.output_gain = ptr(g)
            spec.delay_samples = int(controller.delay_samples)
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
            raise InputError(f"{kind} controller: {err.value.decode()}")
        self._c = C.c_void_p(h)

    def __del__(self):
        _release(self, "_c", "pkm_ctrl_destroy")

    def reset(self, x0=None) -> None:
        """Clear the controller's states; ``x0`` seeds the forward kinematics [m, rad]."""
        x = None if x0 is None else np.ascontiguousarray(x0, dtype=float)
        self._check(lib.pkm_ctrl_reset(self._c, ptr(x)))

    def __call__(self, t, q, qd, ref) -> np.ndarray:
        """One sample, as the Python controllers: ``tau`` [N or N m] from readings and reference."""
        a = [np.ascontiguousarray(v, dtype=float) if v is not None else None
             for v in (q, qd, ref.q, ref.qd, ref.qdd, ref.x)]
        for name, v in zip(("q", "qd", "qref", "qdref", "qddref", "xref"), a):
            if v is not None and v.shape != (self.ndof,):
                raise ArgumentError(f"{self.kind} at t = {float(t):.6g} s: {name} has shape {v.shape}, expected "
                                    f"({self.ndof},)", "PKM_ERR_ARGUMENT")
        tau = np.empty(self.ndof)
        self._check(lib.pkm_ctrl_update(self._c, float(t), *[ptr(v) for v in a], ptr(tau)))
        return tau

    def prime(self, t, q, qd, ref: dict) -> None:
        """Seed the controller's history with past samples (``pkm_ctrl_prime``): their
        readings and reference go through the controller, outputs discarded, so that a run
        starting after them starts where a controller that saw them would be.

        Parameters
        ----------
        t : array_like, shape (n,)
            Sample times [s], oldest first.
        q, qd : array_like, shape (n, nd)
            Readings [m or rad, per s].
        ref : dict
            ``q``, ``qd`` (n, nd) and optionally ``qdd``, ``x`` (None where not needed).

        Example
        -------
        >>> cc.reset(x0); cc.prime(rec.time[k0 - 50:k0], rec.q[k0 - 50:k0], rec.qd[k0 - 50:k0],
        ...                        {"q": rec.qref[k0 - 50:k0], "qd": rec.qdref[k0 - 50:k0]})  # doctest: +SKIP
        """
        t = np.ascontiguousarray(t, dtype=float).ravel()
        n, nd = t.size, self.ndof

        def rows(v, name, required=True):
            if v is None:
                if required:
                    raise ArgumentError(f"controller prime: {name} is required", "PKM_ERR_ARGUMENT")
                return None
            a = np.ascontiguousarray(v, dtype=float)
            if a.shape != (n, nd):
                raise ArgumentError(f"controller prime: {name} has shape {a.shape}, expected ({n}, {nd})",
                                    "PKM_ERR_ARGUMENT")
            return a

        a = [rows(q, "q"), rows(qd, "qd"), rows(ref.get("q"), "ref q"), rows(ref.get("qd"), "ref qd"),
             rows(ref.get("qdd"), "ref qdd", False), rows(ref.get("x"), "ref x", False)]
        self._check(lib.pkm_ctrl_prime(self._c, n, ptr(t), *[ptr(v) for v in a]))

    @property
    def saturated(self) -> int:
        """Samples at which the saturation clipped an effort since the last reset."""
        return int(lib.pkm_ctrl_saturated(self._c))

    def state(self) -> np.ndarray:
        """Everything that determines the future outputs, as a 1-D array (``pkm_ctrl_state_save``)."""
        buf = np.empty(int(lib.pkm_ctrl_state_size(self._c)))
        self._check(lib.pkm_ctrl_state_save(self._c, ptr(buf)))
        return buf

    def load_state(self, state) -> None:
        """Restore a state of :meth:`state`; one of another controller raises ``ArgumentError``."""
        buf = np.ascontiguousarray(state, dtype=float).ravel()
        if buf.size != int(lib.pkm_ctrl_state_size(self._c)):
            raise ArgumentError(f"controller state: {buf.size} values, this controller has "
                                f"{int(lib.pkm_ctrl_state_size(self._c))}", "PKM_ERR_ARGUMENT")
        self._check(lib.pkm_ctrl_state_load(self._c, ptr(buf), buf.size))

    def _check(self, status):
        if status != 0:
            raise_for(status, lib.pkm_ctrl_error(self._c).decode())
