"""The discovery's fit: stepwise selection of the terms on one channel, the block bootstrap,
the shape parameters (a step's position and width, a ripple's period, a fading friction's
velocity scale) and their intervals (the steps of :func:`.channel.discover_channel`;
:mod:`.discovery`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._linalg import small_lstsq, small_lstsq_many
from .search import FADE_RANGE
from .terms import BLOCK, MAX_STEPS, N_BOOT, SIGNED, TERMS
from ..families import acceptance, products
from ..intervals import hac_covariance
from ..regressors import MIN_RELEVANCE, fit
from ..structure import samples_per_independent


# ------------------------------------------------------------------------- fitting

@dataclass
class _Fit:
    terms: list          # [(term, option)]
    coef: np.ndarray     # in units of the columns' deltas (= the core parameter values)
    chi2: float
    cov: np.ndarray
    z95: float = 1.96    # multiplier of the HAC standard errors for 95 % intervals
    cov_classical: np.ndarray | None = None  # (Z'X)^-1 Z'Z (X'Z)^-1, in the weights' units


def _design(search, c, terms, rows):
    eng = search.eng
    w = search.w[c] * eng.use[rows, c]
    X = np.concatenate([search.cols[t][rows, c, :] for t in terms], axis=1) * w[:, None] if terms else None
    Zs = []
    for t in terms:
        z = search.instr.get(t)
        Zs.append(search.cols[t][rows, c, :] if z is None else z[rows, c, :])
    Z = np.concatenate(Zs, axis=1) * w[:, None] if terms else None
    return X, Z, w


def _relevant_z(X, Z):
    """The instruments ``Z`` with each column the reference does not image replaced by X's (a
    new array)."""
    Z = Z.copy()
    for j in range(X.shape[1]):
        nx, nz = np.linalg.norm(X[:, j]), np.linalg.norm(Z[:, j])
        if nx == 0 or nz == 0 or abs(X[:, j] @ Z[:, j]) < MIN_RELEVANCE * nx * nz:
            Z[:, j] = X[:, j]  # a column the reference does not image: least squares for it
    return Z


def fit_terms(search, c, y, terms, rows, instruments=True) -> _Fit:
    """Fit ``terms`` to channel c's residual y on ``rows`` (boolean mask of samples)."""
    X, Z, w = _design(search, c, terms, rows)
    t = y[rows] * w
    if not terms:
        return _Fit([], np.zeros(0), float(t @ t), np.zeros((0, 0)))
    Zr = _relevant_z(X, Z) if instruments else None
    coef = fit(X, t, Zr)
    e = t + X @ coef
    chi2 = float(e @ e)
    # two covariances for the intervals: HAC (the scores' correlation in time: the residual
    # drifts where the model is not quite right) and the classical one (scaled by the caller)
    cov, z95 = hac_covariance(X, e, Zr)
    Zc = X if Zr is None else Zr
    A = np.linalg.pinv(Zc.T @ X)
    return _Fit(list(terms), coef, chi2, cov, z95, A @ (Zc.T @ Zc) @ A.T)


#: terms that span a constant while the joint moves: the library's offset is not refitted beside them
SPAN_CONSTANT = ("constant", "coulomb_pos", "coulomb_neg", "coulomb_both", "fading")


def offset_refit(search, c, held, terms) -> list:
    """``[("constant", 0)]`` when the library's offset held on joint c (in ``held``) is
    refitted beside ``terms`` (none of them spans a constant while the joint moves), else []."""
    if search.name(c, "offset") in held and not any(t in SPAN_CONSTANT for t, _ in terms):
        return [("constant", 0)]
    return []


