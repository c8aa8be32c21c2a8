"""A library effect whose channel keeps a part keyed on another joint, on its joint's position or
on the time since its joint reversed: not named with confidence.

A library effect on joint j is a force of joint j's own motion (its position, rate,
acceleration, effort).  When the truth on j's effort channel also depends on another joint's
input, the effect can take the force's mean over the recording and leave the rest (a friction
in proportion to a neighbouring rail's speed is, on average, a Coulomb friction of the mean
level); the rest inflates the channel's own noise, the yardstick of the structure test
(:mod:`.structure`), which keys a channel only on its own joint's motion and on the pose.  Two
pieces of evidence that what is left is keyed on another joint give such an effect a look-alike
that is a tie, :data:`KEYED_ELSEWHERE` ("a force on slider 4 keyed on another slider (its level
changes with |qd2| ...)"), so it is named tied, not with confidence:

* :func:`modulations`: the effect's level changes with another joint's input (its force on the
  channel times that input explains the residual, against the channel's own noise, beyond the
  structure test's threshold and a look-elsewhere cost), or with a function of its own joint's
  position or of the time since that joint last reversed (:mod:`.own`: a friction rising
  over part of the stroke, one that relaxes after each reversal, taken by the library's
  friction at its mean level); the look-alike then says "keyed on its position" or "keyed on
  the time since its last reversal";
* :func:`modulations` again, where no product passes: the recording is too weak to tell the
  level of a library friction from a keyed one (:mod:`.power`: for some kind of product, no
  level change as large as the friction's level would pass the bar, or the residual leans on a
  product along which the bar cannot exclude a change as large as the level); the look-alike
  then says "perhaps keyed on ...";
* :func:`foreign_inputs`: the flexible stage's claim on the channel (:mod:`..flexible`, judged out
  of fold) names an input of another joint.  A claim on no single input, on the pose (it moves
  with the joint's own position), on time (the drift stage's subject) or on the joint's own
  inputs (the effect's own shape against the plant's) does not count.

A library friction whose level was measured keyed (a product passed) or that the recording
leans to keying (a "perhaps keyed" tie of a leaning product; not of the power alone) ties the
other library effects fitted on its channel as well (:func:`_beside`: "fitted beside Coulomb
friction, whose level is keyed on ...: it may stand in for part of that force") and marks the
discovered terms there partial (:func:`terms_beside`), as a discovered term fitted beside a tied
effect is marked partial.  Effects of no single joint (a platform mass,
a tilt, a delay) act through every joint's motion and are not tested.  docs/discrepancy.md,
section 4, "Nor where what is left is keyed on another joint", "Nor where its level follows the
joint's own position or its reversals" and "Nor beside a friction keyed", states the rule and
what it was measured on.
"""
from __future__ import annotations

import logging
import math
from dataclasses import replace

import numpy as np

from .own import gains

#: group of the look-alike that marks an effect whose channel keeps a part keyed on another joint
KEYED_ELSEWHERE = "keyed_elsewhere"
_log = logging.getLogger(__name__)


def foreign_inputs(fit, joint: int) -> list:
    """The inputs a claimed flexible ``fit`` depends on that belong to a joint other than
    ``joint`` (1-based): their :class:`~..flexible.Dependence` entries, in the fit's order;
    [] when the fit claims nothing or names no input."""
    if not fit.explained:
        return []
    return [d for d in fit.inputs if d.joint is not None and d.joint != joint]


