"""Calibration problems: measured data + a nominal core model = residuals and Jacobians.

A problem maps a vector ``p`` of calibrated parameters (the solver's coordinates) to the
predicted measurements ``predict(p)`` and their Jacobian ``jacobian(p)``; the residual is
``y - predict(p)``.  All physics comes from the core (:class:`cosim.core.Model`); a problem
only chooses which parameters move and stacks the core's outputs.

* :class:`FourbarProblem` (Vitali 2020): y = X of the coupler mid point at crank angles
  theta; p = the four link lengths; columns from ``pkm_fourbar_output``.
* :class:`SixpusProblem` (Tiberi 2020 ch. 4): y = the slider strokes q_i read at held poses
  whose pose was measured by a tracker; predict(p) = the inverse kinematics of the model
  with parameters p at the measured pose; columns from ``pkm_6pus_calib_rows`` with the
  platform points in the platform frame (constant over poses), so dq = q_measured -
  q_IK_nominal(measured pose) = J d(eta) (seed eq. 4.3-4.9).
* :class:`JointProblem` (any other robot the core knows): y = the joint readings at held
  poses measured by a tracker; predict(p) = the core's inverse kinematics at the measured pose
  with the geometric parameters p (every length parameter of the robot that moves a joint);
  columns by central differences of that inverse kinematics.
* :class:`LinearProblem`: a fixed J and dy (e.g. a table typed from a seed).

The 6-PUS rail direction.  The error model of Tiberi 2020 (eq. 4.1) has 10 parameters per
leg, 3 of them the rail direction s, and its columns are the derivatives without keeping
|s| = 1.  The radial one, ds along s, has column dq/ds . s = -q: a stroke scale error, which
a unit rail direction cannot represent (the core requires |s| = 1).  So the calibrated
coordinates keep the two components of s other than its largest one (sy, sz for rails
along x) and compute that one from |s| = 1; the Jacobian is the chain rule of the seed's
columns through that constraint, and the update stays exactly on |s| = 1.  Per leg 9
calibrated coordinates, 54 in all; the seed's 60-parameter analysis is still available
(:meth:`SixpusProblem.error_model_jacobian`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import ArgumentError, InputError, PkmError
from ..recording import FULL_POSE as _FULL, FULL_POSE_UNITS as _FULL_UNITS  # a 6-DOF tracker's columns

__all__ = [
    "CalibrationDataError",
    "CalibrationWarning",
    "Problem",
    "LinearProblem",
    "FourbarProblem",
    "SixpusProblem",
    "JointProblem",
    "FullPoseProblem",
    "SIXPUS_ERROR_MODEL",
    "sixpus_leg_names",
    "calib_rows",
]

PKM_FRAME_WORLD, PKM_FRAME_PLATFORM = 0, 1


class CalibrationDataError(InputError):
    """Calibration data cannot be used: too few poses, unreachable poses, NaN..."""


class CalibrationWarning(UserWarning):
    """Calibration can go on, but something about the data deserves attention."""


def sixpus_leg_names(i: int) -> list[str]:
    """The 10 error-model parameters of leg i (1-based), in Tiberi 2020 eq. 4.1 order
    [X, Y, Z, S0x, S0y, S0z, L, sx, sy, sz], as core parameter names."""
    return [f"leg[{i}].px", f"leg[{i}].py", f"leg[{i}].pz", f"rail[{i}].S0x", f"rail[{i}].S0y",
            f"rail[{i}].S0z", f"leg[{i}].L", f"rail[{i}].sx", f"rail[{i}].sy", f"rail[{i}].sz"]


#: the 60-parameter error model of Tiberi 2020 (eq. 4.2), leg by leg
SIXPUS_ERROR_MODEL = [n for i in range(1, 7) for n in sixpus_leg_names(i)]


def calib_rows(model, x, frame: int = PKM_FRAME_PLATFORM) -> np.ndarray:
    """Regression rows dq_i/d eta_i of the core at pose(s) x: shape (..., 6, 10)
    (:meth:`cosim.core.Model.calib_rows`; ``frame`` is ``PKM_FRAME_WORLD`` or ``PKM_FRAME_PLATFORM``)."""
    return model.calib_rows(x, ("world", "platform")[int(frame)])


def _set_params_fast(model, values: dict) -> None:
    """Set the parameters of a working model (rewritten at each evaluation; the direct search
    makes tens of thousands): :meth:`cosim.core.Model.set_params_unchecked`."""
    model.set_params_unchecked(values)


class Problem:
    """Base class: see the module docstring.

    Attributes
    ----------
    robot : str
    names, units : list of str
        The calibrated coordinates.
    p0 : ndarray
        Their nominal values.
    y : ndarray, shape (m,)
        The measurements.
    row_labels : list of str
        Where each measurement comes from (recording row, time, leg), for messages.
    blocks : list of (label, rows, cols) or None
        Independent blocks of the (block-diagonal) Jacobian.
    prior : ndarray
        Expected size of each parameter's error (search intervals, pose design).
    weights : ndarray or None
        Relative weight of each equation (inverse of its expected noise).
    """

    robot = ""
    names: list
    units: list
    p0: np.ndarray
    y: np.ndarray
    row_labels: list
    blocks = None
    prior: np.ndarray
    weights = None  # per-equation weights (1 / expected noise, relative), or None
    measurement_unit = "m"  # unit of y (the joint unit for a JointProblem)

    def predict(self, p) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, p) -> np.ndarray:
        raise NotImplementedError

    def residual(self, p) -> np.ndarray:
        return self.y - self.predict(p)

    def wresidual(self, p) -> np.ndarray:
        """Weighted residual: what the solvers minimise."""
        r = self.residual(p)
        return r if self.weights is None else self.weights * r

    def wjacobian(self, p) -> np.ndarray:
        """Weighted Jacobian (rows scaled like :meth:`wresidual`)."""
        J = self.jacobian(p)
        return J if self.weights is None else self.weights[:, None] * J

    def model_params(self, p) -> dict:
        """Core parameter values for calibrated coordinates p."""
        return dict(zip(self.names, map(float, p)))

    _p = None  # the coordinates last written into self.model

    def _set(self, p):
        """Write coordinates p into the problem's core model (skipped if unchanged)."""
        p = np.asarray(p, float)
        if self._p is None or not np.array_equal(p, self._p):
            _set_params_fast(self.model, self.model_params(p))
            self._p = p.copy()

    @property
    def nmeas(self) -> int:
        return int(self.y.size)


