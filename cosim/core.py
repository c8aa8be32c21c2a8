"""Python binding of the reference core: models, kinematics, dynamics.

Every physical quantity is computed by the C++ core (``libpkm``); this module only
moves numpy arrays across the C ABI.  Batched calls take arrays of shape ``(n, nd)``
(``nd`` = number of actuators = pose coordinates) and cost one C call, so a million
poses are one call.  Units are SI: m, rad, kg, N, N m, s.

Example
-------
>>> from cosim.core import Model
>>> m = Model("6pus")                       # default parameter set
>>> x = m.home()                            # (x, y, z, rx, ry, rz) [m, rad]
>>> q = m.ik(x)                             # slider strokes [m]
>>> m.fk(q, x_guess=x + 1e-3)               # back to the pose
array([...])
>>> m.set_params({"platform.m": 0.42})      # overrides by name, checked by the core
"""
from __future__ import annotations

import ctypes as C
import json
from dataclasses import dataclass

import numpy as np

from ._native import (
    ArgumentError,
    ParameterError,
    PkmError,
    fast,
    lib,
    pkm_fk_info,
    pkm_fk_options,
    ptr,
    raise_for,
)

__all__ = ["Model", "ParamInfo", "RobotFacts", "robots", "robot_facts", "PkmError", "ParameterError",
           "ArgumentError"]


@dataclass(frozen=True)
class ParamInfo:
    """One named parameter of a model."""

    name: str
    value: float
    unit: str
    description: str


def _errbuf():
    return C.create_string_buffer(1024)


def robots() -> list[str]:
    """Names of the robots compiled into the core (``pkm_robot_name``), e.g. ``["6pus", ...]``."""
    return [lib.pkm_robot_name(i).decode() for i in range(lib.pkm_robot_count())]


@dataclass(frozen=True)
class RobotFacts:
    """What the core says of a robot (``pkm.h`` "robot facts"); nothing in Python restates it.

    Attributes
    ----------
    name : str
        Robot name (``pkm_model_create``).
    ndof : int
        Actuated joints = pose coordinates.
    param_sets : tuple of str
        Named parameter sets, ``"default"`` first.
    pose_names, pose_units : tuple of str
        Pose coordinates (``"x"``, ..., ``"theta"``) and their units (``"m"``, ``"rad"``).
    tracker_names, tracker_units : tuple of str
        What an external tracker measures (a recording's pose columns): the pose
        coordinates, or what the robot measures instead (the four-bar: ``"X"`` in m).
    joint_unit, effort_unit : str
        Unit of the joint coordinates q (``"m"`` or ``"rad"``) and of the efforts
        (``"N"`` or ``"N m"``).
    joint_noun, joint_prefix : str
        How messages name an actuated joint, and the drive parameters' prefix
        (``"rail"`` -> ``"rail[i].coulomb"``).
    """

    name: str
    ndof: int
    param_sets: tuple
    pose_names: tuple
    pose_units: tuple
    tracker_names: tuple
    tracker_units: tuple
    joint_unit: str
    effort_unit: str
    joint_noun: str
    joint_prefix: str

    @property
    def angular_joints(self) -> bool:
        """True for revolute actuated joints (q in rad, efforts in N m)."""
        return self.joint_unit == "rad"


_FACTS: dict = {}


def robot_facts(robot: str) -> RobotFacts:
    """The :class:`RobotFacts` of a robot by name (raises ``ArgumentError`` naming the known ones)."""
    f = _FACTS.get(robot)
    if f is None:
        f = _FACTS[robot] = Model(robot).facts
    return f