def withheld(effects: list, fits: list, noun: str = "joint", modulated: dict | None = None) -> list:
    """``effects`` (:class:`~.results.FoundEffect`) with a tied look-alike
    :data:`KEYED_ELSEWHERE` added to every effect on a joint whose effort channel keeps a part
    keyed elsewhere than the effect's own shape: its flexible fit (``fits``,
    :class:`~.flexible.FlexibleFit`) claims a part keyed on another joint's input, or its level
    changes with one, with the joint's position or with the time since it reversed
    (``modulated``, per effect index, from :func:`modulations`); every other effect on the
    channel of an effect whose level was measured keyed gets one too (:func:`_beside`); the
    others as they are.

    Example
    -------
    >>> effects = withheld(effects, d.flexible, "slider")      # doctest: +SKIP
    >>> [a["group"] for a in effects[0]["lookalikes"]][:1]    # doctest: +SKIP
    ['keyed_elsewhere']
    """
    by_joint = {f.joint: f for f in fits}
    modulated = modulated or {}
    out = []
    for i, e in enumerate(effects):
        fit = by_joint.get(e["joint"]) if e["joint"] is not None else None
        other = foreign_inputs(fit, e["joint"]) if fit is not None else []
        why = []
        if other:
            on = " and ".join(d.group for d in other)
            why.append(f"the flexible model of what is left there depends on the {on} ({100 * fit.share:.0f} % of "
                       f"what is left, out of fold)")
        for feat, chi2, rms, where in modulated.get(i, ()):
            if where.startswith("weak "):
                why.append(f"the recording is too weak to tell its level from one that changes with "
                           f"{_KEYS[where[5:]]} (the smallest change of its level the rule could see, with {feat}, "
                           f"is {100 * chi2:.0f} % of it)")
                continue
            if where.startswith("leaning "):
                why.append(f"the recording leans to a level that changes with {_KEYS[where[8:]]} ({feat}: chi-square "
                           f"{rms:.0f} beyond its cost, above the look-elsewhere cost, below the rule's bar) and "
                           f"cannot exclude a change as large as the level (up to {100 * chi2:.0f} % of it)")
                continue
            what = {"elsewhere": feat, "position": f"its position ({feat})",
                    "reversal": f"the time since it last reversed ({feat})"}[where]
            why.append(f"its level changes with {what} (chi-square {chi2:.0f} in independent samples, rms "
                       f"{rms:.3g})")
        if not why or any(a["group"] == KEYED_ELSEWHERE for a in e["lookalikes"]):
            out.append(e)
            continue
        keys = _keyed_on([_kind(m[3]) for m in modulated.get(i, ())], noun, bool(other))
        weak = not other and all(_kind(m[3]) != m[3] for m in modulated.get(i, ()))
        alike = _alternative(e, noun, " and ".join(keys), why, weak)
        out.append(replace(e, lookalikes=[alike] + list(e["lookalikes"])))
    return _beside(out, modulated, noun)


def _beside(effects: list, modulated: dict, noun: str) -> list:
    """``effects`` with a tied look-alike :data:`KEYED_ELSEWHERE` added to every other library
    effect on the channel of a library friction (:data:`.power.FRICTIONS`) whose level was
    measured keyed (a product of :func:`modulations` passed) or that the recording leans to keying
    (a "leaning" product, significant beyond the look-elsewhere cost; not a "perhaps keyed" tie of
    a weak recording alone, which saw no keyed force): fitted beside it by least squares, an
    inertia, an offset or a kinematic effect takes the part of the keyed force its own force
    correlates with.
    Only beside a friction: the unlisted mechanisms key a friction's level; an inertia or another
    effect whose level reads keyed is itself the stand-in (for a true elasticity's unmodelled
    part, MuJoCo seeds 11 and 12), not a force others stand in for.  An effect tied already by
    this rule is left as it is."""
    keyed = _keyed_frictions(effects, modulated, noun)
    out = []
    for i, e in enumerate(effects):
        by = [(what, keys) for k, what, keys in keyed.get(e["joint"], ()) if k != i]
        if not by or any(a["group"] == KEYED_ELSEWHERE for a in e["lookalikes"]):
            out.append(e)
            continue
        beside = "; ".join(f"{what}, whose level is {keys}" for what, keys in by)
        name = (f"a force on {noun} {e['joint']} {' and '.join(dict.fromkeys(k for _, k in by))} (fitted "
                f"beside {beside}: it may stand in for part of that force)")
        alike = _tie(name, f"{e['name']} on {noun} {e['joint']}, {name}; {e['name']} is not named with confidence")
        out.append(replace(e, lookalikes=[alike] + list(e["lookalikes"])))
    return out


