"""Per-sample calls of core functions that have no batched form, without numpy overhead.

``cosim.core.Model`` loops over samples in Python with a pointer cast per argument
(about 25 us per sample); a diagnosis calls ``pkm_pose_velocity``,
``pkm_pose_acceleration`` and ``pkm_measure_joints`` on every sample of a recording
many times, so this module opens its own handle on the same shared library (the
loader returns the already-loaded image) with ``void*`` argument types and passes
plain integer addresses (about 1 us per sample).  Nothing here computes physics.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, library_path, raise_for

_DLL = None
_FNS: dict = {}

# name -> number of pointer arguments after (model, data)
_ARITY = {
    "pkm_pose_velocity": 3,
    "pkm_pose_acceleration": 4,
    "pkm_joint_velocity": 3,
    "pkm_measure_joints": 4,
    "pkm_actuator_effort": 2,
    "pkm_joint_friction": 2,
}


def _fn(name):
    global _DLL
    if name not in _FNS:
        if _DLL is None:
            lib.pkm_status_name  # the shared binding loads (and checks) the library first
            _DLL = C.CDLL(str(library_path()))
        f = _DLL[name]  # item access: a private function object, the shared one keeps its argtypes
        f.restype = C.c_int
        f.argtypes = [C.c_void_p] * (2 + _ARITY[name])
        _FNS[name] = f
    return _FNS[name]


def per_sample(model, name, *inputs, what="sample", times=None):
    """Call ``name(m, d, in_1[k], ..., out[k])`` for every row k; returns ``out`` (n, nd).

    Raises the core's error for the first failing row, naming the row and, if
    ``times`` is given, its time.
    """
    f = _fn(name)
    arrs = [np.ascontiguousarray(a, dtype=np.float64) for a in inputs]
    n, nd = arrs[0].shape
    out = np.empty((n, nd))
    stride = 8 * nd
    addr = [a.ctypes.data for a in arrs]
    oaddr = out.ctypes.data
    m, d = model._m, model._d
    if len(arrs) == 1:
        a0 = addr[0]
        for k in range(n):
            o = k * stride
            s = f(m, d, a0 + o, oaddr + o)
            if s:
                _fail(model, s, name, k, what, times)
    elif len(arrs) == 2:
        a0, a1 = addr
        for k in range(n):
            o = k * stride
            s = f(m, d, a0 + o, a1 + o, oaddr + o)
            if s:
                _fail(model, s, name, k, what, times)
    else:
        a0, a1, a2 = addr
        for k in range(n):
            o = k * stride
            s = f(m, d, a0 + o, a1 + o, a2 + o, oaddr + o)
            if s:
                _fail(model, s, name, k, what, times)
    return out


def _fail(model, status, name, k, what, times):
    msg = lib.pkm_data_error(model._d).decode()
    when = f" (t = {times[k]:.6g} s)" if times is not None else ""
    raise_for(status, f"{name} failed at {what} {k}{when}: {msg}")


def pose_velocity(model, x, qd, times=None):
    """Pose rates xd (n, nd) of joint rates qd at poses x (core ``pkm_pose_velocity``)."""
    return per_sample(model, "pkm_pose_velocity", x, qd, times=times)


def pose_acceleration(model, x, xd, qdd, times=None):
    """Pose accelerations (n, nd) (core ``pkm_pose_acceleration``)."""
    return per_sample(model, "pkm_pose_acceleration", x, xd, qdd, times=times)


def measure_joints(model, x, xd, tau, times=None):
    """Joint readings (n, nd) of the model's sensors at (x, xd) with applied effort tau
    (core ``pkm_measure_joints``: encoder offset, backlash, compliance)."""
    return per_sample(model, "pkm_measure_joints", x, xd, tau, times=times)


def actuator_effort(model, tau_cmd, times=None):
    """Effort reaching the mechanism for commanded efforts (n, nd) (core saturation)."""
    return per_sample(model, "pkm_actuator_effort", tau_cmd, times=times)
