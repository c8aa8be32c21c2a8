"""The diagnosis (part 5 of the engine): residuals -> candidate effects -> selection and
inference (:mod:`.selection`) -> localisation -> held-out fit -> the answer, a
:class:`Diagnosis`, with its conclusion, ties, structure left unexplained and warnings.
:func:`diagnose` is re-exported by :mod:`cosim.discrepancy`.
"""
from __future__ import annotations

import contextlib
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._native import PkmError
from ..jsonable import jsonable
from .effects import BY_KEY, LIBRARY, groups_for, separating_motion
from .residuals import DiagnosisError, Pipeline
from .results import Alternative, FoundEffect, ParamEstimate

__all__ = ["diagnose", "Diagnosis", "DiagnosisError", "LIBRARY"]

#: |delta BIC| below which two explanations are called a tie (equally good)
TIE_MARGIN = 2.0
#: group of the look-alike that marks a fit leaving structure unexplained (a tie: the effect
#: may stand in for physics the library lacks, so it is not named with confidence)
UNEXPLAINED = "unexplained"


def tied(alternative) -> bool:
    """Whether a look-alike (dict) is a tie with the effect it is listed under: its BIC or its
    fit within :data:`TIE_MARGIN`, or one column with it on the recording (``collinear``)."""
    return (alternative["delta_bic"] < TIE_MARGIN or alternative.get("delta_chi2", float("inf")) < TIE_MARGIN
            or bool(alternative.get("collinear", False)))


@dataclass
class Diagnosis:
    """The answer of :func:`diagnose`.

    Attributes
    ----------
    recording : str
        The recording's path (or "recording").
    robot : str
        Robot of the recording.
    conclusion : str
        One sentence: "no missing physics found", "missing physics: ...", or "cannot
        diagnose: ..." (nothing testable).
    effects : list of :class:`~cosim.discrepancy.results.FoundEffect`
        Selected effects, most important first: ``key``, ``name``, ``joint`` (1-based
        or None), ``params`` ({core name: :class:`~cosim.discrepancy.results.ParamEstimate`:
        value, ci95, nominal, unit}), ``delta_bic``, ``importance``, ``lookalikes``
        (:class:`~cosim.discrepancy.results.Alternative`, with ``statement``).
    theta : dict
        Every fitted core parameter (the plant overrides that model the effects).
    heldout : dict
        Fit on the held-out part before/after: per channel ``rms_before``,
        ``rms_after``, ``nrmse_before``, ``nrmse_after`` (None, with the reason in
        ``nrmse_na``, for a joint that did not move or an effort that stayed zero over the
        held-out part: no scale to divide by); ``gain`` (noise-normalised RMS
        ratio on the affected channels), ``gain_windows`` (the same over the samples
        where the nominal residual is out of its noise band), ``affected`` channels.
    localisation : dict
        Per channel: windows (start, end, peak, phase mix), phase enrichment,
        workspace region.
    not_excited : list of str
        Effects this recording cannot reveal, and what motion or data is missing.
    unavailable : list of str
        Effects not tested at all (robot model lacks them, or no tracker columns).
    unexplained : list of :class:`~cosim.discrepancy.results.Structure`
        Residual channels that keep structure after the fit (:mod:`.structure`): what it
        is keyed on (sign of velocity, sign of command, position, velocity,
        acceleration), its rms against the residual's own noise, and the library effects
        of that kind.  Reported in the conclusion, never "within noise".
    replay : dict or None
        Closed-loop replay of the held-out part with the nominal and the fitted plant.
    files : dict
        Report and figure paths (when ``out`` was given).
    warnings : list of str
        What makes the recording contradict the model as a whole (an effort that runs
        against the model's on a joint: another joint convention, a flipped sign, a gear
        ratio), naming the joint; when not empty, no effect is fitted and the conclusion
        says so.
    """

    recording: str
    robot: str
    conclusion: str
    effects: list
    theta: dict
    heldout: dict
    localisation: dict
    not_excited: list
    unavailable: list
    channels: list
    noise: dict
    replay: dict | None = None
    timings: dict = field(default_factory=dict)
    files: dict = field(default_factory=dict)
    steps: list = field(default_factory=list)
    settings: dict = field(default_factory=dict)
    refused: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    #: residual channels that keep structure after the fit (cosim.discrepancy.structure):
    #: channel, what it is keyed on, the closest library effects, its rms against the noise
    unexplained: list = field(default_factory=list)
    #: forces no library effect names, found by the discovery step (cosim.discrepancy.discovery):
    #: one :class:`~cosim.discrepancy.discovery.DiscoveredTerm` per joint, with its equation
    discovered: list = field(default_factory=list)
    #: library effects withdrawn because a discovered term fits the held-out part better
    #: (look-alikes that fit worse): group, effect, params, held-out chi-squares
    withdrawn: list = field(default_factory=list)
    #: the residual of every channel on the decimated samples: ``time`` (m,) [s], ``before``
    #: (nominal model) and ``after`` (fitted model), (m, channels), in the channels' units
    residual: dict = field(default_factory=dict, repr=False)
    #: with a measured effort (tau_meas columns): the channel the physics is fitted on and the
    #: drive's command-to-effort map per joint (:mod:`.effort_map`); None with one channel
    effort_map: dict | None = None
    #: the full statement the conclusion's paragraph sums up (values, look-alikes, what was
    #: withdrawn; :mod:`.verdict`), "" when the conclusion is the whole of it
    details: str = ""
    #: a force on the platform found for the whole robot (cosim.discrepancy.platform_force), or None
    platform_force: object = None
    #: fitted parameters that drift over the recording (cosim.discrepancy.drift.Drift)
    drifts: list = field(default_factory=list)

    def named(self) -> list:
        """Effect keys in the order they are named (most important first)."""
        out = []
        for e in self.effects:
            if e["key"] not in out:
                out.append(e["key"])
        return out

    def ties(self, key: str) -> list:
        """Effect keys declared equally good as the first group of ``key``."""
        for e in self.effects:
            if e["key"] == key:
                return [a["effect"] for a in e["lookalikes"]
                        if tied(a)]
        return []

    def plant_parameters(self) -> dict:
        """Core/FMU parameters that put the fitted effects into the plant."""
        return dict(self.theta)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("recording", "robot", "conclusion", "effects", "theta", "heldout",
                                               "localisation", "not_excited", "unavailable", "refused", "channels",
                                               "noise", "replay", "timings", "files", "steps", "settings",
                                               "warnings", "unexplained", "discovered", "withdrawn", "details",
                                               "platform_force", "drifts")}

    def to_json(self, indent: int | None = 2) -> str:
        return json.dumps(self.to_dict(), indent=indent, default=jsonable)