def _keyed_frictions(effects: list, modulated: dict, noun: str) -> dict:
    """The library frictions (:data:`.power.FRICTIONS`) of ``effects`` whose level was measured
    keyed (a product of :func:`modulations` passed) or that the recording leans to keying (a
    "leaning " kind), per joint: ``{joint: [(index, name, "keyed on ..." or "perhaps keyed on
    ...")]}``."""
    from .power import FRICTIONS

    keyed = {}
    for i, found in modulated.items():
        if effects[i]["key"] not in FRICTIONS:
            continue
        kinds = [m[3] for m in found if _kind(m[3]) == m[3]]
        leaning = [_kind(m[3]) for m in found if m[3].startswith("leaning ")]
        if kinds or leaning:
            e = effects[i]
            keys = " and ".join(_keyed_on(kinds or leaning, noun))
            keyed.setdefault(e["joint"], []).append((i, e["name"], f"{'' if kinds else 'perhaps '}keyed on {keys}"))
    return keyed


def terms_beside(terms: list, effects: list, modulated: dict, noun: str) -> list:
    """The discovered ``terms`` (:class:`~..discovery.terms.DiscoveredTerm`), each on the joint of a
    library friction of ``effects`` whose level was measured keyed or that the recording leans to
    keying (``modulated``, from :func:`modulations`; :func:`_keyed_frictions`) marked partial:
    fitted beside it by least squares, the term takes the part of the keyed force its own force
    correlates with, as a library effect beside it does (:func:`_beside`; measured on MuJoCo: an
    acceleration term of 8.4 g beside a Coulomb friction whose level relaxes after each reversal,
    docs/discrepancy.md, section 4).  A term already partial is left as it is."""
    keyed = _keyed_frictions(effects, modulated, noun)
    out = []
    for t in terms:
        by = keyed.get(t.joint, ())
        if t.partial or not by:
            out.append(t)
            continue
        beside = "; ".join(f"{what}, whose level is {keys}" for _, what, keys in by)
        out.append(replace(t, partial=f"fitted beside {beside}: it may stand in for part of that force, so it is "
                                      f"not named as the physics with confidence"))
    return out


#: prefixes of a kind of product where no product passed (:func:`modulations`): no keyed force measured
_TENTATIVE = ("weak ", "leaning ")


def _kind(where: str) -> str:
    """The kind of product of a ``where`` of :func:`modulations`, without a tentative prefix."""
    for prefix in _TENTATIVE:
        if where.startswith(prefix):
            return where[len(prefix):]
    return where


#: what a kind of product keys the level on
_KEYS = {"elsewhere": "another joint", "position": "its position", "reversal": "the time since its last reversal"}


def _keyed_on(kinds, noun: str, other: bool = False) -> list:
    """What a level is keyed on, in words, once per kind of product (``kinds``, in order; another
    joint first where the flexible fit named one, ``other``)."""
    keys = ["elsewhere"] if other else []
    keys += [k for k in dict.fromkeys(kinds) if k not in keys]
    return [_KEYS[k].replace("another joint", f"another {noun}") for k in keys]


def _tie(name: str, description: str):
    """The tied look-alike :data:`KEYED_ELSEWHERE` of that ``name`` (no fit of its own)."""
    from ..results import Alternative

    return Alternative(KEYED_ELSEWHERE, KEYED_ELSEWHERE, name, 0.0, 0.0, 0, float("nan"), False, description)


def _alternative(e, noun, keys, why, weak=False):
    name = f"a force on {noun} {e['joint']} {'perhaps ' if weak else ''}keyed on {keys} ({'; '.join(why)})"
    what = (f"the recording cannot tell whether the truth on this channel depends on an input {e['name']} does not "
            f"use" if weak else f"the truth on this channel depends on an input {e['name']} does not use")
    return _tie(name, f"{name}: {what}, and the fit may stand in for part of it; {e['name']} is not named with "
                      f"confidence")


