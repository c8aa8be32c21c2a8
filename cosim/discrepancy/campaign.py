"""Campaigns: several runs of one rig diagnosed together.

An identification campaign is several recordings of one rig (steps up and down, repeats, a
run per payload).  Joined end to end they are not one recording: the motion jumps at every
seam, and a smoother or a difference across a seam makes forces no physics has.  A campaign
is therefore diagnosed as the engine diagnoses a long recording's working set
(:mod:`.working_set`): the runs are placed one after the other as separate stretches of
motion (``segments``) of one :class:`~.working_set.WorkingSet`, each at its own full rate,
and the residual pipeline evaluates only samples whose smoothing window and delays stay
inside one run.  The physical parameters are shared by all runs (one fit); what a run has
of its own is its initial state (the residual needs none: it is formed from each run's own
motion, and every replay starts from the run's own recorded state) and the per-run
quantities the user declares (:data:`PER_RUN_KINDS`).

Held out
    The engine holds out the samples after a cut in time (:meth:`.residuals.Pipeline.split`).
    A campaign orders its pieces so that the cut falls between them: ``held_out="run"``
    puts the last run after the others (fit on the others, judged on it), an integer ``k``
    holds out run ``k`` (0-based), ``"within"`` holds out the last ``1 - train_fraction``
    of every run (each run cut in two pieces; the fitted pieces first).  With
    ``leave_one_out`` every run is held out in turn and the held-out gain of each is
    reported (fit on the others, judged on it).

Per-run fits and agreement
    Every run is also fitted alone with the effects the joint fit named.  For each parameter
    a run's value is compared with the weighted mean of the other runs' values:
    a difference larger than the two 95 % half widths combined (``sqrt(c_k^2 + c_rest^2)``)
    is reported as a run that disagrees (wear, temperature, a changed set-up), and the
    joint fit is made again on the runs that agree.

Per-run quantities
    A declared per-run core parameter of an additive kind (a constant effort offset
    ``<j>[i].offset``, an encoder offset ``<j>[i].encoder_offset``) is fitted on each run
    alone (the run's own diagnosis, the whole library) and taken out of that run's effort or
    reading before the joint fit, which then fits no shared value of it.

Example
-------
>>> from cosim.discrepancy.campaign import read_campaign, diagnose_campaign
>>> c = read_campaign(["up1.csv", "down1.csv", "up2.csv"])            # doctest: +SKIP
>>> res = diagnose_campaign(c, held_out="run")                        # doctest: +SKIP
>>> res.conclusion, res.disagree                                      # doctest: +SKIP
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import CampaignError
from ..jsonable import finite, jsonable

#: effect kinds a per-run quantity may be (additive: taken out of the run's data exactly)
PER_RUN_KINDS = {"offset": "tau", "encoder_offset": "q"}
#: time between two pieces of a campaign on its joined time axis [s] (no sample there)
GAP = 1.0


@dataclass
class Campaign:
    """The runs of one rig.

    Attributes
    ----------
    runs : list of cosim.recording.Recording
        One recording per run, each uniformly sampled, all at the same step.
    names : list of str
        A name per run (its file's stem, or ``run <value>`` of a ``run`` column).
    per_run : tuple of str
        Core parameters that differ from run to run (:data:`PER_RUN_KINDS`).
    where : str
        The campaign's source (a campaign file, or the first run's).
    times : tuple of float
        The runs' start times [s] when known (:mod:`.campaign_drift`), else empty.
    """

    runs: list
    names: list
    per_run: tuple = ()
    where: str = "campaign"
    times: tuple = ()

    @property
    def robot(self) -> str:
        return self.runs[0].robot


def _read(path):
    from ..recording import read_recording

    return read_recording(path)


def _split_run_column(rec) -> tuple[list, list]:
    """The runs of one recording with a ``run`` column: rows grouped by its value, in order
    of first appearance (each run's rows in time order)."""
    col = np.asarray(rec.extra["run"], float)
    runs, names = [], []
    for v in dict.fromkeys(col.tolist()):
        rows = np.flatnonzero(col == v)
        if np.any(np.diff(rows) != 1):
            raise CampaignError(f"{rec.path}: run {v:g} is not one block of consecutive rows (rows "
                                f"{rows[0] + 2} to {rows[-1] + 2} hold other runs too); sort the file by run")
        r = rec.slice(int(rows[0]), int(rows[-1]) + 1)
        r.extra = {k: a for k, a in r.extra.items() if k != "run"}
        runs.append(r)
        names.append(f"run {v:g}")
    return runs, names


def _campaign_file(path: Path):
    """``{"runs": [paths], "per_run": [core parameters]}`` (JSON or TOML), the paths relative to
    the file."""
    import tomllib

    try:
        spec = (tomllib.loads(path.read_text()) if path.suffix == ".toml" else json.loads(path.read_text()))
    except (ValueError, UnicodeDecodeError) as e:
        raise CampaignError(f"{path}: not a campaign file ({e})") from None
    runs = spec.get("runs") if isinstance(spec, dict) else None
    if not isinstance(runs, list) or not runs or not all(isinstance(r, str) for r in runs):
        raise CampaignError(f"{path}: a campaign file lists its runs: runs = [\"run1.csv\", \"run2.csv\", ...]")
    per = spec.get("per_run", [])
    if not isinstance(per, list) or not all(isinstance(p, str) for p in per):
        raise CampaignError(f"{path}: per_run must be a list of core parameter names")
    times = spec.get("times", [])
    if not isinstance(times, list) or not all(isinstance(x, (int, float)) for x in times):
        raise CampaignError(f"{path}: times must be a list of the runs' start times in seconds")
    return [path.parent / r for r in runs], tuple(per), tuple(float(x) for x in times)


def read_campaign(sources, *, per_run=(), times=None) -> Campaign:
    """The runs of a campaign.

    Parameters
    ----------
    sources : str, Path, Recording, or a list of them
        Recording files (each a run), recordings in memory, a campaign file (``.toml`` or
        ``.json``: ``runs = [...]``, optional ``per_run = [...]``), or one recording with a
        ``run`` column (a run per value).
    per_run : iterable of str
        Core parameters that differ from run to run (``rail[1].offset``), besides those a
        campaign file declares.
    times : sequence of float, optional
        The runs' start times [s] (or a campaign file's ``times = [...]``), one per run.

    Returns
    -------
    Campaign

    Raises
    ------
    CampaignError
        Runs of two robots, at different sampling steps, with different joint columns, or
        a per-run parameter of a kind that cannot be taken out of a run, start times that are
        not one finite time per run.
    cosim.recording.RecordingError
        A malformed run (names file, row, column).

    Example
    -------
    >>> c = read_campaign("campaign.toml")              # doctest: +SKIP
    >>> c.names                                         # doctest: +SKIP
    ['steps_up_1', 'steps_down_1', 'steps_up_2']
    """
    from ..recording import Recording

    items = [sources] if isinstance(sources, (str, Path, Recording)) else list(sources)
    declared = tuple(per_run)
    where = str(items[0]) if items and not isinstance(items[0], Recording) else "campaign"
    if len(items) == 1 and not isinstance(items[0], Recording) and Path(items[0]).suffix in (".toml", ".json") \
            and not Path(items[0]).with_suffix(".csv").exists():
        items, more, file_times = _campaign_file(Path(items[0]))
        declared += more
        times = times if times is not None else (file_times or None)
    runs, names = [], []
    for it in items:
        rec = it if isinstance(it, Recording) else _read(it)
        if "run" in rec.extra:
            rs, ns = _split_run_column(rec)
            stem = f"{Path(rec.path).stem} " if rec.path and len(items) > 1 else ""
            runs += rs
            names += [stem + n for n in ns]
        else:
            runs.append(rec)
            names.append(Path(rec.path).stem if rec.path else f"run {len(runs)}")
    c = Campaign(runs, names, tuple(dict.fromkeys(declared)), where,
                 () if times is None else tuple(float(x) for x in times))
    _check(c)
    return c


def _step(rec) -> float:
    t = np.asarray(rec.time, float)
    return float(t[-1] - t[0]) / max(len(t) - 1, 1)


def _check(c: Campaign) -> None:
    """One robot, one sampling step, the same columns, per-run parameters that can be taken out."""
    from ..core.model import Model

    if not c.runs:
        raise CampaignError(f"{c.where}: a campaign needs at least one run")
    r0, n0 = c.runs[0], c.names[0]
    for r, n in zip(c.runs[1:], c.names[1:]):
        if r.robot != r0.robot:
            raise CampaignError(f"runs of two robots: {n} is of {r.robot!r}, {n0} of {r0.robot!r}; a campaign is "
                                f"several runs of one rig")
        if abs(_step(r) - _step(r0)) > 0.01 * _step(r0):
            raise CampaignError(f"{n} is sampled every {_step(r):.6g} s, {n0} every {_step(r0):.6g} s: resample the "
                                f"runs to one step")
        for col in ("qref", "pose", "f_ext"):
            if (getattr(r, col, None) is None) != (getattr(r0, col, None) is None):
                has, lacks = (n, n0) if getattr(r, col, None) is not None else (n0, n)
                raise CampaignError(f"{has} has {col} columns and {lacks} has none: every run of a campaign "
                                    f"records the same columns")
    if c.times and (len(c.times) != len(c.runs) or not all(math.isfinite(x) for x in c.times)):
        raise CampaignError(f"{c.where}: start times {list(c.times)} are not one finite time in seconds per run "
                            f"({len(c.runs)} runs)")
    names = set(Model(r0.robot).param_names())
    for p in c.per_run:
        kind = p.rsplit(".", 1)[-1]
        if p not in names:
            raise CampaignError(f"per-run parameter {p!r} is not a parameter of {r0.robot} "
                                f"(`cosim params {r0.robot}` lists them)")
        if kind not in PER_RUN_KINDS:
            raise CampaignError(f"per-run parameter {p!r}: only an effort offset (<joint>.offset) or an encoder "
                                f"offset (<joint>.encoder_offset) can differ from run to run (they are taken out of "
                                f"each run's data); {kind!r} is shared by the runs")


def pieces_of(c: Campaign, held_out="run", train_fraction: float = 0.7) -> list:
    """The pieces (run, first row, stop row, held out) in the order they are joined: the
    fitted ones first, then the held-out ones (see the module's text)."""
    n = len(c.runs)
    if held_out == "within":
        fit, test = [], []
        for k, r in enumerate(c.runs):
            cut = int(round(train_fraction * len(r)))
            fit.append((k, 0, cut, False))
            test.append((k, cut, len(r), True))
        return fit + test
    k = n - 1 if held_out == "run" else held_out
    if not isinstance(k, (int, np.integer)) or not 0 <= k < n:
        raise CampaignError(f"held_out = {held_out!r}: 'run' (the last run), 'within' (the end of every run) or a "
                            f"run's index 0..{n - 1}")
    if n < 2:
        raise CampaignError(f"{c.where}: one run cannot be held out by run; use held_out='within'")
    return [(j, 0, len(r), False) for j, r in enumerate(c.runs) if j != k] + [(k, 0, len(c.runs[k]), True)]


def joined(c: Campaign, pieces, runs=None):
    """The pieces as one working set (each a segment, :data:`GAP` apart on the time axis)
    and the train fraction whose cut falls between the fitted and the held-out pieces."""
    from .working_set import WorkingSet, concat

    runs = c.runs if runs is None else runs
    parts, segs, row, t_next, cut = [], [], 0, 0.0, None
    for k, a, b, test in pieces:
        p = runs[k].slice(a, b)
        t = np.asarray(p.time, float)
        p.time = t - t[0] + t_next
        if test and cut is None:
            cut = t_next - GAP / 2
        parts.append(p)
        segs.append((row, row + len(p)))
        row += len(p)
        t_next = float(p.time[-1]) + GAP
    rec = concat(parts, copy=True)
    rec.path = None  # several files: the campaign names its runs
    dur = float(sum(r.time[-1] - r.time[0] for r in runs))
    ws = WorkingSet(rec, segs, len(rec), dur, max(b - a for a, b in segs), 1)
    t0, t1 = float(rec.time[0]), float(rec.time[-1])
    return ws, ((cut - t0) / (t1 - t0) if cut is not None else 0.7)


def _corrected(c: Campaign, values: list) -> list:
    """Each run with its per-run quantities (``values[k]``: {parameter: value}) taken out of its
    data: an effort offset from its effort, an encoder offset from its reading."""
    import re

    out = []
    for r, vals in zip(c.runs, values):
        r = r.slice(0, len(r))
        for p, v in vals.items():
            i = int(re.search(r"\[(\d+)\]", p).group(1)) - 1
            col = PER_RUN_KINDS[p.rsplit(".", 1)[-1]]
            a = np.array(getattr(r, col), float)
            a[:, i] -= v
            setattr(r, col, a)
        out.append(r)
    return out


@dataclass
class CampaignDiagnosis:
    """The answer of :func:`diagnose_campaign`.

    Attributes
    ----------
    conclusion : str
        One short paragraph: the joint fit's conclusion, the runs that disagree.
    joint : Diagnosis
        The joint fit of the runs that agree (of all runs when all agree).
    names : list of str
        The runs.
    held_out : str
        Which samples were held out ("run <name>", "the last 30 % of every run").
    per_run : list of dict
        Per run: ``name``, ``params`` ({core parameter: {value, ci95, unit}} of the joint
        fit's effects fitted on the run alone), ``conclusion`` (the run's own diagnosis),
        ``declared`` ({per-run parameter: value taken out of the run}).
    disagree : list of dict
        Parameters a run disagrees on: ``run``, ``param``, ``value``, ``ci95``, ``others``,
        ``others_ci95``, ``unit``.
    first_joint : Diagnosis or None
        The joint fit of all runs when a run disagreed (then refitted without it).
    leave_one_out : list of dict
        Per run held out in turn: ``name``, ``gain`` (held-out residual RMS ratio,
        nominal over fitted), ``conclusion``.
    replays : list of dict
        The replay of each held-out run (closed loop, or open loop with its method).
    drifts : list of RunDrift
        Parameters that drift between the runs (:mod:`.campaign_drift`).
    drift_heldout : list of dict
        The held-out runs' effort residual with the shared constants and with the drifts
        (:func:`.campaign_drift.heldout`).
    """

    conclusion: str
    joint: object
    names: list
    held_out: str
    per_run: list = field(default_factory=list)
    disagree: list = field(default_factory=list)
    first_joint: object = None
    leave_one_out: list = field(default_factory=list)
    replays: list = field(default_factory=list)
    drifts: list = field(default_factory=list)
    drift_heldout: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"conclusion": self.conclusion, "runs": self.names, "held_out": self.held_out,
                "joint": self.joint.to_dict(), "per_run": self.per_run, "disagree": self.disagree,
                "first_joint": None if self.first_joint is None else self.first_joint.to_dict(),
                "leave_one_out": self.leave_one_out, "replays": self.replays,
                "drifts": [d.to_dict() for d in self.drifts], "drift_heldout": self.drift_heldout}

    def to_json(self, indent: int | None = 2) -> str:
        # JSON has no NaN: an unmeasured gain is null, its reason beside it (gain_note)
        return json.dumps(finite(self.to_dict()), indent=indent, allow_nan=False, default=jsonable)


