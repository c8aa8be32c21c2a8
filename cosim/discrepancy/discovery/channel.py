"""The discovery step on one effort channel (:func:`discover_channel`): the selection with the
channel's noise weight, the held-out check, the shapes fitted, the bootstrap's stability, the
final fit and its intervals; the fitting itself is :mod:`.fit` (:mod:`.discovery`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .fit import (_backward, _design, _fit_fade, _fit_period, _fit_step, _ls_fit, _resolved_fade, _shape_intervals,
                  bootstrap, fit_terms, offset_refit, stepwise)
from .terms import ADDS_TO, SAME_COLUMN, STABILITY, TERMS, _term
from ..families import acceptance, products
from ..structure import own_noise, samples_per_independent


@dataclass(frozen=True)
class _Channel:
    """What the search of one effort channel holds fixed (:func:`_channel`)."""
    c: int                # the channel (joint c)
    y: np.ndarray         # its residual (samples,)
    threshold: float      # the library's threshold: the held-out checks' bar
    thr: float            # the threshold plus the look-elsewhere cost: the selection's
    phi: float            # samples per independent one
    n_eff: float          # effective samples of the fitted part
    held: dict            # the model's parameters
    fixed: frozenset      # coefficient keys the model fits on this joint: not searched
    floor: dict           # the least value of each signed coefficient
    seed: int


def _channel(search, c, y, threshold, seed, theta, asymmetry) -> _Channel:
    """The settings of channel c's search (see :func:`discover_channel`)."""
    eng = search.eng
    # The yardstick is the residual's own high-frequency noise (as the structure test's):
    # the engine's noise model is inflated by the very force searched for.
    phi = samples_per_independent(eng.pipe)
    n_eff = float((eng.use[eng.train, c] > 0).sum()) / phi
    lee = 2.0 * math.log(acceptance.n_library(search))  # a family term pays more (search.fam_extra)
    held = search.theta if theta is None else theta
    fixed = frozenset(k for t in TERMS.values() for k in t[0]
                      if search.name(c, k) in held or search.name(c, SAME_COLUMN.get(k, k)) in held)
    floor = {k: -float(held.get(search.name(c, lib), 0.0)) if lib in asymmetry else 0.0 for k, lib in ADDS_TO.items()}
    # an added inertia may lower the rotor's the model holds, never below zero
    rotor = search.name(c, "rotor_inertia")
    floor["force_inertia"] = -float(held.get(rotor, eng.model.param(rotor)))
    return _Channel(c, y, threshold, threshold + lee, phi, n_eff, held, fixed, floor, seed)


def _heldout(search, ch, terms):
    """(the fit of ``terms`` on the fitted part, the channel's held-out chi-square without
    them minus with them, coefficients held)."""
    eng, c, y = search.eng, ch.c, ch.y
    f = fit_terms(search, c, y, terms, eng.train)
    if not terms:
        return f, 0.0
    Xt, _, wt = _design(search, c, terms, eng.test)
    tt = y[eng.test] * wt
    return f, float(tt @ tt) - float(np.sum((tt + Xt @ f.coef) ** 2))


def _stepwise(search, ch, library_only=False):
    """:func:`stepwise` on the channel's fitted part with its settings."""
    return stepwise(search, ch.c, ch.y, search.eng.train, ch.thr, ch.phi, ch.n_eff, ch.fixed, ch.floor, ch.held,
                    library_only=library_only)


def _bootstrap(search, ch, terms, refit):
    """:func:`bootstrap` on the channel's fitted part with its settings."""
    return bootstrap(search, ch.c, ch.y, search.eng.train, terms, ch.thr, ch.phi, ch.n_eff, seed=ch.seed,
                     fixed=ch.fixed, floor=ch.floor, refit=refit, held=ch.held)