def stepwise(search, c, y, rows, threshold, phi, n_eff, fixed=frozenset(), floor=None, held=None,
             library_only=False):
    """Forward selection (then backward elimination) of terms for channel c by BIC in
    effective samples: a term enters when it lowers chi2 + k log N_eff by more than
    ``threshold`` (chi2 in effective samples: the weights carry 1 / sqrt(phi)).  ``rows`` is a
    boolean mask or an index array (a bootstrap resample); ``fixed``: coefficient keys the
    model already fits on this channel (the library's offset), not searched; ``floor``: the
    smallest value of each dissipative coefficient (default 0; minus the library's level of the
    friction it adds to, :data:`ADDS_TO`); ``held``: the model's parameters, whose offset on
    this joint is refitted beside the terms (:func:`offset_refit`), so that no term enters as
    a stand-in for the offset's share of them.  A term of the families pays more to enter
    (``families/acceptance.py``); ``library_only``: the library's candidates only.  Returns
    the terms."""
    floor = floor or {}
    logn = math.log(max(n_eff, 2.0))
    # the library's terms first, then every candidate on top of them (families/acceptance.py)
    candidates, refused = acceptance.searched(search, library_only), set()
    gram = _Gram(search, c, y, rows, candidates)

    def chi2_of(terms):
        c2, coef = gram.fit(terms + offset_refit(search, c, held or {}, terms))
        keys = [k for t, _ in terms for k in TERMS[t][0]]
        # friction and drag dissipate: a negative level is no such term (a Coulomb pair of
        # opposite signs is a constant force while moving), refused as the library refuses
        # a negative friction
        if any(k in SIGNED and v < floor.get(k, 0.0) for k, v in zip(keys, coef)):
            return math.inf
        return c2

    def chi2_each(sets):  # [chi2_of(terms) for terms in sets], the solves of one size in one call
        refit = search.name(c, "offset") in (held or {})  # offset_refit's first condition, for all
        full = [terms + offset_refit(search, c, held, terms) if refit else terms for terms in sets]
        fits = gram.fit_many([gram.columns_of(ts) for ts in full])
        return [c2 if _above_floor(terms, coef, floor) else math.inf for terms, (c2, coef) in zip(sets, fits)]

    def part_of(terms, cand, cols):  # chi-square with only the columns ``cols`` of cand
        ts = terms + offset_refit(search, c, model or {}, terms + [cand])
        return gram.fit_idx(np.concatenate([gram.at[u] for u in ts] + [np.asarray(cols, int)]))[0]

    chosen = []
    chi2 = chi2_of(chosen)
    model = held  # the model's parameters (the loop's "held" is the coefficients entered)
    costs = {t: acceptance.cost(search, t, threshold) for t in candidates}
    cost = lambda t: costs[t] if t in costs else acceptance.cost(search, t, threshold)  # noqa: E731
    price = {t: len(TERMS[t[0]][0]) * logn for t in candidates}  # the BIC price of its coefficients
    coefs = {t: frozenset(TERMS[t[0]][0]) for t in candidates}
    for _ in range(MAX_STEPS):
        best = None
        held = {k for t, _ in chosen for k in TERMS[t][0]} | set(fixed)
        clashing = products.clashing(search, c, chosen, model)  # the core holds one shape per joint
        tried = [cand for cand in candidates
                 if not (cand in refused or not held.isdisjoint(coefs[cand]))  # a coefficient is entered once
                 and not products.clashes(clashing, cand)]
        for cand, c2 in zip(tried, chi2_each([chosen + [cand] for cand in tried])):
            gain = (chi2 - c2) - price[cand] - costs[cand]  # a family term pays more
            if best is None or gain > best[0]:
                best = (gain, cand, c2)
        if best is None or best[0] <= 0.0:
            break
        if not acceptance.own_part(lambda cols: part_of(chosen, best[1], cols), best[2], best[1], gram.at,
                                   logn, cost(best[1])):  # a whole-effort gain is no effort x position
            refused.add(best[1])
            continue
        chosen.append(best[1])
        chi2 = best[2]
        # backward: a term the newer ones made redundant leaves
        for t in list(chosen[:-1]):
            rest = [u for u in chosen if u != t]
            c2 = chi2_of(rest)
            if (c2 - chi2) - len(TERMS[t[0]][0]) * logn <= cost(t):
                chosen, chi2 = rest, c2
    return chosen