def _params(d) -> dict:
    """{core parameter: {value, ci95, unit}} of a diagnosis's library effects."""
    return {p: {"value": float(v["value"]), "ci95": float(v["ci95"]), "unit": v["unit"]}
            for e in d.effects for p, v in e["params"].items()}


def agreement(per_run: list, names: list) -> list:
    """Parameters on which a run disagrees with the others.

    For each parameter fitted on at least three runs (two: the two compared), a run's value
    ``v_k +- c_k`` (95 % half width) is compared with the inverse-variance weighted mean of
    the other runs' values ``m +- c_m``; it disagrees when ``|v_k - m| > w sqrt(c_k^2 + c_m^2)``,
    ``w`` the Bonferroni widening for the M comparisons made (runs times parameters:
    ``z(1 - 0.025 / M) / z(0.975)``, 1 for one comparison, 1.39 for eight), so that a campaign
    of many runs does not call a difference by chance.

    Parameters
    ----------
    per_run : list of dict
        Per run, {parameter: {"value", "ci95", "unit"}}.
    names : list of str
        The runs' names.

    Returns
    -------
    list of dict
        ``run``, ``param``, ``value``, ``ci95``, ``others``, ``others_ci95``, ``unit``,
        ``sigmas`` (the difference over the combined half width), largest first.

    Example
    -------
    >>> runs = [{"a": {"value": 1.0, "ci95": 0.1, "unit": "N"}}] * 3 + [{"a": {"value": 2.0, "ci95": 0.1, "unit": "N"}}]
    >>> dis = agreement(runs, ["r1", "r2", "r3", "r4"])
    >>> dis[0]["run"], dis[0]["param"]           # the farthest first (the others, through a mean it pulls)
    ('r4', 'a')
    >>> odd_runs([r for r in runs], ["r1", "r2", "r3", "r4"])[0]
    ['r4']
    """
    from scipy.stats import norm

    out = []
    params = dict.fromkeys(p for pr in per_run for p in pr)
    # one comparison per run and parameter: the bar of each is widened so that the campaign as a
    # whole calls a difference by chance at most 5 % of the time (Bonferroni)
    m = max(1, sum(sum(1 for pr in per_run if p in pr) for p in params))
    widen = float(norm.ppf(1 - 0.025 / m) / norm.ppf(0.975))
    for p in params:
        have = [(k, pr[p]) for k, pr in enumerate(per_run)
                if p in pr and math.isfinite(pr[p]["ci95"]) and pr[p]["ci95"] > 0]
        if len(have) < 2:
            continue
        for k, e in have:
            rest = [x for j, x in have if j != k]
            w = np.array([1.0 / x["ci95"] ** 2 for x in rest])
            m = float(np.sum(w * [x["value"] for x in rest]) / w.sum())
            cm = float(1.0 / math.sqrt(w.sum()))
            bar = widen * math.hypot(e["ci95"], cm)
            if abs(e["value"] - m) > bar:
                out.append({"run": names[k], "param": p, "value": e["value"], "ci95": e["ci95"], "others": m,
                            "others_ci95": cm, "unit": e["unit"], "sigmas": abs(e["value"] - m) / bar})
    if len(per_run) == 2:  # two runs: one difference, said once (neither is the odd one)
        out = out[::2]
    # the run that differs most from the others is the odd one; the others, compared with a
    # mean that holds it, may cross the bar only through it
    out.sort(key=lambda x: -x["sigmas"])
    return out