class LinearProblem(Problem):
    """A linear model dy = J dp around p0 (e.g. the seed's printed tables)."""

    def __init__(self, J, dy, names, units=None, p0=None, blocks=None, prior=None):
        self.J = np.asarray(J, float)
        self.y = np.asarray(dy, float)
        self.names = list(names)
        self.units = list(units) if units is not None else [""] * len(self.names)
        self.p0 = np.zeros(len(self.names)) if p0 is None else np.asarray(p0, float)
        self.blocks = blocks
        self.prior = np.ones(len(self.names)) if prior is None else np.asarray(prior, float)
        self.row_labels = [f"row {k}" for k in range(self.y.size)]

    def predict(self, p):
        return self.J @ (np.asarray(p, float) - self.p0)

    def jacobian(self, p):
        return self.J


def _check_finite(a, what, columns):
    a = np.asarray(a, float)
    bad = np.argwhere(~np.isfinite(a.reshape(a.shape[0], -1)))
    if bad.size:
        r, c = bad[0]
        raise CalibrationDataError(f"{what}: row {r}, column {columns[c]!r} is not a finite number")
    return a


class FourbarProblem(Problem):
    """Four-bar (Vitali 2020): outputs X [m] measured at crank angles theta [rad].

    Parameters
    ----------
    theta, X : array_like, shape (n,)
    model : cosim.core.Model
        The nominal ``"fourbar"`` model (copied; the copy is moved by ``predict``).
    row_labels : list of str, optional
    min_poses : int
        Angles required (4 for a calibration; fewer for a verification set).
    """

    robot = "fourbar"

    def __init__(self, theta, X, model, row_labels=None, min_poses: int = 4):
        from ..fourbar import LENGTHS

        theta = _check_finite(np.atleast_1d(theta), "four-bar crank angles", ["theta"]).ravel()
        X = _check_finite(np.atleast_1d(X), "four-bar outputs", ["X"]).ravel()
        if theta.shape != X.shape:
            raise CalibrationDataError(f"{theta.size} crank angles but {X.size} outputs")
        self.model = model.copy()
        self.nominal = model.copy()
        self.theta, self.y = theta, X
        self.names = list(LENGTHS)
        self.units = ["m"] * 4
        self.p0 = np.array([model.param(n) for n in self.names])
        self.prior = np.full(4, 1e-3)
        self.row_labels = row_labels or [f"theta = {np.degrees(t):.6g} deg" for t in theta]
        if theta.size < min_poses:
            raise CalibrationDataError(
                f"too few poses: {theta.size} crank angle(s) for 4 link lengths; at least {min_poses} distinct "
                f"angles are needed")
        self._p = None

    def predict(self, p):
        from ..fourbar import output

        self._set(p)
        return output(self.model, self.theta, jacobian=False)

    def jacobian(self, p):
        from ..fourbar import output

        self._set(p)
        return output(self.model, self.theta)[1]


