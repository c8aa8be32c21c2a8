"""A one-sided spring between two joints, found as a pair (:func:`taut_pairs`).

A cable carrier or hose joining carriages j and k pulls only once the difference d = q_j - q_k
stretches it past its slack s: its tension k w softplus((d - s) / w) (softplus(x) = ln(1 + e^x),
a smooth onset of width w) acts against joint j and its opposite on k.  The per-channel search
meets it in pieces: a linear force in the other joint's position (``cross_q``, a tenth of the
stiffness where the cable is taut over a quarter of the difference's range) beside steps,
polynomials and offsets on either channel, or nothing at all, while the library's offsets,
saturations or dead zones on the two joints take part of the tension.

**Which pairs.**  At most :data:`N_SCREENED` pairs the screen names (:func:`_screened`), linked
by a discovered term or not: with every discovered term and every library group of one joint left
out, both channels' residuals fall by more than the threshold plus the screen's look-elsewhere
cost (2 ln of the pairs and hinges tried) on one hinge max(+-(q_j - q_k - s), 0) equal and
opposite on the two channels.  The screen is a statistic of the data; every force is the core's.

**The fit.**  The slack on a grid of :data:`SLACK_QUANTILES` of the difference over the fitted
part, the onset width on :data:`WIDTHS` of its range, both orientations (taut above or below the
slack); at each shape the stiffness (and the library's offsets on the two joints, refitted with
it) by weighted least squares on the core's column; the best shape then moved off the grid
(Nelder-Mead on the slack and the log width, :data:`N_MOVE` evaluations).  Two variants: beside
the library's groups of the two joints, and in their place (offsets excepted: those are refitted).

**The bars.**  The variant replaces the two channels' discovered terms (and, the second, the
library groups) when it pays the selection's criterion (BIC in effective samples, the slack and
the width counted as coefficients), lowers the held-out chi-square by more than the threshold
plus the look-elsewhere cost of every shape tried on every pair in both variants
(2 ln (2 x shapes x pairs)), and the separate model does not fit the held-out part significantly
better (:func:`.judgement.significant`); of two that win, the one of the lower criterion.

The core holds the spring as each joint's ``force_taut`` = k, ``force_xj`` the other joint, and
``force_taut_q`` = s, ``force_taut_w`` = w on j, -s and -w on k
(c_core/src/dynamics/joint_force.hpp), so the plant, the FMU and the replay simulate what is
reported.  The intervals of k, s and w are the linearised ones of the residual's own noise in
effective samples (the columns of the three at the fit).
"""
from __future__ import annotations

import math

import numpy as np

from .terms import Coefficient, DiscoveredTerm

#: quantiles of the difference d = q_j - q_k (fitted part) where the slack is tried
SLACK_QUANTILES = np.linspace(0.05, 0.95, 10)
#: onset widths tried, per range (max - min) of the difference over the fitted part
WIDTHS = (0.02, 0.08)
#: Nelder-Mead evaluations that move the best grid shape
N_MOVE = 40
#: most joint pairs the screen hands to the fit (:func:`_screened`)
N_SCREENED = 2


def _shape(search, lo, hi, K, s, w) -> dict:
    """The core's parameters of a one-sided spring of stiffness K, slack s and signed width w on
    d = q_lo - q_hi (w > 0: taut above s), with its reaction on hi."""
    n = search.name
    return {n(lo, "force_xj"): float(hi + 1), n(lo, "force_taut"): float(K), n(lo, "force_taut_q"): float(s),
            n(lo, "force_taut_w"): float(w), n(hi, "force_xj"): float(lo + 1), n(hi, "force_taut"): float(K),
            n(hi, "force_taut_q"): float(-s), n(hi, "force_taut_w"): float(-w)}


