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
    c_int_p,
    fast,
    lib,
    pkm_ctrl_spec,
    pkm_fk_info,
    pkm_fk_options,
    pkm_loop_record,
    pkm_loop_reference,
    pkm_sim_options,
    pkm_sim_stats,
    ptr,
    raise_for,
)
from .errors import ArgumentError, ParameterError, PkmError, UnsupportedError

__all__ = ["Model", "ParamInfo", "RobotFacts", "robots", "robot_facts", "PkmError", "ParameterError",
           "ArgumentError"]


@dataclass(frozen=True)
class ParamInfo:
    """One named parameter of a model."""

    name: str
    value: float
    unit: str
    description: str


def _fk_options(tol, max_iter, damping) -> pkm_fk_options:
    # A field left to the core: tol and max_iter <= 0, damping < 0 (pkm.h pkm_fk_options).
    return pkm_fk_options(0.0 if tol is None else float(tol), 0 if max_iter is None else int(max_iter),
                          -1.0 if damping is None else float(damping))


def _errbuf():
    return C.create_string_buffer(1024)


def robots() -> list[str]:
    """Names of the robots compiled into the core (``pkm_robot_name``), e.g. ``["6pus", ...]``."""
    return [lib.pkm_robot_name(i).decode() for i in range(lib.pkm_robot_count())]


#: PKM_QUATTRO_NINDEX in pkm.h
_QUATTRO_NINDEX = 22


def quattro_index_names() -> list[str]:
    """Names of the Quattro performance indices, in the column order of
    :meth:`Model.quattro_indices` (``pkm_quattro_index_name``)."""
    return [lib.pkm_quattro_index_name(i).decode() for i in range(_QUATTRO_NINDEX)]


def quattro_index_units() -> dict[str, str]:
    """Unit of each Quattro performance index by name (``pkm_quattro_index_unit``)."""
    return {lib.pkm_quattro_index_name(i).decode(): lib.pkm_quattro_index_unit(i).decode()
            for i in range(_QUATTRO_NINDEX)}


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
    geometry_params : tuple of str
        The parameters a geometric error is described by (``pkm_model_geometry_param``:
        the 6-PUS ``leg[i].L``, one per joint); empty where the robot names none (then
        :meth:`Model.geometry_params` derives them).
    title, file : str
        One line saying what the robot is, and the description file it was compiled from
        (``""`` for the robots written in C++; docs/robots.md).
    features : tuple of str
        The robot-specific function families it provides beyond the common set
        (``pkm_model_has``): ``"6pus_calib_rows"`` (the 60-parameter calibration rows),
        ``"6pus_leg_points"``, ``"fourbar_output"``, ``"quattro_indices"``,
        ``"quattro_gimre"``, ``"quattro_points"``.  Capabilities are asked of the model
        (:meth:`Model.has`), never inferred from its name.
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
    geometry_params: tuple = ()
    title: str = ""
    file: str = ""
    features: tuple = ()

    @property
    def angular_joints(self) -> bool:
        """True for revolute actuated joints (q in rad, efforts in N m)."""
        return self.joint_unit == "rad"


_FACTS: dict = {}


