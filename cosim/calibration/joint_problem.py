"""One calibration problem for any robot: :class:`JointProblem` (and the 6-DOF tracker's
:class:`FullPoseProblem`).

The calibrated parameters are the robot's error model when it ships one
(:mod:`cosim.calibration.error_model`: Tiberi 2020's 60 parameters of the 6-PUS, Vitali 2020's
four link lengths of the four-bar), otherwise every length parameter that moves a joint.  All
values and physics come from the core (:class:`cosim.core.Model`).

Unit vectors of an error model (the 6-PUS rail directions).  Tiberi 2020's columns for the
rail direction s are the derivatives without keeping |s| = 1; the radial one (ds along s) has
column dq/ds . s = -q: a stroke scale error, which a unit vector cannot represent (the core
requires |s| = 1).  So the calibrated coordinates keep the two components of s other than its
largest one and compute that one from |s| = 1; the Jacobian is the chain rule of the core's
columns through that constraint, and every update stays exactly on |s| = 1.  The error model's
own analysis is still available (:meth:`JointProblem.error_model_jacobian`).
"""
from __future__ import annotations

import warnings

import numpy as np

from ..errors import ArgumentError, InputError, PkmError
from ..recording import FULL_POSE as _FULL, FULL_POSE_UNITS as _FULL_UNITS  # a 6-DOF tracker's columns
from .error_model import error_model as _error_model, output as _output
from .problems import (CalibrationDataError, CalibrationWarning, Problem, _check_finite, _joint_blocks, _select,
                       geometry_candidates)

__all__ = ["JointProblem", "FullPoseProblem"]


class _UnitVector:
    """Three parameters forming a unit vector: the dependent component (largest at nominal)
    and the two calibrated ones (their positions in the calibrated coordinates)."""

    def __init__(self, names, nominal, coords):
        s = np.array([nominal.param(n) for n in names])
        self.names = list(names)
        self.dep = int(np.argmax(np.abs(s)))
        self.sign = 1.0 if s[self.dep] > 0 else -1.0
        self.others = [k for k in range(3) if k != self.dep]
        self.cols = [coords.index(names[k]) for k in self.others]

    def vector(self, p):
        s = np.zeros(3)
        s[self.others] = p[self.cols]
        rest = 1.0 - float(s[self.others] @ s[self.others])
        if not rest > 0:
            raise ArgumentError(f"{self.names[0]}: direction components {p[self.cols]} leave no unit vector",
                                "PKM_ERR_PARAMETER")
        s[self.dep] = self.sign * np.sqrt(rest)
        return s