def _above_floor(terms, coef, floor) -> bool:
    """No signed coefficient of ``terms`` (their columns first in ``coef``) below its floor
    (``stepwise``'s test, coefficient by coefficient)."""
    i = 0
    for t, _ in terms:
        for k in TERMS[t][0]:
            if k in SIGNED and coef[i] < floor.get(k, 0.0):
                return False
            i += 1
    return True


#: the candidates' columns of one channel side by side, per search's columns (the last few):
#: id(search.cols) -> (search.cols, {(channel, candidates): (columns, {candidate: their indices})})
_SIDE_BY_SIDE: dict = {}


def _side_by_side(search, c, candidates) -> tuple:
    """``(X, at, sets)``: the columns of ``candidates`` on channel c side by side (samples, columns),
    each candidate's column indices in X and a dict for the indices of sets of them
    (:meth:`_Gram.columns_of`), kept for the searches that share the columns (a selection and the
    bootstrap's resamples read the same ones)."""
    held = _SIDE_BY_SIDE.get(id(search.cols))
    if held is None or held[0] is not search.cols:
        held = _SIDE_BY_SIDE[id(search.cols)] = (search.cols, {})
        while len(_SIDE_BY_SIDE) > 4:  # the oldest out (a dict keeps the order of insertion)
            del _SIDE_BY_SIDE[next(iter(_SIDE_BY_SIDE))]
    key = (c, candidates)
    if key not in held[1]:
        at, n, blocks = {}, 0, []
        for cand in candidates:
            col = search.cols[cand][:, c, :]
            at[cand] = np.arange(n, n + col.shape[1])
            n += col.shape[1]
            blocks.append(col)
        held[1][key] = (np.concatenate(blocks, axis=1), at, {})
    return held[1][key]


class _Gram:
    """The least-squares fits of any set of candidate terms on channel c and ``rows``, from the
    cross products of all candidate columns taken once (a selection fits hundreds of subsets of
    the same columns: a solve of a few unknowns each instead of a least-squares problem over
    the samples)."""

    def __init__(self, search, c, y, rows, candidates=None):
        w = search.w[c] * search.eng.use[rows, c]
        t = y[rows] * w
        # those the selection searches, their columns side by side (the same for every resample)
        Xc, self.at, self._sets = _side_by_side(search, c,
                                                tuple(search.candidates() if candidates is None else candidates))
        X = Xc[rows] * w[:, None]
        self.G, self.b, self.tt = X.T @ X, X.T @ t, float(t @ t)

    def columns_of(self, terms) -> np.ndarray:
        """The column indices of ``terms`` (a list of candidates) one after the other, kept for
        the next selection on the same columns (the bootstrap's resamples try the same sets)."""
        key = tuple(terms)
        i = self._sets.get(key)
        if i is None:
            i = self._sets[key] = np.concatenate([self.at[u] for u in terms]) if terms else np.zeros(0, int)
        return i

    def fit(self, terms):
        """(chi-square, coefficients) of the least-squares fit of ``terms``, as :func:`_ls_fit`."""
        if not terms:
            return self.tt, np.zeros(0)
        return self.fit_idx(np.concatenate([self.at[u] for u in terms]))

    def fit_many(self, sets):
        """``[fit_idx(i) for i in sets]``, bit for bit: the solves of one size in one call
        (:func:`.small_lstsq_many`), each chi-square from copies of its rows laid out as
        ``fit_idx`` takes them."""
        out = [None] * len(sets)
        by_size = {}
        for k, i in enumerate(sets):
            by_size.setdefault(len(i), []).append(k)
        for p, ks in by_size.items():
            if p == 0:
                for k in ks:
                    out[k] = (self.tt, np.zeros(0))
                continue
            idx = np.array([sets[k] for k in ks])
            Gs, bs = self.G[idx[:, :, None], idx[:, None, :]], self.b[idx]
            X = -small_lstsq_many(Gs, bs)
            # each G in fit_idx's memory order (G[i][:, i] is Fortran-ordered), for BLAS to sum
            # in that order: the transposes of a C-ordered stack of the transposed systems
            Gt = np.ascontiguousarray(Gs.transpose(0, 2, 1))
            tt = self.tt
            for r, k in enumerate(ks):
                coef, b, G = X[r], bs[r], Gt[r].T
                out[k] = (max(tt + 2.0 * float(coef @ b) + float(coef @ G @ coef), 0.0), coef)
        return out

    def fit_idx(self, i):
        """(chi-square, coefficients) of the fit of the candidates' columns ``i`` (indices)."""
        if len(i) == 0:
            return self.tt, np.zeros(0)
        G, b = self.G[i][:, i], self.b[i]
        coef = -small_lstsq(G, b)
        # |t + X c|^2 = t't + 2 c'X't + c'X'X c
        return max(self.tt + 2.0 * float(coef @ b) + float(coef @ G @ coef), 0.0), coef


