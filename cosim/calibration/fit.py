"""Kinematic calibration from ``pkm-recording/1`` files, with identifiability analysis.

The calibration reads a recording (never the simulator's internals), builds the
calibration problem of its robot on the nominal model named by the sidecar, analyses
which parameters the data can identify, estimates them with one of the solvers, and
verifies the accuracy gain on held-out poses.

One problem class for every robot (:class:`~cosim.calibration.joint_problem.JointProblem`):
the parameters are the error model the robot ships as data (``robots/calibration/<robot>.toml``,
:mod:`cosim.calibration.error_model`), else every length parameter that moves a joint.

* 6-PUS (Tiberi 2020, ``robots/calibration/6pus.toml``): each row is a held pose: joint
  readings ``q1..q6`` and the pose ``x, y, z, rx, ry, rz`` measured by an external tracker.
  Error model: 10 parameters per leg (platform point in the platform frame, rail origin,
  leg length, rail direction), 60 in all; 54 calibrated coordinates because each rail
  direction keeps |s| = 1.
* Four-bar (Vitali 2020, ``robots/calibration/fourbar.toml``): ``q1`` = crank angle theta,
  pose column ``X`` = measured output.

Example
-------
>>> from cosim.calibration import calibrate
>>> res = calibrate("scenarios/calibration_6pus_campaign.csv", solver="gauss-newton", holdout=0.25)
>>> print(res.text())                       # identifiability, estimates +- SE, accuracy
>>> res.save("out/")                        # figures and the calibrated parameters (JSON)

Submodules: :mod:`~cosim.calibration.ident` (identifiability),
:mod:`~cosim.calibration.solvers` (solvers), :mod:`~cosim.calibration.problems`
(residuals and Jacobians from the core), :mod:`~cosim.calibration.design` (pose
selection), :mod:`~cosim.calibration.data` (synthetic campaigns),
:mod:`~cosim.calibration.seed` (the seeds' examples).
"""
from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .ident import IdentifiabilityReport, identifiability
from .error_model import error_model
from .joint_problem import FullPoseProblem, JointProblem
from .problems import CalibrationDataError, CalibrationWarning, Problem
from .solvers import METHODS, Solution, solve
from ..core.model import Model
from ..recording import Recording, read_recording
from ..errors import InputError

__all__ = [
    "calibrate",
    "CalibrationResult",
    "Accuracy",
    "problem_from_recording",
    "measurements",
    "Measurements",
    "accuracy",
    "split_holdout",
    "CalibrationDataError",
    "CalibrationWarning",
    "METHODS",
    "MODELS",
]

#: which parameters are estimated: the structural model (Tiberi 2020 3.1.1), the prediction
#: model (3.1.2: all parameters, truncated SVD) or all parameters ("full", refuses a
#: rank-deficient set)
MODELS = ("structural", "prediction", "full")


@dataclass
class Measurements:
    """The (pose, joints) pairs a calibration uses, taken from a recording."""

    robot: str
    pose: np.ndarray  # (n, npose) measured pose / output
    q: np.ndarray  # (n, nd) joint readings
    labels: list  # where each comes from (rows, time)
    parameters: dict  # nominal overrides of the sidecar
    source: str
    averaged: bool = False

    def __len__(self) -> int:
        return len(self.q)


