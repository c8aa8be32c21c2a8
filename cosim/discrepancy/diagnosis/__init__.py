"""The diagnosis (part 5 of the engine): residuals -> candidate effects -> selection and
inference (:mod:`.selection`) -> localisation -> held-out fit -> the answer, a
:class:`Diagnosis`, with its conclusion, ties, structure left unexplained and warnings.
:func:`diagnose` is re-exported by :mod:`cosim.discrepancy`.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..._native import PkmError
from ...jsonable import finite, jsonable
from .answer import (GAP_MINORITY, UNDETECTABLE_RATIO, _beside_tie_sentence, _conclusion,  # noqa: F401
                               _drop_unseen_gaps, _effects, _not_excited, _partial_sentence, _two_body_sentence,
                               detection_limit_text)
from .checks import (SURE, _check_motion, convention_contradictions, effort_contradictions,  # noqa: F401
                               heldout_fit, joint_contradictions)
from .replay import _compared, _discover, _replay  # noqa: F401
from ..effects import LIBRARY, groups_for
from ..residuals import DiagnosisError, Pipeline
from ..ties import TIE_MARGIN, UNEXPLAINED, tied  # noqa: F401

__all__ = ["diagnose", "Diagnosis", "DiagnosisError", "LIBRARY"]


@dataclass(frozen=True)
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
        where the nominal residual is out of its noise band), ``affected`` channels; a gain
        that cannot be measured is NaN (null in ``diagnosis.json``) with the reason in
        ``gain_note`` / ``gain_windows_note`` (else None).
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
    #: gear elasticity and backlash of each joint read by a link-side encoder too (q_link<i>
    #: columns; cosim.discrepancy.encoders_step): core parameters with intervals, the effort's side
    encoders: list = field(default_factory=list)
    #: where structure is left: a flexible model of it and its dependence
    #: (cosim.discrepancy.flexible.FlexibleFit, one per effort channel fitted)
    flexible: list = field(default_factory=list)

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
        return {k: getattr(self, k) if k != "flexible" else [f.to_dict() for f in self.flexible] for k in ("recording", "robot", "conclusion", "effects", "theta", "heldout",
                                               "localisation", "not_excited", "unavailable", "refused", "channels",
                                               "noise", "replay", "timings", "files", "steps", "settings",
                                               "warnings", "unexplained", "discovered", "withdrawn", "details",
                                               "platform_force", "drifts", "encoders", "flexible")}

    def to_json(self, indent: int | None = 2) -> str:
        # JSON has no NaN: a figure that could not be measured is null, its reason beside it
        return json.dumps(finite(self.to_dict()), indent=indent, allow_nan=False, default=jsonable)




def _load(recording, max_samples, block_seconds, progress):
    """The working set of ``recording`` (:mod:`.working_set`): the whole recording when it
    has at most ``max_samples`` rows, else blocks of it."""
    from ..working_set import WorkingSet, working_set

    if isinstance(recording, WorkingSet):
        return recording
    try:
        return working_set(recording, max_samples=max_samples, block_seconds=block_seconds, progress=progress)
    except ValueError as e:
        from ...recording import RecordingError

        if isinstance(e, RecordingError):
            raise
        raise DiagnosisError(str(e)) from None


def _model_for(rec, model):
    from ...core.model import Model

    def sidecar_params(m):
        if rec.parameters:
            try:
                m.set_params(rec.parameters)
            except PkmError as e:
                from ...recording import sidecar_path

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
             verbose: bool = False, platform: bool = True, drift: bool = True, families: bool = True,
             flexible: bool = True, black_box: bool = False) -> Diagnosis:
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
        another joint, effort x position, position x rate; a family term pays more than a library
        term and must beat the library-only answer on the held-out part:
        docs/discovery_families.md).  False: the library of one joint's position and rate only.
    platform : bool
        Search one force on the platform for the whole robot (a constant wrench, a cable to an
        anchor, a drag: :mod:`.platform_force`) before the discovery step, and keep it when it and
        the library's selection made again with it fit the held-out part better.
    drift : bool
        Test every fitted parameter for a drift over the recording (a trend or a step in time,
        :mod:`.drift`) and report its size and time course.
    flexible : bool
        Where structure is left, fit it with a flexible model (boosted trees) on every recorded
        input and report how much of it is explainable and on which inputs it depends
        (:mod:`.flexible`).
    black_box : bool
        With ``replay``, also replay the fitted plant plus the flexible model's force as a
        black-box term (evaluated along the recorded motion; ``replay["runs"]`` entry "fitted +
        black box", ``FlexibleFit.black_box`` set).
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
    return _diagnose(recording, model, out=out, window=window, threshold=threshold, train_fraction=train_fraction,
                     effects=effects, replay=replay, figures=figures, max_effects=max_effects, instruments=instruments,
                     compare=compare, discovery=discovery, max_samples=max_samples, block_seconds=block_seconds,
                     progress=progress, verbose=verbose, platform=platform, drift=drift, families=families,
                     flexible=flexible, black_box=black_box)


def _diagnose(recording, model, *, out, window, threshold, train_fraction, effects, replay, figures, max_effects,
              instruments, compare, discovery, max_samples, block_seconds, progress, verbose, platform, drift,
              families, flexible, black_box) -> Diagnosis:
    """:func:`diagnose`'s work, stage after stage (its arguments, all given)."""
    from .._threads import one_blas_thread
    from ..localisation import localise
    from ..engine import attribute, prepare
    from ..working_set import BLOCK_SECONDS, MAX_SAMPLES

    _check_settings(window, threshold, train_fraction)
    t0 = time.perf_counter()
    ws = _load(recording, MAX_SAMPLES if max_samples is None else max_samples,
               BLOCK_SECONDS if block_seconds is None else block_seconds, progress)
    rec = ws.recording
    mdl = _model_for(rec, model)
    from ..effort_map import effort_channels

    commanded = rec  # two effort channels: the physics on the measured one, the drive's map fitted
    rec, effort_map = effort_channels(rec, mdl.facts.effort_unit)
    from ..encoders_step import encoder_findings

    enc = encoder_findings(rec, mdl)  # the two encoders' difference, when a joint has both
    timings = {"read": time.perf_counter() - t0}
    # a working set of blocks, or a campaign's runs (.campaign): no window spans a seam
    segments = None if ws.whole and len(ws.segments) == 1 else ws.segments
    with one_blas_thread():
        pipe = Pipeline(rec, mdl, window=window, segments=segments)
        groups, unavailable = groups_for(mdl, pipe.has_pose, effects)
        groups, one_signed = _drop_unseen_gaps(groups, pipe)
        _check_motion(pipe)
        warnings = convention_contradictions(pipe, mdl)
        if warnings:
            return _contradicted(rec, pipe, warnings, out, t0, enc)
        t1 = time.perf_counter()
        fit = {"train_fraction": train_fraction, "threshold": threshold, "max_groups": max_effects,
               "instruments": instruments, "verbose": verbose}
        eng = prepare(pipe, groups, **fit)
        t2 = time.perf_counter()
        eng, sel = attribute(eng)
        t3 = time.perf_counter()
        eng0, plat = eng, None
        if platform:
            from ..platform_force import diagnosis_stage

            plat, eng, sel = diagnosis_stage(eng, sel, rec, mdl, groups, {"window": window, "segments": segments}, fit)
        t3a = time.perf_counter()
        found, withdrawn, theta, ties, problems = _discovered_and_checked(eng, sel, threshold, discovery, families)
        t3b = time.perf_counter()
        if plat is not None:  # parameters relative to the user's model from here on
            theta = dict(plat.params, **theta)
        held = heldout_fit(eng0, sel, theta)
        from ..drift import find_drifts, for_plant

        drifts = find_drifts(eng0, theta, threshold, {p.name: p.unit for p in mdl.param_info()}) if drift else []
        drifts = for_plant(eng0, theta, drifts, threshold, mdl)  # the courses the replay's plant carries
        if any(d.course is not None for d in drifts):  # judged on the held-out part with them
            from ..drift import residual as drift_residual

            held = heldout_fit(eng0, sel, theta, R_after=drift_residual(eng0, theta, drifts, eng0.R(theta)))
        loc = localise(eng, sel)
        t4 = time.perf_counter()
    timings.update(prepare=t1 - t0 - timings["read"], regressors=t2 - t1, selection=t3 - t2, platform=t3a - t3,
                   discovery=t3b - t3a,
                   heldout_localisation=t4 - t3b)
    r_after, left, effects_out, not_excited, flex, conclusion, details, found, spent = _statement(
        pipe, eng0, eng, sel, theta, ties, found, withdrawn, problems, plat, drifts, held, one_signed, enc,
        effort_map, flexible)
    timings.update(spent)
    replayed = None
    if replay:
        t5 = time.perf_counter()
        flex, replayed = _replayed(commanded, eng0, sel, rec, mdl, compare, theta, r_after, flex, black_box, drifts)
        if details:
            details += _two_body_sentence(replayed, mdl.joint_unit)
        else:
            conclusion += _two_body_sentence(replayed, mdl.joint_unit)
        timings["replay"] = time.perf_counter() - t5
    timings["diagnosis"] = time.perf_counter() - t0
    d = Diagnosis(str(rec.path) if rec.path else "recording", rec.robot, conclusion, effects_out, dict(theta),
                  held, loc, not_excited,
                  [f"{e.name}: {why}" for e, why in unavailable], pipe.channels,
                  {"sigma": dict(zip(pipe.channels, sel.sigma.tolist())),
                   "phi": dict(zip(pipe.channels, sel.phi.tolist())), "n_eff": sel.n_eff},
                  replay=replayed, timings=timings,
                  steps=list(sel.steps), refused=[f"{k}: {v}" for k, v in sel.refused.items()] + problems,
                  settings={"window": window, "threshold": threshold, "train_fraction": train_fraction,
                            "samples": pipe.n, "dt": pipe.dt, "decimation": pipe.step,
                            "smoothing_samples": pipe.window,
                            "working_set": ws.summary()},
                  residual={"time": pipe.t[pipe.idx], "before": eng0.R0, "after": r_after}, unexplained=left,
                  discovered=found, withdrawn=withdrawn, details=details, effort_map=effort_map,
                  platform_force=plat, drifts=drifts, encoders=enc, flexible=flex)
    if out is not None:
        from ..report import write_report

        t6 = time.perf_counter()
        d = replace(d, files=write_report(d, eng, sel, Path(out), figures=figures))  # the report is the diagnosis'
        timings["report"] = time.perf_counter() - t6
    timings["total"] = time.perf_counter() - t0  # the same dict as d.timings: the whole call's time
    return d


