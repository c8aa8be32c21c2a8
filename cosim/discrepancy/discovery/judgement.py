"""The discovery's judgement: a library effect on trial against the discovered terms in its
place on the held-out part (:func:`judge_library`, :func:`significant`), and whether a
discovered term restates a library effect (:func:`restates`; :mod:`.discovery`).
"""
from __future__ import annotations

import copy
import hashlib
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np

from . import refit
from .channel import discover_channel
from .search import Search, make_search
from .terms import BLOCK, DiscoveredTerm, Z_ONE_SIDED
from ..families import acceptance, products


def heldout_chi2(search, R, channels):
    """Weighted chi-square of the held-out samples of ``channels`` (in effective samples)."""
    return float(heldout_samples(search, R, channels).sum())


def heldout_samples(search, R, channels):
    """Each held-out sample's weighted chi-square over ``channels`` (held-out samples,)."""
    eng = search.eng
    test = eng.test
    total = np.zeros(int(np.count_nonzero(test)))
    for c in channels:
        r = R[test, c] * search.w[c] * eng.use[test, c]
        total += r * r
    return total


def significant(search, R_a, R_b, channels, bar: float) -> tuple:
    """Does model B fit the held-out part of ``channels`` significantly better than model A?

    ``(better, gain, se)``: the held-out chi-square of A minus B's (``gain``, in effective
    samples) and its standard error ``se`` (the per-sample differences summed over blocks of
    :data:`BLOCK` consecutive held-out samples, the blocks taken as independent: the
    residuals are autocorrelated and, on a real recording, carry structure neither model
    explains, which white-noise chi-square statistics would not count).  B is better when
    ``gain`` exceeds both ``bar`` (the threshold a term pays to enter, look-elsewhere cost
    included) and :data:`Z_ONE_SIDED` ``se`` (B better than A at 95 %, one-sided)."""
    d = heldout_samples(search, R_a, channels) - heldout_samples(search, R_b, channels)
    gain = float(d.sum())
    nb = len(d) // BLOCK
    if nb >= 2:
        sums = d[:nb * BLOCK].reshape(nb, BLOCK).sum(axis=1)
        se = float(np.std(sums, ddof=1) * math.sqrt(nb) * len(d) / (nb * BLOCK))
    else:
        se = float("inf")
    return gain > bar and gain > Z_ONE_SIDED * se, gain, se


def _with_terms(R, search, terms, rows=slice(None)):
    """R with the discovered terms' forces added (their columns times their coefficients)."""
    R = R.copy()
    for t in terms:
        c = t.joint - 1
        i = 0
        for name in t.terms:
            opt = search.option_of(t, name)
            cols = search.cols[(name, opt)]
            for a in range(cols.shape[2]):
                p = list(t.coefficients.values())[i]
                R[:, c] += cols[:, c, a] * (p.value - p.base)
                i += 1
    return R


@dataclass(frozen=True)
class _Court:
    """What the trials hold fixed: the engine, the library's selection, the threshold a term pays
    to enter the search and the bar of a trial (the threshold plus the look-elsewhere cost)."""
    eng: object
    sel: object
    threshold: float
    bar: float


@dataclass(frozen=True)
class _Verdicts:
    """Where the trials stand: the library's parameters and residual that stay, the terms
    discovered on them (channel -> term or None), the records of the withdrawn and the tied
    groups, per channel the library frictions the terms in their place restated, the search as
    the last discovery left it (its noise weights are the held-out comparisons') and the
    searches made (:func:`_discover_all`)."""
    theta: dict
    R_lib: np.ndarray
    base: dict
    search: Search
    withdrawn: tuple = ()
    ties: tuple = ()
    confirmed: Mapping = field(default_factory=lambda: MappingProxyType({}))  # channel -> frozenset of effect keys
    memo: Mapping = field(default_factory=lambda: MappingProxyType({}))  # a channel's search -> (term, noise weight)