class _Fit:
    """The weighted least squares of the one-sided spring on the two channels at fixed shapes."""

    def __init__(self, eng, search, rest, lo, hi, held):
        self.eng, self.search, self.rest, self.lo, self.hi, self.held = eng, search, rest, lo, hi, held
        self.R0 = eng.try_R(rest)
        d = search.pipe.q_s[search.pipe.idx][eng.train]
        self.span = float(np.ptp(d[:, lo] - d[:, hi]))
        # a stiffness whose force over the difference's range is the joints' RMS effort
        self.delta = float(max(search.effort[lo], search.effort[hi])) / max(self.span, 1e-12)
        one = search.cols.get(("constant", 0))
        self.offsets = []  # the offsets' columns (each on its joint's channel)
        for a in held if self.R0 is not None and one is not None else ():
            O = np.zeros(self.R0.shape)
            O[:, a] = one[:, a, 0]
            self.offsets.append(O)
        self.evals = 0

    def column(self, s, w):
        """The residual's change per unit stiffness at slack s, signed width w (None: refused)."""
        self.evals += 1
        R = self.eng.try_R({**self.rest, **_shape(self.search, self.lo, self.hi, self.delta, s, w)})
        return None if R is None else (R - self.R0) / self.delta

    def solve(self, Xs, rows):
        """``(coefficients, chi2 on rows, weighted design)`` of the columns ``Xs`` on ``rows``."""
        eng, w, chans = self.eng, self.search.w, (self.lo, self.hi)
        A = np.stack([np.concatenate([X[rows, c] * w[c] * eng.use[rows, c] for c in chans]) for X in Xs], 1)
        y = np.concatenate([self.R0[rows, c] * w[c] * eng.use[rows, c] for c in chans])
        if np.linalg.matrix_rank(A) < len(Xs):
            return None, math.inf, A
        coef = -np.linalg.lstsq(A, y, rcond=None)[0]
        return coef, float(np.sum((y + A @ coef) ** 2)), A

    def at(self, s, w):
        """``(coefficients, train chi2, the stiffness's column)`` at shape (s, w)."""
        X = self.column(s, w)
        if X is None:
            return None, math.inf, None
        coef, chi2, _ = self.solve([X] + self.offsets, self.eng.train)
        if coef is None or not coef[0] > 0:  # a cable pulls the two joints together
            return None, math.inf, X
        return coef, chi2, X


def _best_shape(fit) -> tuple:
    """``(s, w, shapes tried)``: the grid's best shape (by the train chi-square) moved off the grid."""
    from scipy.optimize import minimize

    search, eng = fit.search, fit.eng
    q = search.pipe.q_s[search.pipe.idx][eng.train]
    d = q[:, fit.lo] - q[:, fit.hi]
    best, tried = (math.inf, None, None), 0
    for sign in (1.0, -1.0):
        for s in np.quantile(d, SLACK_QUANTILES):
            for f in WIDTHS:
                tried += 1
                chi2 = fit.at(float(s), sign * f * fit.span)[1]
                if chi2 < best[0]:
                    best = (chi2, float(s), sign * f * fit.span)
    if best[1] is None:
        return None, None, tried
    sign = math.copysign(1.0, best[2])
    lo_w = 1e-3 * fit.span

    def cost(x):
        w = sign * max(math.exp(x[1]), lo_w)
        return fit.at(float(x[0]), w)[1]

    res = minimize(cost, [best[1], math.log(abs(best[2]))], method="Nelder-Mead",
                   options={"maxfev": N_MOVE, "xatol": 1e-4 * fit.span, "fatol": 1e-3})
    if res.fun < best[0]:
        return float(res.x[0]), sign * max(math.exp(res.x[1]), lo_w), tried
    return best[1], best[2], tried


def _covariance(fit, coef, X, s, w, s2):
    """The linearised covariance of (k, s, w, offsets...) at the fit: the columns of the slack and
    the width by central differences of the core's residual (four evaluations)."""
    K = float(coef[0])
    h_s, h_w = 1e-3 * abs(w), 1e-3 * abs(w)
    cols = []
    for sp, sm, wp, wm in ((s + h_s, s - h_s, w, w), (s, s, w + math.copysign(h_w, w), w - math.copysign(h_w, w))):
        a, b = fit.column(sp, wp), fit.column(sm, wm)
        if a is None or b is None:
            return None
        cols.append(K * (a - b) / (2 * (h_s if sp != sm else h_w)))
    _, _, A = fit.solve([X] + cols + fit.offsets, fit.eng.train)
    try:
        return s2 * np.linalg.inv(A.T @ A)
    except np.linalg.LinAlgError:
        return None