class JointProblem(Problem):
    """Any robot: joint readings at held poses a tracker measured (or, for an error model with
    ``measure = "output"``, a measured output at joint values: the four-bar's X).

    predict(p) is the core's inverse kinematics at the measured poses (or the core's output at
    the joint values) with the calibrated parameters p; the columns are the core's analytic ones
    when the error model says so (``columns = "core"``), else central differences of the core.
    The rows of a joint that shares no parameter with the others (a leg) form an independent
    block of the identifiability analysis and of the solvers.

    Parameters
    ----------
    pose : array_like, shape (n, npose)
        Measured poses, in the robot's pose coordinates (``Model.facts.pose_names``); for
        ``measure = "output"`` the measured outputs, shape (n,) or (n, 1).
    q : array_like, shape (n, nd)
        Joint readings.
    model : cosim.core.Model
        The nominal model (copied).
    row_labels : list of str, optional
        One label per pose (e.g. "row 12 (t = 11 s)").
    min_poses : int, optional
        Poses required (default: the calibrated parameters of the largest block).
    params : list of str, optional
        The parameters to calibrate, by name or shell pattern (``["leg[*].L"]``); default the
        robot's error model, or every geometric length.
    unreachable : {"drop", "raise"}
        Poses the working model cannot reach: dropped with a :class:`CalibrationWarning` naming
        them, or an error.
    weighting : {"tracker", "none"}
        ``"tracker"`` (default): the error model's tracker weights if it declares them (each
        equation weighted by the inverse of the joint noise tracker noise causes:
        sqrt(|dq_i/dp|^2 + |dq_i/da|^2 / r^2), r the mean distance of the tracker's points,
        dq/dx the core's inverse-kinematic Jacobian); ``"none"``: ordinary least squares.
    error_model : ErrorModel, None or "auto"
        ``"auto"``: the robot's shipped error model unless ``params`` is given.

    Example
    -------
    >>> from cosim.core import Model
    >>> m = Model("6pus")
    >>> x = m.home()[None, :]
    >>> JointProblem(x.repeat(9, 0), m.ik(x).repeat(9, 0), m).names[:3]   # doctest: +SKIP
    ['leg[1].px', 'leg[1].py', 'leg[1].pz']
    """

    def __init__(self, pose, q, model, row_labels=None, min_poses: int | None = None, params=None,
                 unreachable: str = "drop", weighting: str = "tracker", error_model="auto"):
        if weighting not in ("tracker", "none"):
            raise InputError(f"weighting must be 'tracker' or 'none', got {weighting!r}")
        em = (_error_model(model) if params is None else None) if error_model == "auto" else error_model
        self.error_model, self.robot = em, model.robot
        self.measure = em.measure if em is not None else "joints"
        self.nominal = model.copy()
        self.model = self.working_model()
        self._p = None
        pose, q, labels = self._read(pose, q, model, row_labels, unreachable)
        self.pose, self.q, self.pose_labels = pose, q, labels
        nd = q.shape[1]
        out = self.measure == "output"
        self.y = (pose if out else q).ravel()
        self.measurement_unit = "m" if out else model.facts.joint_unit
        what = em.block_label if em is not None else "joint"
        self.row_labels = list(labels) if out else [f"{lab}, {what} {j + 1}" for lab in labels for j in range(nd)]
        self._choose(model, params)
        self._check_count(min_poses)
        self.blocks = self._find_blocks()
        self.weighting = weighting
        if weighting == "tracker" and em is not None and em.weighting == "tracker":
            self.weights = self._tracker_weights()

    # ------------------------------------------------------------------ set-up
    def _read(self, pose, q, model, row_labels, unreachable):
        """Check the arrays and drop (or refuse) the poses the working model cannot reach."""
        nd = model.ndof
        qn = [f"q{i + 1}" for i in range(nd)]
        if self.measure == "output":
            q = _check_finite(np.asarray(q, float).reshape(-1, nd), "joint values", qn)
            pose = _check_finite(np.asarray(pose, float).reshape(q.shape[0], -1), "measured outputs",
                                 ["X"])
            return pose, q, row_labels or [f"q1 = {v:.6g}" for v in q[:, 0]]
        names = list(model.facts.pose_names)
        pose = _check_finite(np.atleast_2d(pose), "measured poses", names)
        q = _check_finite(np.atleast_2d(q), "joint readings", qn)
        if pose.shape != q.shape or pose.shape[1] != nd:
            raise CalibrationDataError(f"{pose.shape[0]} poses of {pose.shape[1]} coordinates and "
                                       f"{q.shape[0]} joint readings of {q.shape[1]}: both need {nd}")
        labels = list(row_labels) if row_labels is not None else [f"pose {k + 1}" for k in range(pose.shape[0])]
        _, status = self.model.ik(pose, errors="status")
        bad = np.flatnonzero(np.asarray(status) != 0)
        if not bad.size:
            return pose, q, labels
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
        warnings.warn(text + " (dropped)", CalibrationWarning, stacklevel=3)
        keep = np.asarray(status) == 0
        return pose[keep], q[keep], [lab for lab, k in zip(labels, keep) if k]

    def _choose(self, model, params):
        """The calibrated coordinates: the error model's (minus each unit vector's dependent
        component), or ``params``, or every geometric length."""
        em = self.error_model
        info = {i.name: i for i in model.param_info()}
        if em is not None:
            dep = {u[int(np.argmax([abs(model.param(n)) for n in u]))] for u in em.unit_vectors}
            chosen = [n for n in em.parameters if n not in dep]
        else:
            geo = self._candidates(model, self.pose)
            chosen = geo if params is None else _select(model, geo, params)
        if not chosen:
            raise CalibrationDataError(f"robot {self.robot!r}: no length parameter moves a joint at these poses")
        self.names = list(chosen)
        self.units = [info[n].unit for n in chosen]
        self.p0 = np.array([info[n].value for n in chosen])
        prior = em.prior if em is not None else {}
        self.prior = np.array([prior.get(info[n].unit, 1e-3 if info[n].unit == "m" else
                                         max(1e-3, 1e-2 * abs(info[n].value))) for n in chosen])
        self._units = [_UnitVector(u, model, self.names) for u in em.unit_vectors] if em is not None else []

    def _check_count(self, min_poses):
        n = self.pose.shape[0]
        em = self.error_model
        per = len(self.names) if em is None or not em.joint_parameters else \
            max(sum(c in j for c in self.names) for j in em.joint_parameters)
        need = (per if em is not None else len(self.names) // self.q.shape[1] + 1) if min_poses is None \
            else int(min_poses)
        if n < need:
            where = f" per {em.block_label}" if em is not None and em.joint_parameters else ""
            raise CalibrationDataError(
                f"too few poses: {n} usable pose(s) for {per} calibrated parameters{where} "
                f"({', '.join(self.names[:per])}{' ...' if len(self.names) > per else ''}); measure at least "
                f"{need} distinct poses")

    def _candidates(self, model, poses):
        """The parameters calibrated by default (:func:`geometry_candidates`)."""
        return geometry_candidates(model, poses)

    def _find_blocks(self):
        """Independent blocks: one per joint of an error model declared ``per_joint``, else
        found from the matrix (:func:`_joint_blocks`), or None for the whole matrix."""
        em, nd, n = self.error_model, self.q.shape[1], self.pose.shape[0]
        if em is not None and em.joint_parameters:
            return [(f"{em.block_label} {i + 1}", np.arange(i, nd * n, nd),
                     np.array([k for k, c in enumerate(self.names) if c in em.joint_parameters[i]]))
                    for i in range(nd)]
        if self.measure == "output":
            return None
        blocks = _joint_blocks(self.jacobian(self.p0), nd)
        if blocks is not None and sum(len(b[2]) for b in blocks) != len(self.names):
            return None  # a parameter that moves no joint here: analyse the whole matrix
        return blocks

    def _tracker_weights(self):
        em = self.error_model
        r = np.mean([np.hypot(*(self.nominal.param(n) for n in pt)) for pt in em.tracker_points])
        Jx = self.model.jacobian(self.pose)  # (n, nd, 6): dq_i / dx_j
        sd = np.sqrt(np.sum(Jx[:, :, :3] ** 2, axis=2) + np.sum(Jx[:, :, 3:] ** 2, axis=2) / r ** 2)
        return (1.0 / sd).reshape(-1)

    # -------------------------------------------------------------- parameters
    def working_model(self, p=None):
        """A copy of the nominal model with the error model's working overrides (a stroke range
        opened: the joints were read, so a model that predicts one a hair outside must still
        compare) and the calibrated coordinates p."""
        m = self.nominal.copy()
        if self.error_model is not None and self.error_model.working_overrides:
            m.set_params(self.error_model.working_overrides)
        if p is not None:
            m.set_params(self.model_params(p))
        return m

    def model_params(self, p) -> dict:
        """Core parameter values for calibrated coordinates p (unit vectors completed)."""
        p = np.asarray(p, float)
        out = dict(zip(self.names, map(float, p)))
        for u in self._units:
            out.update(zip(u.names, map(float, u.vector(p))))
        if self._units:  # in the error model's order
            out = {n: out[n] for n in self.error_model.parameters if n in out}
        return out

    # ------------------------------------------------------------------ physics
    def _core(self, model, jacobian):
        """The core's prediction (and analytic columns over the error model's parameters)."""
        if self.measure == "output":
            r = _output(model, self.q, jacobian=jacobian)
            return r if jacobian else (r, None)
        if not jacobian:
            return self._ik(model), None
        rows = model.calib_rows(self.pose, "platform")  # (n, nd, k) per joint, in per_joint order
        n, nd, k = rows.shape
        J = np.zeros((n * nd, nd * k))
        for i in range(nd):
            J[i::nd, k * i:k * i + k] = rows[:, i, :]
        return None, J

    def _ik(self, model):
        qp, status = model.ik(self.pose, errors="status")
        if np.any(np.asarray(status) != 0):
            k = int(np.flatnonzero(np.asarray(status) != 0)[0])
            try:
                model.ik(self.pose[k])
            except PkmError as e:
                raise CalibrationDataError(
                    f"{self.pose_labels[k]}: the model with the current parameter estimate cannot reach the "
                    f"measured pose ({e}); the estimate has diverged or the data are inconsistent") from None
        return np.asarray(qp, float).reshape(self.q.shape)

    def predict(self, p):
        self._set(p)
        return np.asarray(self._core(self.model, False)[0], float).ravel()

    def error_model_jacobian(self, p=None) -> np.ndarray:
        """The core's columns over every parameter of the error model (Tiberi 2020 eq. 4.6 for
        the 6-PUS: rows (pose, leg) in the order of ``y``, columns ``error_model.parameters``)
        at calibrated coordinates p (default p0)."""
        self._set(self.p0 if p is None else p)
        return np.asarray(self._core(self.model, True)[1], float).reshape(self.y.size, -1)

    def error_model_blocks(self):
        """The independent blocks of :meth:`error_model_jacobian` (one per joint), or None."""
        em, nd, n = self.error_model, self.q.shape[1], self.pose.shape[0]
        if not em.joint_parameters:
            return None
        k = len(em.joint_parameters[0])
        return [(f"{em.block_label} {i + 1}", np.arange(i, nd * n, nd), np.arange(k * i, k * i + k))
                for i in range(nd)]

    def jacobian(self, p):
        p = np.asarray(p, float)
        em = self.error_model
        if em is None or em.columns != "core":
            return self._differences(p)
        Jm = self.error_model_jacobian(p)
        col = {n: k for k, n in enumerate(em.parameters)}
        J = Jm[:, [col[n] for n in self.names]]
        for u in self._units:
            s = u.vector(p)
            c = Jm[:, [col[n] for n in u.names]]
            for j, k in zip(u.cols, u.others):
                # d s_dep / d s_k = -s_k / s_dep keeps |s| = 1
                J[:, j] = c[:, k] - c[:, u.dep] * s[k] / s[u.dep]
        return J

    def _differences(self, p):
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
        super().__init__(full[:, self.decl], q, model, row_labels=row_labels, min_poses=min_poses, params=params,
                         unreachable="raise", error_model=None)
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