@dataclass
class _Dep:
    leg: int
    dep: int  # index 0..2 of the dependent rail-direction component
    sign: float


class SixpusProblem(Problem):
    """6-PUS (Tiberi 2020 ch. 4): slider strokes q read at held poses measured by a tracker.

    Parameters
    ----------
    pose : array_like, shape (n, 6)
        Measured poses (x, y, z [m], rx, ry, rz [rad]).
    q : array_like, shape (n, 6)
        Joint readings [m].
    model : cosim.core.Model
        The nominal ``"6pus"`` model (copied).
    row_labels : list of str, optional
        One label per pose (e.g. "row 12 (t = 11 s)").
    unreachable : {"drop", "raise"}
        What to do with poses the nominal model cannot reach: drop them with a
        :class:`CalibrationWarning` naming them, or raise.
    min_poses : int, optional
        Poses required (default: the 9 calibrated coordinates of a leg).
    weighting : {"tracker", "none"}
        ``"tracker"`` (default): weight each equation by the inverse of the stroke noise
        that tracker noise causes, assuming the tracker sees every platform point with the
        same accuracy (orientation noise = position noise / platform radius): the noise of
        q_i is sqrt(|dq_i/dp|^2 + |dq_i/da|^2 / r^2) times the position noise, dq/dx from
        the core's inverse-kinematic Jacobian at the measured pose.  It is large where a
        leg is close to perpendicular to its rail; down-weighting those equations makes
        the estimates about 25 % more precise.  ``"none"``: ordinary least squares.
    """

    robot = "6pus"

    def __init__(self, pose, q, model, row_labels=None, unreachable="drop", min_poses=None,
                 weighting: str = "tracker"):
        cols = ["x", "y", "z", "rx", "ry", "rz"]
        pose = _check_finite(np.asarray(pose, float).reshape(-1, 6), "6-PUS measured poses", cols)
        q = _check_finite(np.asarray(q, float).reshape(-1, 6), "6-PUS joint readings", [f"q{i}" for i in range(1, 7)])
        if pose.shape != q.shape:
            raise CalibrationDataError(f"{pose.shape[0]} poses but {q.shape[0]} joint readings")
        labels = list(row_labels) if row_labels is not None else [f"pose {k}" for k in range(pose.shape[0])]
        self.nominal = model.copy()
        self.model = self.working_model()
        # the dependent rail-direction component of each leg: its largest at nominal
        self._deps = []
        names, units = [], []
        for i in range(1, 7):
            s = np.array([model.param(f"rail[{i}].s{c}") for c in "xyz"])
            dep = int(np.argmax(np.abs(s)))
            self._deps.append(_Dep(i, dep, 1.0 if s[dep] > 0 else -1.0))
            for k, n in enumerate(sixpus_leg_names(i)):
                if k >= 7 and k - 7 == dep:
                    continue
                names.append(n)
                units.append("1" if k >= 7 else "m")
        self.names, self.units = names, units
        self.p0 = np.array([model.param(n) for n in names])
        self.prior = np.array([1e-2 if u == "1" else 1e-3 for u in units])
        # poses the nominal model cannot reach carry no usable equation
        _, status = self.model.ik(pose, errors="status")
        bad = np.flatnonzero(status != 0)
        if bad.size:
            msgs = []
            for k in bad[:5]:
                try:
                    self.model.ik(pose[k])
                except PkmError as e:
                    msgs.append(f"{labels[k]}: {e}")
            text = (f"{bad.size} of {pose.shape[0]} measured poses are not reachable by the nominal model: "
                    + "; ".join(msgs) + (" ..." if bad.size > 5 else ""))
            if unreachable == "raise":
                raise CalibrationDataError(text)
            warnings.warn(text + " (dropped)", CalibrationWarning, stacklevel=2)
            keep = status == 0
            pose, q = pose[keep], q[keep]
            labels = [l for l, k in zip(labels, keep) if k]
        need = 9 if min_poses is None else int(min_poses)
        if pose.shape[0] < need:
            raise CalibrationDataError(
                f"too few poses: {pose.shape[0]} usable pose(s) give {pose.shape[0]} equations per leg, but each leg "
                f"has 9 calibrated parameters (10 in Tiberi 2020's error model minus the unit rail direction); "
                f"measure at least {need} distinct poses")
        self.pose, self.q = pose, q
        self.pose_labels = labels
        self.y = q.reshape(-1)
        self.row_labels = [f"{labels[k]}, leg {i + 1}" for k in range(pose.shape[0]) for i in range(6)]
        n = pose.shape[0]
        self.blocks = [(f"leg {i + 1}", np.arange(i, 6 * n, 6), np.arange(9 * i, 9 * i + 9)) for i in range(6)]
        self._p = None
        if weighting == "tracker":
            r = np.mean([np.hypot(model.param(f"leg[{i}].px"), model.param(f"leg[{i}].py")) for i in range(1, 7)])
            Jx = self.model.jacobian(pose)  # (n, 6, 6): dq_i / dx_j
            sd = np.sqrt(np.sum(Jx[:, :, :3] ** 2, axis=2) + np.sum(Jx[:, :, 3:] ** 2, axis=2) / r ** 2)
            self.weights = (1.0 / sd).reshape(-1)
        elif weighting != "none":
            raise InputError(f"weighting must be 'tracker' or 'none', got {weighting!r}")
        self.weighting = weighting

    # --------------------------------------------------------------- parameters
    def working_model(self, p=None):
        """A copy of the nominal model with parameters p and without stroke limits.

        The stroke range is a limit of the machine, not geometry: the joints were read,
        so a model that predicts a stroke a hair outside the range must still compare.
        """
        m = self.nominal.copy()
        lim = {}
        for i in range(1, 7):
            lim[f"rail[{i}].qmin"], lim[f"rail[{i}].qmax"] = -1.0, 1.0
        m.set_params(lim)
        if p is not None:
            m.set_params(self.model_params(p))
        return m

    def model_params(self, p) -> dict:
        """Core parameter values (the 60 of the error model) for calibrated coordinates p."""
        p = np.asarray(p, float)
        out = {}
        for b, d in enumerate(self._deps):
            v = p[9 * b:9 * b + 9]
            out.update(zip(sixpus_leg_names(d.leg)[:7], map(float, v[:7])))
            others = [k for k in range(3) if k != d.dep]
            s = np.zeros(3)
            s[others] = v[7:9]
            rest = 1.0 - float(s[others] @ s[others])
            if not rest > 0:
                raise ArgumentError(f"rail {d.leg}: direction components {v[7:9]} leave no unit vector", "PKM_ERR_PARAMETER")
            s[d.dep] = d.sign * np.sqrt(rest)
            out.update({f"rail[{d.leg}].s{c}": float(s[k]) for k, c in enumerate("xyz")})
        return out

    # ----------------------------------------------------------------- physics
    def predict(self, p):
        self._set(p)
        qp, status = self.model.ik(self.pose, errors="status")
        if np.any(status != 0):
            k = int(np.flatnonzero(status != 0)[0])
            try:
                self.model.ik(self.pose[k])
            except PkmError as e:
                raise CalibrationDataError(
                    f"{self.pose_labels[k]}: the model with the current parameter estimate cannot reach the "
                    f"measured pose ({e}); the estimate has diverged or the data are inconsistent") from None
        return qp.reshape(-1)

    def error_model_jacobian(self, p=None, frame: int = PKM_FRAME_PLATFORM) -> np.ndarray:
        """The seed's 60-column regression matrix (eq. 4.6) at parameters p (default p0).

        Rows are (pose, leg) in the order of ``y``; columns :data:`SIXPUS_ERROR_MODEL`.
        """
        self._set(self.p0 if p is None else p)
        rows = calib_rows(self.model, self.pose, frame)  # (n, 6, 10)
        n = self.pose.shape[0]
        J = np.zeros((6 * n, 60))
        for i in range(6):
            J[i::6, 10 * i:10 * i + 10] = rows[:, i, :]
        return J

    def jacobian(self, p):
        J60 = self.error_model_jacobian(p)
        p = np.asarray(p, float)
        J = np.empty((J60.shape[0], 54))
        for b, d in enumerate(self._deps):
            c = J60[:, 10 * b:10 * b + 10]
            others = [k for k in range(3) if k != d.dep]
            s = np.zeros(3)
            s[others] = p[9 * b + 7:9 * b + 9]
            s[d.dep] = d.sign * np.sqrt(1.0 - s[others] @ s[others])
            J[:, 9 * b:9 * b + 7] = c[:, :7]
            for j, k in enumerate(others):
                # d s_dep / d s_k = -s_k / s_dep keeps |s| = 1
                J[:, 9 * b + 7 + j] = c[:, 7 + k] - c[:, 7 + d.dep] * s[k] / s[d.dep]
        return J

    def blocks_60(self):
        n = self.pose.shape[0]
        return [(f"leg {i + 1}", np.arange(i, 6 * n, 6), np.arange(10 * i, 10 * i + 10)) for i in range(6)]