def _statement(pipe, eng0, eng, sel, theta, ties, found, withdrawn, problems, plat, drifts, held, one_signed, enc,
               effort_map, flexible):
    """``(r_after, left, effects, not_excited, flex, conclusion, details, found, spent)`` of a fit:
    the residual after it and the structure left in it, the effects reported, what the recording
    cannot reveal, the flexible model of the structure left (when ``flexible``), the statement of
    it all, the discovered terms with their ``partial`` sentence (new terms: ``found`` is left as
    it was) and the time the flexible stage took ({"flexible": s}, or {} without it)."""
    from ..structure import unexplained

    gone = {w["group"] for w in withdrawn}
    r_after = eng0.R(theta) if theta else eng0.R0
    if any(d.course is not None for d in drifts):  # the fit's residual with the drifts the plant carries
        from ..drift import residual as drift_residual

        r_after = drift_residual(eng0, theta, drifts, r_after)
    left = unexplained(pipe, r_after, floor=eng.accuracy())
    # A fit that leaves structure anywhere may stand in for physics the library lacks: in
    # closed loop a missing force moves every joint's readings and efforts, and a stand-in often
    # acts on other channels than those it leaves structured (measured: docs/discrepancy.md)
    effects_out = [e for e in _effects(eng, sel, ties, left) if e["group"] not in gone and not problems]
    # the same for a discovered term: fitted on top of stand-ins, it may share their error
    found = [replace(t, partial=_partial_sentence(left, t.joint) or _beside_tie_sentence(ties, gone, t))
             for t in found]
    not_excited = _not_excited(eng, sel) + one_signed
    flex, spent = [], {}
    if flexible:
        from ..flexible import flexible_stage

        t3c = time.perf_counter()
        # a discovered term whose form holds less than the trees find in the residual before it: partial
        from ..flexible.rival import rivalled

        found, rivals = rivalled(eng0, theta, r_after, found)
        spent["rival"] = time.perf_counter() - t3c
        # a channel whose structure is a spectral line: fitted with the line's phase as an input, against
        # the own noise of the residual without its lines (the lines' entries)
        flex = flexible_stage(eng0, r_after, [e for e in left if e["signature"] != "periodic"], found, effects_out,
                              theta, lines=[e for e in left if e["signature"] == "periodic"],
                              outfit={c: r.fit for c, r in rivals.items() if r.outfit})
        spent["flexible"] = time.perf_counter() - t3c - spent["rival"]
    if theta:  # a part left on an effect's channel keyed on another joint: the effect may stand in for it
        from ..keyed.elsewhere import modulations, terms_beside, withheld

        modulated, noun = modulations(eng0, theta, effects_out, r_after), pipe.model.facts.joint_noun
        found = terms_beside(found, effects_out, modulated, noun)  # a term beside a friction keyed: partial
        effects_out = withheld(effects_out, flex, noun, modulated)
    if flex:  # a force of the platform's motion through a resonance: an inertia fitted beside it may stand in
        from ..keyed.carried import withheld_carried

        effects_out = withheld_carried(effects_out, flex)
    conclusion = _library_conclusion(effects_out, not_excited, eng, sel, found, withdrawn, plat, drifts)
    conclusion, details = _conclusion_and_details(conclusion, effects_out, found, left, held, plat, drifts, flex,
                                                  problems)
    conclusion = _with_drive_statements(conclusion, enc, effort_map)
    return r_after, left, effects_out, not_excited, flex, conclusion, details, found, spent


