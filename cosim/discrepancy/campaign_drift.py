"""Drifts between the runs of a campaign: a parameter that changes from run to run.

A campaign (:mod:`.campaign`) fits its runs' physical parameters as shared constants; it also
fits every run alone with the effects the joint fit named (``per_run``: a value and a 95 %
interval per run and parameter).  A drive that warms up over a morning, a belt that wears, a
lubricant that thins make a parameter change slowly from run to run: fitted as a constant it is
the runs' mean, and a run at either end of the campaign is predicted with the wrong value.

The test, per parameter fitted on at least :data:`MIN_RUNS` runs: the runs' values ``v_k`` with
their standard errors ``s_k`` (95 % half width / 1.96) against the run's position ``x_k`` (its
start time when the campaign knows the runs' start times, else its index in the run order),
a weighted straight line ``v = a + b x`` (weights ``1 / s_k^2``).  The slope's statistic is
``b / (se_b sqrt(max(1, chi2_r)))``: ``se_b`` from the runs' intervals, ``chi2_r`` the
scatter of the runs about the line over its ``n - 2`` degrees of freedom, so that runs that
scatter beyond their intervals (intervals too narrow, or an odd run) widen the slope's error
instead of making a trend.  Its two-sided p-value is read from Student's t with ``n - 2``
degrees of freedom, and a drift is named when it is below ``alpha / M`` (Bonferroni over the
``M`` parameters tested): a campaign without drift is called drifting at most ``alpha`` of
the time, whatever the number of parameters.  The test is conservative: with intervals that
hold, the statistic is normal and the t's tails are wider.

A drift named is modelled in the campaign's held-out prediction: the held-out run's value of
the parameter is the line fitted on the other runs' values alone (:func:`predict`), put in
place of the shared constant (:func:`heldout`), and the held-out residual is compared with
both.

Example
-------
>>> per = [{"c": {"value": 20.0 - 0.2 * k, "ci95": 0.05, "unit": "N"}} for k in range(8)]
>>> d = between_runs(per, [f"r{k}" for k in range(8)])[0]
>>> d.param, round(d.change, 3), round(d.per_step, 3)
('c', -1.4, -0.2)
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: fewest runs a parameter must be fitted on to be tested for a drift
MIN_RUNS = 4
#: the share of campaigns without drift that may be called drifting
ALPHA = 0.05


@dataclass(frozen=True)
class RunDrift:
    """A parameter that drifts between the runs of a campaign.

    Attributes
    ----------
    param, unit : str
        The core parameter and its unit.
    axis : str
        ``run`` (the runs' order) or ``time`` (the runs' start times [s]).
    x : tuple of float
        The runs' positions on the axis (index from 0, or start time [s]).
    values, ci95 : tuple of float
        The runs' own values and 95 % half widths (NaN where a run has none).
    slope, slope_ci95 : float
        The line's slope per run or per second, and its 95 % half width (the scatter included).
    start, end : float
        The line's value at the first and the last run.
    change : float
        ``end - start``; ``relative``: the change over ``|start|``.
    per_step : float
        The change per run (``change / (n - 1)``).
    p_value, bar : float
        The slope's two-sided p-value and the bar it is below (``alpha / M``).
    scatter : float
        The runs' reduced chi-square about the line (1 when they scatter as their intervals say).
    """

    param: str
    unit: str
    axis: str
    x: tuple
    values: tuple
    ci95: tuple
    slope: float
    slope_ci95: float
    start: float
    end: float
    change: float
    relative: float
    per_step: float
    p_value: float
    bar: float
    scatter: float

    def at(self, x: float) -> float:
        """The line's value at position ``x`` on the drift's axis."""
        x0 = self.x[0]
        return float(self.start + self.slope * (x - x0))

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _line(x, v, s):
    """Weighted straight line through ``(x, v)`` with standard errors ``s``: ``(a, b, se_b,
    chi2)``, ``v = a + b x``."""
    w = 1.0 / s**2
    sw = w.sum()
    xm = float(np.sum(w * x) / sw)
    sxx = float(np.sum(w * (x - xm) ** 2))
    if not sxx > 0:
        return None
    b = float(np.sum(w * (x - xm) * v) / sxx)
    a = float(np.sum(w * v) / sw) - b * xm
    chi2 = float(np.sum(w * (v - a - b * x) ** 2))
    return a, b, 1.0 / math.sqrt(sxx), chi2


def _usable(per_run, p, positions):
    rows = [(x, e[p]["value"], e[p]["ci95"] / 1.96) for x, e in zip(positions, per_run)
            if p in e and math.isfinite(e[p]["value"]) and math.isfinite(e[p]["ci95"]) and e[p]["ci95"] > 0]
    return tuple(np.array(c, float) for c in zip(*rows)) if rows else (np.empty(0),) * 3


def positions(n: int, times=None) -> tuple[str, np.ndarray]:
    """The runs' axis and positions: ``("time", times)`` when the start times are known, else
    ``("run", 0 .. n-1)``."""
    if times is not None and len(times):
        return "time", np.asarray(times, float)
    return "run", np.arange(n, dtype=float)


def between_runs(per_run: list, names: list, times=None, alpha: float = ALPHA) -> list:
    """Parameters that drift between the runs (see the module's text).

    Parameters
    ----------
    per_run : list of dict
        Per run, {parameter: {"value", "ci95", "unit"}} (each run fitted alone).
    names : list of str
        The runs' names (their order is the run order).
    times : sequence of float, optional
        The runs' start times [s]; the drift is then a trend in time, else in the run order.
    alpha : float
        The share of campaigns without drift that may be called drifting.

    Returns
    -------
    list of RunDrift
        Smallest p-value first.

    Example
    -------
    >>> per = [{"c": {"value": 5.0, "ci95": 0.1, "unit": "N"}} for _ in range(6)]
    >>> between_runs(per, list("abcdef"))
    []
    """
    from scipy.stats import t as student

    axis, x_all = positions(len(names), times)
    params = [p for p in dict.fromkeys(p for pr in per_run for p in pr)]
    tested = []
    for p in params:
        x, v, s = _usable(per_run, p, x_all)
        if len(x) >= MIN_RUNS:
            tested.append((p, x, v, s))
    out = []
    bar = alpha / max(len(tested), 1)
    for p, x, v, s in tested:
        fit = _line(x, v, s)
        if fit is None:
            continue
        a, b, se_b, chi2 = fit
        dof = len(x) - 2
        scatter = chi2 / dof
        se = se_b * math.sqrt(max(1.0, scatter))
        pv = float(2.0 * student.sf(abs(b) / se, dof))
        if not pv < bar:
            continue
        unit = next(e[p]["unit"] for e in per_run if p in e)
        start, end = a + b * x_all[0], a + b * x_all[-1]
        vals = tuple(float(e[p]["value"]) if p in e else float("nan") for e in per_run)
        cis = tuple(float(e[p]["ci95"]) if p in e else float("nan") for e in per_run)
        out.append(RunDrift(p, unit, axis, tuple(float(u) for u in x_all), vals, cis, b,
                            float(student.ppf(0.975, dof) * se), float(start), float(end), float(end - start),
                            float((end - start) / abs(start)) if start else float("nan"),
                            float((end - start) / max(len(names) - 1, 1)), pv, bar, float(scatter)))
    return sorted(out, key=lambda d: d.p_value)


def detrended(per_run: list, drifts: list) -> list:
    """``per_run`` with each drifting parameter's values moved onto the line's mean: the
    runs compared by :func:`.campaign.agreement` differ by what the drift does not say.

    Example
    -------
    >>> per = [{"c": {"value": 20.0 - 0.5 * k, "ci95": 0.1, "unit": "N"}} for k in range(5)]
    >>> [round(p["c"]["value"], 6) for p in detrended(per, between_runs(per, list("abcde")))]
    [19.0, 19.0, 19.0, 19.0, 19.0]
    """
    shift = {d.param: (d, float(np.mean([d.at(x) for x in d.x]))) for d in drifts}

    def moved(p, e, k):
        if p not in shift:
            return dict(e)
        d, mid = shift[p]
        return {**e, "value": e["value"] - d.at(d.x[k]) + mid}

    return [{p: moved(p, e, k) for p, e in pr.items()} for k, pr in enumerate(per_run)]


def predict(param: str, per_run: list, x, k: int) -> float | None:
    """Run ``k``'s value of ``param`` from the line through the other runs' values alone
    (``per_run`` and positions ``x`` aligned; None when fewer than two other runs have one).

    Example
    -------
    >>> per = [{"c": {"value": 20.0 - 0.5 * k, "ci95": 0.1, "unit": "N"}} for k in range(5)]
    >>> round(predict("c", per, [0.0, 1.0, 2.0, 3.0, 4.0], 4), 9)     # run 4 from runs 0-3
    18.0
    """
    others = [pr if j != k else {} for j, pr in enumerate(per_run)]
    xs, v, s = _usable(others, param, np.asarray(x, float))
    if len(xs) < 2:
        return None
    fit = _line(xs, v, s)
    return None if fit is None else float(fit[0] + fit[1] * x[k])


def _mean(param: str, per_run: list, k: int) -> float | None:
    """The inverse-variance weighted mean of ``param`` over the runs other than ``k``."""
    rows = [(e[param]["value"], e[param]["ci95"]) for j, e in enumerate(per_run)
            if j != k and param in e and math.isfinite(e[param]["value"]) and e[param]["ci95"] > 0]
    if not rows:
        return None
    v, c = np.array(rows).T
    return float(np.sum(v / c**2) / np.sum(1.0 / c**2))


def _rms(run, model, theta: dict, window: float) -> float:
    """RMS of the effort residual of ``run`` with the core parameters ``theta``."""
    from .residuals import Pipeline

    pipe = Pipeline(run, model, window=window)
    R = pipe.evaluate(theta).stack()[:, : pipe.nd]
    return float(np.sqrt(np.mean(R**2)))


def heldout(campaign, pieces, joint, model, drifts: list, per_run: list, x, window: float = 0.05) -> list:
    """The held-out pieces' effort residual with the shared constants (the joint fit) and with
    the runs' own fits: a drifting parameter at its value predicted for the held-out run
    (:func:`predict`), every other parameter the runs' own fits share at their weighted mean,
    both from the other runs alone (in the joint fit a drifting parameter's mean biases the
    parameters correlated with it; the runs' own fits are free of that).  ``per_run`` and the
    positions ``x`` are aligned with ``campaign.runs``.

    Returns, per held-out piece ``(run, a, b, True)``: ``run`` (name), ``values``
    ({parameter: [constant, predicted]}), ``rms`` ({"nominal", "constant", "drift"} effort
    residual RMS), ``gain_constant`` and ``gain_drift`` (nominal RMS over each) and ``ratio``
    (the constant's RMS over the drift's); or ``skipped``, the core's reason, when the values
    predicted cannot be evaluated (a line extrapolated out of its parameter's range)."""
    from .._native import JointLimitError, ParameterError, UnreachableError
    from .diagnosis import _model_for

    out = []
    for k, a, b, test in pieces:
        if not test:
            continue
        theta, values = dict(joint.theta), {}
        drifting = {d.param for d in drifts}
        for p in theta:
            v = predict(p, per_run, x, k) if p in drifting else _mean(p, per_run, k)
            if v is not None:
                values[p] = [float(theta[p]), v]
                theta[p] = v
        if not drifting & set(values):
            continue
        run = campaign.runs[k].slice(a, b)
        m = _model_for(run, model)
        try:
            rms = {"nominal": _rms(run, m, {}, window), "constant": _rms(run, m, joint.theta, window),
                   "drift": _rms(run, m, theta, window)}
        except (ParameterError, JointLimitError, UnreachableError) as e:  # a value predicted out of range
            out.append({"run": campaign.names[k], "values": values, "skipped": str(e)})
            continue
        out.append({"run": campaign.names[k], "values": values, "rms": rms,
                    "gain_constant": rms["nominal"] / rms["constant"], "gain_drift": rms["nominal"] / rms["drift"],
                    "ratio": rms["constant"] / rms["drift"]})
    return out


def stage(c, runs, per_run: list, drifts: list, used, pieces, joint, model, window: float) -> list:
    """:func:`heldout` for a campaign ``c`` whose runs drift: the held-out ``pieces`` of
    ``used`` (the runs the joint fit kept), each run with its per-run quantities taken out
    (``runs``, aligned with ``c.runs``), ``per_run`` the own fits of all of ``c``'s runs."""
    from dataclasses import replace

    if not drifts:
        return []
    keep = [c.names.index(n) for n in used.names]
    _, x = positions(len(c.names), c.times or None)
    sub = replace(used, runs=[runs[k] for k in keep])
    return heldout(sub, pieces, joint, model, drifts, [per_run[k] for k in keep], x[keep], window)


def predicted(held: list) -> dict:
    """{run name: {parameter: predicted value}} of :func:`heldout`'s answer (the replay's
    "fitted, drift" plant)."""
    return {h["run"]: {p: v[1] for p, v in h["values"].items()} for h in held if "skipped" not in h}


def sentence(drifts: list, held: list, n: int) -> str:
    """The campaign conclusion's words on the drifts between runs ('' when none)."""
    if not drifts:
        return ""
    parts = []
    for d in drifts:
        course = (f"{d.slope:+.3g} ± {d.slope_ci95:.2g} {d.unit} per run" if d.axis == "run" else
                  f"{d.slope * 3600:+.3g} ± {d.slope_ci95 * 3600:.2g} {d.unit} per hour")
        ok = math.isfinite(d.relative)
        rel = f"{abs(100 * d.relative):.1f} % " if ok else ""
        step = f", {abs(100 * d.relative) / max(n - 1, 1):.2g} % per run" if ok else ""
        parts.append(f"{d.param} {'falls' if d.change < 0 else 'rises'} {rel}over the {n} runs{step} "
                     f"({d.start:.4g} -> {d.end:.4g} {d.unit}, {course}, p = {d.p_value:.2g} against "
                     f"{d.bar:.2g})")
    text = "Between the runs, " + "; ".join(parts)
    for h in held:
        if "skipped" in h:
            text += f"; the held-out run {h['run']} is not predicted with the drift: {h['skipped']}"
    done = [h for h in held if "skipped" not in h]
    if len(done) == 1:
        h = done[0]
        text += (f"; modelled as a drift, the held-out run {h['run']}'s effort residual is {h['ratio']:.2f}x lower "
                 f"than with the shared constant (held-out gain {h['gain_drift']:.2f} against "
                 f"{h['gain_constant']:.2f})")
    elif done:
        r = [h["ratio"] for h in done]
        text += (f"; modelled as a drift, the {len(done)} held-out pieces' effort residual is {min(r):.2f}-"
                 f"{max(r):.2f}x lower than with the shared constant (median {float(np.median(r)):.2f})")
    return text