def judge_library(eng, sel, threshold: float):
    """The tie rule between the library's named effects and discovered terms.

    Every effort-family group G of the library's selection is put on trial on the channels it
    acts on, discovery allowed on both sides: (A) the library model with G and the terms
    discovered on top of it, against (B) the model without G and the terms discovered in its
    place, compared on the held-out part (:func:`significant`; the bar is the threshold a
    term pays to enter the search, ``threshold + 2 ln M`` for M candidate terms tried).

    * B significantly better (:func:`significant`), or B with fewer free coefficients (the
      rank of the columns) and a held-out gain above the bar: G is withdrawn (the discovered
      terms explain what it explains, and more or more simply) and listed as a look-alike
      that fits worse;
    * B not significantly worse: G is named, because it carries a physics name, but tied with
      the discovered terms (not with confidence), unless they restate it (:func:`restates`:
      Coulomb or viscous friction split by direction with both levels positive is the library's
      friction with an asymmetry);
    * else G is named: it beats the best discovered term.

    Two effects acting on a common channel then go on trial together against the terms in
    their joint place: withdrawn as a single effect would be, or as one force (see the code's
    comments), and tied when those terms fit as well with no more free coefficients (Coulomb and
    viscous friction standing in together for a friction that fades at low speed).

    Terms in G's place that the library names itself (a constant alone: the drive's offset,
    the library's offset effect) are no discovered alternative: the library's own selection
    has weighed G against its look-alikes.

    The steps: each effect alone on trial (:func:`_single_trials`), two effects on a common
    channel together (:func:`_pair_trial`), the asymmetry of the restated frictions searched on
    the model that stays, then the families' pass (:func:`_families_pass`).

    Returns ``(theta, withdrawn, ties, search, base)``: the library's parameters less the
    withdrawn groups', the withdrawn and the tied groups with their held-out figures, the search,
    and the terms discovered per channel on the final library model."""
    theta = dict(sel.theta)
    search = make_search(eng, theta)
    court = _Court(eng, sel, threshold, threshold + 2.0 * math.log(acceptance.n_library(search)))
    R_lib = eng.R(theta)
    # the trials weigh the library's effects against the library's own terms; the families' terms
    # are searched on the model that stays, on top of it (families/acceptance.py)
    v, base = _discover_all(court, _Verdicts(theta, R_lib, {}, replace(search, fam_on=False)), R_lib,
                            range(eng.nd), theta)
    v, acting = _single_trials(court, replace(v, base=base))
    # Two library effects on one channel may be one force the search names: Coulomb friction and
    # an offset are, while the joint moves, friction that differs by direction.  Alone on trial,
    # each lost to nothing (with the offset kept, the pair in Coulomb's place restated Coulomb);
    # they go on trial together against the terms discovered in their joint place.
    for (a1, ch1), (a2, ch2) in _pairs(acting):
        v = _pair_trial(court, v, a1, a2, sorted(set(ch1) | set(ch2)))
    # On the library model that stays, a direction-split friction may now be the asymmetry of a
    # library friction that the terms in its place restated (on trial each level had to be a
    # friction of its own, so that the library effect stood against the discovered terms alone;
    # a friction kept only as a tie may be a stand-in, whose asymmetry would be no physics)
    again = [c for c in v.confirmed if any(search.name(c, lib) in v.theta for lib in v.confirmed[c])]
    v, found = _discover_all(court, v, v.R_lib, again, v.theta, asymmetry=v.confirmed)
    v = _families_pass(court, replace(v, base={**v.base, **found}))
    v = _refitted(court, v)
    return v.theta, list(v.withdrawn), list(v.ties), v.search, v.base


def _discover_all(court, v, R, chans, th, asymmetry=None, family_only=False) -> tuple:
    """``(verdicts, found)``: {channel: the term discovered on it (:func:`.discover_channel`) for
    the residual R of the model with parameters ``th``} over ``chans``, and the verdicts with
    the search it leaves (each channel's noise weight the one of its search) and the searches
    made.

    The trials search the same channel with the same residual and the same parameters of its
    joint again and again (two thirds of the calls on a 6-PUS with six frictions on trial): a
    search is a function of those and of the search's columns, and sets the joint's noise
    weight, which the held-out comparisons read, so both are kept (``v.memo``)."""
    search, memo = v.search, v.memo
    out = {}
    for c in chans:
        asym = tuple((asymmetry or {}).get(c, ()))
        own = search.name(c, "")
        key = (c, hashlib.sha1(np.ascontiguousarray(R[:, c]).tobytes()).hexdigest(),
               tuple(sorted((k, x) for k, x in th.items() if k.startswith(own))), tuple(sorted(asym)),
               search.fam_on, family_only)
        if key not in memo:
            lib = key[:-2] + (False, False)  # the same search without the families, if made
            done = ((lambda m=memo: m[lib][0]) if search.fam_on and lib in memo  # noqa: E731
                    else acceptance.no_term(family_only))
            term, search = discover_channel(search, c, R[:, c], court.threshold, theta=th, asymmetry=asym,
                                            library_result=done)
            memo = MappingProxyType({**memo, key: (term, search.w[c])})
        term, w = memo[key]
        search = search.with_weight(c, w)
        out[c] = copy.deepcopy(term)
    return replace(v, search=search, memo=memo), out