def _load(recording, max_samples, block_seconds, progress):
    """The working set of ``recording`` (:mod:`.working_set`): the whole recording when it
    has at most ``max_samples`` rows, else blocks of it."""
    from .working_set import WorkingSet, working_set

    if isinstance(recording, WorkingSet):
        return recording
    try:
        return working_set(recording, max_samples=max_samples, block_seconds=block_seconds, progress=progress)
    except ValueError as e:
        from ..recording import RecordingError

        if isinstance(e, RecordingError):
            raise
        raise DiagnosisError(str(e)) from None


def _model_for(rec, model):
    from ..core.model import Model

    def sidecar_params(m):
        if rec.parameters:
            try:
                m.set_params(rec.parameters)
            except PkmError as e:
                from ..recording import sidecar_path

                where = sidecar_path(rec.path) if rec.path else "the recording's sidecar"
                raise DiagnosisError(f"{where}: parameters: {e}") from None
        return m

    if model is None:
        return sidecar_params(Model(rec.robot))
    if isinstance(model, (str, Path)) and Path(model).exists():
        spec = json.loads(Path(model).read_text())
        params = spec.get("parameters", spec)
        params = {k: (v["value"] if isinstance(v, dict) else v) for k, v in params.items()}
        m = Model(spec.get("robot", rec.robot), spec.get("param_set"))
        m.set_params(params)
        return m
    if isinstance(model, str):
        return sidecar_params(Model(rec.robot, model))
    return model