#: parameter groups that are never geometry (the joint's own drive parameters are told apart by
#: the inverse kinematics: they do not move a joint)
_NOT_GEOMETRY = ("gravity.", "drive.", "actuator.", "sensor.", "payload.")


def geometry_candidates(model, poses, measure=None) -> list:
    """Every length parameter [m] of ``model`` (outside gravity, payload and the drive and
    sensor layers) whose change moves a joint of the core's inverse kinematics at ``poses``:
    a central difference of the IK per parameter, all poses in one call.

    Unlike :meth:`cosim.core.Model.geometry_params` (``declared=False``) it keeps the
    parameters named after the joint (a described robot's ``arm[i].Ax``, ``arm[i].r``,
    ``rail[i].S0x``): the drive parameters under the same prefix (friction, offsets,
    limits) do not move the inverse kinematics, so the difference leaves them out.
    ``measure(model, poses)``: what must move instead of the joints (an array).
    """
    x = np.atleast_2d(np.asarray(poses, float))
    if measure is None:
        measure = lambda m, xs: np.asarray(m.ik(xs), float)  # noqa: E731
    base = measure(model, x)
    trial = model.copy()
    keep = []
    for info in model.param_info():
        if info.unit != "m" or info.name.startswith(_NOT_GEOMETRY):
            continue
        h = 1e-6 * max(abs(info.value), 1e-3)
        try:
            trial.set_params({info.name: info.value + h})
            moved = np.max(np.abs(measure(trial, x) - base)) > 1e-9 * h
        except PkmError:
            moved = False
        finally:
            trial.set_params({info.name: info.value})
        if moved:
            keep.append(info.name)
    return keep