def _remember_description(path: str, name: str) -> None:
    """A robot made from a description file answers to its name in this process (the core
    keeps it); for the processes this one starts (sweep workers, FMU builds) its folder
    joins ``PKM_ROBOT_PATH``, where the core looks for ``<name>.toml``."""
    import os

    p = os.path.abspath(path)
    if os.path.basename(p) != f"{name}.toml":
        return  # found by name only where the file is named after the robot
    d = os.path.dirname(p)
    dirs = [x for x in os.environ.get("PKM_ROBOT_PATH", "").split(os.pathsep) if x]
    if d not in dirs:
        os.environ["PKM_ROBOT_PATH"] = os.pathsep.join([d] + dirs)


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
        self.source = robot  # the name or description file it was made from
        if self.robot != robot:
            _remember_description(robot, self.robot)
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
        m, nd, name, src = self._m, self.ndof, self.robot, self.source.encode()
        return RobotFacts(
            name=name, ndof=nd,
            param_sets=tuple(lib.pkm_robot_param_set_name(src, i).decode()
                             for i in range(lib.pkm_robot_param_set_count(src))),
            title=lib.pkm_robot_title(src).decode(), file=lib.pkm_robot_file(src).decode(),
            pose_names=tuple(lib.pkm_model_pose_name(m, i).decode() for i in range(nd)),
            pose_units=tuple(lib.pkm_model_pose_unit(m, i).decode() for i in range(nd)),
            tracker_names=tuple(lib.pkm_model_tracker_name(m, i).decode() for i in range(lib.pkm_model_tracker_count(m))),
            tracker_units=tuple(lib.pkm_model_tracker_unit(m, i).decode() for i in range(lib.pkm_model_tracker_count(m))),
            joint_unit=lib.pkm_model_joint_unit(m).decode(), effort_unit=lib.pkm_model_effort_unit(m).decode(),
            joint_noun=lib.pkm_model_joint_noun(m).decode(), joint_prefix=lib.pkm_model_joint_prefix(m).decode(),
            geometry_params=tuple(self._geometry_declared()),
            features=tuple(lib.pkm_model_feature(m, i).decode() for i in range(lib.pkm_model_feature_count(m))))

    def has(self, feature: str) -> bool:
        """True if the robot provides the robot-specific function family ``feature``
        (:attr:`RobotFacts.features`, ``pkm_model_has``).

        >>> Model("6pus").has("6pus_calib_rows"), Model("quattro").has("6pus_calib_rows")
        (True, False)
        """
        return bool(lib.pkm_model_has(self._m, feature.encode()))

    def _require(self, feature: str, what: str) -> None:
        if not self.has(feature):
            have = ", ".join(self.facts.features) or "none"
            raise UnsupportedError(f"{what} needs a robot that provides {feature!r}; {self.robot!r} does not "
                                   f"(its robot-specific functions: {have})", "PKM_ERR_UNSUPPORTED")

    def _geometry_declared(self) -> list[str]:
        names, i = [], 0
        while True:
            n = lib.pkm_model_geometry_param(self._m, i).decode()
            if not n:
                return names
            names.append(n)
            i += 1

    def geometry_params(self, poses=None, declared: bool = True) -> list[str]:
        """Names of the geometric parameters of this robot.

        With ``declared`` (default) the ones the core names (:attr:`RobotFacts.geometry_params`)
        if it names any; otherwise every length parameter [m] outside the drive layer,
        gravity and payload whose change moves a joint at ``poses`` (shape (n, nd); default
        the home pose): a central difference of the core's inverse kinematics, so a robot
        needs nothing written for it.
        """
        if declared:
            names = self._geometry_declared()
            if names:
                return names
        x = np.atleast_2d(self.home() if poses is None else np.asarray(poses, float))
        base = np.asarray(self.ik(x), float)
        keep = []
        for info in self.param_info():
            # (the drive layer's lengths, a backlash or an encoder offset, do not move the
            # inverse kinematics; a rail's origin or an arm's length do, and are kept)
            if info.unit != "m" or info.name.startswith(("gravity.", "drive.", "actuator.", "sensor.", "payload.")):
                continue
            h = 1e-6 * max(abs(info.value), 1e-3)
            trial = self.copy()
            try:
                trial.set_params({info.name: info.value + h})
                moved = np.max(np.abs(np.asarray(trial.ik(x), float) - base)) > 1e-9 * h
            except PkmError:
                moved = False
            if moved:
                keep.append(info.name)
        return keep

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
        return Model(self.source, self.param_set, self.params())

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

    def fk(self, q, x_guess=None, tol: float | None = None, max_iter: int | None = None,
           damping: float | None = None, errors: str = "raise"):
        """Forward kinematics by damped Newton from ``x_guess`` (default: home pose).

        ``tol`` [m or rad], ``max_iter`` and ``damping`` default to the core's
        (``pkm_fk_options`` in pkm.h: 1e-13, 50, 1e-9).  Raises ``ConvergenceError`` rather
        than return a pose it did not converge to.
        """
        q = self._arr(q, "q")
        if x_guess is None:
            x_guess = self.home()
        opt = _fk_options(tol, max_iter, damping)
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

    def fk_info(self, q, x_guess=None, tol: float | None = None, max_iter: int | None = None):
        """Single forward kinematics solve returning ``(x, iterations, residual)`` (defaults as :meth:`fk`)."""
        q = np.ascontiguousarray(self._arr(q, "q"))
        xg = np.ascontiguousarray(self._arr(self.home() if x_guess is None else x_guess, "x_guess"))
        x = np.empty(self.ndof)
        info = pkm_fk_info()
        opt = _fk_options(tol, max_iter, None)
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

    def chain_points(self, x):
        """Where each leg is at pose(s) x, for drawing: (..., nd, 3, 3) [m, world], per leg its
        base joint, its moving proximal joint (slider, elbow, cylinder end) and its platform
        joint.  Every robot but the four-bar (``UnsupportedError`` there)."""
        return self._loop("pkm_chain_points", [x], ["x"], (self.ndof, 3, 3))

    def joint_velocity(self, x, xd):
        return self._loop("pkm_joint_velocity", [x, xd], ["x", "xd"], (self.ndof,))

    def pose_velocity(self, x, qd, times=None, what="item"):
        """Pose rates xd, shape (..., nd), of joint rates qd at poses x (``pkm_pose_velocity``)."""
        return self._batch_or_loop("pkm_pose_velocity_batch", "pkm_pose_velocity", [x, qd], ["x", "qd"], times,
                                   what)

    def joint_acceleration(self, x, xd, xdd):
        return self._loop("pkm_joint_acceleration", [x, xd, xdd], ["x", "xd", "xdd"], (self.ndof,))

    def pose_acceleration(self, x, xd, qdd, times=None, what="item"):
        """Pose accelerations xdd, shape (..., nd) (``pkm_pose_acceleration``)."""
        return self._batch_or_loop("pkm_pose_acceleration_batch", "pkm_pose_acceleration", [x, xd, qdd],
                                   ["x", "xd", "qdd"], times, what)

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

    def _batch_or_loop(self, fn, name, inputs, names, times, what):
        """The core's batched form; when a row fails, the per-item call raises its error
        naming the row (and its time, given ``times``)."""
        out, status = self._batch(getattr(lib, fn), inputs, names, errors="status")
        if np.any(status):
            self._loop(name, inputs, names, (self.ndof,), times=times, what=what)
        return out

    def measure_joints(self, x, xd, tau, times=None, what="item"):
        """Joint readings of the model's sensors at (x, xd) with applied effort tau, shape
        (..., nd) (``pkm_measure_joints``: encoder offset, backlash, compliance).  A failing
        row is named in the error (with its time from ``times``, if given)."""
        q = self._single("pkm_measure_joints", (x, xd, tau), (self.ndof,))
        if q is not None:
            return q
        return self._batch_or_loop("pkm_measure_joints_batch", "pkm_measure_joints", [x, xd, tau],
                                   ["x", "xd", "tau"], times, what)

    def sensor_readings(self, x, xd, tau, drive=None):
        """``(q, qd)``: the sensors' joint readings and rates at one state (x, xd) [m, rad] under
        the applied effort tau (``pkm_sensor_readings``): :meth:`measure_joints` and the joint
        rates, and on a joint that is two bodies, given ``drive = (theta, theta_d)`` (e.g.
        ``Simulator.drive_state``), its drive body plus the encoder offset, and its rate."""
        v = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, xd, tau)]
        th, thd = (None, None) if drive is None else (np.ascontiguousarray(a, dtype=np.float64) for a in drive)
        q, qd = np.empty(self.ndof), np.empty(self.ndof)
        self._check(lib.pkm_sensor_readings(self._m, self._d, *(ptr(a) for a in v), ptr(th), ptr(thd), ptr(q),
                                            ptr(qd)))
        return q, qd

    def two_body_joints(self) -> int:
        """How many joints are two bodies (``drive.two_body = 1`` and a backlash or a compliance
        on them; docs/integration.md)."""
        return int(lib.pkm_model_two_body_joints(self._m))

    def actuator_effort(self, tau_cmd, times=None, what="item"):
        """Effort reaching the mechanism for a commanded one, shape (..., nd) (``pkm_actuator_effort``:
        dead zone, saturation).  A failing row is named in the error (with its time from
        ``times``, if given)."""
        u = self._single("pkm_actuator_effort", (tau_cmd,), (self.ndof,))
        if u is not None:
            return u
        return self._batch_or_loop("pkm_actuator_effort_batch", "pkm_actuator_effort", [tau_cmd], ["tau_cmd"],
                                   times, what)

    def energy(self, x, xd):
        """(kinetic, potential) energy [J], each shape (...)."""
        e = self._loop("pkm_energy", [x, xd], ["x", "xd"], (2,), out_parts=2)
        return e[..., 0], e[..., 1]

    # ------------------------------------------------- robot-specific functions (:meth:`has`)
    def calib_rows(self, x, frame: str = "world"):
        """6-PUS calibration regression rows, shape (..., 6, 10): dq_i / d eta_i per leg.

        eta_i = [X, Y, Z, S0x, S0y, S0z, L, sx, sy, sz] (Tiberi 2020 eq. 4.1).  ``frame="world"``
        differentiates with respect to the world position of the platform point (the seed's
        tables), ``"platform"`` with respect to ``leg[i].px/py/pz``.  Stroke limits are not
        applied (the rows are geometry); an unreachable or singular pose raises.
        """
        self._require("6pus_calib_rows", "calib_rows")
        frames = {"world": 0, "platform": 1}
        if frame not in frames:
            raise ArgumentError(f"frame must be 'world' or 'platform', got {frame!r}", "PKM_ERR_ARGUMENT")
        f = frames[frame]
        return self._loop("pkm_6pus_calib_rows", [x], ["x"], (6, 10), extra=(f,), what="pose")

    def leg_points(self, x):
        """6-PUS world positions ``(P, S)`` of the platform points and sliders, each (..., 6, 3) [m]."""
        self._require("6pus_leg_points", "leg_points")
        ps = self._loop("pkm_6pus_leg_points", [x], ["x"], (2, 6, 3), out_parts=2)
        return ps[..., 0, :, :], ps[..., 1, :, :]

    def fourbar_output(self, theta, jacobian: bool = True):
        """Four-bar coupler mid-point X [m] at crank angle(s) theta [rad], and dX/d(l1..l4)
        [m/m] of shape ``theta.shape + (4,)`` if ``jacobian`` (``pkm_fourbar_output``)."""
        self._require("fourbar_output", "fourbar_output")
        th = np.asarray(theta, dtype=float)
        flat = th.reshape(-1)
        X = np.empty(flat.shape)
        J = np.empty(flat.shape + (4,))
        out = np.empty(1)
        for k, t in enumerate(flat):
            row = J[k] if jacobian else None
            self._check(lib.pkm_fourbar_output(self._m, self._d, float(t), ptr(out), ptr(row)))
            X[k] = out[0]
        X = X.reshape(th.shape)
        return X if not jacobian else (X, J.reshape(th.shape + (4,)))

    def quattro_indices(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """Performance indices of poses (..., 4) -> (values (..., n_index), status (...)), one
        core call (``pkm_quattro_indices``); names and units in :func:`quattro_index_names`."""
        self._require("quattro_indices", "quattro_indices")
        x = np.ascontiguousarray(poses, dtype=np.float64)
        if x.shape[-1:] != (4,):
            raise ArgumentError(f"poses must have 4 coordinates (x, y, z, theta) in the last axis, got {x.shape}",
                                "PKM_ERR_ARGUMENT")
        flat = x.reshape(-1, 4)
        n = flat.shape[0]
        nidx = len(quattro_index_names())
        out = np.empty((n, nidx))
        status = np.zeros(n, dtype=np.intc)
        lib.pkm_quattro_indices(self._m, self._d, n, ptr(flat), ptr(out), status.ctypes.data_as(c_int_p))
        return out.reshape(x.shape[:-1] + (nidx,)), status.reshape(x.shape[:-1])

    def quattro_gimre(self, x) -> np.ndarray:
        """Quattro generalized inertia matrix reduced to the end effector, (4, 4) at pose x
        [kg, kg m, kg m^2] (``pkm_quattro_gimre``)."""
        self._require("quattro_gimre", "quattro_gimre")
        xv = np.ascontiguousarray(x, dtype=np.float64)
        N = np.empty((4, 4))
        self._check(lib.pkm_quattro_gimre(self._m, self._d, ptr(xv), ptr(N)))
        return N

    def quattro_points(self, x) -> dict:
        """Quattro world points A, B, C (4, 3) [m] of the four arms at pose x (motor axis,
        elbow, platform joint) (``pkm_quattro_points``)."""
        self._require("quattro_points", "quattro_points")
        xv = np.ascontiguousarray(x, dtype=np.float64)
        A, B, Cp = np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3))
        self._check(lib.pkm_quattro_points(self._m, self._d, ptr(xv), ptr(A), ptr(B), ptr(Cp)))
        return {"A": A, "B": B, "C": Cp}


