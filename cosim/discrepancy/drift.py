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
tried).  Its time course is also measured directly: the parameter refitted on its own in
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

    def __getitem__(self, k):
        return getattr(self, k)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("param", "unit", "kind", "mean", "size", "ci95", "time", "start", "end",
                                               "delta_bic", "bar", "windows", "equation", "course", "held")}


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


def _course(eng, y_all, c_all, t, rows, s2):
    """The parameter refitted alone in WINDOWS windows of the rows: centres, values, 95 %."""
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
        out["value"].append(float(x @ y_all[w]) / den)
        out["ci95"].append(1.96 * math.sqrt(s2 / den))
    return out


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
    found = []
    for k in keys:
        col = _column(eng, theta, R, k)
        if col is None:
            continue
        c = eng.vec(col, rows)
        if not float(c @ c) > 0:
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
        s2 = max(1.0, min(chi_t, best_s[1]) / max(len(y) - 2, 1))
        p = float(theta[k])
        course = _course(eng, y, c, t, rows, s2)
        course["value"] = [p + v for v in course["value"]]
        course["span"] = [float(tr.min()), float(tr.max())]
        u = (units or {}).get(k, "")
        if d_trend >= d_step if forced in (None, "either") else forced == "trend":
            X = np.stack([c, c * (tt - tm) / T], 1)
            size = float(coef_t[1])
            ci = 1.96 * math.sqrt(s2 * np.linalg.pinv(X.T @ X)[1, 1])
            dr = Drift(k, u, "trend", p, size, ci, None, p + coef_t[0] - size / 2, p + coef_t[0] + size / 2,
                       float(d_trend), float(bar), course,
                       f"{k}(t) = {p + coef_t[0]:.4g} + ({size:.3g} ± {ci:.2g}) (t - {tm:.3g} s) / {T:.3g} s {u}")
        else:
            ts, _, coef_s, h = best_s
            X = np.stack([c, c * (h - h.mean())], 1)
            size = float(coef_s[1])
            ci = 1.96 * math.sqrt(s2 * np.linalg.pinv(X.T @ X)[1, 1])
            w = float(h.mean())
            before = p + coef_s[0] - size * w
            dr = Drift(k, u, "step", p, size, ci, float(ts), before, before + size, float(d_step), float(bar), course,
                       f"{k}(t) = {before:.4g} {u} before t = {ts:.3g} s, {before + size:.4g} {u} after "
                       f"(a step of {size:.3g} ± {ci:.2g} {u})")
        found.append(dr)
    return sorted(found, key=lambda d: -d.delta_bic)


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
        parts.append(p)
    return "drift: " + "; ".join(parts)


def markdown(drifts, files: dict) -> list:
    """The report's section on the drifts (lines of Markdown)."""
    L = ["## Drifts", "",
         "Every fitted parameter tried as a trend or a step in time over the whole recording (BIC with the "
         "look-elsewhere cost of every parameter and step time tried); the time course is the parameter refitted "
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
        L += [f"- **{d.equation}** (BIC decrease {d.delta_bic:.0f}, bar {d.bar:.1f}); {plant}",
              "  - windows: " + ", ".join(f"{v:.4g} ± {c:.2g} at {t:.3g} s"
                                          for t, v, c in zip(d.windows["t"], d.windows["value"], d.windows["ci95"]))]
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