def _select(model, candidates, patterns):
    """The names of ``candidates`` (or of any parameter of the model) matching ``patterns``
    (names or shell patterns: ``leg[*].L``; square brackets are literal)."""
    import fnmatch

    every = model.param_names()
    out = []
    for pat in patterns:
        hit = [n for n in every if fnmatch.fnmatchcase(n, _literal_brackets(pat))]
        if not hit:
            raise CalibrationDataError(f"{model.robot} has no parameter matching {pat!r} (its geometric "
                                       f"parameters: {', '.join(candidates)})")
        out += [n for n in hit if n not in out]
    return out


def _literal_brackets(pat: str) -> str:
    """A shell pattern whose square brackets match themselves (``leg[1].L``, ``leg[*].L``)."""
    return "".join({"[": "[[]", "]": "[]]"}.get(c, c) for c in pat)


def _joint_blocks(J, nd):
    """Independent blocks of a joint-space regression matrix: the joints and parameters
    connected through non-zero columns (a described robot's legs, one block each)."""
    npose = J.shape[0] // nd
    scale = np.abs(J).max() or 1.0
    touch = np.abs(J).reshape(npose, nd, -1).max(axis=0) > 1e-12 * scale  # (joint, parameter)
    parent = list(range(nd))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for c in range(touch.shape[1]):
        js = np.flatnonzero(touch[:, c])
        for j in js[1:]:
            parent[find(j)] = find(js[0])
    groups = {}
    for j in range(nd):
        groups.setdefault(find(j), []).append(j)
    if len(groups) == 1:
        return None
    blocks = []
    for js in groups.values():
        cols = np.flatnonzero(touch[js].any(axis=0))
        if cols.size == 0:
            continue
        rows = np.array([k * nd + j for k in range(npose) for j in js])
        label = f"joint {js[0] + 1}" if len(js) == 1 else "joints " + ", ".join(str(j + 1) for j in js)
        blocks.append((label, rows, cols))
    return blocks