def _terms(search, fit, coef, cov, s, w, d_held, before, after) -> list:
    """The one-sided spring as the two channels' :class:`DiscoveredTerm` (``pair`` = the other
    joint), stated in the direction that stretches it: joint a pulled back once q_a - q_b passes
    the slack."""
    lo, hi = fit.lo, fit.hi
    K = float(coef[0])
    half = [1.96 * math.sqrt(max(float(cov[i, i]), 0.0)) for i in range(3)]
    a, b, slack = (lo, hi, s) if w > 0 else (hi, lo, -s)
    units = {p.name: p.unit for p in search.eng.model.param_info()}
    facts = search.eng.model.facts
    u, qu = units.get(search.name(lo, "force_taut"), ""), facts.joint_unit
    where = f"{1e3 * slack:.3g} mm" if qu == "m" else f"{slack:.4g} {qu}"
    eq = (f"a cable between {facts.joint_noun} {a + 1} and {facts.joint_noun} {b + 1}: {K:.3g} {u} past "
          f"{where} of slack (q{a + 1} - q{b + 1})")
    eq += (f" (a one-sided spring: F_{a + 1} = +k w softplus((q{a + 1} - q{b + 1} - s) / w), F_{b + 1} = -F_{a + 1}, "
           f"k = {K:.3g} +- {half[0]:.2g} {u}, s = {slack:.5g} +- {half[1]:.2g} {qu}, "
           f"w = {abs(w):.3g} +- {half[2]:.2g} {qu})")
    # the offsets are refitted from the values the separate terms left (``fit.rest``)
    refit = {search.name(c, "offset"): (float(fit.rest.get(search.name(c, "offset"), 0.0) + coef[1 + i]),
                                        1.96 * math.sqrt(max(float(cov[3 + i, 3 + i]), 0.0)))
             for i, c in enumerate(fit.held)}
    out = []
    for c, o in ((lo, hi), (hi, lo)):
        n = search.name
        coefs = {n(c, "force_taut"): Coefficient(n(c, "force_taut"), K, half[0], u)}
        if n(c, "offset") in refit:
            coefs[n(c, "offset")] = Coefficient(n(c, "offset"), *refit[n(c, "offset")], units.get(n(c, "offset"), ""),
                                                base=float(search.theta.get(n(c, "offset"), 0.0)))
        full = _shape(search, lo, hi, K, s, w)
        sh = {n(c, k): full[n(c, k)] for k in ("force_xj", "force_taut_q", "force_taut_w")}
        out.append(DiscoveredTerm(c + 1, search.pipe.channels[c], ["taut"], eq, coefs, sh,
                                  "a one-sided spring between two joints: a cable carrier or hose joining two "
                                  "carriages that pulls once taut", {}, before[c], after[c], d_held, "position",
                                  shape_ci95={n(c, "force_taut_q"): half[1], n(c, "force_taut_w"): half[2]},
                                  pair=o + 1))
    return out


def _stand_ins(sel, theta, chans) -> list:
    """The library's groups of one of the joints ``chans`` still in ``theta``, but the offsets (the
    one-sided spring refits those): they may stand in for part of its tension."""
    return [a.group for a in sel.selected if a.group.joint in chans and a.group.key != "offset"
            and all(p in theta for p in a.group.params)]


def _trial(eng, search, sel, theta, found, lo, hi, threshold, libs=()):
    """``(terms, separate terms, library groups replaced, criterion)`` of the one-sided spring on
    joints lo, hi in place of their discovered terms and the library groups ``libs`` when it wins
    (see the module's text), else None."""
    from .judgement import significant
    from .pair import chi2_on, dropped, held_rms, kept
    from ..structure import samples_per_independent

    chans = (lo, hi)
    sep = [t for t in found if t.joint - 1 in chans]
    rest = {p: v for p, v in theta.items() if p not in dropped(sep, libs, "spring")}
    held = tuple(a for a in chans if search.name(a, "offset") in rest)
    fit = _Fit(eng, search, rest, lo, hi, held)
    R_sep = eng.try_R(theta)
    if fit.R0 is None or R_sep is None or not fit.span > 0:
        return None
    s, w, tried = _best_shape(fit)
    if s is None:
        return None
    coef, chi_taut, X = fit.at(s, w)
    if coef is None:
        return None
    R_taut = fit.R0 + coef[0] * X + sum(b * O for b, O in zip(coef[1:], fit.offsets))
    phi = samples_per_independent(eng.pipe)
    n_eff = sum(float((eng.use[eng.train, c] > 0).sum()) for c in chans) / phi
    if not n_eff > 1.0:
        return None
    n_taut = 1 + len(fit.offsets) + 2  # the stiffness, the offsets refitted, the slack and the width
    k_sep = sum(not kept(t, p, "spring") for t in sep for p in t.coefficients) + sum(len(g.params) for g in libs)
    crit = chi_taut + n_taut * math.log(n_eff)
    if not crit < chi2_on(search, R_sep, chans, eng.train) + k_sep * math.log(n_eff):
        return None
    # the held-out check with the look-elsewhere cost of the shapes tried on every pair of joints
    # and both variants (:func:`taut_pairs`), and the separate model not significantly better there
    nd = search.nd
    bar = threshold + 2.0 * math.log(2 * tried * nd * (nd - 1) / 2)
    d_held = chi2_on(search, fit.R0, chans, eng.test) - chi2_on(search, R_taut, chans, eng.test)
    if not d_held > bar or significant(search, R_taut, R_sep, chans, threshold)[0]:
        return None
    s2 = max(chi_taut / max(n_eff - n_taut, 1.0), 1.0)
    cov = _covariance(fit, coef, X, s, w, s2)
    if cov is None:
        return None
    before = {a: held_rms(eng, fit.R0, a) for a in chans}
    after = {a: held_rms(eng, R_taut, a) for a in chans}
    return _terms(search, fit, coef, cov, s, w, d_held, before, after), sep, list(libs), crit