def diagnose(recording, model=None, *, out=None, window: float = 0.05, threshold: float = 10.0,
             train_fraction: float = 0.7, effects=None, replay: bool = True, figures: bool = True,
             max_effects: int = 6, instruments: bool = True, compare=None, discovery: bool = True,
             max_samples: int | None = None, block_seconds: float | None = None, progress: bool | None = False,
             verbose: bool = False, platform: bool = True, drift: bool = True, families: bool = False) -> Diagnosis:
    """Diagnose a recording against the core model.

    Parameters
    ----------
    recording : str, Path, cosim.recording.Recording or WorkingSet
        A ``pkm-recording/1`` table (CSV, Parquet or HDF5, with its sidecar, read in blocks
        of rows), a recording object, or a working set already made
        (:func:`~cosim.discrepancy.working_set.working_set`).
    model : cosim.core.Model, str or Path, optional
        The model to test: a Model, a named parameter set ("default", "appendix_a"),
        or a JSON parameter file (``cosim params <robot> --json``).  Default: the
        robot's default set with the sidecar's parameter overrides.
    out : str or Path, optional
        Directory for the Markdown report and its figures.
    window : float
        Smoothing window of the residuals [s].
    threshold : float
        BIC decrease an effect must bring to be named (calibrated on clean cases).
    train_fraction : float
        Fraction of the recording used for the fit; the rest is held out.
    effects : iterable of str, optional
        Restrict the library to these effect keys.
    replay : bool
        Re-simulate the held-out part in closed loop with the nominal and the fitted
        plant (needs the controller in the sidecar and ``qref`` columns).
    figures : bool
        Draw the figures (with ``out``).
    max_effects : int
        Largest number of entries of the forward selection (an all-joints entry names
        one group per joint).
    compare : iterable of str or dict, optional
        More plants for the replay, each replayed like the nominal and the fitted one: named
        parameter sets of the robot (``["reference"]``, a published model) or
        ``{name: {core parameter: value}}`` (overrides of the nominal model).
    instruments : bool
        Estimate the masses, inertias and viscous frictions by instrumental variables
        (their columns along the reference motion, free of the rate noise) when the
        recording has ``qref``; False: least squares on the measured motion, biased low by
        the noise of the measured accelerations (errors in variables).
    discovery : bool
        After the library, search each effort channel for a joint force no library effect
        names (:mod:`.discovery`), and withdraw a library effect a discovered term fits
        the held-out part better than.
    families : bool
        The discovery step also searches the term families of :mod:`.families` (friction
        growing with the load, friction zones, a Coulomb level over the stroke, couplings to
        another joint, effort x position, position x rate), each term paying more than a library
        term (docs/discovery_families.md).  Off by default: with them on, the Clavel delta's
        held-out rotor inertia (tests/discrepancy/test_discovery_held_out.py) keeps an offset
        the added inertia refits to zero without them.
    platform : bool
        Search one force on the platform for the whole robot (a constant wrench, a cable to an
        anchor, a drag: :mod:`.platform_force`) before the discovery step, and keep it when it and
        the library's selection made again with it fit the held-out part better.
    drift : bool
        Test every fitted parameter for a drift over the recording (a trend or a step in time,
        :mod:`.drift`) and report its size and time course.
    max_samples : int, optional
        Most rows the diagnosis holds (default
        :data:`~cosim.discrepancy.working_set.MAX_SAMPLES`, 200,000): a longer recording is
        diagnosed on a working set of blocks spread over all of it, each at the full rate
        (:mod:`.working_set`; memory and time bounded whatever its length).
    block_seconds : float, optional
        Length of those blocks [s] (default 20).
    progress : bool, optional
        Progress bar of the rows read (None: on a terminal, after 2 s).

    Returns
    -------
    Diagnosis

    Raises
    ------
    cosim.recording.RecordingError
        Malformed file (names the file, row, column).
    DiagnosisError
        A recording the engine cannot use (too short, not uniformly sampled, no
        dynamics for the robot, ...): says what is missing.
    """
    from ._threads import one_blas_thread
    from .localisation import localise
    from .engine import attribute, prepare

    for name, v, lo in (("window", window, 0.0), ("threshold", threshold, 0.0)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > lo):
            raise DiagnosisError(f"{name} = {v!r} must be a positive number")
    if not (0.0 < train_fraction < 1.0):
        raise DiagnosisError(f"train_fraction = {train_fraction!r} must be in (0, 1)")
    from .working_set import BLOCK_SECONDS, MAX_SAMPLES

    t0 = time.perf_counter()
    ws = _load(recording, MAX_SAMPLES if max_samples is None else max_samples,
               BLOCK_SECONDS if block_seconds is None else block_seconds, progress)
    rec = ws.recording
    mdl = _model_for(rec, model)
    from .effort_map import effort_channels

    commanded = rec  # two effort channels: the physics on the measured one, the drive's map fitted
    rec, effort_map = effort_channels(rec, mdl.facts.effort_unit)
    timings = {"read": time.perf_counter() - t0}
    with one_blas_thread():
        # a working set of blocks, or a campaign's runs (.campaign): no window spans a seam
        pipe = Pipeline(rec, mdl, window=window, segments=None if ws.whole and len(ws.segments) == 1 else ws.segments)
        groups, unavailable = groups_for(mdl, pipe.has_pose, effects)
        groups, one_signed = _drop_unseen_gaps(groups, pipe)
        _check_motion(pipe)
        warnings = convention_contradictions(pipe, mdl)
        if warnings:
            return _contradicted(rec, pipe, warnings, out, t0)
        t1 = time.perf_counter()
        eng = prepare(pipe, groups, train_fraction=train_fraction, threshold=threshold, max_groups=max_effects,
                      instruments=instruments, verbose=verbose)
        t2 = time.perf_counter()
        eng, sel = attribute(eng)
        t3 = time.perf_counter()
        eng0, plat = eng, None
        if platform:
            from .platform_force import diagnosis_stage

            plat, eng, sel = diagnosis_stage(eng, sel, rec, mdl, groups, {
                "window": window, "segments": None if ws.whole and len(ws.segments) == 1 else ws.segments}, {
                "train_fraction": train_fraction, "threshold": threshold, "max_groups": max_effects,
                "instruments": instruments, "verbose": verbose})
        t3a = time.perf_counter()
        found, withdrawn, theta, ties = [], [], dict(sel.theta), []
        if discovery:
            from .families import searched

            with searched() if families else contextlib.nullcontext():
                found, withdrawn, theta, ties = _discover(eng, sel, threshold)
        from .verdict import fit_problems, headline

        problems = fit_problems(eng, theta) if theta else []  # a fit outside the physical ranges is refused
        if problems:
            theta, found, withdrawn, ties = {}, [], [], []
        t3b = time.perf_counter()
        if plat is not None:  # parameters relative to the user's model from here on
            theta = dict(plat.params, **theta)
        held = heldout_fit(eng0, sel, theta)
        from .drift import find_drifts

        drifts = find_drifts(eng0, theta, threshold, {p.name: p.unit for p in mdl.param_info()}) if drift else []
        loc = localise(eng, sel)
        t4 = time.perf_counter()
    timings.update(prepare=t1 - t0 - timings["read"], regressors=t2 - t1, selection=t3 - t2, platform=t3a - t3,
                   discovery=t3b - t3a,
                   heldout_localisation=t4 - t3b)
    from .structure import sentence, unexplained

    gone = {w["group"] for w in withdrawn}
    r_after = eng0.R(theta) if theta else eng0.R0
    left = unexplained(pipe, r_after, floor=eng.accuracy())
    # A fit that leaves structure anywhere may stand in for physics the library lacks: in
    # closed loop a missing force moves every joint's readings and efforts, and a stand-in often
    # acts on other channels than those it leaves structured (measured: docs/discrepancy.md)
    effects_out = [e for e in _effects(eng, sel, ties, left) if e["group"] not in gone and not problems]
    for t in found:  # the same for a discovered term: fitted on top of stand-ins, it may share their error
        t.partial = _partial_sentence(left, t.joint) or _beside_tie_sentence(ties, gone, t)
    not_excited = _not_excited(eng, sel) + one_signed
    conclusion = _conclusion(effects_out, not_excited, eng, sel, found, withdrawn)
    if plat is not None:
        from .platform_force import sentence as platform_sentence

        conclusion = platform_sentence(plat, conclusion)
    if drifts:
        from .drift import sentence as drift_sentence

        conclusion += "; " + drift_sentence(drifts)
    if left:
        conclusion = (conclusion + "; " + sentence(left) if effects_out or found else
                      "no effect of the library explains the residual: " + sentence(left))
    from .platform_force import short_name

    others = ([short_name(plat)] if plat is not None else []) + [f"a drift of {dr.param} (a {dr.kind})" for dr in drifts]
    head = headline(effects_out, found, left, held.get("gain"), UNEXPLAINED, tied, others)
    details, conclusion = (conclusion, head) if head else ("", conclusion)
    if problems:
        details, conclusion = "", ("fit refused, not physical: " + "; ".join(problems) + ". The effects fitted to "
                                   "these values are not reported and the nominal model stands: the fit is degenerate "
                                   "on this recording (nearly dependent effects, or a recording that is not what the "
                                   "model thinks, such as runs joined end to end)")

    d = Diagnosis(str(rec.path) if rec.path else "recording", rec.robot, conclusion, effects_out, dict(theta),
                  held, loc, not_excited,
                  [f"{e.name}: {why}" for e, why in unavailable], pipe.channels,
                  {"sigma": dict(zip(pipe.channels, sel.sigma.tolist())),
                   "phi": dict(zip(pipe.channels, sel.phi.tolist())), "n_eff": sel.n_eff},
                  steps=list(sel.steps), refused=[f"{k}: {v}" for k, v in sel.refused.items()] + problems,
                  settings={"window": window, "threshold": threshold, "train_fraction": train_fraction,
                            "samples": pipe.n, "dt": pipe.dt, "decimation": pipe.step,
                            "smoothing_samples": pipe.window,
                            "working_set": ws.summary()},
                  residual={"time": pipe.t[pipe.idx], "before": eng0.R0, "after": r_after}, unexplained=left,
                  discovered=found, withdrawn=withdrawn, details=details, effort_map=effort_map)
    d.platform_force, d.drifts = plat, drifts
    if effort_map is not None:
        d.conclusion += "; " + effort_map["statement"]
    if replay:
        t5 = time.perf_counter()
        d.replay = _replay(commanded, eng0, sel, _compared(rec, mdl, compare), theta)
        if d.details:
            d.details += _two_body_sentence(d.replay, mdl.joint_unit)
        else:
            d.conclusion += _two_body_sentence(d.replay, mdl.joint_unit)
        timings["replay"] = time.perf_counter() - t5
    timings["diagnosis"] = time.perf_counter() - t0
    d.timings = timings
    if out is not None:
        from .report import write_report

        t6 = time.perf_counter()
        d.files = write_report(d, eng, sel, Path(out), figures=figures)
        timings["report"] = time.perf_counter() - t6
    timings["total"] = time.perf_counter() - t0
    return d


