"""The discovery's judgement: a library effect on trial against the discovered terms in its
place on the held-out part (:func:`judge_library`, :func:`significant`), and whether a
discovered term restates a library effect (:func:`restates`; :mod:`.discovery`).
"""
from __future__ import annotations

import copy
import hashlib
import math

import numpy as np

from .fit import discover_channel
from .search import Search
from .terms import BLOCK, DiscoveredTerm, Z_ONE_SIDED
from ..families import acceptance, products
from ..structure import own_noise


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
            opt = _option(search, t, name)
            cols = search.cols[(name, opt)]
            for a in range(cols.shape[2]):
                p = list(t.coefficients.values())[i]
                R[:, c] += cols[:, c, a] * (p.value - p.base)
                i += 1
    return R


def _option(search, t, name):
    if name in products.TERMS:
        return products.option_of(search, t, name)
    if name == "ripple":
        P = t.shape[search.name(t.joint - 1, "force_period")]
        return next((o for o, ps in search.periods.items() if ps[t.joint - 1] == P), 0)
    if name == "fading":
        v = t.shape[search.name(t.joint - 1, "force_cv")]
        return next((o for o, vs in enumerate(search.fades) if vs[t.joint - 1] == v), 0)
    if name != "step":
        return 0
    q = t.shape[search.name(t.joint - 1, "force_step_q")]
    for o, (qs, _) in enumerate(search.steps):
        if qs[t.joint - 1] == q:
            return o
    return 0


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

    Returns ``(theta, withdrawn, ties, search, base)``: the library's parameters less the
    withdrawn groups', the withdrawn and the tied groups with their held-out figures, the search,
    and the terms discovered per channel on the final library model."""
    theta = dict(sel.theta)
    search = Search(eng, theta)
    bar = threshold + 2.0 * math.log(acceptance.n_library(search))
    withdrawn, ties = [], []
    acting = []  # (selected group, the channels it acts on), in the order put on trial
    confirmed = {}  # channel -> library frictions that the terms in their place restated

    # The trials search the same channel with the same residual and the same parameters of its
    # joint again and again (two thirds of the calls on a 6-PUS with six frictions on trial): a
    # search is a function of those, of the search's columns and of the joint's noise weight,
    # which it sets and which the held-out comparisons read, so both are kept
    memo = {}

    def discover_all(R, chans, th, asymmetry=None, family_only=False):
        out = {}
        for c in chans:
            asym = tuple((asymmetry or {}).get(c, ()))
            own = search.name(c, "")
            key = (c, hashlib.sha1(np.ascontiguousarray(R[:, c]).tobytes()).hexdigest(),
                   tuple(sorted((k, v) for k, v in th.items() if k.startswith(own))), tuple(sorted(asym)),
                   search.fam_on, family_only)
            if key not in memo:
                lib = key[:-2] + (False, False)  # the same search without the families, if made
                done = (lambda: memo[lib][0]) if search.fam_on and lib in memo else acceptance.no_term(family_only)
                memo[key] = (discover_channel(search, c, R[:, c], threshold, theta=th, asymmetry=asym,
                                              library_result=done), search.w[c])
            term, search.w[c] = memo[key]
            out[c] = copy.deepcopy(term)
        return out

    R_lib = eng.R(theta)
    # the trials weigh the library's effects against the library's own terms; the families' terms
    # are searched on the model that stays, on top of it (families/acceptance.py)
    search.fam_on = False
    base = discover_all(R_lib, range(eng.nd), theta)
    # the yardstick of "acts on a channel": the residual's own noise (the engine's noise model
    # is inflated by a missing force and would hide a small stand-in such as a gravity tilt)
    noise = np.array([own_noise(eng.pipe, R_lib[eng.train, c], eng.accuracy()[c]) for c in range(eng.nd)])
    for a in sorted(sel.selected, key=lambda a: a.importance):
        g = a.group
        if g.effect.family not in ("effort", "both"):
            continue
        th_minus = {k: v for k, v in theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        chans = [c for c in range(eng.nd)
                 if np.sqrt(np.mean((R_lib[:, c] - R_minus[:, c]) ** 2)) > 0.3 * noise[c]]
        if not chans:
            continue
        acting.append((a, chans))
        in_place = [t for t in discover_all(R_minus, chans, th_minus).values() if t is not None]
        if not in_place or all(library_named(t) for t in in_place):
            continue
        on_top = [base[c] for c in chans if base.get(c) is not None]
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, in_place)
        A, B = heldout_chi2(search, R_A, chans), heldout_chi2(search, R_B, chans)
        # free coefficients: a direction-split pair on top of the library's symmetric friction
        # adds one (its asymmetry), not two
        k_A = len(g.params) - 1 + _rank(search, [R_lib - R_minus], on_top, chans)
        k_B = _rank(search, [], in_place, chans)
        better, gain, se = significant(search, R_A, R_B, chans, bar)
        restated = any(restates(t, g.key) for t in in_place)
        if restated:
            for c in chans:
                confirmed.setdefault(c, set()).add(g.key)
        figures = {"heldout_chi2_library": A, "heldout_chi2_discovered": B, "gain": gain, "se": se, "bar": bar,
                   "coefficients": [k_A, k_B]}
        # fewer free coefficients and a held-out gain above the bar, or a gain beyond its
        # uncertainty as well
        if (better or (k_B < k_A and gain > bar)) and not restated:
            theta = th_minus
            withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                              "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                              "replaced_by": [t.channel for t in in_place], **figures})
            R_lib = R_minus
            base.update(discover_all(R_lib, chans, theta))
        elif not restated and -gain <= max(bar, Z_ONE_SIDED * se):
            # not told apart on the held-out part: the library effect is named, not with confidence
            _tie(ties, (g,), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
    # Two library effects on one channel may be one force the search names: Coulomb friction and
    # an offset are, while the joint moves, friction that differs by direction.  Alone on trial,
    # each lost to nothing (with the offset kept, the pair in Coulomb's place restated Coulomb);
    # they go on trial together against the terms discovered in their joint place.
    for (a1, ch1), (a2, ch2) in _pairs(acting):
        g1, g2 = a1.group, a2.group
        if not all(p in theta for p in (*g1.params, *g2.params)):
            continue  # one of them was withdrawn already
        th_minus = {k: v for k, v in theta.items() if k not in g1.params and k not in g2.params}
        chans = sorted(set(ch1) | set(ch2))
        R_minus = eng.R(th_minus)
        in_place = [t for t in discover_all(R_minus, chans, th_minus).values() if t is not None]
        if not in_place or any(library_named(t) for t in in_place):
            continue
        # both frictions restated (split by direction, every level positive): they are named,
        # their asymmetry searched on top, as alone on trial
        if all(any(restates(t, g.key) for t in in_place) for g in (g1, g2)):
            continue
        # one of them restated alone (equal levels): the terms in place of both need only it,
        # and the other one stands on trial against them
        alone = [g for g in (g1, g2) if any(restates(t, g.key, distinct=True) for t in in_place)]
        other = [g for g in (g1, g2) if g not in alone]
        # the library's side as it would stay: with the asymmetry of the frictions the terms
        # in their place restated (searched on top of them)
        on_top = [t for t in discover_all(R_lib, chans, theta, asymmetry=confirmed).values() if t is not None]
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, in_place)
        A, B = heldout_chi2(search, R_A, chans), heldout_chi2(search, R_B, chans)
        k_A = (len(g1.params) + len(g2.params) - 2
               + _rank(search, [R_lib - eng.R({k: v for k, v in theta.items() if k not in g.params})
                                for g in (g1, g2)], on_top, chans))
        k_B = _rank(search, [], in_place, chans)
        better, gain, se = significant(search, R_A, R_B, chans, bar)
        figures = {"heldout_chi2_library": A, "heldout_chi2_discovered": B, "gain": gain, "se": se,
                   "bar": bar, "coefficients": [k_A, k_B]}
        as_well = -gain <= max(bar, Z_ONE_SIDED * se)
        if alone:
            # the other effect may be a stand-in the discovered terms do without: when they fit
            # as well with no more free coefficients, it is tied (not named with confidence), and
            # so is the restated one, whose level was fitted with the stand-in's share
            if k_B <= k_A and as_well:
                _tie(ties, (g1, g2), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
            continue
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
            figures.update(together=[g1.title, g2.title], as_well=not better)
            for g in (g1, g2):
                withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                                  "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                                  "replaced_by": [t.channel for t in in_place], **figures})
            ties[:] = [t for t in ties if t["group"] not in (g1.label, g2.label)]
            theta, R_lib = th_minus, R_minus
            base.update(discover_all(R_lib, chans, theta))
        elif k_B <= k_A and as_well:
            # one force in place of both fits as well with no more free coefficients (Coulomb and
            # viscous friction for a friction that fades at low speed): neither is named with
            # confidence, the two may stand in for it together
            _tie(ties, (g1, g2), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
    # On the library model that stays, a direction-split friction may now be the asymmetry of a
    # library friction that the terms in its place restated (on trial each level had to be a
    # friction of its own, so that the library effect stood against the discovered terms alone;
    # a friction kept only as a tie may be a stand-in, whose asymmetry would be no physics)
    again = [c for c in confirmed if any(search.name(c, lib) in theta for lib in confirmed[c])]
    base.update(discover_all(R_lib, again, theta, asymmetry=confirmed))
    theta, base = _families_pass(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all, confirmed)
    return theta, withdrawn, ties, search, base


def _families_pass(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all, confirmed):
    """With the families in the search: their terms searched on every channel of the model that
    stays, and the library's effects of one joint on trial again (:func:`_trials_again`).
    Returns ``(theta, base)``."""
    search.fam_on = True
    if acceptance.split(search.candidates())[1]:
        base = discover_all(R_lib, range(eng.nd), theta, asymmetry=confirmed)
        theta, R_lib = _trials_again(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all, confirmed)
    return theta, base


def _trials_again(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all, confirmed):
    """The library's effects of one joint that stay, on trial once more with the families searched
    on both sides where the terms in their place hold a family term that may withdraw one
    (:data:`.families.acceptance.WITHDRAWING`): an effect whose place such terms take is
    withdrawn by the tie rule's test (significantly better on the held-out part, or fewer free
    coefficients and a gain above the bar), and ``base`` (channel -> term) takes the terms in its
    place.  Returns ``(theta, R_lib)``."""
    for a in sel.selected:
        g = a.group
        c = g.joint
        if g.effect.family not in ("effort", "both") or c is None or not all(p in theta for p in g.params):
            continue
        th_minus = {k: v for k, v in theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        in_place = discover_all(R_minus, [c], th_minus, asymmetry=confirmed, family_only=True).get(c)
        if in_place is None or not acceptance.withdrawing(in_place):
            continue
        on_top = [base[c]] if base.get(c) is not None else []
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, [in_place])
        k_A = len(g.params) - 1 + _rank(search, [R_lib - R_minus], on_top, [c])
        k_B = _rank(search, [], [in_place], [c])
        better, gain, se = significant(search, R_A, R_B, [c], bar)
        if better or (k_B < k_A and gain > bar):
            withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                              "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                              "replaced_by": [in_place.channel], "heldout_chi2_library": heldout_chi2(search, R_A, [c]),
                              "heldout_chi2_discovered": heldout_chi2(search, R_B, [c]), "gain": gain, "se": se,
                              "bar": bar, "coefficients": [k_A, k_B]})
            theta, R_lib, base[c] = th_minus, R_minus, in_place
    return theta, R_lib


def _tie(ties, groups, in_place, extra, figures, channels):
    """Each of ``groups`` tied with the terms ``in_place`` (once): named, not with confidence; the
    record says on which ``channels`` and with which parameters (a discovered term fitted
    beside it there is no physics of its own either, diagnosis.answer._beside_tie_sentence)."""
    for g in groups:
        if not any(t["group"] == g.label for t in ties):
            ties.append({"group": g.label, "title": g.title, "params": list(g.params), "channels": list(channels),
                         "terms": [t.equation for t in in_place], "extra_params": extra, **figures})


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
            block = search.cols[(name, _option(search, t, name))][:, c, :]
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