class JointProblem(Problem):
    """Any robot: joint readings q at held poses whose pose a tracker measured.

    The calibrated coordinates are the robot's geometric parameters as the core lists them:
    every parameter in metres outside the drive layer, gravity and payload whose change moves
    a joint at these poses (:func:`geometry_candidates`), or the ones ``params`` names.
    predict(p) is the core's inverse kinematics with those values; the columns are central
    differences of it (a robot needs nothing written for calibration).  The rows of a joint
    that shares no parameter with the others (a leg of a described robot) form an
    independent block of the identifiability analysis and of the solvers.

    Parameters
    ----------
    pose : array_like, shape (n, nd)
        Measured poses, in the robot's pose coordinates (``Model.facts.pose_names``).
    q : array_like, shape (n, nd)
        Joint readings.
    model : cosim.core.Model
        The nominal model (copied).
    row_labels : list of str, optional
    min_poses : int, optional
        Poses required (default: enough equations for the parameters).
    params : list of str, optional
        The parameters to calibrate, by name or shell pattern (``["leg[*].L"]``); default
        every geometric one.
    """

    def __init__(self, pose, q, model, row_labels=None, min_poses: int | None = None, params=None):
        nd = model.ndof
        names = model.facts.pose_names
        self.pose = _check_finite(np.atleast_2d(pose), "measured poses", list(names))
        self.q = _check_finite(np.atleast_2d(q), "joint readings", [f"q{i + 1}" for i in range(nd)])
        if self.pose.shape != self.q.shape or self.pose.shape[1] != nd:
            raise CalibrationDataError(f"{self.pose.shape[0]} poses of {self.pose.shape[1]} coordinates and "
                                       f"{self.q.shape[0]} joint readings of {self.q.shape[1]}: both need {nd}")
        self.robot = model.robot
        self.measurement_unit = model.facts.joint_unit
        self.model, self.nominal = model.copy(), model.copy()
        self.y = self.q.ravel()
        self._p = None
        info = {i.name: i for i in model.param_info()}
        geo = self._candidates(model, self.pose)
        chosen = geo if params is None else _select(model, geo, params)
        if not chosen:
            raise CalibrationDataError(f"robot {self.robot!r}: no length parameter moves a joint at these poses")
        keep = [info[n] for n in chosen]
        self.names = [i.name for i in keep]
        self.units = [i.unit for i in keep]
        self.p0 = np.array([i.value for i in keep])
        self.prior = np.array([1e-3 if i.unit == "m" else max(1e-3, 1e-2 * abs(i.value)) for i in keep])
        self.pose_labels = row_labels or [f"pose {k + 1}" for k in range(self.pose.shape[0])]
        self.row_labels = [f"{lab}, joint {j + 1}" for lab in self.pose_labels for j in range(nd)]
        need = len(keep) // nd + 1 if min_poses is None else min_poses
        if self.pose.shape[0] < need:
            raise CalibrationDataError(f"too few poses: {self.pose.shape[0]} for {len(keep)} parameters "
                                       f"({', '.join(self.names)}); at least {need} are needed")
        self.blocks = self._find_blocks()

    def _candidates(self, model, poses):
        """The parameters calibrated by default (:func:`geometry_candidates`)."""
        return geometry_candidates(model, poses)

    def _find_blocks(self):
        """Independent blocks (:func:`_joint_blocks`), or None for the whole matrix."""
        blocks = _joint_blocks(self.jacobian(self.p0), self.q.shape[1])
        if blocks is not None and sum(len(b[2]) for b in blocks) != len(self.names):
            return None  # a parameter that moves no joint here: analyse the whole matrix
        return blocks

    def _ik(self, model):
        return np.asarray(model.ik(self.pose), float).reshape(self.pose.shape)

    def predict(self, p):
        self._set(p)
        return self._ik(self.model).ravel()

    def jacobian(self, p):
        p = np.asarray(p, float)
        J = np.empty((self.y.size, p.size))
        for j in range(p.size):
            h = 1e-6 * max(abs(p[j]), 1e-3)
            up, dn = p.copy(), p.copy()
            up[j] += h
            dn[j] -= h
            J[:, j] = (self.predict(up) - self.predict(dn)) / (2 * h)
        self._set(p)
        return J



