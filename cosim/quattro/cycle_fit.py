"""The fitted cycle-time model of the Adept Quattro: the torque-limited cycle of
:mod:`cosim.quattro.cycle_time` stretched in time, re-planned with a torque fraction and with a
settling time per stop, fitted on some of Virzi 2010's measured tables (6.1-6.5) and judged on
the others.

Example
-------
>>> from cosim.quattro import cycle_fit as cf
>>> fit = cf.fit_cycle_model(fit_tables=("6.1", "6.5"))
>>> print(fit.summary())
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.model import Model
from ..errors import InputError
from .cycle_time import CYCLES, Measured, _limits, cycle_waypoints, load_measured, spearman, topp_segment
from .maps import model as quattro_model

__all__ = ["CYCLE_TERMS", "CycleFit", "fit_cycle_model", "select_cycle_model"]

# ------------------------------------------------------------ fitted cycle model

# The terms of the fitted cycle model: unit, neutral value, allowed range.  Each is a physical parameter:
#   time_scale [-]      : the controller runs the torque-limited profile stretched in time by this factor
#                         (a speed override: velocities / scale, inertial torques / scale^2, gravity unchanged).
#   torque_fraction [-] : the controller re-plans each move time-optimally with this fraction of the arm
#                         torque capability (gear ratio x nominal motor torque, tau_arm_max); gravity keeps its full share,
#                         so the pose dependence of the cycle time grows as the fraction falls.
#   settle [s]          : fine-positioning / settling time added at each of the six stops of a cycle.
CYCLE_TERMS = {"time_scale": ("-", 1.0, (0.5, 10.0)), "torque_fraction": ("-", 1.0, (0.02, 1.0)),
               "settle": ("s", 0.0, (0.0, 0.2))}


@dataclass
class CycleFit:
    """A cycle-time model fitted on some measured tables and its prediction of all of them.

    Attributes
    ----------
    terms : tuple of str
        The fitted terms (keys of ``CYCLE_TERMS``); the others keep their neutral value.
    params, intervals : dict
        Fitted value and 95 % interval (low, high) of each term, in the units of ``CYCLE_TERMS``.
    fit_tables : tuple of str
    model_t10, torque_limited_t10, scale_only_t10 : dict
        Per table, the time of 10 cycles [s]: fitted model, torque-limited model, and the torque-limited
        model times one scale factor fitted on the same tables (the baseline the model must beat).
    rms_pct, scale_only_rms_pct : dict
        Per table, RMS relative error [%] of the model and of the scale-only baseline.
    peak_speed, peak_acceleration : float
        Largest tool speed [m/s] and path acceleration [m/s^2] of the fitted motion over all rows.
    interval_method : str
        ``"profile likelihood"`` (every term linear: each term scanned over its allowed range with the
        others re-fitted, kept where the likelihood-ratio statistic stays below 3.84) or ``"jacobian"``
        (the linearised covariance, used when the torque fraction is fitted).
    held_out_band : dict
        Per held-out table, (low, high) of the model's mean relative error [%] over every parameter
        set the fit tables do not reject (profile likelihood only).  A band that excludes 0 means the
        fit tables rule out what the held-out table measured: the model misses something between them.
    extrapolated : dict
        Per held-out table whose cycle (move lengths) no fit table has, a sentence saying so: a per-stop
        and a per-move term are only told apart by tables of different move lengths.
    """

    terms: tuple
    params: dict
    intervals: dict
    fit_tables: tuple
    measured: dict
    model_t10: dict
    torque_limited_t10: dict
    scale_only_t10: dict
    rms_pct: dict
    scale_only_rms_pct: dict
    peak_speed: float = float("nan")
    peak_acceleration: float = float("nan")
    aic: float = float("nan")
    candidates: dict = field(default_factory=dict)   # terms -> AIC, when chosen by select_cycle_model
    interval_method: str = "jacobian"
    held_out_band: dict = field(default_factory=dict)
    extrapolated: dict = field(default_factory=dict)

    def summary(self) -> str:
        lines = [f"cycle model fitted on table(s) {', '.join(self.fit_tables)}:"]
        if self.candidates:
            ranked = sorted(self.candidates.items(), key=lambda kv: kv[1])
            lines.append("  terms chosen by AIC: " + "; ".join(
                f"{' + '.join(k) or 'none'} {v:.1f}" for k, v in ranked))
            tried = {k for c in self.candidates for k in c}
            left = [k for k in CYCLE_TERMS if k in tried and k not in self.terms]
            if left:
                lines.append(f"  left out (the data do not support it): {', '.join(left)}")
        for k in self.terms:
            lo, hi = self.intervals[k]
            unit = CYCLE_TERMS[k][0]
            unit = "" if unit == "-" else f" {unit}"
            bounds = CYCLE_TERMS[k][2]
            loose = ("; not determined by these tables: the interval spans the allowed range"
                     if lo <= bounds[0] and hi >= bounds[1] else "")
            lines.append(f"  {k} = {self.params[k]:.4g}{unit} (95 % {lo:.3g} .. {hi:.3g}{unit}{loose})")
        lines.append(f"  fitted motion: peak tool speed {self.peak_speed:.2f} m/s, peak path acceleration "
                     f"{self.peak_acceleration:.0f} m/s^2")
        lines.append(f"  intervals: {self.interval_method}")
        for t in sorted(self.rms_pct):
            tag = "fit" if t in self.fit_tables else "held out"
            band = ""
            if t in self.held_out_band:
                lo, hi = self.held_out_band[t]
                verdict = "contains" if lo <= 0.0 <= hi else "EXCLUDES"
                band = (f"; mean error over the parameters the fit tables allow {lo:+.1f} .. {hi:+.1f} % "
                        f"({verdict} the measurement)")
            lines.append(f"  table {t} ({tag}): RMS error {self.rms_pct[t]:.2f} % "
                         f"(scale-only torque-limited model {self.scale_only_rms_pct[t]:.2f} %), Spearman "
                         f"{spearman(self.model_t10[t], self.measured[t].t10):+.2f}{band}")
            if t in self.extrapolated:
                lines.append(f"    extrapolated: {self.extrapolated[t]}")
        return "\n".join(lines)


def _segment_times(m: Model, ms: Measured, torque_fraction: float, n: int):
    """Per row of one table: the six segment times [s] (rows, 6), and the peak tool speed [m/s] and
    path acceleration [m/s^2] over the six (rows,)."""
    tau = torque_fraction * _limits(m)
    out, vmax, amax = np.empty((len(ms.z), 6)), np.zeros(len(ms.z)), np.zeros(len(ms.z))
    for r, z in enumerate(ms.z):
        w = cycle_waypoints(m, z, ms.cycle, ms.layout)
        for i in range(6):
            prof = topp_segment(m, w[i], w[i + 1], n=n, tau_max=tau)
            out[r, i] = prof.duration
            vmax[r] = max(vmax[r], float(prof.sd.max()))
            amax[r] = max(amax[r], float(np.abs(np.diff(prof.sd ** 2) / (2 * np.diff(prof.s))).max()))
    return out, vmax, amax


def _least_squares(residual, terms):
    """Least squares of ``residual`` over ``terms`` within their allowed ranges: the fitted values,
    their 95 % intervals from the Jacobian at the optimum (residual variance times (J^T J)^-1) and
    the solution vector (empty without terms)."""
    from scipy.optimize import least_squares

    params, intervals = {}, {}
    if not terms:
        return params, intervals, []
    x0 = [{"time_scale": 2.0, "torque_fraction": 0.3, "settle": 0.02}[k] for k in terms]
    lb = [CYCLE_TERMS[k][2][0] for k in terms]
    ub = [CYCLE_TERMS[k][2][1] for k in terms]
    sol = least_squares(residual, x0, bounds=(lb, ub), diff_step=1e-3)
    dof = max(sol.fun.size - len(terms), 1)
    cov = np.linalg.pinv(sol.jac.T @ sol.jac) * float(sol.fun @ sol.fun) / dof
    for i, k in enumerate(terms):
        half = 1.96 * math.sqrt(max(cov[i, i], 0.0))
        # a term pressed against its bound is reported at it (settle 0, not 4e-16 s)
        params[k] = float(min(max(sol.x[i], lb[i]), ub[i]))
        if abs(params[k] - lb[i]) < 1e-9 * (ub[i] - lb[i]):
            params[k] = lb[i]
        intervals[k] = (max(params[k] - half, lb[i]), min(params[k] + half, ub[i]))
    return params, intervals, sol.x


def fit_cycle_model(fit_tables=("6.1", "6.5"), terms=("time_scale", "settle"), n: int = 150,
                    param_set: str = "appendix_a", measured=None) -> CycleFit:
    """Fit the cycle-time model on some measured tables and predict every table.

    The model of one cycle is ``time_scale * sum(T_i) + 6 * settle``, where T_i are the six
    time-optimal segments planned with ``torque_fraction`` of the torque capability.  The parameters
    are fitted by least squares on the relative error of the fit tables; the 95 % intervals come from
    the Jacobian at the optimum (residual variance times (J^T J)^-1).

    Parameters
    ----------
    fit_tables : sequence of str
        Tables to fit on ("6.1" ... "6.5"); the others are held out.
    terms : sequence of str
        Terms to fit (see ``CYCLE_TERMS``); a term left out keeps its neutral value
        (no stretch, full torque, no settling).
    n : int
        Grid intervals per segment of the time-optimal profile.
    param_set : str
        Quattro parameter set (``appendix_a`` is the one whose torque-limited trend matches the tables).

    Returns
    -------
    CycleFit

    Example
    -------
    >>> from cosim.quattro import cycle_fit as cf
    >>> fit = cf.fit_cycle_model(fit_tables=("6.1", "6.5"))
    >>> print(fit.summary())
    """
    unknown = [t for t in terms if t not in CYCLE_TERMS]
    if unknown:
        raise InputError(f"unknown cycle-model term {unknown[0]!r} (known: {', '.join(CYCLE_TERMS)})")
    meas = measured or load_measured()
    missing = [t for t in fit_tables if t not in meas]
    if missing or not fit_tables:
        raise InputError(f"fit table {missing[0] if missing else '(none)'!r} is not among the measured tables "
                         f"({', '.join(sorted(meas))})")
    m = quattro_model(param_set)
    terms, fit_tables = tuple(terms), tuple(fit_tables)
    cache = {}

    def segments(t, fraction):
        key = (t, float(fraction))
        if key not in cache:
            cache[key] = _segment_times(m, meas[t], fraction, n)
        return cache[key]

    def full(p):
        v = {k: CYCLE_TERMS[k][1] for k in CYCLE_TERMS}
        v.update(dict(zip(terms, p)))
        return v

    def predict(v, tables):
        return {t: 10 * (v["time_scale"] * segments(t, v["torque_fraction"])[0].sum(axis=1) + 6 * v["settle"])
                for t in tables}

    def residual(p):
        pr = predict(full(p), fit_tables)
        return np.concatenate([(pr[t] - meas[t].t10) / meas[t].t10 for t in fit_tables])

    params, intervals, x = _least_squares(residual, terms)
    values = full(x)
    tables = sorted(meas)
    model = predict(values, tables)
    method, band = "jacobian", {}
    if terms and "torque_fraction" not in terms:
        intervals, band = _profile_intervals(terms, params, fit_tables, tables, meas,
                                             {t: segments(t, 1.0)[0].sum(axis=1) for t in tables})
        method = "profile likelihood"
    fit_cycles = {meas[t].cycle for t in fit_tables}
    extrapolated = {t: (f"its {meas[t].cycle} cycle ({_moves_mm(meas[t].cycle)} mm moves) is in no fit table "
                        f"({', '.join(sorted(fit_cycles))} only): how the time grows with move length is not "
                        f"measured by the fit")
                    for t in tables if t not in fit_tables and meas[t].cycle not in fit_cycles}
    base = predict(full([]), tables) if not terms else {t: 10 * segments(t, 1.0)[0].sum(axis=1) for t in tables}
    scale = (sum(float(base[t] @ meas[t].t10) for t in fit_tables)
             / sum(float(base[t] @ base[t]) for t in fit_tables))
    scaled = {t: scale * base[t] for t in tables}

    def rms(pr):
        return {t: float(np.sqrt(np.mean(((pr[t] - meas[t].t10) / meas[t].t10) ** 2)) * 100) for t in tables}

    rel = np.concatenate([(model[t] - meas[t].t10) / meas[t].t10 for t in fit_tables])
    aic = float(rel.size * math.log(max(float(rel @ rel), 1e-300) / rel.size) + 2 * len(terms))
    motion = [segments(t, values["torque_fraction"]) for t in tables]
    peak_v = max(float(mo[1].max()) for mo in motion) / values["time_scale"]
    peak_a = max(float(mo[2].max()) for mo in motion) / values["time_scale"] ** 2
    return CycleFit(terms, params, intervals, fit_tables, meas, model, base, scaled, rms(model), rms(scaled),
                    peak_v, peak_a, aic, interval_method=method, held_out_band=band, extrapolated=extrapolated)


def _moves_mm(cycle: str) -> str:
    return "/".join(f"{v * 1e3:.0f}" for v in CYCLES[cycle])


# 95 % point of chi-square with one degree of freedom: the likelihood-ratio threshold of a profile interval.
_CHI2_1_95 = 3.841


def _profile_intervals(terms, params, fit_tables, tables, meas, sums, samples: int = 41):
    """Profile-likelihood intervals of the linear terms (time_scale, settle) and the held-out bands.

    With the torque fraction fixed the model of one row is linear, ``10 (scale S + 6 settle)`` with S
    the sum of the six torque-limited move times, so every profile point is an exact 1-D least-squares
    fit.  A term is moved away from its optimum with the other re-fitted (clipped to its range); the
    interval ends where N ln(RSS / RSS_min) reaches 3.84, or at the allowed range.  Unlike the Jacobian
    this stays honest at a bound (a settle of zero) and where the fit tables barely constrain a term.
    The band of a held-out table is its mean relative error over the parameter sets inside the
    intervals, widened by 1.96 times the fit's residual scatter over the root of the table's rows.
    """
    from scipy.optimize import brentq

    rel = {t: 10 * sums[t] / meas[t].t10 for t in tables}           # d(pred / meas) / d scale
    per_stop = {t: 60.0 / meas[t].t10 for t in tables}               # d(pred / meas) / d settle
    cols = {"time_scale": np.concatenate([rel[t] for t in fit_tables]),
            "settle": np.concatenate([per_stop[t] for t in fit_tables])}
    n = cols["time_scale"].size

    def profile(k, v):
        # residual = scale A_s + settle A_c - 1: fix term k at v, solve the other in closed form, clip to range
        vals = {name: CYCLE_TERMS[name][1] for name in cols}
        vals[k] = v
        base = sum(vals[name] * cols[name] for name in cols) - 1.0
        for name in terms:
            if name != k:
                col = cols[name]
                lo, hi = CYCLE_TERMS[name][2]
                step = float(np.clip(vals[name] - (col @ base) / (col @ col), lo, hi)) - vals[name]
                base = base + step * col
                vals[name] += step
        return float(base @ base), vals

    rss_min = min(profile(k, params[k])[0] for k in terms)

    def excess(k, v):
        return n * math.log(max(profile(k, v)[0], 1e-300) / max(rss_min, 1e-300)) - _CHI2_1_95

    intervals, accepted = {}, []
    for k in terms:
        lo, hi = CYCLE_TERMS[k][2]
        p = params[k]
        ends = [brentq(lambda v: excess(k, v), edge, p, xtol=1e-9) if edge != p and excess(k, edge) > 0 else edge
                for edge in (lo, hi)]
        intervals[k] = (float(ends[0]), float(ends[1]))
        accepted += [profile(k, float(v))[1] for v in np.linspace(ends[0], ends[1], samples)]
    sigma = math.sqrt(rss_min / max(n - len(terms), 1))
    band = {}
    for t in tables:
        if t in fit_tables:
            continue
        errs = [float(np.mean(v["time_scale"] * rel[t] + v["settle"] * per_stop[t] - 1.0)) for v in accepted]
        widen = 1.96 * sigma / math.sqrt(len(rel[t]))
        band[t] = (100 * (min(errs) - widen), 100 * (max(errs) + widen))
    return intervals, band


def select_cycle_model(fit_tables=("6.1", "6.5"), n: int = 150, param_set: str = "appendix_a",
                       measured=None, terms=tuple(CYCLE_TERMS)) -> CycleFit:
    """Fit every non-empty combination of ``terms`` (default all of ``CYCLE_TERMS``) and keep the
    one with the lowest AIC.

    AIC = N ln(RSS / N) + 2 k on the relative errors of the fit tables (N rows, k terms), the same
    discipline as the discrepancy engine: a term enters only if it pays for itself.  The returned
    fit lists every candidate's AIC and the terms left out.

    Example
    -------
    >>> from cosim.quattro import cycle_fit as cf
    >>> print(cf.select_cycle_model(fit_tables=("6.1",)).summary())
    """
    from itertools import combinations

    names = list(terms)
    fits = [fit_cycle_model(fit_tables, c, n=n, param_set=param_set, measured=measured)
            for r in range(1, len(names) + 1) for c in combinations(names, r)]
    best = min(fits, key=lambda f: f.aic)
    best.candidates = {f.terms: f.aic for f in fits}
    return best