def _check_settings(window, threshold, train_fraction) -> None:
    """Raise :class:`DiagnosisError` for a window or threshold that is not a positive number, or
    a training fraction outside (0, 1)."""
    for name, v, lo in (("window", window, 0.0), ("threshold", threshold, 0.0)):
        if not (isinstance(v, (int, float)) and np.isfinite(v) and v > lo):
            raise DiagnosisError(f"{name} = {v!r} must be a positive number")
    if not (0.0 < train_fraction < 1.0):
        raise DiagnosisError(f"train_fraction = {train_fraction!r} must be in (0, 1)")


def _discovered_and_checked(eng, sel, threshold, discovery, families):
    """``(found, withdrawn, theta, ties, problems)``: the discovery step's terms, the library
    effects they withdraw, the fitted parameters and ties after it, and why the fit is not
    physical; a fit outside the physical ranges is refused as a whole (empty terms and
    parameters, the problems kept)."""
    found, withdrawn, theta, ties = [], [], dict(sel.theta), []
    if discovery:
        from ..families import searched

        with searched(families):
            found, withdrawn, theta, ties = _discover(eng, sel, threshold)
    from ..verdict import fit_problems

    problems = fit_problems(eng, theta) if theta else []  # a fit outside the physical ranges is refused
    if problems:
        theta, found, withdrawn, ties = {}, [], [], []
    return found, withdrawn, theta, ties, problems