def _selected(search, ch, library_result=None) -> tuple:
    """``(search, terms)``: the terms selected on the channel, and the search with the channel's
    noise weight (``search.w``) from the residual's own noise, measured again on the residual of
    the terms found."""
    eng, c, y = search.eng, ch.c, ch.y
    train = eng.train
    r, terms = y, []
    search = search.with_weight(c, 0.0)
    for _ in range(3):
        # the force searched for also shows in the differences one window apart when it varies
        # fast (a spring on a quick arm): the noise is measured again on the residual of the
        # terms found, and the search repeated with it
        sigma = own_noise(eng.pipe, r[train], eng.accuracy()[c])
        if search.w[c] > 0 and abs(math.log(search.w[c] * sigma * math.sqrt(ch.phi))) < math.log(1.25):
            break
        search = search.with_weight(c, 1.0 / (sigma * math.sqrt(ch.phi)))
        terms = _stepwise(search, ch)
        if any(acceptance.is_family(t) for t in terms):  # or the library-only selection (held out)
            terms = acceptance.or_library(terms, lambda: _stepwise(search, ch, library_only=True),
                                          lambda ts: _heldout(search, ch, ts), ch.threshold, search,
                                          library_result, lambda ts: offset_refit(search, ch.c, ch.held, ts))
        if not terms:
            break
        f0 = fit_terms(search, c, y, terms, np.ones_like(train))
        r = y + np.concatenate([search.cols[t][:, c, :] for t in terms], axis=1) @ f0.coef
    return search, terms


def _shapes_fitted(search, ch, terms) -> tuple:
    """``(search, terms)``: ``terms`` with the shapes of a step, a ripple, a fading friction and
    a zone fitted (the search holding the shapes tried), and the terms that stood in for the
    step's misplaced edge gone again (the backward pass of the selection, on the fitted step)."""
    c, y, train = ch.c, ch.y, search.eng.train
    search, fitted = _fit_step(search, c, y, terms, train)
    search, fitted = _fit_period(search, c, y, fitted, train)
    search, fitted = _fit_fade(search, c, y, fitted, train)
    fitted = _resolved_fade(search, c, y, fitted, train)
    search, fitted = products.fit_zone(search, c, y, fitted, train, lambda s, ts: _ls_fit(s, c, y, ts, train)[0],
                                       lambda s, ts: _heldout(s, ch, ts)[1])
    if fitted != terms:
        terms = _backward(search, c, y, fitted, train, ch.thr, ch.n_eff)
    return search, terms


def _stable(search, ch, terms):
    """``(terms, stability, spread, refitted)``: the terms that come back in the bootstrap's
    resamples or that the held-out part needs, those that stood in for the offset's part gone,
    their stability and their coefficients' bootstrap spread (with the library's offset
    ``refitted`` beside them, :func:`offset_refit`); None when no term stays."""
    c, y, train = ch.c, ch.y, search.eng.train
    # The library's offset on this joint is refitted with the terms: fitted before them, it
    # took the part of their force the recording's mean leaves (a spring's force at the mean
    # position: its rest position would be missed).  Not beside Coulomb friction split by
    # direction: while the joint moves the two levels span the constant already.
    stab, spread = _bootstrap(search, ch, terms, offset_refit(search, c, ch.held, terms))
    # An unstable term goes unless the held-out part needs it: near-equivalent candidates (a
    # constant and a step at the end of the stroke) split the resamples' votes between them.
    full = _heldout(search, ch, terms)[1]
    kept = [t for t in terms
            if stab[t] >= STABILITY or full - _heldout(search, ch, [u for u in terms if u != t])[1] > ch.threshold]
    if not kept:
        return None
    if kept != terms:
        terms = kept
        _, spread = _bootstrap(search, ch, terms, offset_refit(search, c, ch.held, terms))
    extra = offset_refit(search, c, ch.held, terms)
    if extra:
        # terms that stood in for the offset's part (a step at the end of the stroke) leave
        pruned = _backward(search, c, y, terms, train, ch.thr, ch.n_eff, keep=extra)
        if pruned != terms:
            terms = pruned
            _, spread = _bootstrap(search, ch, terms, extra)
    return terms, stab, spread, extra


