"""A library effect whose channel keeps a part keyed on another joint: not named with confidence.

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
  structure test's threshold and a look-elsewhere cost);
* :func:`foreign_inputs`: the flexible stage's claim on the channel (:mod:`.flexible`, judged out
  of fold) names an input of another joint.  A claim on no single input, on the pose (it moves
  with the joint's own position), on time (the drift stage's subject) or on the joint's own
  inputs (the effect's own shape against the plant's) does not count.

Effects of no single joint (a platform mass, a tilt, a delay) act through every joint's motion
and are not tested.  docs/discrepancy.md, section 4, "Nor where what is left is keyed on another
joint", states the rule and what it was measured on.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

#: group of the look-alike that marks an effect whose channel keeps a part keyed on another joint
KEYED_ELSEWHERE = "keyed_elsewhere"


def foreign_inputs(fit, joint: int) -> list:
    """The inputs a claimed flexible ``fit`` depends on that belong to a joint other than
    ``joint`` (1-based): their :class:`~.flexible.Dependence` entries, in the fit's order;
    [] when the fit claims nothing or names no input."""
    if not fit.explained:
        return []
    return [d for d in fit.inputs if d.joint is not None and d.joint != joint]


def withheld(effects: list, fits: list, noun: str = "joint", modulated: dict | None = None) -> list:
    """``effects`` (:class:`~.results.FoundEffect`) with a tied look-alike
    :data:`KEYED_ELSEWHERE` added to every effect on a joint whose effort channel keeps a part
    keyed on another joint: its flexible fit (``fits``, :class:`~.flexible.FlexibleFit`) claims a
    part keyed on another joint's input, or its level changes with one (``modulated``, per effect
    index, from :func:`modulations`); the others as they are.

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
        if i in modulated:
            feat, chi2, rms = modulated[i]
            why.append(f"its level changes with {feat} (chi-square {chi2:.0f} in independent samples, rms "
                       f"{rms:.3g})")
        if not why or any(a["group"] == KEYED_ELSEWHERE for a in e["lookalikes"]):
            out.append(e)
            continue
        out.append(replace(e, lookalikes=[_alternative(e, noun, why)] + list(e["lookalikes"])))
    return out


def _alternative(e, noun, why):
    from .results import Alternative

    name = f"a force on {noun} {e['joint']} keyed on another {noun} ({'; '.join(why)})"
    return Alternative(KEYED_ELSEWHERE, KEYED_ELSEWHERE, name, 0.0, 0.0, 0, float("nan"), False,
                       f"{name}: the truth on this channel depends on an input {e['name']} does not use, and the fit "
                       f"may stand in for part of it; {e['name']} is not named with confidence")


def modulations(eng, theta: dict, effects: list, R, threshold: float | None = None) -> dict:
    """Effects whose level changes with another joint's input: per effect index, ``(feature,
    chi2, rms)`` of the strongest such modulation that passes, else absent.

    For an effect on joint j with its force g on j's effort channel (the residual without the
    effect's parameters less the residual ``R`` with them, ``theta`` the fitted parameters),
    the residual of that channel is fitted with g and g (z - mean z) for each input z of another
    joint (the flexible stage's inputs, :func:`.flexible.inputs`: position, rate, acceleration,
    effort, histories; each also as |z - median z|): a friction in proportion to a neighbour's
    speed is g times that speed.  The chi-square the product explains beyond g, in independent
    samples against the channel's own noise (:func:`.signatures.own_noise`), less ln n_eff for
    its coefficient, passes above the structure test's threshold plus the look-elsewhere cost
    2 ln M (M products tried for the effect)."""
    from .flexible import inputs
    from .signatures import own_noise, samples_per_independent
    from .structure import THRESHOLD
    from .ties import tied

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
        if j is None or not e["params"] or any(tied(a) for a in e["lookalikes"]):  # named tied already
            continue
        c = j - 1
        R_wo = eng.R({k: v for k, v in theta.items() if k not in e["params"]})
        g = R_wo[:, c] - R[:, c]
        y = R[:, c] - R[:, c].mean()
        sigma = own_noise(pipe, y, floor[c])
        if not (sigma > 0 and np.any(g != 0)):
            continue
        other = [k for k, col in enumerate(columns) if col[2] is not None and col[2] != j]
        Z = X[:, other]
        Z = np.column_stack([Z, np.abs(Z - np.median(Z, axis=0))])
        names = [columns[k][0] for k in other] + [f"|{columns[k][0]}|" for k in other]
        Z = Z - Z.mean(axis=0)
        keep = Z.std(axis=0) > 0
        Z, names = Z[:, keep], [nm for nm, ok in zip(names, keep) if ok]
        if not names:
            continue
        gc = g - g.mean()
        base = y - gc * float(gc @ y) / float(gc @ gc)  # the effect's own column refitted
        P = g[:, None] * Z
        P = P - gc[:, None] * ((gc @ P) / float(gc @ gc))[None, :]  # the product beyond g
        norm = np.einsum("ij,ij->j", P, P)
        gain = np.where(norm > 0, (P.T @ base) ** 2 / np.where(norm > 0, norm, 1.0), 0.0)
        best = int(np.argmax(gain))
        chi2 = float(gain[best]) / sigma ** 2 / phi
        bar = bar0 + 2.0 * math.log(len(names))
        if chi2 - math.log(n_eff) > bar:
            out[i] = (names[best], chi2, math.sqrt(float(gain[best]) / n))
    return out