# ----------------------------------------------------------------- integration
_METHODS = {"bdf": 0, "adams": 1, "erk": 2, "erk23": 3}
_METHOD_NAMES = {v: k for k, v in _METHODS.items()}
#: integration method names and their pkm.h codes (pkm_lmm; the FMUs' solver.method)
METHOD_CODES = dict(_METHODS)


def default_options() -> dict:
    """The core's default integrator options (``pkm_sim_default_options``) as a dict."""
    o = pkm_sim_options()
    lib.pkm_sim_default_options(C.byref(o))
    return {
        "method": _METHOD_NAMES[o.method],
        "rtol": o.rtol,
        "atol": o.atol,
        "max_step": o.max_step,
        "max_steps": o.max_steps,
        "sing_min": o.sing_min,
    }


def _release(obj, attr: str, destroy: str) -> None:
    """Destroy the core handle ``obj.<attr>`` once (for ``__del__``; quiet at interpreter shutdown)."""
    try:
        h = getattr(obj, attr, None)
        if h:
            getattr(lib, destroy)(h)
            setattr(obj, attr, None)
    except Exception:  # interpreter shutdown
        pass


class Simulator:
    """An integration of one robot's task-space state under a held input.

    Parameters
    ----------
    model : cosim.core.Model
        The robot.  The simulator copies it: later ``model.set_params`` calls do not
        change a simulator that already exists.
    method : {"erk", "erk23", "bdf", "adams"}
        ``"erk"`` (default): explicit Runge-Kutta 5(4) (Dormand-Prince) that keeps its
        step size from one ``advance`` to the next, about one step per millisecond
        under a 1 kHz controller; for non-stiff motion.  ``"erk23"``: the Bogacki-Shampine
        3(2) pair, 4 instead of 7 forward-dynamics calls a step: faster at loose
        tolerances (docs/integration.md has the error / speed table).  ``"bdf"``: CVODE's BDF with
        Newton iteration and a dense difference-quotient Jacobian (stiff-safe: use it
        with Coulomb friction and a small ``drive.v_eps``).  ``"adams"``: CVODE's
        Adams with fixed-point iteration.
    rtol : float
        Relative tolerance of the local error (dimensionless).
    atol : float
        Absolute tolerance of the local error, applied to every state component
        [m, rad, m/s, rad/s].
    max_step : float
        Largest internal step [s]; 0 means unlimited.
    max_steps : int
        Largest number of internal steps within one ``advance``.
    sing_min : float
        The integration stops when the direct-singularity measure (``Model.singularity``
        column 1, in [0, 1]) falls below this value; 0 disables the check.

    Notes
    -----
    After ``Simulator(model)`` the state is the model's home pose at rest at t = 0 s
    with a zero input.  The result of an ``advance`` depends only on the simulator's
    state (:meth:`save_state`: t, x, xd, the held input, the explicit method's next
    step size and the actuator-delay history) and the options: restoring a saved
    state with :meth:`load_state` and advancing again reproduces the same numbers bit
    for bit.  ``reset`` starts afresh (the explicit method chooses a new first step).

    Examples
    --------
    >>> from cosim.core import Model
    >>> m = Model("6pus")
    >>> sim = Simulator(m)
    >>> sim.reset(0.0, m.home(), [0.01, 0, 0, 0, 0, 0])
    >>> sim.set_input(m.gravity_load(m.home()))
    >>> sim.advance(0.1)
    >>> t, x, xd = sim.state
    """

    def __init__(self, model, method: str = "erk", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = 0.0, max_steps: int = 100000, sing_min: float = 1e-4):
        if method not in _METHODS:
            raise ArgumentError(f"method must be one of {sorted(_METHODS)}, got {method!r}", "PKM_ERR_ARGUMENT")
        self.model = model
        self.ndof = model.ndof
        self.options = {"method": method, "rtol": float(rtol), "atol": float(atol), "max_step": float(max_step),
                        "max_steps": int(max_steps), "sing_min": float(sing_min)}
        opt = pkm_sim_options(_METHODS[method], float(rtol), float(atol), float(max_step), int(max_steps),
                              float(sing_min))
        err = C.create_string_buffer(1024)
        h = lib.pkm_sim_create(model._m, C.byref(opt), err, len(err))
        if not h:
            # pkm_sim_create reports by message only; map it to the status it stands for.
            msg = err.value.decode()
            if msg.startswith("pkm_sim options") or "is NULL" in msg:
                status = -1  # PKM_ERR_ARGUMENT
            elif "validate" in msg:
                status = -2  # PKM_ERR_PARAMETER
            elif msg.startswith("CVODE"):
                status = -7  # PKM_ERR_INTEGRATION
            else:
                status = -9  # PKM_ERR_INTERNAL
            raise_for(status, msg)
        self._s = C.c_void_p(h)
        self._x = np.empty(self.ndof)
        self._xd = np.empty(self.ndof)
        self._t = C.c_double(0.0)

    def __del__(self):
        _release(self, "_s", "pkm_sim_destroy")

    def _check(self, status: int) -> None:
        if status != 0:
            raise_for(status, lib.pkm_sim_error(self._s).decode())

    def _vec(self, v, name: str) -> np.ndarray:
        a = np.ascontiguousarray(v, dtype=np.float64)
        if a.shape != (self.ndof,):
            raise ArgumentError(f"{name} must have shape ({self.ndof},), got {a.shape}", "PKM_ERR_ARGUMENT")
        return a

    def reset(self, t0: float, x, xd=None) -> None:
        """Set the time t0 [s], pose x [m, rad] and pose rate xd [m/s, rad/s] (default 0).

        Raises the core's error (``UnreachableError``, ``JointLimitError``,
        ``SingularError``, ``ArgumentError``) if the state is not a valid start; the
        simulator keeps its previous state then.
        """
        x = self._vec(x, "x")
        xd = np.zeros(self.ndof) if xd is None else self._vec(xd, "xd")
        self._check(lib.pkm_sim_reset(self._s, float(t0), ptr(x), ptr(xd)))

    def set_input(self, tau) -> None:
        """Hold the actuator efforts tau [N or N m], shape (nd,), from now on."""
        tau = self._vec(tau, "tau")
        self._check(lib.pkm_sim_set_input(self._s, ptr(tau)))

    def set_external(self, f) -> None:
        """Hold a known external effort f [N or N m] per joint, positive along +q, from now on
        (``pkm_sim_set_external``): added to the actuator effort, not saturated, not delayed."""
        f = self._vec(f, "f")
        self._check(lib.pkm_sim_set_external(self._s, ptr(f)))

    def advance(self, t_end: float) -> None:
        """Integrate to t_end [s] with the held input.

        On a stroke limit (``JointLimitError``), a direct singularity (``SingularError``)
        or a CVODE failure (``IntegrationError``), the state stays where the
        integration stopped and the exception's message names the leg and the time.
        """
        self._check(lib.pkm_sim_advance(self._s, float(t_end)))

    def save_state(self) -> np.ndarray:
        """The simulator's whole state as a 1-D array (``pkm_sim_state_save``), for
        :meth:`load_state` on this or another simulator of the same model and options."""
        buf = np.empty(int(lib.pkm_sim_state_size(self._s)))
        self._check(lib.pkm_sim_state_save(self._s, ptr(buf)))
        return buf

    def load_state(self, state) -> None:
        """Restore a state from :meth:`save_state`; a damaged or foreign one raises
        ``ArgumentError`` and changes nothing."""
        buf = np.ascontiguousarray(state, dtype=float).ravel()
        self._check(lib.pkm_sim_state_load(self._s, ptr(buf), buf.size))

    @property
    def state(self):
        """``(t, x, xd)``: time [s], pose [m, rad], pose rate [m/s, rad/s] (copies)."""
        self._check(lib.pkm_sim_get_state(self._s, C.byref(self._t), ptr(self._x), ptr(self._xd)))
        return float(self._t.value), self._x.copy(), self._xd.copy()

    @property
    def drive_state(self):
        """``(theta, theta_d)``: drive-side position [m or rad] and rate per joint
        (``pkm_sim_drive_state``): the drive body's on a joint that is two bodies
        (``drive.two_body = 1`` with a backlash or a compliance), the joint's own otherwise."""
        th, thd = np.empty(self.ndof), np.empty(self.ndof)
        self._check(lib.pkm_sim_drive_state(self._s, ptr(th), ptr(thd)))
        return th, thd

    @property
    def applied_effort(self) -> np.ndarray:
        """Effort acting on the mechanism now [N or N m] (``pkm_sim_applied_effort``): the
        held input after saturation, or with ``actuator.delay`` the command issued that much
        earlier (zero before the first)."""
        tau = np.empty(self.ndof)
        self._check(lib.pkm_sim_applied_effort(self._s, ptr(tau)))
        return tau

    @property
    def stats(self) -> dict:
        """Integrator counters summed over all advances since creation: steps, rhs_evals
        (with BDF including those of the difference-quotient Jacobian), jac_evals,
        error_test_fails, nonlin_conv_fails."""
        st = pkm_sim_stats()
        self._check(lib.pkm_sim_get_stats(self._s, C.byref(st)))
        return {name: int(getattr(st, name)) for name, _ in pkm_sim_stats._fields_}