def _term_fitted(search, ch, terms, stab, spread, extra):
    """The :class:`DiscoveredTerm` of ``terms`` with the library's offset terms ``extra``
    refitted beside them, with intervals, or None when the held-out part does not need them, an
    added inertia leaves the joint's below zero or its effort terms make the drive self-lock."""
    eng, c, y, train, test = search.eng, ch.c, ch.y, search.eng.train, search.eng.test
    terms = terms + extra
    f, d_held = _heldout(search, ch, terms)
    # an effort term's column bends with its coefficient (the core solves for the applied effort)
    coef = products.refine_effort(search, c, terms, f.coef, ch.held, train,
                                  lambda t: list(zip(TERMS[t][0], TERMS[t][1])))
    if coef is None:  # coefficients no plant holds (the drive would self-lock)
        return None
    f = replace(f, coef=coef)
    if not d_held > ch.threshold:
        return None
    # the fit with instruments may leave the selection's least squares: a joint inertia below
    # zero is no body (and no plant of the core)
    keys = [k for t, _ in terms for k in TERMS[t][0]]
    if any(k == "force_inertia" and v < ch.floor[k] for k, v in zip(keys, f.coef)):
        return None
    # the widest of: the HAC interval, the classical one of the residual's own noise in effective
    # samples (s^2 >= 1: never narrower than that noise allows), and the bootstrap's spread of
    # the coefficients (which also sees the selection of the terms)
    s2 = max(f.chi2 / max(ch.n_eff - len(f.coef), 1.0), 1.0)
    half = np.maximum(np.maximum(f.z95 * np.sqrt(np.maximum(np.diag(f.cov), 0.0)),
                                 1.96 * np.sqrt(np.maximum(np.diag(f.cov_classical), 0.0) * s2)), 1.96 * spread)
    use_t = eng.use[test, c] > 0
    rms = lambda a: float(np.sqrt(np.mean(a[use_t] ** 2))) if use_t.any() else float("nan")  # noqa: E731
    yt = y[test]
    Xraw = np.concatenate([search.cols[t][test, c, :] for t in terms], axis=1)
    base = {search.name(c, "offset"): float(ch.held[search.name(c, "offset")])} if extra else {}
    return _term(search, c, terms, f.coef, half, stab, rms(yt), rms(yt + Xraw @ f.coef), d_held, base=base,
                 shape_ci95=_shape_intervals(search, c, y, terms, f.coef, train, s2))


def discover_channel(search, c, y, threshold, seed=0, theta=None, asymmetry=(), library_result=None):
    """``(term, search)``: the discovered term on effort channel c (joint c) for the residual y
    (samples,) of the model with parameters ``theta`` (default the search's), or None, and the
    search with the channel's noise weight and the shapes the fit tried (:class:`.Search` is a
    value: the one given is unchanged).  A coefficient ``theta``
    holds on this joint (the library's offset) is not searched: it is fitted already.  For the
    library frictions in ``asymmetry`` ("viscous", "coulomb") a direction-split friction may be
    the asymmetry of the library's symmetric one on this joint (:data:`ADDS_TO`: the total, not
    the coefficient, must not be negative); otherwise each split level is a friction of its
    own.  ``library_result``: a function giving this search's result without the families' terms
    (made already), returned when the selection holds none of them.

    The steps: the selection (:func:`_selected`), the held-out check, the shapes fitted
    (:func:`_shapes_fitted`), the bootstrap's stability (:func:`_stable`), the final fit and its
    intervals (:func:`_term_fitted`)."""
    ch = _channel(search, c, y, threshold, seed, theta, asymmetry)
    search, terms = _selected(search, ch, library_result)
    if library_result is not None and not any(acceptance.is_family(t) for t in terms):
        return library_result(), search  # the same selection as without the families: its result
    # the cheap held-out check first, then the bootstrap's stability
    if not terms or not _heldout(search, ch, terms)[1] > threshold:
        return None, search
    search, terms = _shapes_fitted(search, ch, terms)
    stable = _stable(search, ch, terms)
    if stable is None:
        return None, search
    return _term_fitted(search, ch, *stable), search
