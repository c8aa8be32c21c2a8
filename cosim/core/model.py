"""A robot model with its work data: parameters, kinematics, dynamics, the drive layer and the
robot-specific function families the core declares (:meth:`Model.has`).  The example is the
package's (:mod:`cosim.core`).
"""
from __future__ import annotations

import ctypes as C
import json

import numpy as np

from .._native import fast, lib, pkm_fk_info, pkm_fk_options, ptr, raise_for
from ..errors import ArgumentError, ParameterError, PkmError, UnsupportedError
from ._handles import _errbuf
from .facts import ParamInfo, RobotFacts, robots
from .model_courses import CourseMethods
from .model_drive import DriveLayerMethods
from .model_families import RobotFamilyMethods


def _fk_options(tol, max_iter, damping) -> pkm_fk_options:
    # A field left to the core: tol and max_iter <= 0, damping < 0 (pkm.h pkm_fk_options).
    return pkm_fk_options(0.0 if tol is None else float(tol), 0 if max_iter is None else int(max_iter),
                          -1.0 if damping is None else float(damping))



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



class Model(DriveLayerMethods, RobotFamilyMethods, CourseMethods):
    """A robot model (constant parameters) with its own work data.

    Parameters
    ----------
    robot : str
        Robot kind, one of :func:`robots` ("6pus", "quattro", "fourbar"), a description file
        (docs/robots.md) or a serial arm's URDF file (``.urdf``, docs/robots.md, URDF).
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
        if robot.endswith(".urdf"):  # a serial arm's URDF, read into a description (cosim/robots/urdf.py)
            from ..robots.urdf import register_urdf

            robot = register_urdf(robot)
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
        where the robot has no limit (a continuous axis, docs/robots.md; the current values
        of the limit parameters)."""
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
        """An independent model with the same parameters and time courses (and its own work data)."""
        out = Model(self.source, self.param_set, self.params())
        for name, c in self.courses().items():
            out.set_course(name, c.pop("kind"), **c)
        return out

    def __repr__(self) -> str:
        return f"Model({self.robot!r}, ndof={self.ndof}, nparam={len(self.param_names())})"

    # ----------------------------------------------------------------- parameters
    def param_names(self) -> list[str]:
        return [name for name, _, _ in self._param_table()]

    def _param_table(self) -> tuple:
        """(name, unit, description) of every parameter, read from the core once per model (the
        core fixes a model's table when it creates it; only the values change)."""
        table = self.__dict__.get("_table")
        if table is None:
            table = self.__dict__["_table"] = tuple(
                (lib.pkm_param_name(self._m, i).decode(), lib.pkm_param_unit(self._m, i).decode(),
                 lib.pkm_param_description(self._m, i).decode()) for i in range(lib.pkm_model_nparam(self._m)))
        return table

    def param_info(self) -> list[ParamInfo]:
        """Name, value, unit and description of every parameter."""
        return [ParamInfo(name, float(lib.pkm_param_get(self._m, i)), unit, description)
                for i, (name, unit, description) in enumerate(self._param_table())]

    def params(self) -> dict[str, float]:
        """Current parameter values by name [SI units]."""
        return {p.name: p.value for p in self.param_info()}

    def param(self, name: str) -> float:
        return float(lib.pkm_param_get(self._m, self._index(name)))

    def _index(self, name: str) -> int:
        i = lib.pkm_param_index(self._m, name.encode())
        if i < 0:
            raise ParameterError(self._unknown_parameter(name), "PKM_ERR_PARAMETER")
        return i

    def _unknown_parameter(self, name) -> str:
        """The message for a parameter name the robot lacks: the closest names it has, and
        the command that lists them all."""
        import difflib

        names = self.param_names()
        close = difflib.get_close_matches(str(name), names, n=3, cutoff=0.6)
        hint = f"; did you mean {', '.join(close)}?" if close else ""
        return (f"{self.robot} has no parameter named {name!r}{hint} "
                f"(`cosim params {self.robot}` lists its {len(names)} parameters)")

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

    def platform_pose(self, x):
        """The platform's full pose (x, y, z, rx, ry, rz) [m, rad] at pose(s) x and the motion
        map S = d(full pose)/dx, shapes (..., 6) and (..., 6, nd): the components a robot does
        not declare are held at 0 or, with PRS or RPS legs, dependent (the parasitic motion,
        solved from the legs' passive revolute joints).  Described robots, the 6-PUS and the
        Quattro (not the four-bar or a single axis).

        Example: ``Model("robots/tripod_3rps.toml").platform_pose([0.45, 0.1, 0.05])[0]``."""
        xs = self._arr(x, "x")
        flat = np.ascontiguousarray(xs.reshape(-1, self.ndof))
        X = np.empty((len(flat), 6))
        S = np.empty((len(flat), 6, self.ndof))
        f = fast("pkm_platform_pose")
        for k in range(len(flat)):
            st = f(self._m, self._d, flat[k].ctypes.data, X[k].ctypes.data, S[k].ctypes.data)
            if st:
                raise_for(st, f"item {k}: {lib.pkm_data_error(self._d).decode()}")
        return X.reshape(xs.shape[:-1] + (6,)), S.reshape(xs.shape[:-1] + (6, self.ndof))

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

    def energy(self, x, xd):
        """(kinetic, potential) energy [J], each shape (...)."""
        e = self._loop("pkm_energy", [x, xd], ["x", "xd"], (2,), out_parts=2)
        return e[..., 0], e[..., 1]