def measurements(rec, use: str = "auto") -> Measurements:
    """The measurements of a recording.

    Parameters
    ----------
    rec : Recording or path
    use : {"auto", "held", "rows"}
        ``"rows"``: every row is a measurement (q and the pose at the same instant are
        related by the kinematics whether the robot moves or not).  ``"held"``: the
        recording has a ``label`` column tagging the rows of each held pose (> 0; 0 while
        moving, as the scenario exports write it); each hold gives one measurement, the
        mean of its second half (settled; averaging divides the sensor noise).
        ``"auto"``: ``"held"`` if there is a ``label`` column, else ``"rows"``.
    """
    if not isinstance(rec, Recording):
        rec = read_recording(rec)
    where = str(rec.path) if rec.path else "recording"
    if rec.pose is None:
        raise CalibrationDataError(
            f"{where}: no pose columns ({', '.join(rec.pose_columns)}): a calibration campaign must record the "
            f"measured pose (or output) next to the joint readings")
    if use not in ("auto", "held", "rows"):
        raise InputError(f"use must be 'auto', 'held' or 'rows', got {use!r}")
    lab = rec.extra.get("label")
    if use == "held" and lab is None:
        raise CalibrationDataError(f"{where}: no 'label' column tagging the held poses (use='rows' takes every row)")
    # a 6-DOF tracker's full pose (the parasitic components too) when the recording has it
    P = rec.pose if rec.pose_full is None else rec.pose_full
    if use == "rows" or (use == "auto" and lab is None):
        return Measurements(rec.robot, P, rec.q, [f"row {k + 2} (t = {rec.time[k]:g} s)" for k in
                                                         range(len(rec))], rec.parameters, where)
    pose, q, labels = [], [], []
    for k in sorted(set(np.asarray(lab).tolist()) - {0.0}):
        rows = np.flatnonzero(lab == k)
        last = rows[len(rows) // 2:]
        pose.append(P[last].mean(axis=0))
        q.append(rec.q[last].mean(axis=0))
        labels.append(f"hold {k:g} (rows {last[0] + 2}-{last[-1] + 2}, t = {rec.time[last[0]]:g}-"
                      f"{rec.time[last[-1]]:g} s)")
    if not pose:
        raise CalibrationDataError(f"{where}: the 'label' column tags no held pose (all 0)")
    return Measurements(rec.robot, np.array(pose), np.array(q), labels, rec.parameters, where, averaged=True)


def problem_from_recording(rec, rows=None, nominal: Model | None = None, unreachable: str = "drop",
                           min_poses: int | None = None, use: str = "auto", weighting: str = "tracker",
                           params=None) -> Problem:
    """The calibration problem of a recording (or of some of its measurements).

    Parameters
    ----------
    rec : Recording, Measurements or path
    rows : array_like of int, optional
        Measurements to use (0-based; default all).
    nominal : Model, optional
        Nominal model (default: the sidecar's robot with its parameter overrides).
    unreachable : {"drop", "raise"}
        Poses the nominal model cannot reach: dropped with a warning, or an error.
    min_poses : int, optional
        Poses required (default: enough to calibrate; 1 for a verification set).
    use : {"auto", "held", "rows"}
        See :func:`measurements`.
    weighting : {"tracker", "none"}
        Equation weights, for an error model that declares tracker weights (the 6-PUS; see
        :class:`~cosim.calibration.joint_problem.JointProblem`).
    params : list of str, optional
        The parameters to calibrate, by name or shell pattern (``["leg[*].L"]``); default the
        error model the robot ships (``robots/calibration/<robot>.toml``: the 6-PUS, the
        four-bar), else every length that moves a joint.
    """
    meas = rec if isinstance(rec, Measurements) else measurements(rec, use)
    idx = np.arange(len(meas)) if rows is None else np.asarray(rows)
    if nominal is None:
        try:
            nominal = Model(meas.robot, params=meas.parameters)
        except Exception as e:
            raise CalibrationDataError(f"{meas.source}: the sidecar's parameters do not make a valid {meas.robot} "
                                       f"model: {e}") from None
    labels = [meas.labels[k] for k in idx]
    few = 1 if min_poses is not None and min_poses <= 1 else min_poses
    if meas.pose is not None and meas.pose.shape[1] == 6 and nominal.ndof < 6:
        # a 6-DOF tracker of a robot that declares fewer components: the parasitic motion too
        return FullPoseProblem(meas.pose[idx], meas.q[idx], nominal, row_labels=labels, min_poses=few,
                               params=params)
    em = error_model(nominal) if params is None else None
    if (em is None or em.measure == "joints") and meas.pose.shape[1] != nominal.ndof:
        raise CalibrationDataError(f"{meas.source}: calibrating {meas.robot!r} needs tracker columns of its pose "
                                   f"({', '.join(nominal.facts.pose_names)})")
    return JointProblem(meas.pose[idx], meas.q[idx], nominal, row_labels=labels, min_poses=few, params=params,
                        unreachable=unreachable, weighting=weighting, error_model=em)


def split_holdout(n: int, fraction: float, seed: int = 0):
    """Random split of n rows into (calibration, held-out) index arrays."""
    if not 0.0 <= fraction < 1.0:
        raise InputError(f"holdout fraction must be in [0, 1), got {fraction}")
    perm = np.random.default_rng(seed).permutation(n)
    nh = int(round(fraction * n))
    return np.sort(perm[nh:]), np.sort(perm[:nh])


@dataclass
class Accuracy:
    """Model accuracy on a set of poses, nominal vs calibrated.

    Joint measurements: ``position`` is the RMS over poses of |p_FK(q_measured) - p_measured|
    over the pose coordinates in metres [m], ``orientation`` the RMS of the difference norm of
    those in radians [rad], ``joint`` the RMS of q_measured - q_IK(pose_measured).  An output
    measurement (the four-bar): ``position`` is the RMS of the output error X_measured - X(q)
    [m], the others are 0.
    """

    n: int
    position: tuple  # (nominal, calibrated)
    orientation: tuple
    joint: tuple
    per_pose: np.ndarray  # (n, 2) per-pose position error, nominal and calibrated [m]
    excluded: list = field(default_factory=list)  # poses left out (forward kinematics failed)
    #: a full-pose calibration: per undeclared component (the parasitic x, y, rz), the RMS of
    #: measured minus predicted at the measured declared pose, (nominal, calibrated) [m or rad]
    parasitic: dict = field(default_factory=dict)

    @property
    def gain(self) -> float:
        """position RMS nominal / calibrated"""
        return float(self.position[0] / self.position[1]) if self.position[1] > 0 else float("inf")


def accuracy(problem: Problem, p_cal) -> Accuracy:
    """Accuracy of the nominal (``problem.p0``) and calibrated (``p_cal``) models on the
    problem's poses.

    A pose whose measured joints a model cannot assemble (its forward kinematics
    fails: a badly wrong model near the edge of the workspace) is left out of the RMS
    values of both models and named in ``Accuracy.excluded``.
    """
    if isinstance(problem, FullPoseProblem):
        return _full_pose_accuracy(problem, p_cal)
    if isinstance(problem, JointProblem) and problem.measure == "joints":
        return _joint_accuracy(problem, p_cal)
    e0, e1 = problem.residual(problem.p0), problem.residual(p_cal)
    rms0, rms1 = float(np.sqrt(np.mean(e0 ** 2))), float(np.sqrt(np.mean(e1 ** 2)))
    return Accuracy(e0.size, (rms0, rms1), (0.0, 0.0), (0.0, 0.0), np.column_stack([np.abs(e0), np.abs(e1)]))


def _joint_accuracy(problem, p_cal) -> Accuracy:
    """Accuracy of a :class:`JointProblem`: the core's forward kinematics of the measured joints
    against the measured pose (position over the pose coordinates in metres, orientation over
    those in radians, as the core names their units) and the joint residual, per pose.  A robot
    whose pose has no length coordinate is scored by its joint residual alone."""
    units = problem.nominal.facts.pose_units
    lin = [i for i, u in enumerate(units) if u == "m"]
    ang = [i for i, u in enumerate(units) if u == "rad"]
    nd, n = problem.q.shape[1], problem.q.shape[0]
    rms = lambda v: float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0  # noqa: E731
    dq = [(problem.q - problem.predict(p).reshape(n, nd)) for p in (problem.p0, p_cal)]
    if not lin:
        per = np.column_stack([np.linalg.norm(d, axis=1) for d in dq])
        return Accuracy(n, (rms(dq[0]), rms(dq[1])), (0.0, 0.0), (rms(dq[0]), rms(dq[1])), per)
    ok = np.ones(n, bool)
    xs = []
    for p in (problem.p0, p_cal):
        problem._set(p)
        x, st = problem.model.fk(problem.q, x_guess=problem.pose, errors="status")
        ok &= np.asarray(st) == 0
        xs.append(np.asarray(x, float))
    if not ok.any():
        raise CalibrationDataError("forward kinematics of the measured joints failed at every pose: the models "
                                   "cannot assemble the recorded joint readings")
    dp = [np.linalg.norm(x[ok][:, lin] - problem.pose[ok][:, lin], axis=1) for x in xs]
    da = [np.linalg.norm(x[ok][:, ang] - problem.pose[ok][:, ang], axis=1) for x in xs]
    dj = [d[ok] for d in dq]
    return Accuracy(int(ok.sum()), (rms(dp[0]), rms(dp[1])), (rms(da[0]), rms(da[1])), (rms(dj[0]), rms(dj[1])),
                    np.column_stack(dp), [lab for lab, k in zip(problem.pose_labels, ok) if not k])


def _full_pose_accuracy(problem, p_cal) -> Accuracy:
    """Accuracy of a :class:`FullPoseProblem`: the core's forward kinematics of the measured
    joints, completed by its parasitic components, against the measured full pose (position
    over x y z, orientation over rx ry rz); the joint residual; and per parasitic component
    the residual at the measured declared pose (what the legs force against what the tracker
    saw)."""
    n, nd = problem.q.shape
    rms = lambda v: float(np.sqrt(np.mean(v ** 2))) if v.size else 0.0  # noqa: E731
    ok = np.ones(n, bool)
    full, pred = [], []
    for p in (problem.p0, p_cal):
        problem._set(p)
        x, st = problem.model.fk(problem.q, x_guess=problem.pose, errors="status")
        ok &= np.asarray(st) == 0
        X = np.full((n, 6), np.nan)
        good = np.asarray(st) == 0
        if good.any():
            X[good] = np.asarray(problem.model.platform_pose(np.asarray(x, float)[good])[0]).reshape(-1, 6)
        full.append(X)
        pred.append(problem.predict(p).reshape(n, -1))
    if not ok.any():
        raise CalibrationDataError("forward kinematics of the measured joints failed at every pose: the models "
                                   "cannot assemble the recorded joint readings")
    meas = problem.full[ok]
    dp = [np.linalg.norm(X[ok, :3] - meas[:, :3], axis=1) for X in full]
    da = [np.linalg.norm(X[ok, 3:] - meas[:, 3:], axis=1) for X in full]
    dj = [problem.q[ok] - P[ok, :nd] for P in pred]
    names = ("x", "y", "z", "rx", "ry", "rz")
    para = {names[k]: (rms(meas[:, k] - pred[0][ok, nd + j]), rms(meas[:, k] - pred[1][ok, nd + j]))
            for j, k in enumerate(problem.other)}
    return Accuracy(int(ok.sum()), (rms(dp[0]), rms(dp[1])), (rms(da[0]), rms(da[1])), (rms(dj[0]), rms(dj[1])),
                    np.column_stack(dp), [lab for lab, k in zip(problem.pose_labels, ok) if not k], para)


@dataclass
class CalibrationResult:
    """Everything a calibration run found; ``text()`` is the report."""

    robot: str
    source: str
    problem: Problem
    model_kind: str
    identifiability: IdentifiabilityReport
    error_model: IdentifiabilityReport | None  # the error model's own analysis (the 6-PUS: Tiberi 2020's 60 columns)
    solution: Solution
    calibration_accuracy: Accuracy
    holdout_accuracy: Accuracy | None
    warnings: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    @property
    def calibrated_params(self) -> dict:
        """Core parameter values of the calibrated model."""
        return self.problem.model_params(self.solution.p)

    def calibrated_model(self) -> Model:
        m = self.problem.nominal.copy()
        m.set_params(self.calibrated_params)
        return m

    def text(self) -> str:
        s, idr = self.solution, self.identifiability
        L = [f"Calibration of {self.robot} from {self.source}"] + [f"  {n}" for n in self.notes]
        L.append(f"  {self.problem.nmeas} equations from {self.calibration_accuracy.n} poses"
                 + (f", {self.holdout_accuracy.n} poses held out" if self.holdout_accuracy else ", no pose held out"))
        if self.error_model is not None:
            L.append("")
            em = self.problem.error_model
            per = len(em.joint_parameters[0]) if em.joint_parameters else len(em.parameters)
            L.append(f"{em.source.split(',')[0]} error model ({len(em.parameters)} parameters, unit vectors not "
                     f"kept): per {em.block_label}")
            for b in self.error_model.blocks:
                dropped = ", ".join(c.parameter.split(".")[-1] for c in b.combinations)
                L.append(f"  [{b.label}] rank {b.rank}/{per}, cond {b.cond_scaled:.3g} -> {b.cond_after:.3g} after "
                         f"dropping {dropped or 'nothing'}")
            L.append(f"  the radial combination of a unit vector (ds along s: for a rail direction the column -q, a "
                     f"stroke scale) is what a unit vector cannot represent: the calibrated coordinates keep |s| = 1 "
                     f"({len(self.problem.names)} in all)")
        L.append("")
        L.append(idr.text())
        L.append("")
        L.append(f"Solver {s.method} ({self.model_kind} model): {s.iterations} iteration(s), {s.nfev} residual "
                 f"evaluations, {s.seconds * 1e3:.1f} ms, {'converged' if s.converged else 'NOT converged'}: "
                 f"{s.message}")
        mu = "u" + self.problem.measurement_unit  # um or urad
        sig = ", ".join(f"{v * 1e6:.3g}" for v in np.atleast_1d(s.sigma))
        L.append(f"  residual RMS {s.rms_before * 1e6:.4g} {mu} -> {s.rms_after * 1e6:.4g} {mu}; residual sigma "
                 f"[{mu}] {sig}; {s.rank} identified directions")
        L.append("")
        L.append(f"  {'parameter':<16} {'nominal':>12} {'estimate':>12} {'delta':>10} {'SE':>9}  unit")
        for j, n in enumerate(s.names):
            u = self.problem.units[j]
            f, unit = (1e3, "mm") if u == "m" else (1e3, "1e-3")
            if s.free[j]:
                L.append(f"  {n:<16} {s.p0[j] * f:12.5f} {s.p[j] * f:12.5f} {s.dp[j] * f:+10.5f} "
                         f"{s.se[j] * f:9.5f}  {unit}")
            else:
                L.append(f"  {n:<16} {s.p0[j] * f:12.5f} {'(fixed)':>12} {'':>10} {'':>9}  {unit}")
        L.append("")
        for label, a in (("calibration poses", self.calibration_accuracy), ("held-out poses", self.holdout_accuracy)):
            if a is None:
                continue
            if isinstance(self.problem, FullPoseProblem):
                para = "; ".join(f"{c} {v[0] * 1e6:.4g} -> {v[1] * 1e6:.4g} {'um' if c in ('x', 'y', 'z') else 'urad'}"
                                 for c, v in a.parasitic.items())
                L.append(f"Accuracy on {label} ({a.n}): position RMS (forward kinematics of the joints and the "
                         f"parasitic components vs the 6-DOF tracker) {a.position[0] * 1e6:.4g} um -> "
                         f"{a.position[1] * 1e6:.4g} um (gain {a.gain:.3g}x); orientation RMS "
                         f"{a.orientation[0] * 1e6:.4g} -> {a.orientation[1] * 1e6:.4g} urad; joint RMS "
                         f"{a.joint[0] * 1e6:.4g} -> {a.joint[1] * 1e6:.4g} "
                         f"{'um' if self.problem.nominal.facts.joint_unit == 'm' else 'urad'}")
                L.append(f"  parasitic motion, measured - predicted at the measured pose (RMS): {para}")
            elif isinstance(self.problem, JointProblem) and self.problem.measure == "joints":
                units = self.problem.nominal.facts.pose_units
                jo = (f"joint RMS {a.joint[0] * 1e6:.4g} {mu} -> {a.joint[1] * 1e6:.4g} {mu}")
                if "m" not in units:
                    L.append(f"Accuracy on {label} ({a.n}): {jo} (gain {a.gain:.3g}x)")
                    continue
                ori = (f"; orientation RMS {a.orientation[0] * 1e6:.4g} -> {a.orientation[1] * 1e6:.4g} urad"
                       if "rad" in units else "")
                L.append(f"Accuracy on {label} ({a.n}): position RMS (forward kinematics of the joints vs the "
                         f"tracker) {a.position[0] * 1e6:.4g} um -> {a.position[1] * 1e6:.4g} um (gain {a.gain:.3g}x)"
                         f"{ori}; {jo}")
            else:
                L.append(f"Accuracy on {label} ({a.n}): output RMS {a.position[0] * 1e6:.4g} {mu} -> "
                         f"{a.position[1] * 1e6:.4g} {mu} (gain {a.gain:.3g}x)")
        for w in self.warnings:
            L.append("warning: " + w)
        return "\n".join(L)

    def save(self, outdir) -> list:
        """Figures (PNG) and the calibrated parameters (JSON) into ``outdir``; returns the paths."""
        from .plots import plot_result

        out = Path(outdir)
        out.mkdir(parents=True, exist_ok=True)
        paths = plot_result(self, out)
        pj = out / "calibrated_parameters.json"
        pj.write_text(json.dumps({"robot": self.robot, "source": self.source, "method": self.solution.method,
                                  "model": self.model_kind, "parameters": self.calibrated_params,
                                  "standard_errors": {n: v[3] for n, v in self.solution.estimates().items()}},
                                 indent=2))
        (out / "calibration_report.txt").write_text(self.text() + "\n")
        return paths + [pj, out / "calibration_report.txt"]


def _error_model_analysis(prob, cond_max):
    """The identifiability of the error model's own parameters when the calibrated coordinates
    differ from them (the 6-PUS: Tiberi 2020's 60 columns, unit vectors unconstrained), else None."""
    em = getattr(prob, "error_model", None)
    if em is None or len(em.parameters) == len(prob.names):
        return None
    info = {i.name: i.unit for i in prob.nominal.param_info()}
    Je = prob.error_model_jacobian()
    if prob.weights is not None:
        Je = prob.weights[:, None] * Je
    return identifiability(Je, list(em.parameters), [info[n] for n in em.parameters], cond_max=cond_max,
                           blocks=prob.error_model_blocks())


def calibrate(recording, solver: str = "gauss-newton", model: str = "structural", holdout: float = 0.0,
              cond_max: float = 100.0, seed: int = 0, nominal: Model | None = None, use: str = "auto",
              weighting: str = "tracker", params=None, **solver_options) -> CalibrationResult:
    """Calibrate a robot's geometry from a recording.

    Parameters
    ----------
    recording : path or Recording
        A ``pkm-recording/1`` calibration campaign.
    solver : {"pinv", "pinv-iter", "gauss-newton", "lm", "golden"}
    model : {"structural", "prediction", "full"}
        Structural: estimate the parameters kept by the condition-number loop (the others
        stay nominal, their effect absorbed by the identifiable combinations); prediction:
        all parameters by truncated SVD (rcond = 1/cond_max); full: all parameters, an
        error if the data cannot identify them all.
    holdout : float
        Fraction of the poses kept out of the calibration to verify it.
    cond_max : float
        Condition-number limit (Tiberi 2020: 100).
    seed : int
        Seed of the held-out split.
    nominal : Model, optional
        Nominal model (default: from the sidecar).
    use : {"auto", "held", "rows"}
        Which rows make the measurements (see :func:`measurements`).
    weighting : {"tracker", "none"}
        Weight the equations by their expected noise (default; for an error model that
        declares tracker weights, the 6-PUS) or not.
    params : list of str, optional
        The parameters to calibrate, by name or shell pattern (``["leg[*].L"]``); default the
        robot's error model, else every length parameter that moves a joint.
    **solver_options
        Passed to :func:`cosim.calibration.solvers.solve` (tol, max_iter, width, basis...).

    Raises
    ------
    CalibrationDataError
        Too few poses, no pose columns, a rank-deficient set with ``model="full"``...
    """
    if model not in MODELS:
        raise InputError(f"unknown model {model!r} (known: {', '.join(MODELS)})")
    if solver not in METHODS:
        raise InputError(f"unknown solver {solver!r} (known: {', '.join(METHODS)})")
    meas = measurements(recording, use)
    source = meas.source
    cal_idx, hold_idx = split_holdout(len(meas), holdout, seed)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", CalibrationWarning)
        prob = problem_from_recording(meas, cal_idx, nominal, weighting=weighting, params=params)
        # the held-out poses are scored with the calibrated coordinates (the error model's, or
        # the lengths that moved a joint in the calibration poses)
        hold = problem_from_recording(meas, hold_idx, nominal, min_poses=1, weighting=weighting,
                                      params=prob.names if prob.error_model is None else params) \
            if hold_idx.size else None
    msgs = [str(w.message) for w in caught]
    notes = []
    if meas.averaged:
        notes.append(f"{len(meas)} held poses (label column), each the mean of its settled second half")
    # analyse the matrix the solver works with (weighted rows), so that the structural
    # model's combinations are exactly what the estimates represent
    J0 = prob.wjacobian(prob.p0)
    idr = identifiability(J0, prob.names, prob.units, cond_max=cond_max, blocks=prob.blocks)
    msgs += idr.warnings
    err_model = _error_model_analysis(prob, cond_max)
    rcond = 1e-10
    if model == "structural":
        free = idr.retained_mask()
    elif model == "prediction":
        free = np.ones(len(prob.names), bool)
        rcond = 1.0 / cond_max
    else:
        if idr.not_identifiable or any(b.rank < len(b.names) for b in idr.blocks):
            bad = ", ".join(idr.not_identifiable) or "(see the null directions)"
            raise CalibrationDataError(
                f"{source}: rank-deficient pose set: the data cannot identify every parameter "
                f"(not identifiable: {bad}); use model='structural' or 'prediction', or measure more varied poses")
        free = np.ones(len(prob.names), bool)
    sol = solve(prob, solver, free=free, rcond=rcond, **solver_options)
    if not sol.converged:
        msgs.append(f"solver {solver} did not converge: {sol.message}")
    if np.any(np.isinf(sol.se)):
        msgs.append("as many parameters as equations in some block: no redundancy, the standard errors are unknown "
                    "(inf); measure more poses")
    acc_cal = accuracy(prob, sol.p)
    acc_hold = accuracy(hold, sol.p) if hold is not None else None
    for label, a in (("calibration", acc_cal), ("held-out", acc_hold)):
        if a is not None and a.excluded:
            msgs.append(f"{len(a.excluded)} {label} pose(s) left out of the accuracy figures because a model cannot "
                        f"assemble their measured joints: " + "; ".join(a.excluded[:5]))
    if hold is None:
        msgs.append("no pose held out: the accuracy gain is measured on the calibration poses themselves")
    for m in msgs:
        warnings.warn(m, CalibrationWarning, stacklevel=2)
    return CalibrationResult(meas.robot, source, prob, model, idr, err_model, sol, acc_cal, acc_hold, msgs, notes)