def _trial(search, R_lib, R_minus, on_top, in_place, chans, bar, n_lib, columns):
    """``(better, figures)`` of a trial on ``chans``: the library model (residual ``R_lib``)
    with the terms ``on_top`` against the model without the effects on trial (``R_minus``) with
    the terms ``in_place``; ``better`` as :func:`significant`, the figures as the records hold
    them.  Free coefficients: the library's side ``n_lib`` plus the rank of ``columns`` (the
    effects' residual differences) with the terms on top, the other side the rank of its terms'."""
    R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, in_place)
    A, B = heldout_chi2(search, R_A, chans), heldout_chi2(search, R_B, chans)
    k_A = n_lib + _rank(search, columns, on_top, chans)
    k_B = _rank(search, [], in_place, chans)
    better, gain, se = significant(search, R_A, R_B, chans, bar)
    return better, {"heldout_chi2_library": A, "heldout_chi2_discovered": B, "gain": gain, "se": se, "bar": bar,
                    "coefficients": [k_A, k_B]}


def _withdrawn_record(sel, g, in_place, figures) -> dict:
    """The record of group g withdrawn for the terms ``in_place`` with the trial's figures."""
    return {"group": g.label, "effect": g.effect.name, "title": g.title,
            "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
            "replaced_by": [t.channel for t in in_place], **figures}