class Model:
    """A robot model (constant parameters) with its own work data.

    Parameters
    ----------
    robot : str
        Robot kind, one of :func:`robots` ("6pus", "quattro", "fourbar").
    param_set : str, optional
        Named parameter set ("default"; the Quattro also has "appendix_a").
    params : dict, optional
        Parameter overrides by name, e.g. ``{"leg[1].L": 0.117}`` [SI units].

    Notes
    -----
    A ``Model`` owns one ``pkm_data`` work buffer: use one ``Model`` per thread
    (``Model.copy()`` makes an independent one).
    """

    def __init__(self, robot: str = "6pus", param_set: str | None = None, params: dict | None = None):
        err = _errbuf()
        h = C.c_void_p()
        if not isinstance(robot, str):
            raise ArgumentError(f"robot must be a name ({', '.join(robots())}), got {robot!r}", "PKM_ERR_ARGUMENT")
        s = lib.pkm_model_create_status(robot.encode(), param_set.encode() if param_set else None, C.byref(h), err,
                                        len(err))
        raise_for(s, err.value.decode())
        self._m = h
        self._d = C.c_void_p(lib.pkm_data_create(self._m))
        self.robot = lib.pkm_model_robot(self._m).decode()
        self.param_set = param_set or "default"
        self.ndof = int(lib.pkm_model_ndof(self._m))
        self._slots = {}
        if params:
            self.set_params(params)

    # ------------------------------------------------------------------ lifecycle
    def __del__(self):
        try:
            if getattr(self, "_d", None):
                lib.pkm_data_destroy(self._d)
            if getattr(self, "_m", None):
                lib.pkm_model_destroy(self._m)
        except Exception:  # interpreter shutdown
            pass

    @property
    def facts(self) -> RobotFacts:
        """The robot's :class:`RobotFacts` (coordinates, units, parameter sets) from the core."""
        m, nd, name = self._m, self.ndof, self.robot
        return RobotFacts(
            name=name, ndof=nd,
            param_sets=tuple(lib.pkm_robot_param_set_name(name.encode(), i).decode()
                             for i in range(lib.pkm_robot_param_set_count(name.encode()))),
            pose_names=tuple(lib.pkm_model_pose_name(m, i).decode() for i in range(nd)),
            pose_units=tuple(lib.pkm_model_pose_unit(m, i).decode() for i in range(nd)),
            tracker_names=tuple(lib.pkm_model_tracker_name(m, i).decode() for i in range(lib.pkm_model_tracker_count(m))),
            tracker_units=tuple(lib.pkm_model_tracker_unit(m, i).decode() for i in range(lib.pkm_model_tracker_count(m))),
            joint_unit=lib.pkm_model_joint_unit(m).decode(), effort_unit=lib.pkm_model_effort_unit(m).decode(),
            joint_noun=lib.pkm_model_joint_noun(m).decode(), joint_prefix=lib.pkm_model_joint_prefix(m).decode())

    @property
    def joint_unit(self) -> str:
        """Unit of the joint coordinates q: ``"m"`` (sliders) or ``"rad"`` (revolute)."""
        return lib.pkm_model_joint_unit(self._m).decode()

    def joint_limits(self):
        """``(qmin, qmax)`` of the actuated joints [m or rad], arrays of shape (nd,); NaN
        where the robot has no limit (the current values of the limit parameters)."""
        lo, hi = np.full(self.ndof, np.nan), np.full(self.ndof, np.nan)
        a, b = C.c_int(), C.c_int()
        for i in range(self.ndof):
            self._check(lib.pkm_model_joint_limits(self._m, i, C.byref(a), C.byref(b)))
            if a.value >= 0:
                lo[i] = lib.pkm_param_get(self._m, a.value)
            if b.value >= 0:
                hi[i] = lib.pkm_param_get(self._m, b.value)
        return lo, hi

    def copy(self) -> "Model":
        """An independent model with the same parameters (and its own work data)."""
        return Model(self.robot, self.param_set, self.params())

    def __repr__(self) -> str:
        return f"Model({self.robot!r}, ndof={self.ndof}, nparam={len(self.param_names())})"

    # ----------------------------------------------------------------- parameters
    def param_names(self) -> list[str]:
        return [lib.pkm_param_name(self._m, i).decode() for i in range(lib.pkm_model_nparam(self._m))]

    def param_info(self) -> list[ParamInfo]:
        """Name, value, unit and description of every parameter."""
        out = []
        for i in range(lib.pkm_model_nparam(self._m)):
            out.append(
                ParamInfo(
                    lib.pkm_param_name(self._m, i).decode(),
                    float(lib.pkm_param_get(self._m, i)),
                    lib.pkm_param_unit(self._m, i).decode(),
                    lib.pkm_param_description(self._m, i).decode(),
                )
            )
        return out

    def params(self) -> dict[str, float]:
        """Current parameter values by name [SI units]."""
        return {p.name: p.value for p in self.param_info()}

    def param(self, name: str) -> float:
        return float(lib.pkm_param_get(self._m, self._index(name)))

    def _index(self, name: str) -> int:
        i = lib.pkm_param_index(self._m, name.encode())
        if i < 0:
            raise ParameterError(f"{self.robot} has no parameter named {name!r}", "PKM_ERR_PARAMETER")
        return i

    def set_params(self, values: dict) -> None:
        """Set parameters by name and re-validate the whole set.

        Raises ``ParameterError`` naming the parameter if a value is out of its range
        or the set is inconsistent (the model keeps its previous values then).
        """
        old = self.params()
        err = _errbuf()
        try:
            for name, v in values.items():
                s = lib.pkm_param_set(self._m, self._index(name), float(v), err, len(err))
                raise_for(s, err.value.decode())
            s = lib.pkm_model_validate(self._m, err, len(err))
            raise_for(s, err.value.decode())
        except PkmError:
            for name, v in old.items():
                lib.pkm_param_set(self._m, self._index(name), v, err, len(err))
            lib.pkm_model_validate(self._m, err, len(err))
            raise

    def set_params_unchecked(self, values: dict) -> None:
        """Set parameters by name and validate, without saving the previous values first.

        For a working model rewritten at every evaluation (a calibration's direct search, the
        discrepancy engine's finite differences): several times cheaper than
        :meth:`set_params`.  On failure the model is left invalid (the next call rewrites it)
        and ``ParameterError`` names the cause.
        """
        idx = self.__dict__.setdefault("_fast_index", {})
        err = _errbuf()
        for name, v in values.items():
            i = idx.get(name)
            if i is None:
                i = idx[name] = self._index(name)
            raise_for(lib.pkm_param_set(self._m, i, float(v), err, len(err)), err.value.decode())
        raise_for(lib.pkm_model_validate(self._m, err, len(err)), err.value.decode())

    def to_json(self, indent: int | None = 2) -> str:
        """The parameter set as JSON: ``{"robot", "param_set", "parameters": {name: {value, unit, description}}}``."""
        return json.dumps(
            {
                "robot": self.robot,
                "param_set": self.param_set,
                "parameters": {
                    p.name: {"value": p.value, "unit": p.unit, "description": p.description}
                    for p in self.param_info()
                },
            },
            indent=indent,
        )

    # ------------------------------------------------------------------- helpers
    def _single(self, name, inputs, out_shape, extra=()):
        """One item through the core function ``name`` with preallocated argument buffers
        and integer addresses (no per-call pointer objects): ~2-3 us from Python instead of
        ~20.  None when an input is not one item of nd coordinates (a numpy array of shape
        (nd,)); the caller then takes the general path, which also says what is wrong."""
        call = self._slots.get(name)
        if call is None:
            call = self._slots[name] = self._make_single(name, len(inputs), out_shape, extra)
        return call(*inputs)

    def _make_single(self, name, nin, out_shape, extra):
        f, nd, m, d = fast(name), self.ndof, self._m, self._d
        bufs = [np.empty(nd) for _ in range(nin)]
        addrs = [b.ctypes.data for b in bufs]
        out = np.empty(out_shape)
        args = (m, d, *addrs, *extra, out.ctypes.data)
        shape, arr = (nd,), np.ndarray

        def fail(s):
            raise_for(s, lib.pkm_data_error(d).decode())

        if nin == 1:
            (b0,) = bufs

            def call(a0):
                if type(a0) is not arr or a0.shape != shape:
                    return None
                b0[:] = a0
                s = f(*args)
                return fail(s) if s else out.copy()
        else:
            b0, b1, b2 = bufs

            def call(a0, a1, a2):
                if type(a0) is not arr or type(a1) is not arr or type(a2) is not arr or \
                        a0.shape != shape or a1.shape != shape or a2.shape != shape:
                    return None
                b0[:] = a0
                b1[:] = a1
                b2[:] = a2
                s = f(*args)
                return fail(s) if s else out.copy()
        return call

    def _check(self, status: int) -> None:
        if status != 0:
            raise_for(status, lib.pkm_data_error(self._d).decode())

    def _arr(self, a, name: str) -> np.ndarray:
        a = np.ascontiguousarray(a, dtype=np.float64)
        if a.shape[-1:] != (self.ndof,):
            raise ArgumentError(
                f"{name} must have {self.ndof} coordinates in its last axis for robot {self.robot}, "
                f"got shape {a.shape}",
                "PKM_ERR_ARGUMENT",
            )
        return a

    def _batch(self, fn, inputs, names, errors="raise"):
        arrs = [self._arr(a, n) for a, n in zip(inputs, names)]
        shape = np.broadcast_shapes(*[a.shape for a in arrs])
        arrs = [np.ascontiguousarray(np.broadcast_to(a, shape).reshape(-1, self.ndof)) for a in arrs]
        n = arrs[0].shape[0]
        out = np.empty((n, self.ndof))
        status = np.zeros(n, dtype=np.intc)
        s = fn(self._m, self._d, n, *[ptr(a) for a in arrs], ptr(out), status.ctypes.data_as(C.POINTER(C.c_int)))
        if errors == "raise":
            self._check(s)
            return out.reshape(shape)
        return out.reshape(shape), status.reshape(shape[:-1])

    def _loop(self, name, inputs, names, out_shape, *, extra=(), out_parts=1, times=None, what="item"):
        """Per-item C call ``name(m, d, *inputs[k], *extra, *out_parts[k])`` for functions
        without a batched form; raises the core's error for the first failing item, naming
        the item (and its time if ``times`` is given)."""
        f = fast(name)
        arrs = [self._arr(a, n) for a, n in zip(inputs, names)]
        shape = np.broadcast_shapes(*[a.shape for a in arrs])
        flat = [np.ascontiguousarray(np.broadcast_to(a, shape).reshape(-1, self.ndof)) for a in arrs]
        n = flat[0].shape[0]
        out = np.empty((n,) + out_shape)
        m, d = self._m, self._d
        istride = 8 * self.ndof
        osize = 8 * (out.size // n if n else 0)
        part = osize // out_parts
        base = [a.ctypes.data for a in flat]
        obase = out.ctypes.data
        for k in range(n):
            o = obase + k * osize
            s = f(m, d, *[b + k * istride for b in base], *extra, *[o + j * part for j in range(out_parts)])
            if s:
                when = f" (t = {times[k]:.6g} s)" if times is not None else ""
                raise_for(s, f"{what} {k}{when}: {lib.pkm_data_error(d).decode()}")
        return out.reshape(shape[:-1] + out_shape)

    # ---------------------------------------------------------------- kinematics
    def home(self) -> np.ndarray:
        """The home pose [m, rad]."""
        x = np.empty(self.ndof)
        self._check(lib.pkm_model_home(self._m, ptr(x)))
        return x

    def ik(self, x, errors: str = "raise"):
        """Inverse kinematics: joints q [m or rad] of pose(s) x, shape (..., nd).

        With ``errors="status"`` returns ``(q, status)`` and NaN rows where status != 0
        instead of raising on the first unreachable pose.
        """
        if errors == "raise":
            q = self._single("pkm_ik", (x,), (self.ndof,))
            if q is not None:
                return q
        return self._batch(lib.pkm_ik_batch, [x], ["x"], errors)

    def fk(self, q, x_guess=None, tol: float = 1e-13, max_iter: int = 50, damping: float = 1e-9,
           errors: str = "raise"):
        """Forward kinematics by damped Newton from ``x_guess`` (default: home pose).

        Raises ``ConvergenceError`` rather than return a pose it did not converge to.
        """
        q = self._arr(q, "q")
        if x_guess is None:
            x_guess = self.home()
        opt = pkm_fk_options(tol, max_iter, damping)
        arrs = [np.ascontiguousarray(np.broadcast_to(a, np.broadcast_shapes(q.shape, np.shape(x_guess))))
                .reshape(-1, self.ndof) for a in (q, self._arr(x_guess, "x_guess"))]
        n = arrs[0].shape[0]
        out = np.empty((n, self.ndof))
        status = np.zeros(n, dtype=np.intc)
        s = lib.pkm_fk_batch(self._m, self._d, n, ptr(arrs[0]), ptr(arrs[1]), C.byref(opt), ptr(out),
                             status.ctypes.data_as(C.POINTER(C.c_int)))
        shape = np.broadcast_shapes(q.shape, np.shape(x_guess))
        if errors == "raise":
            self._check(s)
            return out.reshape(shape)
        return out.reshape(shape), status.reshape(shape[:-1])

    def fk_info(self, q, x_guess=None, tol: float = 1e-13, max_iter: int = 50):
        """Single forward kinematics solve returning ``(x, iterations, residual)``."""
        q = np.ascontiguousarray(self._arr(q, "q"))
        xg = np.ascontiguousarray(self._arr(self.home() if x_guess is None else x_guess, "x_guess"))
        x = np.empty(self.ndof)
        info = pkm_fk_info()
        opt = pkm_fk_options(tol, max_iter, 1e-9)
        self._check(lib.pkm_fk(self._m, self._d, ptr(q), ptr(xg), C.byref(opt), ptr(x), C.byref(info)))
        return x, info.iterations, info.residual

    def jacobians(self, x):
        """(Jx, Jq, J) at pose x, with Jx xd = Jq qd and qd = J xd; each (nd, nd)."""
        x = np.ascontiguousarray(self._arr(x, "x"))
        n = self.ndof
        Jx, Jq, J = np.empty((n, n)), np.empty((n, n)), np.empty((n, n))
        self._check(lib.pkm_jacobians(self._m, self._d, ptr(x), ptr(Jx), ptr(Jq), ptr(J)))
        return Jx, Jq, J

    def jacobian(self, x):
        """J(x), shape (..., nd, nd): qd = J xd."""
        n = self.ndof
        J = self._single("pkm_jacobians", (x,), (n, n), extra=(None, None))
        if J is not None:
            return J

        return self._loop("pkm_jacobians", [x], ["x"], (n, n), extra=(None, None))

    def jacobian_dot(self, x, xd):
        """dJ/dt along (x, xd), shape (..., nd, nd)."""
        n = self.ndof
        return self._loop("pkm_jacobian_dot", [x, xd], ["x", "xd"], (n, n))

    def singularity(self, x):
        """Singularity measures (..., 2) in [0, 1]: [inverse-kinematic, direct]; 0 = singular."""
        return self._loop("pkm_singularity", [x], ["x"], (2,))

    def joint_velocity(self, x, xd):
        return self._loop("pkm_joint_velocity", [x, xd], ["x", "xd"], (self.ndof,))

    def pose_velocity(self, x, qd):
        return self._loop("pkm_pose_velocity", [x, qd], ["x", "qd"], (self.ndof,))

    def joint_acceleration(self, x, xd, xdd):
        return self._loop("pkm_joint_acceleration", [x, xd, xdd], ["x", "xd", "xdd"], (self.ndof,))

    def pose_acceleration(self, x, xd, qdd):
        return self._loop("pkm_pose_acceleration", [x, xd, qdd], ["x", "xd", "qdd"], (self.ndof,))

    # ------------------------------------------------------------------ dynamics
    def inverse_dynamics(self, x, xd, xdd, errors: str = "raise"):
        """Actuator efforts tau [N or N m], shape (..., nd), producing xdd at (x, xd)."""
        if errors == "raise":
            tau = self._single("pkm_inverse_dynamics", (x, xd, xdd), (self.ndof,))
            if tau is not None:
                return tau
        return self._batch(lib.pkm_inverse_dynamics_batch, [x, xd, xdd], ["x", "xd", "xdd"], errors)

    def forward_dynamics(self, x, xd, tau, errors: str = "raise"):
        """Pose acceleration xdd, shape (..., nd), from (x, xd, tau)."""
        if errors == "raise":
            xdd = self._single("pkm_forward_dynamics", (x, xd, tau), (self.ndof,))
            if xdd is not None:
                return xdd
        return self._batch(lib.pkm_forward_dynamics_batch, [x, xd, tau], ["x", "xd", "tau"], errors)

    def mass_matrix(self, x):
        """Task-space mass matrix, shape (..., nd, nd): kinetic energy = xd' M xd / 2."""
        n = self.ndof
        return self._loop("pkm_mass_matrix", [x], ["x"], (n, n))

    def gravity_load(self, x):
        """Actuator efforts that hold the robot still at x, shape (..., nd)."""
        g = self._single("pkm_gravity_load", (x,), (self.ndof,))
        if g is not None:
            return g
        return self._loop("pkm_gravity_load", [x], ["x"], (self.ndof,))

    def measure_joints(self, x, xd, tau):
        """Joint readings of the model's sensors at (x, xd) with applied effort tau, shape
        (..., nd) (``pkm_measure_joints``: encoder offset, backlash, compliance)."""
        q = self._single("pkm_measure_joints", (x, xd, tau), (self.ndof,))
        if q is not None:
            return q
        return self._loop("pkm_measure_joints", [x, xd, tau], ["x", "xd", "tau"], (self.ndof,))

    def actuator_effort(self, tau_cmd):
        """Effort reaching the mechanism for a commanded one, shape (..., nd) (``pkm_actuator_effort``:
        dead zone, saturation)."""
        u = self._single("pkm_actuator_effort", (tau_cmd,), (self.ndof,))
        if u is not None:
            return u
        return self._loop("pkm_actuator_effort", [tau_cmd], ["tau_cmd"], (self.ndof,))

    def energy(self, x, xd):
        """(kinetic, potential) energy [J], each shape (...)."""
        e = self._loop("pkm_energy", [x, xd], ["x", "xd"], (2,), out_parts=2)
        return e[..., 0], e[..., 1]

    # ------------------------------------------------------------- 6-PUS specific
    def _require_6pus(self, what: str) -> None:
        if self.robot != "6pus":
            raise ArgumentError(f"{what} is a 6-PUS function; this model is {self.robot!r}", "PKM_ERR_ARGUMENT")

    def calib_rows(self, x, frame: str = "world"):
        """6-PUS calibration regression rows, shape (..., 6, 10): dq_i / d eta_i per leg.

        eta_i = [X, Y, Z, S0x, S0y, S0z, L, sx, sy, sz] (seed 000 eq. 4.1).  ``frame="world"``
        differentiates with respect to the world position of the platform point (the seed's
        tables), ``"platform"`` with respect to ``leg[i].px/py/pz``.  Stroke limits are not
        applied (the rows are geometry); an unreachable or singular pose raises.
        """
        self._require_6pus("calib_rows")
        frames = {"world": 0, "platform": 1}
        if frame not in frames:
            raise ArgumentError(f"frame must be 'world' or 'platform', got {frame!r}", "PKM_ERR_ARGUMENT")
        f = frames[frame]
        return self._loop("pkm_6pus_calib_rows", [x], ["x"], (6, 10), extra=(f,))

    def leg_points(self, x):
        """6-PUS world positions ``(P, S)`` of the platform points and sliders, each (..., 6, 3) [m]."""
        self._require_6pus("leg_points")
        ps = self._loop("pkm_6pus_leg_points", [x], ["x"], (2, 6, 3), out_parts=2)
        return ps[..., 0, :, :], ps[..., 1, :, :]