def odd_runs(per_run: list, names: list) -> tuple[list, list]:
    """The runs that disagree with the others, one at a time: the run farthest from the others
    (:func:`agreement`) is set aside and the rest compared again, while at least three runs
    remain and some disagree.  Returns (their names, their disagreements with the runs left).
    With two runs neither is the odd one: ([], their disagreement)."""
    keep = list(range(len(names)))
    odd, said = [], []
    while True:
        dis = agreement([per_run[k] for k in keep], [names[k] for k in keep])
        if not dis:
            return odd, said
        if len(keep) < 3:
            return odd, said or dis
        worst = dis[0]["run"]
        odd.append(worst)
        said += [x for x in dis if x["run"] == worst]
        keep = [k for k in keep if names[k] != worst]


def _diagnose(ws, model, tf, kw, **more):
    """One run's diagnosis, or joined pieces' (no drift in time there: see :mod:`.campaign_drift`)."""
    from ..recording import Recording
    from .diagnosis import diagnose

    return diagnose(ws, model, train_fraction=tf, **{"replay": False, "figures": False,
                                                      "drift": isinstance(ws, Recording), **kw, **more})


def _declared_values(c: Campaign, model, tf, kw, effects) -> list:
    """Per run, {per-run parameter: its value on the run alone minus the nominal one}."""
    from .diagnosis import _model_for

    if not c.per_run:
        return [{} for _ in c.runs]
    nominal = _model_for(c.runs[0], model).params()
    out = []
    for r in c.runs:
        th = _diagnose(r, model, tf, kw, effects=effects, discovery=False).plant_parameters()
        out.append({p: float(th.get(p, nominal[p]) - nominal[p]) for p in c.per_run})
    return out