def _single_trials(court, v):
    """Each effort-family group of the selection alone on trial, least important first, on the
    channels it acts on (:func:`_single_trial`).  Returns ``(verdicts, acting)``: acting the
    groups on trial with their channels, in trial order."""
    eng = court.eng
    noise = refit.channel_noise(eng, v.R_lib)
    acting = []  # (selected group, the channels it acts on), in the order put on trial
    for a in sorted(court.sel.selected, key=lambda a: a.importance):
        g = a.group
        if g.effect.family not in ("effort", "both"):
            continue
        th_minus = {k: x for k, x in v.theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        chans = refit.acting_channels(eng, v.R_lib, R_minus, noise)
        if not chans:
            continue
        acting.append((a, chans))
        v = _single_trial(court, v, g, th_minus, R_minus, chans)
    return v, acting


def _single_trial(court, v, g, th_minus, R_minus, chans):
    """Group g on trial on ``chans`` against the terms discovered in its place (the model
    ``th_minus``, residual ``R_minus``): the verdicts with g withdrawn, tied, or named."""
    v, found = _discover_all(court, v, R_minus, chans, th_minus)
    in_place = [t for t in found.values() if t is not None]
    if not in_place or all(library_named(t) for t in in_place):
        return v
    on_top = [v.base[c] for c in chans if v.base.get(c) is not None]
    # free coefficients: a direction-split pair on top of the library's symmetric friction
    # adds one (its asymmetry), not two
    better, figures = _trial(v.search, v.R_lib, R_minus, on_top, in_place, chans, court.bar, len(g.params) - 1,
                             [v.R_lib - R_minus])
    bar, gain, se, (k_A, k_B) = court.bar, figures["gain"], figures["se"], figures["coefficients"]
    restated = any(restates(t, g.key) for t in in_place)
    if restated:
        v = replace(v, confirmed=MappingProxyType({**v.confirmed,
                                                   **{c: v.confirmed.get(c, frozenset()) | {g.key} for c in chans}}))
    # fewer free coefficients and a held-out gain above the bar, or a gain beyond its
    # uncertainty as well
    if (better or (k_B < k_A and gain > bar)) and not restated:
        v = replace(v, theta=th_minus, R_lib=R_minus,
                    withdrawn=v.withdrawn + (_withdrawn_record(court.sel, g, in_place, figures),))
        v, found = _discover_all(court, v, R_minus, chans, th_minus)
        return replace(v, base={**v.base, **found})
    if not restated and -gain <= max(bar, Z_ONE_SIDED * se):
        # not told apart on the held-out part: the library effect is named, not with confidence
        return replace(v, ties=_tied(v.ties, (g,), in_place, k_B - k_A, figures,
                                     [court.eng.pipe.channels[c] for c in chans]))
    return v


def _pair_trial(court, v, a1, a2, chans):
    """Two selected effects acting on the common channels ``chans`` on trial together against
    the terms discovered in their joint place: the verdicts with both withdrawn, tied, or as
    they were."""
    eng, bar = court.eng, court.bar
    g1, g2 = a1.group, a2.group
    if not all(p in v.theta for p in (*g1.params, *g2.params)):
        return v  # one of them was withdrawn already
    th_minus = {k: x for k, x in v.theta.items() if k not in g1.params and k not in g2.params}
    R_minus = eng.R(th_minus)
    v, found = _discover_all(court, v, R_minus, chans, th_minus)
    in_place = [t for t in found.values() if t is not None]
    if not in_place or any(library_named(t) for t in in_place):
        return v
    # both frictions restated (split by direction, every level positive): they are named,
    # their asymmetry searched on top, as alone on trial
    if all(any(restates(t, g.key) for t in in_place) for g in (g1, g2)):
        return v
    # one of them restated alone (equal levels): the terms in place of both need only it,
    # and the other one stands on trial against them
    alone = [g for g in (g1, g2) if any(restates(t, g.key, distinct=True) for t in in_place)]
    # the library's side as it would stay: with the asymmetry of the frictions the terms
    # in their place restated (searched on top of them)
    v, found = _discover_all(court, v, v.R_lib, chans, v.theta, asymmetry=v.confirmed)
    on_top = [t for t in found.values() if t is not None]
    columns = [v.R_lib - eng.R({k: x for k, x in v.theta.items() if k not in g.params}) for g in (g1, g2)]
    better, figures = _trial(v.search, v.R_lib, R_minus, on_top, in_place, chans, bar,
                             len(g1.params) + len(g2.params) - 2, columns)
    gain, se, (k_A, k_B) = figures["gain"], figures["se"], figures["coefficients"]
    as_well = -gain <= max(bar, Z_ONE_SIDED * se)
    tied = replace(v, ties=_tied(v.ties, (g1, g2), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans]))
    if alone:
        # the other effect may be a stand-in the discovered terms do without: when they fit
        # as well with no more free coefficients, it is tied (not named with confidence), and
        # so is the restated one, whose level was fitted with the stand-in's share
        return tied if k_B <= k_A and as_well else v
    # the pair is withdrawn by the rule of a single effect's trial (the terms in place of
    # both significantly better, or fewer free coefficients and a held-out gain above the
    # bar: a saturation and viscous friction that stand in for quadratic drag), or, for two
    # effects whose sum is, while the joint moves, a term of the search (:data:`ONE_FORCE`)
    # or that are one column on this recording (the inference's ``collinear`` look-alikes),
    # with no more free coefficients and a held-out fit not worse beyond the bar or its
    # uncertainty: the simpler account is the one force (the two effects are listed as
    # look-alikes that fit as well, not named)
    one = {g1.key, g2.key} in ONE_FORCE or any(c.get("collinear") and c["group"] == g2.label
                                               for c in a1.lookalikes)
    if better or (k_B < k_A and gain > bar) or (one and k_B <= k_A and as_well):
        figures = dict(figures, together=[g1.title, g2.title], as_well=not better)
        v = replace(v, theta=th_minus, R_lib=R_minus,
                    withdrawn=v.withdrawn + tuple(_withdrawn_record(court.sel, g, in_place, figures) for g in (g1, g2)),
                    ties=tuple(t for t in v.ties if t["group"] not in (g1.label, g2.label)))
        v, found = _discover_all(court, v, R_minus, chans, th_minus)
        return replace(v, base={**v.base, **found})
    # one force in place of both fits as well with no more free coefficients (Coulomb and
    # viscous friction for a friction that fades at low speed): neither is named with
    # confidence, the two may stand in for it together
    return tied if k_B <= k_A and as_well else v


def _families_pass(court, v):
    """With the families in the search: their terms searched on every channel of the model that
    stays, and the library's effects of one joint on trial again (:func:`_trial_again`)."""
    v = replace(v, search=replace(v.search, fam_on=True))
    if acceptance.split(v.search.candidates())[1]:
        v, base = _discover_all(court, v, v.R_lib, range(court.eng.nd), v.theta, asymmetry=v.confirmed)
        v = replace(v, base=base)
        for a in court.sel.selected:
            v = _trial_again(court, v, a.group)
    return v