def modulations(eng, theta: dict, effects: list, R, threshold: float | None = None) -> dict:
    """Effects whose level changes with another joint's input, with their own joint's position or
    with the time since their joint last reversed: per effect index, a list of ``(feature, chi2,
    rms, where)`` (``where`` "elsewhere", "position" or "reversal"), the strongest product of each
    kind that passes; absent when none does.

    For an effect on joint j with its force g on j's effort channel (the residual without the
    effect's parameters less the residual ``R`` with them, ``theta`` the fitted parameters),
    the residual of that channel is fitted with g and g (z - mean z) for each input z of another
    joint (the flexible stage's inputs, :func:`.flexible.inputs`: position, rate, acceleration,
    effort, histories; each also as |z - median z|): a friction in proportion to a neighbour's
    speed is g times that speed; and with g z for each function z of the joint's own position
    and of the time since its last reversal (:func:`.own.own_products`; not for the
    kinematic effects, ``own.KINEMATIC``, whose force is such a function by nature).  The
    chi-square the product explains beyond g, in independent samples against the channel's own
    noise (:func:`.signatures.own_noise`), less ln n_eff for its coefficient, passes above the
    structure test's threshold plus the look-elsewhere cost 2 ln M (M products tried for the
    effect, every kind together).  Where none passes, the effect is listed with ``where`` "weak "
    + the kind, ``feature`` the kind's best-powered product and ``chi2`` the smallest change of
    the level it could see (a fraction of the level, :func:`.power.smallest_change`), for each
    kind whose smallest change exceeds :data:`.power.LEVEL_CHANGE`; and with ``where`` "leaning "
    + the kind, ``feature`` the product the residual leans on, ``chi2`` the largest change of the
    level the bar does not exclude and ``rms`` its chi-square less ln n_eff
    (:func:`.power.leaning_change`), for each other kind with such a product: the library's
    frictions only (:data:`.power.FRICTIONS`)."""
    from ..flexible.stage import inputs
    from .own import KINEMATIC, beyond, own_products
    from .power import FRICTIONS, leaning_change, smallest_change, spans, too_weak
    from ..signatures import own_noise, samples_per_independent
    from ..structure import THRESHOLD
    from ..ties import tied

    pipe = eng.pipe
    R = np.asarray(R, float)
    n = R.shape[0]
    phi = samples_per_independent(pipe)
    n_eff = n / phi
    if n_eff < 10:
        return {}
    X, columns = inputs(pipe, R)
    floor = eng.accuracy()
    bar0 = THRESHOLD if threshold is None else threshold
    out = {}
    for i, e in enumerate(effects):
        j = e["joint"]
        if j is None or not e["params"]:
            continue
        already = any(tied(a) for a in e["lookalikes"])  # named tied already: not tested (but for the record)
        if already and not _log.isEnabledFor(logging.DEBUG):
            continue
        c = j - 1
        R_wo = eng.R({k: v for k, v in theta.items() if k not in e["params"]})
        g = R_wo[:, c] - R[:, c]
        y = R[:, c] - R[:, c].mean()
        sigma = own_noise(pipe, y, floor[c])
        if not (sigma > 0 and np.any(g != 0)):
            continue
        gc = g - g.mean()
        if not float(gc @ gc) > 0:  # a constant (an offset): its products are the inputs themselves
            continue
        base = y - gc * float(gc @ y) / float(gc @ gc)  # the effect's own column refitted
        P, names, span = _elsewhere_products(g, X, columns, j)
        wheres = ["elsewhere"] * len(names)
        if e["key"] not in KINEMATIC:
            Z, own_names, own_wheres = own_products(pipe, j)
            P = np.column_stack([P, beyond(g, Z)])
            names, wheres, span = names + own_names, wheres + own_wheres, np.concatenate([span, spans(Z)])
        if not names:
            continue
        bar, var, cost = bar0 + 2.0 * math.log(len(names)), sigma ** 2 * phi, math.log(n_eff)
        label = f"{e['key']}[{j}]" + (" (tied already)" if already else "")
        passed = _passing(P, base, names, wheres, var, bar, cost, label)
        if already:
            continue
        if passed:
            out[i] = [(f, c2, math.sqrt(gn / n), w) for f, c2, gn, w in passed]
            continue
        if e["key"] not in FRICTIONS:
            continue
        changes = smallest_change(P, span, wheres, var, bar + cost)
        for where, (delta, k) in changes.items():
            _log.debug("%s: %s smallest visible change of the level %.3g (%s)", label, where, delta, names[k])
        leaning = leaning_change(P, base, span, wheres, var, bar + cost, cost, bar - bar0)
        for where, (change, k, stat) in leaning.items():
            _log.debug("%s: %s largest change of the level not excluded %.3g (%s; chi2 - ln n_eff = %.1f)", label,
                       where, change, names[k], stat)
        weak = too_weak(changes)  # no product could pass: the recording cannot tell the level constant
        found = [(names[changes[w][1]], delta, float("nan"), "weak " + w) for w, delta in weak]
        found += [(names[k], change, stat, "leaning " + w) for w, (change, k, stat) in leaning.items()
                  if w not in dict(weak)]  # the data lean to a keyed level the rule cannot bound below the level
        if found:
            out[i] = found
    return out


