"""A library effect of the platform's inertia beside a force of the platform's motion through a
resonance: not named with confidence.

A body the platform carries on a spring (a tuned mass damper, a pendulum) pushes on the platform
with its acceleration through the body's resonance (:mod:`..flexible.motion`): below the resonance
that force is the body's mass times the platform's acceleration, near it the force lags and
grows.  The library's effects of the platform's inertia (:data:`INERTIAL`: a platform mass or
inertia error, a payload) are forces of the platform's acceleration of the same instant; fitted
to such a body, one of them takes the part of its force in phase with the acceleration and
leaves the rest, which the structure test (:mod:`..structure`, keyed on each joint's own motion
and on the pose) does not key on, so the fit may leave no structure it can see.  Measured on
MuJoCo (``bench/foreign/mujoco_unlisted.py --kinds platform_tmd``, seen seed 62703: 57 g on a
spring at 4.2 Hz, damping ratio 0.076): a platform inertia error named with confidence, no
structure left, while the flexible stage explained 29-63 % of what is left on five channels,
each on the platform's motion alone.

So when the flexible stage claims a part of any channel (out of fold, its own bars) that depends
on the platform's motion (:data:`..flexible.motion.MOTION`, a history of the platform's
acceleration no library effect is keyed on), every effect of :data:`INERTIAL` gets a tied
look-alike :data:`CARRIED` ("a body the platform carries on a spring ..."): named tied, not with
confidence.  The whole recording counts, not the effect's channels: a platform effect acts on
every channel.  Other effects are not tested: a rail's rotor inertia is keyed on its own
rail's acceleration, which the keyed rule (:mod:`.elsewhere`) judges; a tilt is a force of the
pose, a delay one of the efforts' course.  docs/discrepancy.md, section 4, "Nor beside a body the
platform carries on a spring", states the rule and the seen sets it is measured on.
"""
from __future__ import annotations

from dataclasses import replace

#: group of the look-alike that marks an inertia fitted beside a force of the platform's motion
#: through a resonance
CARRIED = "carried_resonance"
#: the library's effects whose force is the platform's (or a rigidly carried body's) response to
#: the platform's acceleration of the same instant
INERTIAL = ("platform_mass", "platform_inertia", "payload")


def resonant_claims(fits) -> list:
    """The claimed flexible ``fits`` (:class:`~..flexible.FlexibleFit`) that depend on the
    platform's motion through a resonance (an input of the group :data:`..flexible.motion.MOTION`),
    in the fits' order; [] when none does."""
    from ..flexible.motion import MOTION

    return [f for f in fits if f.explained and any(d.group == MOTION for d in f.inputs)]


def withheld_carried(effects: list, fits: list) -> list:
    """``effects`` (:class:`~..results.FoundEffect`) with a tied look-alike :data:`CARRIED` added
    to every effect of :data:`INERTIAL` when a flexible fit of ``fits`` claims a part on the
    platform's motion (:func:`resonant_claims`); the others, and every effect when no fit does,
    as they are.  An effect marked already is left as it is.

    Example
    -------
    >>> effects = withheld_carried(effects, d.flexible)        # doctest: +SKIP
    >>> [a["group"] for a in effects[0]["lookalikes"]][:1]     # doctest: +SKIP
    ['carried_resonance']
    """
    claims = resonant_claims(fits)
    if not claims:
        return effects
    where = ", ".join(f"{f.channel} {100 * f.share:.0f} %" for f in claims)
    name = (f"a body the platform carries on a spring (the flexible model of what is left depends on the "
            f"platform's acceleration through a resonance: {where} of what is left, out of fold)")
    out = []
    for e in effects:
        if e["key"] not in INERTIAL or any(a["group"] == CARRIED for a in e["lookalikes"]):
            out.append(e)
            continue
        out.append(replace(e, lookalikes=[_tie(name, e["name"])] + list(e["lookalikes"])))
    return out


def _tie(name: str, effect: str):
    """The tied look-alike :data:`CARRIED` of that ``name`` beside ``effect`` (no fit of its own)."""
    from ..results import Alternative

    return Alternative(CARRIED, CARRIED, name, 0.0, 0.0, 0, float("nan"), False,
                       f"{name}: below its resonance such a body is a mass the platform carries, so {effect} "
                       f"may take the part of its force in phase with the platform's acceleration; {effect} is "
                       f"not named with confidence")