def _trial_again(court, v, g):
    """Group g, an effect of one joint that stays, on trial once more with the families searched
    on both sides where the terms in its place hold a family term that may withdraw it
    (:data:`.families.acceptance.WITHDRAWING`): withdrawn by the tie rule's test (significantly
    better on the held-out part, or fewer free coefficients and a gain above the bar), ``base``
    (channel -> term) then taking the terms in its place."""
    c = g.joint
    if g.effect.family not in ("effort", "both") or c is None or not all(p in v.theta for p in g.params):
        return v
    th_minus = {k: x for k, x in v.theta.items() if k not in g.params}
    R_minus = court.eng.R(th_minus)
    v, found = _discover_all(court, v, R_minus, [c], th_minus, asymmetry=v.confirmed, family_only=True)
    in_place = found.get(c)
    if in_place is None or not acceptance.withdrawing(in_place):
        return v
    on_top = [v.base[c]] if v.base.get(c) is not None else []
    better, figures = _trial(v.search, v.R_lib, R_minus, on_top, [in_place], [c], court.bar, len(g.params) - 1,
                             [v.R_lib - R_minus])
    gain, (k_A, k_B) = figures["gain"], figures["coefficients"]
    if not (better or (k_B < k_A and gain > court.bar)):
        return v
    return replace(v, theta=th_minus, R_lib=R_minus, base={**v.base, c: in_place},
                   withdrawn=v.withdrawn + (_withdrawn_record(court.sel, g, [in_place], figures),))