def _passing(P, base, names, wheres, var, bar, cost, key) -> list:
    """``[(feature, chi2, sum of squares, where)]``: the product (a column of ``P``) that explains
    most of ``base``, when its chi-square (the sum of squares over ``var``) less ``cost`` passes
    ``bar``; then, beside it, the strongest product of each other kind (``wheres``) that passes
    the same bar with the first in the fit (a position and a reversal keyed level are often
    correlated on one recording: the second is named only for what the first leaves)."""
    gain = gains(P, base)
    first = int(np.argmax(gain))
    chi2 = gain / var
    for where in dict.fromkeys(wheres):  # the strongest of each kind alone, for the record
        k = max((k for k, w in enumerate(wheres) if w == where), key=lambda k: gain[k])
        _log.debug("%s: %s %s chi2 - ln n_eff = %.1f against %.1f", key, where, names[k], chi2[k] - cost, bar)
    if not chi2[first] - cost > bar:
        return []
    out = [(names[first], float(chi2[first]), float(gain[first]), wheres[first])]
    p = P[:, first] / math.sqrt(float(P[:, first] @ P[:, first]))
    rest = P - p[:, None] * (p @ P)[None, :]
    gain = gains(rest, base - p * float(p @ base))
    for where in dict.fromkeys(wheres):
        at = [k for k, w in enumerate(wheres) if w == where]
        best = max(at, key=lambda k: gain[k])
        if where != wheres[first] and gain[best] / var - cost > bar:
            out.append((names[best], float(gain[best] / var), float(gain[best]), where))
    return out


def _elsewhere_products(g, X, columns, j) -> tuple:
    """``(P, names, span)``: the products g (z - mean z) for every input z of a joint other than
    ``j`` (and |z - median z|), with what g explains of them taken out, and the range of each z
    (:func:`.power.spans`)."""
    from .power import spans

    other = [k for k, col in enumerate(columns) if col[2] is not None and col[2] != j]
    Z = X[:, other]
    Z = np.column_stack([Z, np.abs(Z - np.median(Z, axis=0))])
    names = [columns[k][0] for k in other] + [f"|{columns[k][0]}|" for k in other]
    Z = Z - Z.mean(axis=0)
    keep = Z.std(axis=0) > 0
    Z, names = Z[:, keep], [nm for nm, ok in zip(names, keep) if ok]
    gc = g - g.mean()
    P = g[:, None] * Z
    P = P - gc[:, None] * ((gc @ P) / float(gc @ gc))[None, :]  # the product beyond g
    return P, names, spans(Z)