def _contradicted(rec, pipe, warnings, out, t0) -> Diagnosis:
    """The answer for a recording that contradicts the model: the warnings, no effects
    (a fit would name the convention as some physics), and a short report."""
    conclusion = ("cannot diagnose: the recording contradicts the model: " + "; ".join(warnings))
    d = Diagnosis(str(rec.path) if rec.path else "recording", rec.robot, conclusion, [], {}, {}, {}, [], [],
                  pipe.channels, {}, warnings=list(warnings),
                  settings={"samples": pipe.n, "dt": pipe.dt})
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        lines = [f"# Diagnosis of {d.recording}", "", f"**{conclusion}**", "", "## Warnings", ""]
        lines += [f"- {w}" for w in warnings]
        (out / "report.md").write_text("\n".join(lines) + "\n")
        (out / "diagnosis.json").write_text(d.to_json())
        d.files = {"report": str(out / "report.md"), "json": str(out / "diagnosis.json")}
    d.timings = {"total": time.perf_counter() - t0}
    return d


_DECLARE = ('Declare it in the sidecar ("joint_convention": {"sign": [...], "offset": [...]}, recorded = sign * '
            'model + offset)')


def convention_contradictions(pipe, mdl) -> list:
    """Joints the recording measures in another convention than the model's, one
    sentence each: from the pose columns when there are any (:func:`joint_contradictions`),
    then from the efforts (:func:`effort_contradictions`) for the joints not named yet."""
    out = joint_contradictions(pipe, mdl)
    named = {w.split(":")[0] for w in out}
    return out + [w for w in effort_contradictions(pipe, mdl) if w.split(":")[0] not in named]


def joint_contradictions(pipe, mdl) -> list:
    """Joints whose recorded reading runs against the inverse kinematics of the recorded
    pose (slope below 0 of the reading on it: a reversed joint coordinate) or sits far
    from it (by more than 5 cm or 0.5 rad: an offset no encoder error explains); [] without
    pose columns.  The library's reading effects (offset, backlash, compliance) stay far
    inside both bounds."""
    if pipe.pose is None or list(mdl.facts.pose_names) != list(pipe.rec.pose_columns):
        return []
    q_ik, status = mdl.ik(pipe.pose[pipe.idx], errors="status")
    ok = status == 0
    if ok.sum() < 10:
        return []
    q_rec, q_ik = pipe.q[pipe.idx][ok], q_ik[ok]
    noun, out = mdl.facts.joint_noun, []
    for i in range(q_rec.shape[1]):
        a, b = q_rec[:, i] - q_rec[:, i].mean(), q_ik[:, i] - q_ik[:, i].mean()
        spread = float(b @ b)
        slope = float(a @ b) / spread if spread > 0 else 1.0
        gap = float(np.median(q_rec[:, i] - q_ik[:, i]))
        unit = mdl.joint_unit
        far = abs(gap) > (0.5 if unit == "rad" else 0.05)
        if slope < 0:
            out.append(f"{noun} {i + 1}: the recorded reading q{i + 1} runs against the inverse kinematics of the "
                       f"recorded pose (slope {slope:.2f}): a joint coordinate running the other way? {_DECLARE}")
        elif far:
            out.append(f"{noun} {i + 1}: the recorded reading q{i + 1} is {gap:.4g} {unit} from the inverse "
                       f"kinematics of the recorded pose: another zero of the joint coordinate? {_DECLARE}")
    return out


#: how many times more residual the model plus a constant effort offset must leave than a
#: scale (a gear ratio, a unit, a sign) before the check blames the recording's convention
SURE = 3.0


def effort_contradictions(pipe, mdl) -> list:
    """Joints whose recorded effort runs against the model's, one sentence each.

    The nominal inverse dynamics along the measured motion is compared with the
    recorded effort joint by joint (smoothed, decimated samples): a cosine below -0.5
    (gravity load of the wrong sign, a reversed rail coordinate) or, where they agree in
    shape (cosine above 0.9), a scale outside 0.5-2 (a gear ratio, a unit) is no missing
    physics the library can name: it is a convention the recording does not share with
    the model.  A constant effort offset (a cable carrier, an unbalanced mass, a force
    on the joint) also changes the cosine and the scale of a one-signed effort, and it is
    physics: the convention is blamed only if it is sure, that is if a scale (with a
    constant) explains the recorded effort and the model plus a constant offset leaves
    at least ``SURE`` times more residual; the sentence gives both residuals.
    """
    tau_m = pipe.S(mdl.inverse_dynamics(pipe.x_f, pipe.xd_f, pipe.xdd_f))[pipe.idx]
    tau_r = pipe.tau_s[pipe.idx]
    noun, unit = mdl.facts.joint_noun, mdl.facts.effort_unit
    out = []
    for i in range(tau_r.shape[1]):
        a, b = tau_r[:, i], tau_m[:, i]
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        if not (na > 0 and nb > 0):
            continue
        cos, scale = float(a @ b) / (na * nb), float(a @ b) / (nb * nb)
        col = f"tau{i + 1}"
        against = cos < -0.5
        if not (against or (cos > 0.9 and not 0.5 < scale < 2.0)):
            continue
        # The two explanations: the model times a scale plus a constant, the model plus a
        # constant offset (physics the library names).
        (s, c), *_ = np.linalg.lstsq(np.column_stack([b, np.ones_like(b)]), a, rcond=None)
        r_scale = float(np.sqrt(np.mean((a - s * b - c) ** 2)))
        r_offset = float(np.std(a - b))
        if (0.5 < s < 2.0) or r_offset < SURE * r_scale:
            continue
        sure = (f"the model times {s:.3g} plus {c:.3g} {unit} leaves {r_scale:.3g} {unit} RMS, the model plus a "
                f"constant offset {r_offset:.3g} {unit}, {r_offset / max(r_scale, 1e-300):.0f} times more")
        if against:
            out.append(f"{noun} {i + 1}: the recorded effort runs against the model's (cosine {cos:.2f}; {sure}): "
                       f"was it recorded in another joint convention or with the opposite sign of {col}? {_DECLARE}")
        else:
            out.append(f"{noun} {i + 1}: the recorded effort is the model's times {s:.3g} (cosine {cos:.2f}; "
                       f"{sure}): a gear ratio or a unit in {col}? Convert the column to the joint's effort")
    return out