def _library_without(effects, per_run) -> list | None:
    """The effect keys of the joint fit: ``effects`` (default the library) without the kinds of
    the per-run parameters (each run has its own value, taken out of its data)."""
    from .effects import LIBRARY

    kinds = {p.rsplit(".", 1)[-1] for p in per_run}
    if not kinds:
        return effects
    return [k for k in (effects or [e.key for e in LIBRARY]) if k not in kinds]


def _held_out_words(c: Campaign, held_out, train_fraction) -> str:
    if held_out == "within":
        return f"the last {100 * (1 - train_fraction):.0f} % of every run"
    k = len(c.runs) - 1 if held_out == "run" else held_out
    return f"run {c.names[k]} (fitted on the others)"


def diagnose_campaign(campaign, model=None, *, held_out="run", leave_one_out: bool = False, out=None,
                      window: float = 0.05, threshold: float = 10.0, train_fraction: float = 0.7, effects=None,
                      discovery: bool = True, instruments: bool = True, replay: bool = True,
                      figures: bool = True, max_samples: int | None = None) -> CampaignDiagnosis:
    """Diagnose the runs of a campaign together (see the module's text).

    Parameters
    ----------
    campaign : Campaign, or what :func:`read_campaign` reads
        The runs.
    model : cosim.core.Model, str or Path, optional
        The model tested (as :func:`.diagnosis.diagnose`).
    held_out : {"run", "within"} or int
        The last run, the end of every run, or run ``k`` (0-based) is held out.
    leave_one_out : bool
        Also fit on all runs but one, judged on it, for every run.
    out : str or Path, optional
        Directory of the joint fit's report and ``campaign.json``.
    window, threshold, train_fraction, effects, discovery, instruments, figures
        As :func:`.diagnosis.diagnose` (``train_fraction``: the share of every run fitted
        with ``held_out="within"``, and of each run's own fit).
    replay : bool
        Replay each held-out run (closed loop, or open loop for an open-loop run).
    max_samples : int, optional
        Most rows the runs may hold together (default
        :data:`~cosim.discrepancy.working_set.MAX_SAMPLES`): a campaign holds its runs whole.

    Returns
    -------
    CampaignDiagnosis

    Raises
    ------
    CampaignError, DiagnosisError, cosim.recording.RecordingError

    Example
    -------
    >>> res = diagnose_campaign(["run1.csv", "run2.csv", "run3.csv"], held_out="run")  # doctest: +SKIP
    >>> [x["run"] for x in res.disagree]                                               # doctest: +SKIP
    ['run3']
    """
    from .working_set import MAX_SAMPLES

    c = campaign if isinstance(campaign, Campaign) else read_campaign(campaign)
    rows, budget = sum(len(r) for r in c.runs), MAX_SAMPLES if max_samples is None else max_samples
    if rows > budget:
        raise CampaignError(f"{c.where}: {len(c.runs)} runs of {rows:,} rows in all, more than the {budget:,} a "
                            f"diagnosis holds (max_samples, --max-samples): a campaign holds its runs whole, so "
                            f"give fewer or shorter runs, or a larger budget if the memory allows it")
    kw = {"window": window, "threshold": threshold, "instruments": instruments}
    declared = _declared_values(c, model, train_fraction, kw, effects)
    runs = _corrected(c, declared)
    lib = _library_without(effects, c.per_run)
    ws, tf = joined(c, pieces_of(c, held_out, train_fraction), runs)
    joint = _diagnose(ws, model, tf, kw, effects=lib, discovery=discovery)
    per = []
    for k, r in enumerate(runs):
        d = _diagnose(r, model, train_fraction, kw, effects=joint.named(), discovery=False) if joint.named() else None
        per.append({"name": c.names[k], "params": _params(d) if d else {}, "declared": declared[k],
                    "conclusion": d.conclusion if d else "nothing fitted jointly, nothing to compare"})
    from . import campaign_drift as cd
    drifts = cd.between_runs([p["params"] for p in per], c.names, c.times or None)
    odd, disagree = odd_runs(cd.detrended([p["params"] for p in per], drifts), c.names)  # about the drifts' lines
    used, first = c, None
    if odd and len(runs) - len(odd) >= 2:
        keep = [k for k, n in enumerate(c.names) if n not in odd]
        used = Campaign([runs[k] for k in keep], [c.names[k] for k in keep], (), c.where)
        ws, tf = joined(used, pieces_of(used, held_out if held_out == "within" else "run", train_fraction))
        first = joint
        joint = _diagnose(ws, model, tf, kw, effects=lib, discovery=discovery, out=out, figures=figures)
    elif out is not None:
        joint = _diagnose(ws, model, tf, kw, effects=lib, discovery=discovery, out=out, figures=figures)
    loro = []
    if leave_one_out and len(used.runs) >= 2:
        for k, name in enumerate(used.names):
            wsk, tfk = joined(used, pieces_of(used, k, train_fraction))
            d = _diagnose(wsk, model, tfk, kw, effects=lib, discovery=discovery)
            loro.append({"name": name, "gain": d.heldout.get("gain"), "gain_note": d.heldout.get("gain_note"),
                         "named": d.named(), "conclusion": d.conclusion})
    words = _held_out_words(used, held_out if not first or held_out == "within" else "run", train_fraction)
    joint = replace(joint, recording=f"joint fit of {', '.join(used.names)}")
    pieces = pieces_of(used, held_out if not first or held_out == "within" else "run", train_fraction)
    res = CampaignDiagnosis("", joint, c.names, words, per, disagree, first, loro, [], drifts,
                            cd.stage(c, runs, [p["params"] for p in per], drifts, used, pieces, joint, model, window))
    if replay:
        from .campaign_replay import replay_held_out

        res.replays = replay_held_out(used, pieces, joint, model, cd.predicted(res.drift_heldout))
    res.conclusion = _conclusion(res, odd)
    if out is not None:
        Path(out).mkdir(parents=True, exist_ok=True)
        (Path(out) / "campaign.json").write_text(res.to_json())
    return res


def _conclusion(res: CampaignDiagnosis, odd: list) -> str:
    """The campaign's paragraph: the joint fit's conclusion, then what the runs say."""
    n = len(res.names)
    text = f"{res.joint.conclusion.rstrip('.')}. {n} runs diagnosed together, held out: {res.held_out}"
    if res.disagree:
        said = []
        for x in res.disagree:
            said.append(f"{x['run']}: {x['param']} = {x['value']:.4g} +- {x['ci95']:.2g} {x['unit']} against "
                        f"{x['others']:.4g} +- {x['others_ci95']:.2g} {x['unit']} on the other runs")
        text += (". The runs disagree beyond their intervals (wear, temperature, a changed set-up?): "
                 + "; ".join(dict.fromkeys(said)))
        if res.first_joint is not None:
            text += f"; the joint fit is of the {n - len(odd)} runs that agree, without {', '.join(odd)}"
    elif any(p["params"] for p in res.per_run):
        text += ". The runs agree: every parameter fitted on each run alone is within its interval of the others'"
    if res.drifts:
        from .campaign_drift import sentence

        text += (" (about the drifts' lines). " if not res.disagree and any(p["params"] for p in res.per_run)
                 else ". ") + sentence(res.drifts, res.drift_heldout, n)
    return text
