"""Drifts: a fitted parameter that changes over the recording instead of staying constant.

Friction falls as a drive warms up; a payload is changed half way.  Fitted as a constant, such a
parameter is its mean over the recording and the residual keeps a slow structure.  For every
parameter the diagnosis fitted, with ``c_p`` its residual column at the fitted model (a finite
difference of the residual pipeline: the core evaluates it), two drift models are tried over
the whole recording, each column multiplied by a function of time:

- a **trend**: ``p(t) = p + b (t - t_mid)``, one more coefficient ``b``;
- a **step**: ``p(t) = p - d (1 - w) + d H(t - t_s)`` for a step of ``d`` at ``t_s``, searched on a
  grid of times between 10 % and 90 % of the recording (w the fraction of samples after ``t_s``:
  the mean stays ``p``); two coefficients (``d``, ``t_s``).

A drift is named when its BIC decrease over the constant exceeds the diagnosis's threshold
plus the look-elsewhere cost ``2 ln M`` (M: every parameter times every model and step time
tried), and two more rules hold, each general (no kind of force named in them):

- **Time beyond the place** (:func:`beyond_places`): a force keyed on where the robot is looks
  like a change in time wherever the trajectory visits other places later in the recording.
  The recording's samples are grouped into :data:`PLACES` places (k-means of the joint
  positions, each joint scaled by its spread).  On each channel where one level per place is
  supported (the residual with the parameter's constant fitted: its chi-square decrease less
  ``PLACES ln n`` above the bar), those levels are taken out of the residual, of the
  parameter's column and of its drift column alike, and the drift is kept only where its BIC
  decrease over the constant, so judged, still exceeds the bar: what the time adds beyond the
  place, within places visited before and after the change.  Where no channel supports a
  force keyed on the place (a drift and nothing else, a trajectory that seldom revisits its
  places), the drift stands on its own BIC decrease: time and place cannot be told apart
  there, and the place is the one without support.
- **One time course, one statement** (:func:`_one_statement`): a drift whose time course (a
  trend, or a step at the same time within one grid step) is that of a stronger drift already
  named is named only where it adds beyond it (its BIC decrease beside the stronger drift above
  the bar); else it is listed as a parameter the same course also fits (``Drift.also``), and
  the replay's plant carries only the stronger one (separately fitted, both would carry the
  same change twice).

Its time course is also measured directly: the parameter refitted on its own in
:data:`WINDOWS` consecutive windows (the others held), each with its 95 % interval, for the
report and its figure.

The replay's plant carries a drift the core can model (a parameter's time course in its
integrator, ``pkm_param_set_course``: a trend of a drive-layer parameter, a step of any
parameter): :func:`for_plant` fits it again on the fitting rows alone, its kind chosen there
too, so that the held-out part it is judged on played no part in its kind or size, and
:func:`apply` gives it to the plant.  A
trend of a mechanism parameter (a mass) is held at its mean, and the report says so.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

#: windows of the time course
WINDOWS = 6
#: step times tried, as fractions of the recording
STEP_GRID = np.linspace(0.1, 0.9, 33)
#: places (k-means of the scaled joint positions) a force keyed on where the robot is may take
#: a level in, per channel, before a drift is judged (:func:`beyond_places`)
PLACES = 16
#: k-means iterations of the places (fewer only where no sample changes place)
PLACE_ITERATIONS = 15


@dataclass
class Drift:
    """A parameter that drifts over the recording.

    Attributes
    ----------
    param : str
        The core parameter.
    unit : str
        Its unit.
    kind : str
        ``trend`` or ``step``.
    mean : float
        The constant the diagnosis fitted (the mean over the recording).
    size : float
        ``trend``: the change over the recording (slope x duration); ``step``: the step's height.
    ci95 : float
        Half-width of the 95 % interval of ``size``.
    time : float or None
        ``step``: when it happens [s, the recording's time].
    start, end : float
        The value at the start and at the end of the recording under the drift model.
    delta_bic : float
        BIC decrease over the constant.
    bar : float
        The threshold plus the look-elsewhere cost.
    windows : dict
        The time course: ``t`` (window centres [s]), ``value`` and ``ci95`` of the parameter
        refitted in each window, ``span`` the recording's first and last time [s].
    equation : str
        The drift as an equation in time.
    """

    param: str
    unit: str
    kind: str
    mean: float
    size: float
    ci95: float
    time: float | None
    start: float
    end: float
    delta_bic: float
    bar: float
    windows: dict = field(default_factory=dict)
    equation: str = ""
    #: the course the replay's plant carries (:meth:`cosim.core.Model.set_course`'s arguments
    #: and ``value``, the parameter's value), fitted on the fitting rows; None: the mean
    course: dict | None = None
    #: why the plant holds the mean instead ("" when it carries the course)
    held: str = ""
    #: BIC decrease over the constant with a force keyed on the place taken out (None: not judged)
    beyond_places: float | None = None
    #: the channels (0-based) where a force keyed on the place is supported, taken out before
    #: ``beyond_places`` (None: not judged)
    place_channels: list | None = None
    #: parameters the same time course also fits, adding nothing beyond this drift
    also: tuple = ()

    def __getitem__(self, k):
        return getattr(self, k)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("param", "unit", "kind", "mean", "size", "ci95", "time", "start", "end",
                                               "delta_bic", "bar", "windows", "equation", "course", "held",
                                               "beyond_places", "place_channels", "also")}


def _column(eng, theta, R, k):
    """Residual column (m, C) of parameter ``k`` at ``theta`` (forward difference)."""
    v = float(theta[k])
    nominal = eng.nominal.get(k, 0.0)
    h = max(abs(v - nominal), abs(v), 1e-12) * 1e-3
    Rk = eng.try_R(dict(theta, **{k: v + h}))
    if Rk is None:
        Rk = eng.try_R(dict(theta, **{k: v - h}))
        h = -h
    if Rk is None:
        return None
    return (Rk - R) / h


def _lstsq(X, y):
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    return coef, float(r @ r)


def _course(eng, y_all, c_all, t, rows, s2, p):
    """The parameter (fitted constant ``p``) refitted alone in WINDOWS windows of the rows:
    centres, values, 95 %, and the rows' first and last time (``span``)."""
    edges = np.linspace(t[rows].min(), t[rows].max(), WINDOWS + 1)
    C = eng.C
    out = {"t": [], "value": [], "ci95": []}
    tt = np.tile(t[rows], C)  # the stacked vectors are channel after channel
    for a, b in zip(edges[:-1], edges[1:]):
        w = (tt >= a) & (tt <= b)
        x = c_all[w]
        den = float(x @ x)
        if den <= 0:
            continue
        out["t"].append(0.5 * (a + b))
        out["value"].append(p + float(x @ y_all[w]) / den)
        out["ci95"].append(1.96 * math.sqrt(s2 / den))
    out["span"] = [float(t[rows].min()), float(t[rows].max())]
    return out


def places(positions, n_places: int = PLACES) -> np.ndarray:
    """The place of every sample: k-means of the joint positions, each joint scaled by its spread.

    Parameters
    ----------
    positions : numpy.ndarray, shape (m, n)
        Joint positions [the joints' units].
    n_places : int
        Places (fewer when there are fewer distinct samples).

    Returns
    -------
    numpy.ndarray of int, shape (m,)
        The place of each sample, 0 .. n_places - 1: scikit-learn's k-means (Lloyd,
        :data:`PLACE_ITERATIONS` iterations) from centres at the first sample and then each at
        the sample farthest from those taken, so the places are the same on every run (no
        random start).
    """
    q = np.asarray(positions, float)
    Z = (q - q.mean(0)) / np.maximum(q.std(0), 1e-12)
    centres = [Z[0]]
    far = np.sum((Z - Z[0]) ** 2, 1)
    for _ in range(n_places - 1):
        if not far.max() > 0:
            break
        centres.append(Z[int(np.argmax(far))])
        far = np.minimum(far, np.sum((Z - centres[-1]) ** 2, 1))
    from sklearn.cluster import KMeans

    km = KMeans(len(centres), init=np.array(centres), n_init=1, max_iter=PLACE_ITERATIONS, tol=0.0,
                algorithm="lloyd")
    return km.fit(Z).labels_.astype(int)


def _off_places(v, weights, label, channels=None):
    """``v`` (stacked channel after channel, as :meth:`FitState.vec`) less its least-squares fit
    by one level per place on each of ``channels`` (default: all; the level's column is the
    channel's weights there)."""
    m, C = weights.shape
    n = int(label.max()) + 1
    out = np.array(v, float)
    for ch in range(C) if channels is None else channels:
        seg, w = out[ch * m:(ch + 1) * m], weights[:, ch]
        den = np.bincount(label, w * w, n)
        level = np.divide(np.bincount(label, w * seg, n), den, out=np.zeros(n), where=den > 0)
        seg -= w * level[label]
    return out


def beyond_places(y, c, profile, weights, label, n_coef: int, logn: float, bar: float) -> tuple:
    """A drift against a force keyed on the place: the channels where such a force is supported,
    and what the drift adds beyond it there.

    Parameters
    ----------
    y, c : numpy.ndarray, shape (m C,)
        The weighted residual to cancel and the parameter's weighted column, stacked.
    profile : numpy.ndarray, shape (m C,)
        The drift's time course (centred), stacked as ``c``.
    weights : numpy.ndarray, shape (m, C)
        The weights of the rows and channels.
    label : numpy.ndarray of int, shape (m,)
        The place of each row (:func:`places`).
    n_coef : int
        The drift's coefficients (1 for a trend, 2 for a step).
    logn : float
        ``ln`` of the effectively independent samples.
    bar : float
        The BIC decrease a channel's levels must bring to be supported.

    Returns
    -------
    (float, list of int)
        The drift's BIC decrease over the constant with the force keyed on the place taken out
        of the supported channels (near ``-n_coef logn`` where the places alone reproduce the
        time course; the drift's own decrease where no channel supports it), and those channels
        (a channel's levels supported on the residual with the constant fitted: their
        chi-square decrease less one ``logn`` per level above ``bar``).
    """
    m, C = weights.shape
    coef, _ = _lstsq(c[:, None], y)
    r = y - c * coef[0]
    rp = _off_places(r, weights, label)
    levels = int(label.max()) + 1
    gain = np.sum(r.reshape(C, m) ** 2, 1) - np.sum(rp.reshape(C, m) ** 2, 1)  # channel after channel
    channels = [ch for ch in range(C) if gain[ch] - levels * logn > bar]
    yp, cp, gp = (_off_places(v, weights, label, channels) for v in (y, c, c * profile))
    if not float(cp @ cp) > 0:
        return -n_coef * logn, channels
    _, chi_c = _lstsq(cp[:, None], yp)
    _, chi_t = _lstsq(np.stack([cp, gp], 1), yp)
    return float(chi_c - chi_t - n_coef * logn), channels


def _places_of(eng, rows):
    """A function giving the places (:func:`places`) and weights of ``eng``'s ``rows``, made on
    first call (most recordings name no drift to judge) and kept for the next parameter."""
    made = []

    def get():
        if not made:
            made.append((places(eng.pipe.q_s[eng.pipe.idx][rows]), np.asarray(eng.W)[rows]))
        return made[0]
    return get


def _profile(tt, tm, T, step_time=None):
    """The centred time course of a drift at the stacked times ``tt`` (their middle ``tm`` and
    span ``T`` [s]): a trend where ``step_time`` is None, else a step at ``step_time`` [s]."""
    if step_time is None:
        return (tt - tm) / T
    h = (tt >= step_time).astype(float)
    return h - h.mean()


def _against_place(place, y, c, times, step_time, logn, bar):
    """:func:`beyond_places` of a drift (a trend where ``step_time`` is None, else a step then)
    at the places ``place`` gives (:func:`_places_of`); ``times`` is ``(tt, tm, T)``, the stacked
    times, their middle and span."""
    label, weights = place()
    g = _profile(*times, step_time)
    return beyond_places(y, c, g, weights, label, 1 if step_time is None else 2, logn, bar)


def _same_course(a, b, T) -> bool:
    """Drifts ``a`` and ``b`` have one time course: both trends, or steps within one grid step."""
    if a.kind != b.kind:
        return False
    return a.kind == "trend" or abs(a.time - b.time) <= T * (STEP_GRID[1] - STEP_GRID[0]) * 1.001


def _one_statement(found, cols, y, tt, T, tm, logn):
    """``found`` (strongest first) with each drift whose time course a stronger kept drift has
    kept only where it adds beyond that one (BIC decrease above its bar); else its parameter is
    listed in the stronger one's ``also``."""
    kept = []
    for d in found:
        with_same = [k for k in kept if _same_course(k, d, T)]
        if with_same:
            first = with_same[0]
            g = _profile(tt, tm, T, None if first.kind == "trend" else first.time)
            base = [cols[k.param] for k in with_same] + [cols[d.param]] + [cols[k.param] * g for k in with_same]
            _, chi_0 = _lstsq(np.stack(base, 1), y)
            _, chi_1 = _lstsq(np.stack(base + [cols[d.param] * g], 1), y)
            if chi_0 - chi_1 - logn <= d.bar:
                kept[kept.index(first)] = replace(first, also=first.also + (d.param,))
                continue
        kept.append(d)
    return kept


def find_drifts(eng, theta: dict, threshold: float, units: dict | None = None, rows=None, kinds=None) -> list:
    """Drifts of the fitted parameters ``theta`` over the recording (all its rows).

    Parameters
    ----------
    eng : FitState
        The diagnosis's fit state (its pipeline, weights and noise).
    theta : dict
        The fitted parameters (core name -> value), relative to ``eng``'s model.
    threshold : float
        BIC decrease a drift must bring, before the look-elsewhere cost.
    units : dict, optional
        Core name -> unit, for the report.
    rows : array of bool, optional
        The rows of ``eng``'s recording to fit on (default: all of them).
    kinds : dict, optional
        Parameter -> ``trend``, ``step`` or ``either``: those parameters only, each fitted as
        that kind (``either``: the kind whose BIC decrease is larger on these rows) whatever its
        BIC against the bar (a drift already named, fitted again on other rows).

    Returns
    -------
    list of Drift
        The drifts named, largest BIC decrease first.

    Example
    -------
    >>> find_drifts(eng, d.theta, 10.0)        # doctest: +SKIP
    [Drift(param='rail[2].coulomb', kind='trend', size=-0.41, ...)]
    """
    if not theta:
        return []
    pipe = eng.pipe
    t = pipe.t[pipe.idx]
    rows = np.ones(len(t), bool) if rows is None else np.asarray(rows, bool)
    R = eng.R(theta)
    y = -eng.vec(R, rows)  # what a change of the parameters' columns must cancel
    tr = t[rows]
    tt = np.tile(tr, eng.C)
    T = float(tr.max() - tr.min()) if len(tr) else 0.0
    if not T > 0:
        return []
    tm = 0.5 * (tr.max() + tr.min())
    cuts = tr.min() + STEP_GRID * T
    logn = math.log(eng.n_eff)
    keys = [k for k in theta if np.isfinite(theta[k]) and (kinds is None or k in kinds)]
    tried = len(keys) * (1 + len(cuts))
    bar = threshold + 2.0 * math.log(max(tried, 1))
    found, cols, place_of = [], {}, _places_of(eng, rows)
    for k in keys:
        col = _column(eng, theta, R, k)
        c = None if col is None else eng.vec(col, rows)
        if c is None or not float(c @ c) > 0:
            continue
        _, chi_c = _lstsq(c[:, None], y)  # the constant refitted on every row
        coef_t, chi_t = _lstsq(np.stack([c, c * (tt - tm) / T], 1), y)
        best_s = None
        for ts in cuts:
            h = (tt >= ts).astype(float)
            coef_s, chi_s = _lstsq(np.stack([c, c * (h - h.mean())], 1), y)
            if best_s is None or chi_s < best_s[1]:
                best_s = (ts, chi_s, coef_s, h)
        d_trend = chi_c - chi_t - logn
        d_step = chi_c - best_s[1] - 2 * logn
        forced = None if kinds is None else kinds[k]
        if forced is None and max(d_trend, d_step) <= bar:
            continue
        beyond = place = None
        if forced is None:  # the place judged first: time is kept only where it adds beyond it
            beyond, place = _against_place(place_of, y, c, (tt, tm, T),
                                           best_s[0] if d_step > d_trend else None, logn, bar)
            if beyond <= bar:  # a force keyed on the place, supported on its channels, explains it
                continue
        s2 = max(1.0, min(chi_t, best_s[1]) / max(len(y) - 2, 1))
        p = float(theta[k])
        course = _course(eng, y, c, t, rows, s2, p)
        u = (units or {}).get(k, "")
        if d_trend >= d_step if forced in (None, "either") else forced == "trend":
            X = np.stack([c, c * (tt - tm) / T], 1)
            size = float(coef_t[1])
            ci = 1.96 * math.sqrt(s2 * np.linalg.pinv(X.T @ X)[1, 1])
            dr = Drift(k, u, "trend", p, size, ci, None, p + coef_t[0] - size / 2, p + coef_t[0] + size / 2,
                       float(d_trend), float(bar), course,
                       f"{k}(t) = {p + coef_t[0]:.4g} + ({size:.3g} ± {ci:.2g}) (t - {tm:.3g} s) / {T:.3g} s {u}",
                       beyond_places=beyond, place_channels=place)
        else:
            ts, _, coef_s, h = best_s
            X = np.stack([c, c * (h - h.mean())], 1)
            size = float(coef_s[1])
            ci = 1.96 * math.sqrt(s2 * np.linalg.pinv(X.T @ X)[1, 1])
            w = float(h.mean())
            before = p + coef_s[0] - size * w
            dr = Drift(k, u, "step", p, size, ci, float(ts), before, before + size, float(d_step), float(bar), course,
                       f"{k}(t) = {before:.4g} {u} before t = {ts:.3g} s, {before + size:.4g} {u} after "
                       f"(a step of {size:.3g} ± {ci:.2g} {u})", beyond_places=beyond, place_channels=place)
        found.append(dr)
        cols[k] = c
    found = sorted(found, key=lambda d: -d.delta_bic)
    return found if kinds is not None else _one_statement(found, cols, y, tt, T, tm, logn)


def _course_of(d: Drift) -> dict:
    """The core course of drift ``d`` (:meth:`cosim.core.Model.set_course`'s keywords and the
    parameter's ``value``): a trend through its middle value at the middle of its span, a step
    from its value before to its value after."""
    if d.kind == "trend":
        t0, t1 = d.windows["span"]
        return {"kind": "trend", "value": float(0.5 * (d.start + d.end)), "rate": float(d.size / (t1 - t0)),
                "t0": float(0.5 * (t0 + t1))}
    return {"kind": "step", "value": float(d.start), "size": float(d.end - d.start), "t0": float(d.time)}


def for_plant(eng, theta: dict, drifts: list, threshold: float, model) -> list:
    """``drifts`` with the course the replay's plant carries: each drift named on the whole
    recording fitted again on the fitting rows alone (``~eng.test``): its kind (trend or step,
    the larger BIC decrease on those rows), size, value and step time owe nothing to the
    held-out part.  The plant carries it (``Drift.course``) where the fitting rows support a
    drift (a BIC decrease over the constant above ``threshold`` there) and the core can model
    it; else it holds the mean, and ``Drift.held`` says why."""
    from ..errors import PkmError

    if not drifts:
        return drifts
    train = ~np.asarray(eng.test, bool)
    again = {d.param: d for d in find_drifts(eng, theta, threshold, rows=train,
                                             kinds={d.param: "either" for d in drifts})}
    out = []
    for d in drifts:
        a = again.get(d.param)
        if a is None:
            out.append(replace(d, held="no column on the fitting rows: the plant holds the mean"))
            continue
        if not a.delta_bic > threshold:
            out.append(replace(d, held=f"the fitting rows alone do not support a drift (BIC decrease "
                                       f"{a.delta_bic:.1f} <= {threshold:g}): the plant holds the mean"))
            continue
        c = _course_of(a)
        try:
            apply(model.copy(), [replace(d, course=c)])
        except PkmError as e:  # the core cannot carry it (a trend of a mechanism parameter)
            out.append(replace(d, held=f"the plant holds the mean: {e}"))
            continue
        out.append(replace(d, course=c))
    return out


def apply(model, drifts) -> None:
    """Give ``model`` the courses of ``drifts`` (those with one): each parameter set to the
    course's value, then its course (:meth:`cosim.core.Model.set_course`)."""
    for d in drifts:
        if d.course is None:
            continue
        c = dict(d.course)
        model.set_params({d.param: c.pop("value")})
        model.set_course(d.param, c.pop("kind"), **c)


def residual(eng, theta: dict, drifts, R):
    """The residual ``R`` (m, C) of ``eng``'s rows at ``theta`` with the modelled drifts' courses in
    place of their constants, to first order: each parameter's residual column times its course
    less its constant.  What the structure test reads after a fit whose plant carries drifts."""
    t = eng.pipe.t[eng.pipe.idx]
    for d in drifts:
        col = None if d.course is None else _column(eng, theta, R, d.param)
        if col is None:
            continue
        c = d.course
        p = (c["value"] + c["rate"] * (t - c["t0"]) if c["kind"] == "trend" else
             np.where(t >= c["t0"], c["value"] + c["size"], c["value"]))
        R = R + col * (p - theta[d.param])[:, None]
    return R


def _listed(names, shown: int = 3) -> str:
    """``names`` in a sentence: the first ``shown`` and how many more."""
    names = list(names)
    if len(names) <= shown:
        return ", ".join(names)
    return ", ".join(names[:shown]) + f" and {len(names) - shown} more"


def sentence(drifts) -> str:
    """The conclusion's clause on the drifts."""
    parts = []
    for d in drifts:
        if d.kind == "trend":
            p = (f"{d.param} drifts from {d.start:.4g} to {d.end:.4g} {d.unit} over the recording "
                 f"({d.size:+.3g} ± {d.ci95:.2g} {d.unit})")
        else:
            p = (f"{d.param} steps from {d.start:.4g} to {d.end:.4g} {d.unit} at t = {d.time:.3g} s "
                 f"({d.size:+.3g} ± {d.ci95:.2g} {d.unit})")
        if d.course is None:
            p += " (the plant holds the mean)"
        elif d.course["kind"] != d.kind:  # the fitting rows alone chose the other kind
            p += f", modelled as a drift ({'a trend' if d.course['kind'] == 'trend' else 'a step'} on the fitting rows)"
        else:
            p += ", modelled as a drift"
        if d.also:
            p += f"; the same course also fits {_listed(d.also)}"
        parts.append(p)
    return "drift: " + "; ".join(parts)


def markdown(drifts, files: dict) -> list:
    """The report's section on the drifts (lines of Markdown)."""
    L = ["## Drifts", "",
         "Every fitted parameter tried as a trend or a step in time over the whole recording (BIC with the "
         "look-elsewhere cost of every parameter and step time tried), and not where a force keyed on the place "
         f"({PLACES} places of the joint positions, levels on the channels that support them) explains it; the "
         "time course is "
         "the parameter refitted "
         f"alone in {WINDOWS} windows.  A drift the core can model is modelled as a drift: the replay's plant "
         "carries it as its parameter's time course, fitted again (its kind chosen too) on the fitting rows alone.", ""]
    for d in drifts:
        if d.course is not None:
            c = d.course
            how = (f"a trend of {c['rate']:.4g} {d.unit}/s through {c['value']:.4g} {d.unit} at {c['t0']:.3g} s"
                   if c["kind"] == "trend" else
                   f"a step of {c['size']:.4g} {d.unit} at {c['t0']:.3g} s from {c['value']:.4g} {d.unit}")
            plant = f"modelled as a drift: the plant carries {how}"
        else:
            plant = d.held or "the plant holds the mean"
        beside = "" if d.beyond_places is None else (
            f", {d.beyond_places:.0f} beyond a force keyed on the place on channels "
            f"{', '.join(str(ch + 1) for ch in d.place_channels)}" if d.place_channels else
            ", no channel supports a force keyed on the place")
        L += [f"- **{d.equation}** (BIC decrease {d.delta_bic:.0f}{beside}, bar {d.bar:.1f}); {plant}",
              "  - windows: " + ", ".join(f"{v:.4g} ± {c:.2g} at {t:.3g} s"
                                          for t, v, c in zip(d.windows["t"], d.windows["value"], d.windows["ci95"]))]
        if d.also:
            L += ["  - the same time course also fits, adding nothing beyond it: " + ", ".join(d.also)]
    if "drifts" in files:
        L += ["", "![the drifting parameters over the recording](drifts.png)"]
    return L + [""]


def figure(drifts, path):
    """The drifting parameters' time course (window refits with 95 % bars) and drift models."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(drifts), 1, figsize=(7, 2.6 * len(drifts)), squeeze=False)
    for ax, d in zip(axes[:, 0], drifts):
        w = d.windows
        ax.errorbar(w["t"], w["value"], yerr=w["ci95"], fmt="o", label="refitted per window (95 %)")
        t0, t1 = w["span"]
        if d.kind == "trend":
            ax.plot([t0, t1], [d.start, d.end], "-", label="trend")
        else:
            ax.step([t0, d.time, t1], [d.start, d.end, d.end], where="post", label="step")
        if d.course is not None:  # what the replay's plant carries (fitted on the fitting rows)
            c, tt = d.course, np.array([t0, t1])
            if c["kind"] == "trend":
                ax.plot(tt, c["value"] + c["rate"] * (tt - c["t0"]), "--", label="the plant's course")
            else:
                ax.step([t0, c["t0"], t1], [c["value"], c["value"] + c["size"], c["value"] + c["size"]], "--",
                        where="post", label="the plant's course")
        ax.axhline(d.mean, color="grey", ls=":", label="the constant fitted (the mean)")
        ax.set_ylabel(f"{d.param} [{d.unit}]")
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return str(path)