def _blocks(rows, rng):
    """A moving-block bootstrap resample of the True rows (indices, with repetition)."""
    where = np.flatnonzero(rows)
    n = len(where)
    nb = max(1, n // BLOCK)
    starts = rng.integers(0, max(1, n - BLOCK), nb)
    return where[(starts[:, None] + np.arange(BLOCK)[None, :]).ravel() % n]


def _ls_fit(search, c, y, terms, rows):
    """(chi-square, coefficients) of the least-squares fit of ``terms`` to channel c on
    ``rows`` (mask or index array): the comparison baseline, as in the library's selection."""
    w = search.w[c] * search.eng.use[rows, c]
    t = y[rows] * w
    if not terms:
        return float(t @ t), np.zeros(0)
    X = np.concatenate([search.cols[u][rows, c, :] for u in terms], axis=1) * w[:, None]
    coef = fit(X, t)
    e = t + X @ coef
    return float(e @ e), coef


def bootstrap(search, c, y, rows, terms, threshold, phi, n_eff, seed=0, fixed=frozenset(), floor=None, refit=(),
              held=None):
    """Share of block-bootstrap resamples whose stepwise selection picks each of ``terms``,
    and the spread (standard deviation) of the coefficients of ``terms`` and ``refit`` (terms
    fitted with them, not selected) over them."""
    rng = np.random.default_rng(seed + 7 * c)
    hits = {t: 0 for t in terms}
    coefs = []
    for _ in range(N_BOOT):
        pick = _blocks(rows, rng)
        chosen = stepwise(search, c, y, pick, threshold, phi, n_eff, fixed, floor, held)
        for t in terms:
            hits[t] += any(set(TERMS[u[0]][0]) & set(TERMS[t[0]][0]) for u in chosen)
        coefs.append(_ls_fit(search, c, y, list(terms) + list(refit), pick)[1])
    spread = np.std(np.array(coefs), axis=0) if terms else np.zeros(0)
    return {t: hits[t] / N_BOOT for t in terms}, spread


# ------------------------------------------------------------------------- the shapes

def _fit_step(search, c, y, terms, rows):
    """The step of ``terms`` (if any) with its position and width fitted (Nelder-Mead on the
    fitted part's chi-square, every other term refitted with it, from the grid's step; the
    width kept within 2-100 % of the joint's position spread, the position within its range):
    ``(search, terms)``, the search holding the steps tried and ``terms`` with the step's option
    replaced by the fitted one."""
    from scipy.optimize import minimize

    k = next((i for i, (t, _) in enumerate(terms) if t == "step"), None)
    if k is None:
        return search, terms
    qs, ws = search.steps[terms[k][1]]
    q0, w0 = float(qs[c]), float(ws[c])
    lo, hi = float(search.q_range[0][c]), float(search.q_range[1][c])
    T = float(search.travel[c])
    tried = {}

    def at(x):
        nonlocal search
        q, w = q0 + x[0] * w0, w0 * math.exp(x[1])
        if not (lo <= q <= hi and 0.02 * T <= w <= T):
            return math.inf, None
        search, o = search.with_step(c, q, w)
        chi2 = _ls_fit(search, c, y, terms[:k] + [("step", o)] + terms[k + 1:], rows)[0]
        tried[o] = chi2
        return chi2, o

    r = minimize(lambda x: at(x)[0], np.zeros(2), method="Nelder-Mead",
                 options={"initial_simplex": [[0, 0], [0.5, 0], [0, 0.5]], "xatol": 0.01, "fatol": 0.1,
                          "maxfev": 40})
    best = min(tried, key=tried.get, default=None)
    start = _ls_fit(search, c, y, terms, rows)[0]
    if best is None or not tried[best] < start or not np.isfinite(r.fun):
        return search, terms
    return search, terms[:k] + [("step", best)] + terms[k + 1:]


def _fit_period(search, c, y, terms, rows):
    """The ripple of ``terms`` (if any) with its period fitted (``(search, terms)`` as :func:`_fit_shape`), from the
    spectrum's period P0 as P0 (1 + x), x from 0.5 % either side, within +-3 %."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "ripple"), None)
    if k is None:
        return search, terms
    P0 = float(search.periods[terms[k][1]][c])
    if not P0 > 0:
        return search, terms
    return _fit_shape(search, c, y, terms, rows, k, lambda s, x: s.with_ripple(c, P0 * (1.0 + x)), 0.005,
                      (-0.03, 0.03))


def _fit_fade(search, c, y, terms, rows):
    """The fading friction of ``terms`` (if any) with its velocity scale fitted (``(search, terms)`` as
    :func:`_fit_shape`),
    from the grid's v0 as v0 exp(x), x from 0.3 either side, within :data:`FADE_RANGE` of the
    joint's RMS rate and no slower than three times the rate readings' noise."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "fading"), None)
    if k is None:
        return search, terms
    v0 = float(search.fades[terms[k][1]][c])
    lo, hi = (math.log(max(f * search.rate[c], search.v_floor[c]) / v0) for f in FADE_RANGE)
    return _fit_shape(search, c, y, terms, rows, k, lambda s, x: s.with_fade(c, v0 * math.exp(x)), 0.3, (lo, hi))


def _resolved_fade(search, c, y, terms, rows):
    """``terms`` with a fading friction whose velocity scale the recording does not resolve
    (its 95 % interval reaches down to :attr:`Search.v_floor`, the slowest scale the rate
    readings tell from a sharp friction) taken as the sharp pair, the simpler account."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "fading"), None)
    if k is None:
        return terms
    f = fit_terms(search, c, y, terms, rows)
    n_eff = float((search.eng.use[rows, c] > 0).sum()) / samples_per_independent(search.eng.pipe)
    s2 = max(f.chi2 / max(n_eff - len(f.coef), 1.0), 1.0)
    name = search.name(c, "force_cv")
    v = search.shape("fading", c, terms[k][1])[name]
    half = _shape_intervals(search, c, y, terms, f.coef, rows, s2).get(name, math.inf)
    if v - half > search.v_floor[c]:
        return terms
    return terms[:k] + [("coulomb_both", 0)] + terms[k + 1:]


def _fit_shape(search, c, y, terms, rows, k, option_at, h, bounds):
    """Term k of ``terms`` with one shape parameter fitted: Newton steps on the fitted part's
    chi-square (the other terms refitted with it) from the parabola through the three best
    values of x tried (``option_at(search, x)``: ``(search, option)``, the search with the term
    at x as an option; x = 0 is the term's own), starting at 0 and +-h, within ``bounds``; done
    when the step is below a tenth of x's standard error the parabola's curvature gives (a
    chi-square rise of 1), or after four steps.  ``(search, terms)``: the search holding the
    options tried, ``terms`` with the term's option replaced by the best one tried."""
    name = terms[k][0]
    start = _ls_fit(search, c, y, terms, rows)[0]
    tried = {0.0: (start, None)}  # x -> (chi-square, option)
    lo, hi = bounds

    def at(x):
        nonlocal search
        if x not in tried:
            search, o = option_at(search, x)
            tried[x] = (_ls_fit(search, c, y, terms[:k] + [(name, o)] + terms[k + 1:], rows)[0], o)
        return tried[x][0]

    for x in (-h, h):
        if lo <= x <= hi:
            at(x)
    for _ in range(4):
        xs = sorted(tried, key=lambda x: tried[x][0])[:3]
        if len(xs) < 3:
            break
        a2, a1, _ = np.polyfit(xs, [tried[x][0] for x in xs], 2)
        best = xs[0]
        if a2 > 0:
            x = float(np.clip(-a1 / (2 * a2), lo, hi))
            if abs(x - best) < 0.1 / math.sqrt(a2):
                break
        else:  # no minimum between them: on towards the lower side
            x = float(np.clip(best + (2 * h if best >= max(xs) else -2 * h), lo, hi))
        if x in tried:
            break
        at(x)
    best = min(tried, key=lambda x: tried[x][0])
    if tried[best][1] is None or not tried[best][0] < start:
        return search, terms
    return search, terms[:k] + [(name, tried[best][1])] + terms[k + 1:]


def _backward(search, c, y, terms, rows, threshold, n_eff, keep=()):
    """The backward pass of :func:`stepwise` on ``terms`` (least squares, with the terms
    ``keep`` fitted beside them): a term leaves when the others without it lose no more than
    ``threshold`` plus its BIC price."""
    logn = math.log(max(n_eff, 2.0))
    keep = list(keep)
    chi2 = _ls_fit(search, c, y, terms + keep, rows)[0]
    for t in list(terms):
        rest = [u for u in terms if u != t]
        if not rest:
            break
        c2 = _ls_fit(search, c, y, rest + keep, rows)[0]
        if (c2 - chi2) - len(TERMS[t[0]][0]) * logn <= acceptance.cost(search, t, threshold):
            terms, chi2 = rest, c2
    return terms


def _shape_intervals(search, c, y, terms, coef, rows, s2):
    """95 % half widths of the shape parameters a fit moves (a step's position and width, a
    ripple's period, a fading friction's velocity scale), from the fit linearised in them: the
    derivative of the term's force over each shape parameter (central differences of the
    pipeline's columns) as one more column beside the terms' own; the wider of the classical
    (s^2 >= 1) and the HAC interval."""
    out, extra = {}, []
    i = 0
    for t, o in terms:
        n = len(TERMS[t][0])
        a = coef[i:i + n]
        i += n
        shape = search.shape(t, c, o)
        if t == "step":
            keys = ("force_step_q", "force_step_w")
        elif t == "ripple":
            keys = ("force_period",)
        elif t == "fading":
            keys = ("force_cv",)
        elif t == "zone":
            keys = ("force_czone_q", "force_czone_w")
        else:
            continue
        for key in keys:
            name = search.name(c, key)
            v = shape[name]
            h = 1e-3 * (v if key in ("force_period", "force_cv") else search.travel[c])
            force = []
            for sgn in (1, -1):
                sh = dict(shape, **{name: v + sgn * h})
                force.append(sum(a[b] * search.column(c, k2, sc, sh)
                                 for b, (k2, sc) in enumerate(zip(TERMS[t][0], TERMS[t][1]))))
            extra.append((name, (force[0] - force[1]) / (2 * h)))
    if not extra:
        return out
    w = search.w[c] * search.eng.use[rows, c]
    X = np.concatenate([search.cols[u][rows, c, :] for u in terms] + [d[rows, None] for _, d in extra], axis=1)
    X = X * w[:, None]
    e = y[rows] * w + X[:, :len(coef)] @ coef
    cov_c = np.linalg.pinv(X.T @ X) * s2
    cov_h, z95 = hac_covariance(X, e)
    for j, (name, _) in enumerate(extra):
        jj = len(coef) + j
        out[name] = float(max(1.96 * math.sqrt(max(cov_c[jj, jj], 0.0)), z95 * math.sqrt(max(cov_h[jj, jj], 0.0))))
    return out