# --------------------------------------------------------- compiled controllers
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
            raise ValueError(f"{kind} controller: {err.value.decode()}")
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


#: the recorded channels of ``pkm_closed_loop`` (pkm_loop_record), in its order
LOOP_FIELDS = ("q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd", "tau")


def closed_loop_call(sim: Simulator, ctrl: CompiledController, *, t, dt: float, ref: dict, rows: dict,
                     k0: int, k1: int, tau_before=None, q_noise=None, qd_noise=None,
                     measure: bool = False, f_ext=None) -> tuple[int, int, str]:
    """One ``pkm_closed_loop`` call over samples ``k0:k1`` (see
    :func:`cosim.closed_loop.run_compiled`, which chains calls).

    ``ref`` maps ``q, qd, qdd, x`` to C-contiguous (n, nd) arrays (``qdd``, ``x`` may be
    None); ``rows`` maps :data:`LOOP_FIELDS` to (n, nd) arrays that receive the samples.
    Returns ``(status, samples done in this call, message)``.
    """
    m = k1 - k0

    def at(a):
        return None if a is None else ptr(a[k0:k1])

    before = None if tau_before is None else np.ascontiguousarray(tau_before, dtype=float)
    spec = pkm_loop_reference(m, float(t[k0]), float(dt), at(t), at(ref["q"]), at(ref["qd"]), at(ref.get("qdd")),
                              at(ref.get("x")), ptr(before), at(f_ext))
    rec = pkm_loop_record(*[at(rows[f]) for f in LOOP_FIELDS])
    done = C.c_size_t(0)
    st = lib.pkm_closed_loop(sim._s, ctrl._c, C.byref(spec), at(q_noise), at(qd_noise), int(bool(measure)),
                             C.byref(rec), C.byref(done))
    return st, int(done.value), (lib.pkm_sim_error(sim._s).decode() if st else "")