def _check_motion(pipe):
    """A recording that does not move cannot excite any dynamic effect: say so."""
    if np.all(np.abs(pipe.qd_s[pipe.idx]) < 1e-9):
        raise DiagnosisError(f"{pipe.where}: the joints do not move (all rates below 1e-9): a standstill "
                             f"recording cannot excite friction, inertia, delays or any other dynamic effect; "
                             f"record a motion with accelerations, constant-velocity phases and reversals")


def heldout_fit(eng, sel, theta: dict | None = None) -> dict:
    """Residuals on the held-out samples before (nominal) and after (fitted) modelling.

    RMS over the samples each channel uses (a joint's rest phases, where its friction
    and backlash depend on a rate below the reading noise, are left out, as in the
    fit); ``rms_all_*`` over every held-out sample."""
    test = eng.test
    theta = sel.theta if theta is None else theta
    Rb = eng.R({})[test]
    Ra = eng.R(theta)[test] if theta else Rb
    use = eng.use[test] > 0
    pipe = eng.pipe
    chans = pipe.channels
    nd = pipe.nd
    scale = np.concatenate([np.sqrt(np.mean(pipe.tau_s[pipe.idx[test]] ** 2, axis=0)),
                            np.std(pipe.q[pipe.idx[test]], axis=0)])[: len(chans)]
    # A scale at the rounding level of the channel's own values (a joint held still reads
    # a spread of 1e-16 m) is no scale: the joint did not move, the NRMSE is n/a.
    size = np.concatenate([np.max(np.abs(pipe.tau_s), axis=0), np.max(np.abs(pipe.q), axis=0)])[: len(chans)]
    scale = np.where(scale > 1024 * np.finfo(float).eps * size, scale, 0.0)

    def rms(a):
        return np.sqrt(np.sum(a**2 * use, axis=0) / np.maximum(use.sum(axis=0), 1))

    rb, ra = rms(Rb), rms(Ra)
    sig = sel.sigma
    # Channels the fitted effects act on: their contribution exceeds twice the noise on
    # at least 2 % of the held-out samples (a Stribeck term acts at reversals only).
    acts = (np.abs(Rb - Ra) > 2.0 * sig) & use
    affected = [i for i in range(len(chans)) if acts[:, i].mean() >= 0.02]
    pick = affected or list(range(len(chans)))
    gain = float(np.sqrt(np.sum((rb[pick] / sig[pick]) ** 2) / max(np.sum((ra[pick] / sig[pick]) ** 2), 1e-300)))
    # The same ratio over the held-out samples where the nominal residual leaves its
    # noise band (the localised windows): an effect that acts in a few phases (Stribeck
    # at slow reversals) is diluted by the noise of the other samples in the RMS above.
    band = (np.abs(Rb) > 3.0 * sig) & use
    num = sum(np.sum((Rb[band[:, i], i] / sig[i]) ** 2) for i in pick)
    den = sum(np.sum((Ra[band[:, i], i] / sig[i]) ** 2) for i in pick)
    gain_w = float(np.sqrt(num / den)) if den > 0 else float("nan")
    rb_all, ra_all = np.sqrt(np.mean(Rb**2, axis=0)), np.sqrt(np.mean(Ra**2, axis=0))
    per = {c: {"rms_before": float(rb[i]), "rms_after": float(ra[i]),
               **_nrmse(rb[i], ra[i], scale[i], i < nd), "noise": float(sig[i]),
               "rms_all_before": float(rb_all[i]), "rms_all_after": float(ra_all[i]),
               "unit": _unit(pipe, i)} for i, c in enumerate(chans)}
    tt = pipe.t[pipe.idx[test]]
    fitted = bool(theta)
    if fitted and not affected:
        # The fitted effects change nothing on the held-out part beyond the noise (a
        # saturation never reached there): no gain can be measured.
        gain = gain_w = float("nan")
    return {"channels": per, "gain": gain if fitted else 1.0,
            "gain_windows": gain_w if fitted else 1.0,
            "window_fraction": float(band[:, pick].mean()) if pick else 0.0,
            "affected": [chans[i] for i in affected],
            "samples": int(test.sum()), "start": float(tt[0]) if test.any() else None,
            "end": float(tt[-1]) if test.any() else None, "nd": nd}


def _open_statement(items) -> str:
    chans = ", ".join(s["channel"] for s in items)
    keyed = "; ".join(dict.fromkeys(s["keyed_on"] for s in items))
    return f"structure remains unexplained on {chans} (keyed on {keyed})"


def _partial_sentence(left, joint: int) -> str:
    """For a discovered term on ``joint`` (1-based): "" when the recording keeps no structure
    (``left``, :func:`.structure.unexplained`), else why it is not named as the physics."""
    own = [s for s in left if s["joint"] == joint]  # its effort or its reading
    if own:
        return (_open_statement(own) + " with the term added: a partial fit that may stand in for what is "
                "missing, not the physics")
    if left:
        return (_open_statement(left) + ": the fit of the recording is incomplete and the term may take part of "
                "what is missing, so it is not named as the physics with confidence")
    return ""


def _partial_reason(partial: str) -> str:
    """The conclusion's short form of why a discovered term is a partial fit."""
    return "fitted beside a tied library effect" if partial.startswith("fitted beside") else "structure remains"


def _beside_tie_sentence(ties, gone, term) -> str:
    """For a discovered ``term``: why it is not named as the physics when a library effect kept
    on its channel is tied with terms discovered in its place (the two fit as well; fitted
    beside it, the term shares what the effect explains), else "".  An effect whose parameters
    the term refits itself (the drive's offset beside a spring: the spring's rest position) is
    part of the term, not beside it."""
    beside = [t["title"] for t in ties if term.channel in t.get("channels", ()) and t["group"] not in gone
              and not set(t.get("params", ())) & set(term.coefficients)]
    if not beside:
        return ""
    return (f"fitted beside {', '.join(dict.fromkeys(beside))}, which terms discovered in its place fit as well: "
            "the two share what they explain, so the term is not named as the physics with confidence")


def _nrmse(rms_before, rms_after, scale, effort: bool) -> dict:
    """The held-out RMS over the channel's own scale (RMS effort, or the joint's spread), or,
    where that scale is zero (a joint that did not move over the held-out part, an effort
    that stayed zero), ``None`` with the reason in ``nrmse_na``: no ratio, never a NaN."""
    if scale > 0 and math.isfinite(scale):
        return {"nrmse_before": float(rms_before / scale), "nrmse_after": float(rms_after / scale), "nrmse_na": None}
    why = "no effort on the joint" if effort else "joint did not move"
    return {"nrmse_before": None, "nrmse_after": None, "nrmse_na": f"{why} over the held-out part: n/a"}