def _screened(eng, search, sel, theta, found, threshold) -> list:
    """The joint pairs (lo, hi) whose two channels' residuals, with every discovered term and every
    library group of one joint left out, both fall by more than the threshold plus the
    look-elsewhere cost of the screen (2 ln of the pairs and hinges tried) on one common hinge
    max(+-(q_lo - q_hi - s), 0), equal and opposite on the two channels (a constant on each), s
    on :data:`SLACK_QUANTILES` of the difference: a tension on their difference past a slack.  A
    statistic of the data that triggers the core's fit (:func:`_trial`), not a force.  At most
    :data:`N_SCREENED`, the largest first."""
    nd = search.nd
    bare = {p: v for p, v in theta.items()
            if not any(p in t.params() for t in found) and not any(p in a.group.params for a in sel.selected
                                                                   if a.group.joint is not None)}
    R = eng.try_R(bare)
    if R is None:
        return []
    rows = eng.train
    q = search.pipe.q_s[search.pipe.idx][rows]
    if q.shape[0] < 2 * len(SLACK_QUANTILES):  # too few fitted samples to place a slack
        return []
    pairs = [(a, b) for a in range(nd) for b in range(a + 1, nd)]
    bar = threshold + 2.0 * math.log(max(1, nd * (nd - 1) // 2 * 2 * len(SLACK_QUANTILES)))
    out = []
    for lo, hi in pairs:
        u = [eng.use[rows, c] * search.w[c] for c in (lo, hi)]
        y = [R[rows, c] * u[i] for i, c in enumerate((lo, hi))]
        y = [yi - u[i] * (yi @ u[i]) / max(u[i] @ u[i], 1e-300) for i, yi in enumerate(y)]  # a constant each
        d = q[:, lo] - q[:, hi]
        best = 0.0
        for s in np.quantile(d, SLACK_QUANTILES):
            for sign in (1.0, -1.0):
                h = np.maximum(sign * (d - s), 0.0)
                H = [h * u[0], -h * u[1]]
                H = [Hi - u[i] * (Hi @ u[i]) / max(u[i] @ u[i], 1e-300) for i, Hi in enumerate(H)]
                hh = H[0] @ H[0] + H[1] @ H[1]
                if not hh > 0:
                    continue
                a = -(y[0] @ H[0] + y[1] @ H[1]) / hh
                gains = [yi @ yi - (yi + a * Hi) @ (yi + a * Hi) for yi, Hi in zip(y, H)]
                if min(gains) > bar:
                    best = max(best, sum(gains))
        if best > 0:
            out.append((best, (lo, hi)))
    return [p for _, p in sorted(out, reverse=True)[:N_SCREENED]]


def taut_pairs(eng, search, sel, theta, found, withdrawn, threshold):
    """``(found, withdrawn, theta)`` with each one-sided spring between two joints found as one
    pair term (see the module's text).  Tried on the pairs the screen names (:func:`_screened`),
    each in two variants:
    beside the library's groups of the two joints, and in their place (they may stand in for part
    of the tension); the variant of the lower criterion that wins replaces the two channels'
    discovered terms, and the library groups it replaces and the library's offsets it refitted to
    zero (within their 95 % interval) are withdrawn (``replaced_by`` its channels)."""
    from .pair import installed

    pairs = _screened(eng, search, sel, theta, found, threshold)
    done = set()
    for lo, hi in pairs:
        if {lo, hi} & done:  # a joint holds one other joint (force_xj)
            continue
        libs = _stand_ins(sel, theta, (lo, hi))
        tries = [_trial(eng, search, sel, theta, found, lo, hi, threshold)]
        if libs:
            tries.append(_trial(eng, search, sel, theta, found, lo, hi, threshold, libs))
        won = min((t for t in tries if t is not None), key=lambda t: t[3], default=None)
        if won is None:
            continue
        terms, sep, libs, _ = won
        found, withdrawn, theta = installed(sel, theta, found, withdrawn, terms, sep, libs, "spring")
        done |= {lo, hi}
    return found, withdrawn, theta