def _refitted(court, v):
    """Each library effect that stays, refitted beside the families' terms and judged again by
    the library's entry criterion (:func:`.refit.rejudge`): withdrawn where the terms hold its
    share and, searched again without it, fit the held-out part as well; tied where it is the
    same force as the terms' centres moved, or where only the held-out part needs it."""
    if not any(refit.holds_family(t) for t in v.base.values()):
        return v
    eng, bar = court.eng, court.bar
    for a in sorted(court.sel.selected, key=lambda a: a.importance):
        g = a.group
        if g.effect.family not in ("effort", "both") or not all(p in v.theta for p in g.params):
            continue
        th_minus = {k: x for k, x in v.theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        verdict = refit.rejudge(v.search, v.theta, v.R_lib, R_minus, g, v.base, court.threshold)
        if verdict is None or verdict.kind == "keep":
            continue
        chans = list(verdict.channels)
        old = [v.base[c] for c in chans if v.base.get(c) is not None]
        needed, gain, se = significant(v.search, verdict.R_without, verdict.R_with, chans, bar)
        figures = {"heldout_chi2_library": heldout_chi2(v.search, verdict.R_with, chans),
                   "heldout_chi2_discovered": heldout_chi2(v.search, verdict.R_without, chans),
                   "gain": -gain, "se": se, "bar": bar, "coefficients": [verdict.k_with, verdict.k_without],
                   "refit": {"gain": verdict.gain, "bar": verdict.bar, "centres": verdict.centres}}
        if verdict.kind == "withdraw" and not needed:
            v2, found = _discover_all(court, v, R_minus, chans, th_minus, asymmetry=v.confirmed)
            new = [t for t in found.values() if t is not None]
            worse = significant(v.search, _with_terms(R_minus, v2.search, new), _with_terms(v.R_lib, v.search, old),
                                chans, bar)[0]
            if new and not worse:
                v = replace(v2, theta=th_minus, R_lib=R_minus, base={**v.base, **found},
                            withdrawn=v2.withdrawn + (_withdrawn_record(court.sel, g, new, figures),),
                            ties=tuple(t for t in v2.ties if t["group"] != g.label))
                continue
        in_place = [refit.centred(t, verdict.centres, eng.model.facts.joint_unit) for t in old]
        v = replace(v, ties=_tied(v.ties, (g,), in_place, verdict.k_without - verdict.k_with, figures,
                                  [eng.pipe.channels[c] for c in chans]))
    return v


def _tied(ties, groups, in_place, extra, figures, channels) -> tuple:
    """``ties`` with each of ``groups`` tied with the terms ``in_place`` (once): named, not with
    confidence; the record says on which ``channels`` and with which parameters (a discovered
    term fitted beside it there is no physics of its own either,
    diagnosis.answer._beside_tie_sentence)."""
    out = tuple(ties)
    for g in groups:
        if not any(t["group"] == g.label for t in out):
            out += ({"group": g.label, "title": g.title, "params": list(g.params), "channels": list(channels),
                     "terms": [t.equation for t in in_place], "extra_params": extra, **figures},)
    return out


def _pairs(acting):
    """Pairs of library effects on trial that act on a common channel, in trial order."""
    return [(x, y) for i, x in enumerate(acting) for y in acting[i + 1:] if set(x[1]) & set(y[1])]


def _rank(search, extra, terms, chans) -> int:
    """Number of independent columns among ``extra`` (residual differences, (samples, channels))
    and the columns of ``terms``, over the samples of ``chans`` stacked."""
    cols = [np.concatenate([e[:, c] for c in chans]) for e in extra]
    n = search.eng.test.shape[0]
    for t in terms:
        c = t.joint - 1
        if c not in chans:
            continue
        for name in t.terms:
            block = search.cols[(name, search.option_of(t, name))][:, c, :]
            for a in range(block.shape[1]):
                v = np.zeros(n * len(chans))
                k = chans.index(c)
                v[k * n:(k + 1) * n] = block[:, a]
                cols.append(v)
    if not cols:
        return 0
    M = np.array(cols).T
    M = M / np.maximum(np.linalg.norm(M, axis=0), 1e-300)
    sv = np.linalg.svd(M, compute_uv=False)
    return int(np.sum(sv > 1e-6 * sv[0]))


def library_named(term: DiscoveredTerm) -> bool:
    """The term is one the effect library names itself: a constant alone (the drive's offset)."""
    return list(term.terms) == ["constant"]




#: pairs of library effects that are, while the joint moves, one term of the search: Coulomb
#: friction (or one fading at low speed) and a constant offset are friction that differs by
#: direction (the levels' mean and half their difference); so is a dead zone in the offset's
#: place, a constant force where the joint's command keeps one sign.  For the same reason a dead
#: zone and an offset are one force there: a constant outside the zone and whatever the few
#: samples inside it (the efforts nearest zero) hold; alone on trial each is taken over by the other
ONE_FORCE = (tuple({f, c} for f in ("coulomb", "smooth_coulomb") for c in ("offset", "dead_zone"))
             + ({"offset", "dead_zone"},))

#: the coefficient keys of the direction-split pair of a library friction (a friction that fades
#: below a velocity scale: the Coulomb pair through tanh(qd / force_cv), the term "fading")
_PAIR_KEYS = {"coulomb": ("force_cpos", "force_cneg"), "viscous": ("force_vpos", "force_vneg"),
              "smooth_coulomb": ("force_cpos", "force_cneg")}


def restates(term: DiscoveredTerm, key: str, distinct: bool = False) -> bool:
    """The discovered term holds the library effect ``key``: an added inertia positive beyond its
    interval holds the rotor inertia (the same column); Coulomb (viscous) friction split
    by direction with both levels positive beyond their intervals, i.e. the library's friction
    (the levels' mean) and an asymmetry (their difference; none when they are equal within
    their intervals).  A level for one direction only (a one-way damper) is no such friction.
    ``distinct``: the term restates the effect alone, with nothing besides: the two levels
    equal within their intervals (then the pair is the library's friction, not friction that
    differs by direction).  Coulomb levels that fade below a velocity scale (the term "fading")
    restate the library's friction that fades (``smooth_coulomb``), not its sharp Coulomb friction,
    and a sharp pair not the fading one."""
    if key == "rotor_inertia":
        # an added inertia on the joint is the rotor's physics (one column): a positive one restates it
        inertia = [c for name, c in term.coefficients.items() if name.endswith(".force_inertia")]
        return (bool(inertia) and inertia[0].value > inertia[0].ci95
                and (not distinct or list(term.terms) == ["inertia"]))
    if key not in _PAIR_KEYS:
        return False
    if key in ("coulomb", "smooth_coulomb") and ("fading" in term.terms) != (key == "smooth_coulomb"):
        return False  # a sharp pair is no friction that fades, nor a fading one a sharp friction
    pos = neg = None
    for name, c in term.coefficients.items():
        k = name.rsplit(".", 1)[1]
        if k == _PAIR_KEYS[key][0]:
            pos = c
        elif k == _PAIR_KEYS[key][1]:
            neg = c
    both = pos is not None and neg is not None and pos.value > pos.ci95 and neg.value > neg.ci95
    if distinct:
        return both and abs(pos.value - neg.value) <= math.hypot(pos.ci95, neg.ci95)
    return both