def _unit(pipe, i):
    # the core's units of the robot's joints and efforts (RobotFacts), not a robot-name test
    facts = pipe.model.facts
    return facts.effort_unit if i < pipe.nd else facts.joint_unit


def _units(mdl):
    return {p.name: p.unit for p in mdl.param_info()}


def _effects(eng, sel, ties=(), left=()) -> list:
    """The selected groups as :class:`FoundEffect`, with their look-alikes: the library's,
    a discovered term tied with it (``ties``), and, when structure is ``left`` unexplained
    (:func:`.structure.unexplained`), the statement that the fit may stand in for what is
    missing (a tie: not named with confidence)."""
    units = _units(eng.model)
    out = []
    for a in sel.selected:
        g = a.group
        params = {p: ParamEstimate(float(a.values[p]), float(a.ci.get(p, float("nan"))), float(eng.nominal[p]),
                                   units.get(p, "")) for p in g.params}
        looks = []
        for c in a.lookalikes:
            if c.get("collinear"):
                st = (f"{c['name']} is the same column on this recording (partial correlation "
                      f"{c['correlation']:.3f}, variance inflation {1 / max(1 - c['correlation'] ** 2, 1e-12):.3g}): "
                      f"the two act as one "
                      f"force here and their split is no physics; neither is named with confidence; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            elif c["delta_bic"] < TIE_MARGIN:
                st = (f"{c['name']} explains the data as well (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): the two cannot be told apart with this data; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            elif c.get("delta_chi2", float("inf")) < TIE_MARGIN:
                st = (f"{c['name']} fits the data as well (chi-square {c['delta_chi2']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): the same physics on this recording; only its "
                      f"{c['extra_params']} extra parameter(s) cost it delta BIC {c['delta_bic']:+.1f}, which is no "
                      f"evidence against it; {separating_motion(g.key, c['effect'])} would separate them")
            elif c["delta_bic"] < eng.settings.lookalike_margin:
                st = (f"{c['name']} is a weaker alternative (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): not told apart with confidence; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            else:
                st = (f"{c['name']} was ruled out (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f})")
            looks.append(Alternative(**c, statement=st))
        for tie in ties:
            if tie["group"] == g.label:
                eq = "; ".join(tie["terms"])
                d2 = tie["heldout_chi2_discovered"] - tie["heldout_chi2_library"]
                looks.insert(0, Alternative(
                    "discovered", "discovered", f"a force no library effect names ({eq})", 0.0, d2,
                    tie["extra_params"], float("nan"), False,
                    f"a force no library effect names ({eq}) fits the held-out part as well (chi-square "
                    f"{d2:+.1f}): {g.effect.name} is not named with confidence on this recording"))
        if left:
            chans = ", ".join(s["channel"] for s in left)
            looks.insert(0, Alternative(
                UNEXPLAINED, UNEXPLAINED, f"structure left unexplained on {chans}", 0.0, 0.0, 0, float("nan"),
                False, f"{_open_statement(left)}: the fit may stand in for what is missing; "
                       f"{g.effect.name} is not named with confidence"))
        out.append(FoundEffect(g.key, g.effect.name, g.label, g.title, None if g.joint is None else g.joint + 1,
                               g.effect.family, params, a.delta_bic, a.importance,
                               g.effect.plant.replace("{j}", _prefix(eng.model)), looks, _derived(g, a.values, eng)))
    return out


def _prefix(model):
    from .effects import joint_prefix

    return joint_prefix(model)


def _derived(g, values, eng) -> dict:
    """Quantities a reader wants besides the core parameters (tilt angle, ...)."""
    if g.key == "gravity_tilt":
        gx, gy = values.get("gravity.x", 0.0), values.get("gravity.y", 0.0)
        gz = eng.nominal.get("gravity.z", -9.81)
        return {"tilt_deg": math.degrees(math.atan2(math.hypot(gx, gy), abs(gz))),
                "azimuth_deg": math.degrees(math.atan2(gy, gx))}
    if g.key == "payload" and "payload.x" in values:
        return {"offset_mm": [1e3 * values[f"payload.{c}"] for c in "xyz"]}
    return {}


#: smallest share of a joint's samples on the minority side of its effort for a backlash gap
#: to be told from a constant offset (2 %: 0.18 s of a 9 s recording on the other face)
GAP_MINORITY = 0.02


def _drop_unseen_gaps(groups, pipe):
    """Backlash groups of joints whose effort keeps one sign: the carriage never leaves its
    face, the gap reads as a constant offset b/2 (the same physics on this recording), so its
    size cannot be measured.  Returns the remaining groups and the 'not excited' sentences."""
    tau = np.asarray(pipe.tau_c, float)
    neg = np.mean(tau < 0.0, axis=0)
    minority = np.minimum(neg, 1.0 - neg)
    keep, said = [], []
    for g in groups:
        if g.key == "backlash" and g.joint is not None and minority[g.joint] < GAP_MINORITY:
            said.append(f"{BY_KEY['backlash'].name} (joint {g.joint + 1}): its effort keeps one sign on "
                        f"{100 * (1 - minority[g.joint]):.1f} % of the samples, so a gap reads as a constant "
                        f"offset of half its size (the encoder offset covers it); it needs efforts of both signs "
                        f"on that joint")
            continue
        keep.append(g)
    return keep, said


def _not_excited(eng, sel) -> list:
    """Effects whose smallest detectable size exceeds their reference size."""
    chosen = {a.group.label for a in sel.selected}
    # a look-alike that fits as well as a named effect is the same physics on this recording
    # (said with that effect), not an effect the recording cannot reveal
    chosen |= {c["group"] for a in sel.selected for c in a.lookalikes
               if tied(c)}
    by_effect = {}
    same = {}
    for lab, (size, ref) in sel.detectability.items():
        g = eng.options[lab][0].group
        if lab in chosen or not np.isfinite(ref) or ref <= 0 or not (size > ref):
            continue
        if lab in sel.collinear:
            same.setdefault(g.key, []).append(g)
            continue
        by_effect.setdefault(g.key, []).append((g, size, ref))
    out = [f"{BY_KEY[key].name}{_where(gs)}: its signature on this recording is a combination of the effects "
           f"already fitted ({', '.join(a.group.title for a in sel.selected)}), so it cannot be told from them; it "
           f"needs {BY_KEY[key].requires}" for key, gs in same.items()]
    units = _units(eng.model)
    for key, items in by_effect.items():
        e = BY_KEY[key]
        unit = units.get(items[0][0].params[0], "")
        where = ", ".join(f"joint {g.joint + 1}" for g, _, _ in items if g.joint is not None)
        worst = max(items, key=lambda it: it[1] / it[2] if np.isfinite(it[1]) else math.inf)
        out.append(f"{e.name}{' (' + where + ')' if where else ''}: {detection_limit_text(worst[1], worst[2], unit)}"
                   f"; it needs {e.requires}")
    return out


#: a smallest detectable size this many times an effect's small size is no size at all: the
#: recording does not excite the effect (a limit of 6e300 kg says that, not a mass)
UNDETECTABLE_RATIO = 1e3


def detection_limit_text(size: float, ref: float, unit: str) -> str:
    """How small an effect this recording could reveal, in words: the limit and the effect's
    small size, or, when the limit is infinite, not a number or absurdly large
    (above :data:`UNDETECTABLE_RATIO` times the small size), that the recording does not
    show the effect at any size.

    Example
    -------
    >>> detection_limit_text(float("inf"), 0.05, "kg")
    'not detectable on this recording (it does not excite it: no size of it would show; a small one is 0.05 kg)'
    """
    if not (np.isfinite(size) and size <= UNDETECTABLE_RATIO * ref):
        return (f"not detectable on this recording (it does not excite it: no size of it would show; a small one "
                f"is {ref:.3g} {unit})")
    return f"this recording cannot reveal it below {size:.3g} {unit} (a small one is {ref:.3g} {unit})"


def _where(groups) -> str:
    joints = ", ".join(f"joint {g.joint + 1}" for g in groups if g.joint is not None)
    return f" ({joints})" if joints else ""


def _discover(eng, sel, threshold):
    """The discovery step (:mod:`.discovery`): library effects put on trial against
    discovered terms, then the terms found on every effort channel of what is left.
    Returns (terms, withdrawn groups, parameters: library kept + discovered, the groups tied
    with discovered terms)."""
    from .discovery import judge_library

    theta, withdrawn, ties, search, base = judge_library(eng, sel, threshold)
    found = [t for t in base.values() if t is not None]  # the terms on what the library keeps
    withdrawn += _offsets_refitted_away(sel, found, {w["group"] for w in withdrawn})
    for t in found:
        t.instead_of = [_withdrawn_sentence(w) for w in withdrawn if t.channel in w["replaced_by"]]
        theta.update(t.params())
    pipe = eng.pipe
    R_all = eng.R(theta) if found else None
    for t in found:
        c = t.joint - 1
        without = eng.R({k: v for k, v in theta.items() if k not in t.params()})[:, c]
        key = {"position": pipe.q_s, "velocity": pipe.qd_s, "acceleration": pipe.qdd_s}[t.key_variable][pipe.idx, c]
        t.curve = {"key": key, "before": without, "after": R_all[:, c]}
    return found, withdrawn, theta, ties


def _offsets_refitted_away(sel, found, gone) -> list:
    """The library's offsets that a discovered term refitted to zero on its joint (its value with
    the term within its 95 % interval of zero): it stood in for the term, and is withdrawn (the
    plant's parameters hold the refitted value)."""
    out = []
    for t in found:
        for a in sel.selected:
            g = a.group
            c = t.coefficients.get(g.params[0]) if g.key == "offset" else None
            if c is None or g.label in gone or c.base == 0 or abs(c.value) > c.ci95:
                continue
            out.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                        "params": {g.params[0]: float(sel.theta.get(g.params[0], float("nan")))},
                        "replaced_by": [t.channel], "refitted": {"value": c.value, "ci95": c.ci95, "unit": c.unit}})
    return out


def _withdrawn_sentence(w) -> str:
    if "refitted" in w:
        r = w["refitted"]
        return (f"{w['title']}: refitted with the discovered term to {r['value']:.3g} +- {r['ci95']:.2g} {r['unit']}, "
                f"zero within its interval (it stood in for the term)")
    a, b = w["heldout_chi2_library"], w["heldout_chi2_discovered"]
    if w.get("as_well"):  # put on trial with another effect: two effects where one force suffices
        return (f"{w['title']}: with {' and '.join(t for t in w['together'] if t != w['title'])}, fits the held-out "
                f"part as well as the one discovered force in their place (chi-square {a:.1f} with them, {b:.1f} "
                f"with it: {w['gain']:.1f} +- {w['se']:.1f}, bar {w['bar']:.1f}), with no fewer coefficients")
    return (f"{w['title']}: fits the held-out part worse (chi-square {a:.1f} with it, {b:.1f} with the discovered "
            f"term in its place: {w['gain']:.1f} +- {w['se']:.1f}, bar {w['bar']:.1f})")


def _conclusion(effects, not_excited, eng, sel, found=(), withdrawn=()) -> str:
    if found:
        parts = [f"{t.equation} ({', '.join(t.terms)}; {t.mechanisms})"
                 + (f" [not named as the physics: {_partial_reason(t.partial)}]" if t.partial else "") for t in found]
        head = "missing physics no library effect names: " + "; ".join(parts)
        if withdrawn:
            worse = [w["title"] for w in withdrawn if not w.get("as_well") and "refitted" not in w]
            same = [w["title"] for w in withdrawn if w.get("as_well")]
            zero = [w["title"] for w in withdrawn if "refitted" in w]
            if worse:
                head += "; look-alike(s) of the library that fit the held-out part worse: " + ", ".join(worse)
            if zero:
                head += "; refitted to zero with the terms (they stood in for them): " + ", ".join(zero)
            if same:
                head += ("; look-alike(s) of the library that fit the held-out part as well, two effects for one "
                         "force: " + ", ".join(same))
        if effects:
            head += "; and from the library: " + _conclusion(effects, not_excited, eng, sel)[len("missing physics: "):]
        return head
    if effects:
        parts = []
        for e in effects:
            vals = "; ".join(f"{p} = {v['value']:.4g} +- {v['ci95']:.2g} {v['unit']}" for p, v in e["params"].items())
            same = [a["name"] for a in e["lookalikes"] if tied(a) and a["group"] != UNEXPLAINED]
            parts.append(f"{e['title']} ({vals})" + (f" [tie: {', '.join(same)} fits as well]" if same else ""))
        open_ = any(a["group"] == UNEXPLAINED for e in effects for a in e["lookalikes"])
        return "missing physics: " + ", ".join(parts) + (
            " [none named with confidence: the fit leaves structure unexplained and may stand in for what is "
            "missing]" if open_ else "")
    excited = [lab for lab, (size, ref) in sel.detectability.items() if not (np.isfinite(ref) and size > ref)]
    if not excited:
        return "cannot diagnose: the recording excites none of the effects of the library (see 'not excited')"
    return "no missing physics found"


def _two_body_sentence(replay, unit) -> str:
    """What the two-body replay of a fitted gap or compliance showed on its joints' readings,
    for the conclusion ("" without one)."""
    runs = (replay or {}).get("runs", {})
    two, reading = runs.get("fitted, two bodies", {}), runs.get("fitted", {})
    if "rms_q" not in two or "rms_q" not in reading:
        return ""
    joints = replay["two_body"]["joints"]
    closer = all(two["rms_q"][i] < reading["rms_q"][i] for i in joints)
    parts = ", ".join(f"q{i + 1} {two['rms_q'][i]:.3g} {unit} against {reading['rms_q'][i]:.3g} {unit}" for i in joints)
    return (f"; replayed as two bodies (drive and carriage) the held-out readings come "
            f"{'closer to' if closer else 'no closer to'} the recording than with the reading model ({parts})")


def _compared(rec, mdl, compare) -> dict:
    """The plants ``compare`` names for the replay: {name: Model}."""
    from ..core.model import Model

    if not compare:
        return {}
    out = {}
    for name, spec in (compare.items() if isinstance(compare, dict) else ((c, None) for c in compare)):
        try:
            if spec is None:
                out[name] = Model(rec.robot, name)
            else:
                out[name] = mdl.copy()
                out[name].set_params(spec)
        except PkmError as e:
            raise DiagnosisError(f"compare: {name}: {e}") from None
    return out


def _replay(rec, eng, sel, compared=None, theta=None):
    """Closed-loop replay of the held-out part: the core plant (nominal, then fitted, then,
    with a fitted gap or compliance, the fitted plant with those drives as two bodies,
    :mod:`.drive_bodies`, then the ``compared`` ones) driven by the recorded controller and
    reference, against the recorded motion.  Each run starts from the recorded state at the
    first held-out sample, its controller primed with the recorded readings and reference of
    every sample before it (filters, differences, integrators and computation delay as the
    rig's controller had them: started at rest, a rig's controller with a delay outputs
    nothing at first and sees no velocity, a kick of hundreds of newtons on a real drive).
    Per run the RMS differences and the relative error of the efforts, norm of the
    difference over the norm of the recorded effort."""
    from .drive_bodies import drive_joints, fit_two_body, fitting_window
    from .plant import closed_loop, controller_from, reference_from_recording

    if rec.qref is None:  # no reference: an open-loop experiment is replayed open loop (.open_loop)
        from .open_loop import heldout_replay

        return heldout_replay(rec, eng, sel.theta if theta is None else theta, compared)
    mdl = eng.model
    pipe = eng.pipe
    test = eng.test
    k0 = int(pipe.idx[test][0]) if test.any() else None
    if k0 is None:
        return {"skipped": "no held-out samples"}
    # on a working set of blocks the runs stay inside one block: the held-out one from k0,
    # the two-body fit in the block of the last fitted sample
    rec = rec.slice(0, pipe.segment_of(k0)[1])
    fit_from, fit_to = int(pipe.idx[0]), k0
    if len(pipe.segments) > 1 and (pipe.idx < k0).any():
        a, b = pipe.segment_of(int(pipe.idx[pipe.idx < k0][-1]))
        fit_from, fit_to = int(pipe.idx[pipe.idx >= a][0]), min(k0, b)
    try:
        ref = reference_from_recording(rec, mdl)
    except Exception as e:  # noqa: BLE001 - reported, not fatal
        return {"skipped": f"the reference could not be mapped to poses: {e}"}
    ctrl, why = controller_from(rec.controller, mdl)
    if ctrl is None:
        return {"skipped": why}
    from ..injection import from_recording

    injected = from_recording(rec)  # a test signal the rig added into its loop, replayed at its point

    def run(plant, ref, start):
        ctrl, _ = controller_from(rec.controller, mdl)  # a fresh controller (its own state) per run
        return closed_loop(plant, ctrl, ref, x0=pipe.x_f[start], xd0=pipe.xd_f[start], start=start,
                           rtol=1e-8, atol=1e-10, f_ext=getattr(rec, "f_ext", None),  # a known input, replayed
                           history=(rec.q[:start], rec.qd[:start]) if start > 0 else None, inject=injected)

    out = {"start": float(rec.time[k0]), "runs": {}}
    theta = sel.theta if theta is None else theta
    plants = {"nominal": mdl.copy(), "fitted": mdl.copy()}
    if theta:
        plants["fitted"].set_params(theta)
    joints = drive_joints(theta, mdl)
    if joints:
        k_fit, n_fit = fitting_window(pipe, joints, fit_from, fit_to)
        extra, rows = fit_two_body(rec, pipe, plants["fitted"], joints, run, ref, k_fit, n_fit)
        if extra is None:
            out["two_body"] = {"skipped": rows}
        else:
            plants["fitted, two bodies"] = plants["fitted"].copy()
            plants["fitted, two bodies"].set_params(extra)
            # score: the two bodies' differences on the window over the reading model's (< 1: closer)
            out["two_body"] = {"params": extra, "joints": [i for _, i, _, _ in joints],
                               "window": [float(rec.time[k_fit]), float(rec.time[k_fit + n_fit])],
                               "score": min(r["score"] for r in rows if "score" in r), "grid": rows}
    plants.update(compared or {})
    for name, plant in plants.items():
        try:
            res = run(plant, ref, k0)
        except Exception as e:  # noqa: BLE001 - a failing replay is reported
            out["runs"][name] = {"error": str(e)}
            continue
        s = slice(k0, k0 + len(res.time))
        dq = res.q - rec.q[s]
        dt_ = res.tau - rec.tau[s]
        out["runs"][name] = {"rms_q": np.sqrt(np.mean(dq**2, axis=0)).tolist(),
                             "rms_tau": np.sqrt(np.mean(dt_**2, axis=0)).tolist(),
                             "rel_tau": (np.linalg.norm(dt_, axis=0)
                                         / np.maximum(np.linalg.norm(rec.tau[s], axis=0), 1e-300)).tolist(),
                             "time": res.time, "q": res.q, "tau": res.tau}
    return out
