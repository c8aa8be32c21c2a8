"""A library effect whose channel keeps a part keyed on another joint: not named with confidence.

A library effect on joint j is a force of joint j's own motion (its position, rate,
acceleration, effort).  When the flexible model of what is left on j's effort channel
(:mod:`.flexible`) claims a part out of fold (a significant share, by the stage's own bars) and
depends on an input of *another* joint, the fit leaves a force the effect cannot carry: the
truth on that channel is keyed on something the effect does not use, and the effect may be
fitted to the part of it that its own column happens to follow (a friction in proportion to a
neighbouring rail's speed is, on average over the recording, a Coulomb friction of the mean
level; a smooth Coulomb friction takes that mean and leaves the rest within the structure
test's yardstick, which the same force inflates).  Such an effect gets a look-alike that is a
tie, :data:`KEYED_ELSEWHERE`: "a force on slider 4 keyed on the history of slider 1 (flexible
model, 13 % of what is left) fits beside it", so it is named tied, not with confidence.

The structure test (:mod:`.structure`) looks for structure keyed on the joint's own motion and on
the pose; it never sees a dependence on another joint.  The flexible stage does, and its claim
is judged out of fold; this rule only reads it.  What it does not count: a claim "on no single
input" (what it is keyed on is unknown), a dependence on the pose or on time (the pose moves with
the joint's own position; time is the drift stage's), and effects of no single joint (a platform
mass, a tilt, a delay: they act through every joint's motion).  docs/discrepancy.md, section 4,
"Named with confidence only where nothing is left", states the rule and what it was measured on.
"""
from __future__ import annotations

from dataclasses import replace

#: group of the look-alike that marks an effect whose channel keeps a part keyed on another joint
KEYED_ELSEWHERE = "keyed_elsewhere"


def foreign_inputs(fit, joint: int) -> list:
    """The inputs a claimed flexible ``fit`` depends on that belong to a joint other than
    ``joint`` (1-based): their :class:`~.flexible.Dependence` entries, in the fit's order;
    [] when the fit claims nothing or names no input."""
    if not fit.explained:
        return []
    return [d for d in fit.inputs if d.joint is not None and d.joint != joint]


def withheld(effects: list, fits: list, noun: str = "joint") -> list:
    """``effects`` (:class:`~.results.FoundEffect`) with a tied look-alike
    :data:`KEYED_ELSEWHERE` added to every effect on a joint whose effort channel's flexible
    fit (``fits``, :class:`~.flexible.FlexibleFit`) claims a part keyed on another joint's input;
    the others as they are.

    Example
    -------
    >>> effects = withheld(effects, d.flexible, "slider")      # doctest: +SKIP
    >>> [a["group"] for a in effects[0]["lookalikes"]][:1]    # doctest: +SKIP
    ['keyed_elsewhere']
    """
    from .results import Alternative

    by_joint = {f.joint: f for f in fits}
    out = []
    for e in effects:
        fit = by_joint.get(e["joint"]) if e["joint"] is not None else None
        other = foreign_inputs(fit, e["joint"]) if fit is not None else []
        if not other or any(a["group"] == KEYED_ELSEWHERE for a in e["lookalikes"]):
            out.append(e)
            continue
        on = " and ".join(d.group for d in other)
        name = (f"a force on {noun} {e['joint']} keyed on the {on} (flexible model, {100 * fit.share:.0f} % of what "
                f"is left out of fold)")
        alt = Alternative(KEYED_ELSEWHERE, KEYED_ELSEWHERE, name, 0.0, 0.0, 0, float("nan"), False,
                          f"{name} remains beside it: the truth on {fit.channel} depends on an input "
                          f"{e['name']} does not use, and the fit may stand in for part of it; {e['name']} is not "
                          f"named with confidence")
        out.append(replace(e, lookalikes=[alt] + list(e["lookalikes"])))
    return out