def _library_conclusion(effects_out, not_excited, eng, sel, found, withdrawn, plat, drifts) -> str:
    """The statement of what the library, the discovery step, the platform force and the
    drifts found."""
    conclusion = _conclusion(effects_out, not_excited, eng, sel, found, withdrawn)
    if plat is not None:
        from ..platform_force import sentence as platform_sentence

        conclusion = platform_sentence(plat, conclusion)
    if drifts:
        from ..drift import sentence as drift_sentence

        conclusion += "; " + drift_sentence(drifts)
    return conclusion


def _conclusion_and_details(conclusion, effects_out, found, left, held, plat, drifts, flex, problems):
    """``(conclusion, details)``: the headline that sums up the full statement (and the full
    statement as details), with the structure left and the flexible model's finding; a fit
    refused as not physical says so instead."""
    from ..platform_force import short_name
    from ..structure import sentence
    from ..verdict import headline

    if left:
        conclusion = (conclusion + "; " + sentence(left) if effects_out or found else
                      "no effect of the library explains the residual: " + sentence(left))
    others = ([short_name(plat)] if plat is not None else []) + [
        f"a drift of {dr.param} (a {dr.kind}" + (f"; the same {dr.kind} fits {len(dr.also)} more parameter{'s' * (len(dr.also) > 1)}" if dr.also else "")
        + ")" for dr in drifts]
    head = headline(effects_out, found, left, held.get("gain"), UNEXPLAINED, tied, others)
    if flex:
        from ..flexible import sentence as flexible_sentence

        if flexible_sentence(flex):
            conclusion += "; " + flexible_sentence(flex)
    details, conclusion = (conclusion, head) if head else ("", conclusion)
    if problems:
        details, conclusion = "", ("fit refused, not physical: " + "; ".join(problems) + ". The effects fitted to "
                                   "these values are not reported and the nominal model stands: the fit is degenerate "
                                   "on this recording (nearly dependent effects, or a recording that is not what the "
                                   "model thinks, such as runs joined end to end)")
    return conclusion, details