class FullPoseProblem(JointProblem):
    """A robot that declares some pose components (a 3-PRS or 3-RPS head: z, rx, ry) measured
    by a 6-DOF tracker: the joints and the other components (the parasitic x, y, rz) at held
    poses.

    The measured declared components are the poses; the measurements are the joint readings
    and the measured other components.  predict(p) is the core's inverse kinematics at those
    poses and the core's solution of the other components there (``Model.platform_pose``),
    with the geometric parameters p; so a geometry error shows twice: in the joints, and in
    the parasitic motion the legs force.  The parasitic equations couple every leg (no
    independent blocks).  Angular equations are weighted by ``angle_length`` (an angle error
    seen by a tracker as the displacement of points that far apart), the others by 1.

    Parameters
    ----------
    pose : array_like, shape (n, 6)
        Measured full poses x, y, z [m], rx, ry, rz [rad].
    q : array_like, shape (n, nd)
        Joint readings.
    model : cosim.core.Model
        The nominal model (copied): a described robot declaring fewer than six components.
    row_labels, min_poses, params
        As :class:`JointProblem`; ``params`` default: every length that moves a joint or a
        parasitic component at these poses.
    angle_length : float
        Length [m] that turns a radian residual into metres for the weights (default 0.1 m).

    Example
    -------
    >>> from cosim.core import Model
    >>> from cosim.calibration import data
    >>> m = Model("robots/tripod_3rps.toml")
    >>> X = data.candidate_poses(m, 20, rng=1)
    >>> rec = data.joint_campaign(m, {"leg[1].bx": m.param("leg[1].bx") + 2e-4}, X, tracker_noise=0.0,
    ...                           full_pose=True)
    >>> FullPoseProblem(rec.pose_full, rec.q, m).names[:3]         # doctest: +SKIP
    ['leg[1].bx', 'leg[1].by', 'leg[1].bz']
    """

    def __init__(self, pose, q, model, row_labels=None, min_poses: int | None = None, params=None,
                 angle_length: float = 0.1):
        nd = model.ndof
        full = _check_finite(np.atleast_2d(pose), "measured full poses", list(_FULL))
        q = _check_finite(np.atleast_2d(q), "joint readings", [f"q{i + 1}" for i in range(nd)])
        if full.shape[1] != 6 or full.shape[0] != q.shape[0] or q.shape[1] != nd:
            raise CalibrationDataError(f"{full.shape[0]} measured poses of {full.shape[1]} components and "
                                       f"{q.shape[0]} joint readings of {q.shape[1]}: need 6 components "
                                       f"({' '.join(_FULL)}) and {nd} joints per pose")
        declared = list(model.facts.pose_names)
        if not set(declared) < set(_FULL):
            raise CalibrationDataError(f"robot {model.robot!r} declares {' '.join(declared)}: a full-pose "
                                       f"calibration is for a robot that declares some of x y z rx ry rz")
        self.decl = [_FULL.index(n) for n in declared]
        self.other = [k for k in range(6) if k not in self.decl]
        self.full = full
        self._angle_length = float(angle_length)
        super().__init__(full[:, self.decl], q, model, row_labels=row_labels, min_poses=min_poses, params=params)
        self.y = np.concatenate([self.q, self.full[:, self.other]], axis=1).ravel()
        self.row_labels = [f"{lab}, {what}" for lab in self.pose_labels
                           for what in [f"joint {j + 1}" for j in range(nd)] + [_FULL[k] for k in self.other]]
        w_other = [1.0 if _FULL_UNITS[k] == "m" else self._angle_length for k in self.other]
        w_joint = [1.0 if model.facts.joint_unit == "m" else self._angle_length] * nd
        self.weights = np.tile(np.array(w_joint + w_other), self.pose.shape[0])
        self.measurement_unit = "m"

    def _find_blocks(self):
        return None  # the parasitic components couple the legs

    def _candidates(self, model, poses):
        """Every length [m] (outside gravity, payload, drive and sensors) whose change moves a
        joint or a parasitic component at ``poses``."""
        return geometry_candidates(model, poses, measure=self._measure)

    def _measure(self, model, poses):
        """(n, joints + other components): the joints and the undeclared pose components of
        ``model`` at ``poses``."""
        q = np.asarray(model.ik(poses), float).reshape(poses.shape[0], -1)
        X, _ = model.platform_pose(poses)
        return np.concatenate([q, np.asarray(X).reshape(-1, 6)[:, self.other]], axis=1)

    def predict(self, p):
        self._set(p)
        return self._measure(self.model, self.pose).ravel()