def _with_drive_statements(conclusion, enc, effort_map) -> str:
    """The conclusion with what the link-side encoders and the measured effort's map say."""
    if enc:
        from ..encoders_step import sentence as encoder_sentence

        conclusion = conclusion.rstrip(".") + "; " + encoder_sentence(enc)
    if effort_map is not None:
        conclusion += "; " + effort_map["statement"]
    return conclusion


def _replayed(commanded, eng0, sel, rec, mdl, compare, theta, r_after, flex, black_box, drifts=()):
    """``(flex, replay)``: the closed-loop replay of the held-out part, with the flexible
    model's force as a black-box term when asked and one is explained (its fits then marked
    ``black_box``)."""
    bb = None
    if black_box and any(f.explained for f in flex):
        from .replay import black_box_for_plant

        bb = black_box_for_plant(eng0, r_after, flex, len(rec.time))
        flex = [replace(f, black_box=True) if f.explained else f for f in flex]
    return flex, _replay(commanded, eng0, sel, _compared(rec, mdl, compare), theta, black_box=bb, drifts=drifts)


def _contradicted(rec, pipe, warnings, out, t0, enc) -> Diagnosis:
    """The answer for a recording that contradicts the model: the warnings, no effects
    (a fit would name the convention as some physics), and a short report."""
    conclusion = ("cannot diagnose: the recording contradicts the model: " + "; ".join(warnings))
    timings = {}  # the whole call's time, once the report is written
    if enc:
        from ..encoders_step import sentence as encoder_sentence

        conclusion += "; " + encoder_sentence(enc)
    d = Diagnosis(str(rec.path) if rec.path else "recording", rec.robot, conclusion, [], {}, {}, {}, [], [],
                  pipe.channels, {}, warnings=list(warnings),
                  settings={"samples": pipe.n, "dt": pipe.dt}, encoders=enc, timings=timings)
    if out is not None:
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        lines = [f"# Diagnosis of {d.recording}", "", f"**{conclusion}**", "", "## Warnings", ""]
        lines += [f"- {w}" for w in warnings] + [""]
        from ..encoders_step import markdown as encoder_markdown

        lines += encoder_markdown(enc)
        (out / "report.md").write_text("\n".join(lines) + "\n")
        (out / "diagnosis.json").write_text(d.to_json())
        d = replace(d, files={"report": str(out / "report.md"), "json": str(out / "diagnosis.json")})
    timings["total"] = time.perf_counter() - t0
    return d
