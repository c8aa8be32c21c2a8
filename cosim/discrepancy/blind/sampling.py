"""The hidden physics of a blind case: the effect types the generator can hide (:data:`TYPES`),
an effect's magnitudes drawn from the config (:func:`sample_effect`), and the forces no library
effect names with the checks of their discovered equations (:data:`UNLISTED`; :mod:`.blind`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError
from ..effects import geometry_layout, joint_prefix
from ..families.generator import KINDS as FAMILY_KINDS, sample as family_sample

#: effect types the generator can hide, per robot (those with magnitudes in the config)
TYPES = ["coulomb", "viscous", "stribeck", "smooth_coulomb", "rotor_inertia", "payload", "platform_mass", "platform_inertia",
         "gravity_tilt", "actuator_delay", "sensor_delay", "saturation", "dead_zone", "encoder_offset", "backlash",
         "compliance", "geometry", "offset"]


@dataclass
class Hidden:
    """One hidden effect in an answer key."""

    type: str
    params: dict                       # core parameter -> true value
    joints: list = field(default_factory=list)  # 1-based, [] for global effects
    nominal: dict = field(default_factory=dict)  # core parameter -> nominal value


class _Redraw(Exception):
    """This trajectory cannot carry the effect asked for: draw the case again."""


def _uniform(rng, lohi):
    lo, hi = lohi
    return float(rng.uniform(lo, hi))


def sample_effect(kind, model, rng, cfg, tau_peak) -> Hidden:
    """Draw one hidden effect of type ``kind`` for ``model`` (magnitudes from cfg).

    ``tau_peak`` is (peak feed-forward effort, largest gravity load[, share of the samples on
    the minority side of the effort's sign]) per joint over the reference: the saturation
    level, and the joints a backlash can be put on (a gap shows only where the effort the
    transmission carries changes sign; elsewhere it is an offset of b/2)."""
    eff = cfg["effects"][model.robot]
    gen = cfg["general"]
    nd = model.ndof
    pre = joint_prefix(model)
    nominal = model.params()
    sign = float(rng.choice([-1.0, 1.0]))

    def joints():
        if rng.uniform() < gen.get("all_joints", 0.0) and kind not in ("saturation", "backlash", "geometry",
                                                                        "stribeck"):
            return list(range(1, nd + 1))
        return [int(rng.integers(1, nd + 1))]

    if kind == "backlash" and len(tau_peak) > 2:
        rng.uniform()  # the all-joints draw of joints(), kept so the other draws stay as they were
        ok = [j for j in range(nd) if tau_peak[2][j] >= 0.05]
        if not ok:
            raise _Redraw("no joint's effort changes sign along this trajectory: a gap would read as an offset")
        j = int(rng.choice(ok)) + 1
        name = f"{pre}[{j}].backlash"
        p = {name: nominal[name] + _uniform(rng, eff[kind])}
        return Hidden(kind, p, [j], {k: nominal[k] for k in p})
    # The drawn sizes are what the model lacks: added to the nominal value (a description's
    # defaults may give a drive parameter, e.g. a reflected rotor inertia, that is not 0).
    if kind in ("coulomb", "viscous", "rotor_inertia", "backlash", "compliance", "dead_zone"):
        js = joints()
        p = {f"{pre}[{j}].{kind}": nominal[f"{pre}[{j}].{kind}"] + _uniform(rng, eff[kind]) for j in js}
        return Hidden(kind, p, js, {k: nominal[k] for k in p})
    if kind in ("encoder_offset", "offset"):
        js = joints()
        p = {f"{pre}[{j}].{kind}": nominal[f"{pre}[{j}].{kind}"]
             + float(rng.choice([-1, 1])) * _uniform(rng, eff[kind]) for j in js}
        return Hidden(kind, p, js, {k: nominal[k] for k in p})
    if kind in ("stribeck", "smooth_coulomb"):
        # an amplitude (added to the nominal one) and a velocity scale, on one joint
        amp, vel = {"stribeck": ("stribeck", "stribeck_v"), "smooth_coulomb": ("coulomb", "coulomb_v")}[kind]
        j = int(rng.integers(1, nd + 1))
        p = {f"{pre}[{j}].{amp}": nominal[f"{pre}[{j}].{amp}"] + _uniform(rng, eff[kind]),
             f"{pre}[{j}].{vel}": _uniform(rng, eff[kind + "_v"])}
        return Hidden(kind, p, [j], {k: nominal[k] for k in p})
    if kind == "saturation":
        return _saturation(rng, eff, pre, nominal, tau_peak, nd)
    if kind == "payload":
        p = {"payload.m": _uniform(rng, eff["payload_m"])}
        if "payload_xy" in eff:
            r = eff["payload_xy"]
            p["payload.x"] = float(rng.uniform(-r, r))
            p["payload.y"] = float(rng.uniform(-r, r))
            p["payload.z"] = _uniform(rng, eff["payload_z"])
        return Hidden(kind, p, [], {k: nominal[k] for k in p})
    if kind == "platform_mass":
        p = {"platform.m": nominal["platform.m"] * (1 + sign * _uniform(rng, eff[kind]))}
        return Hidden(kind, p, [], {k: nominal[k] for k in p})
    if kind == "platform_inertia":
        names = ("platform.Ixx", "platform.Iyy", "platform.Izz")
        for _ in range(100):  # principal moments of a rigid body obey the triangle inequality
            p = {k: nominal[k] * (1 + float(rng.choice([-1, 1])) * _uniform(rng, eff[kind])) for k in names}
            a, b, c = (p[k] for k in names)
            if a + b >= c and a + c >= b and b + c >= a:
                break
        return Hidden(kind, p, [], {k: nominal[k] for k in p})
    if kind == "gravity_tilt":
        a = math.radians(_uniform(rng, eff[kind]))
        az = float(rng.uniform(0, 2 * math.pi))
        g = math.sqrt(sum(nominal[f"gravity.{c}"] ** 2 for c in "xyz"))
        p = {"gravity.x": g * math.sin(a) * math.cos(az), "gravity.y": g * math.sin(a) * math.sin(az),
             "gravity.z": -g * math.cos(a)}
        return Hidden(kind, p, [], {k: nominal[k] for k in p})
    if kind in ("actuator_delay", "sensor_delay"):
        name = kind.replace("_", ".")
        return Hidden(kind, {name: _uniform(rng, eff[kind])}, [], {name: nominal[name]})
    if kind == "geometry":
        return _geometry_error(model, rng, eff, nominal, sign)
    raise InputError(f"the generator cannot hide effect type {kind!r} (it can hide: {', '.join(TYPES)})")


def _saturation(rng, eff, pre, nominal, tau_peak, nd) -> Hidden:
    """An effort limit on one joint.  ``tau_peak`` = (peak effort, largest gravity load) per
    joint: a limit below the gravity load would drop the robot, so the level stays above it,
    on a joint whose peaks are well above its gravity load."""
    peak, static = tau_peak[:2]
    ok = [j for j in range(nd) if peak[j] > 1.25 * static[j]]
    if not ok:
        raise _Redraw("no joint's peak effort is well above its gravity load on this trajectory")
    j = int(rng.choice(ok)) + 1
    level = min(max(_uniform(rng, eff["saturation"]) * float(peak[j - 1]), 1.15 * float(static[j - 1])),
                0.95 * float(peak[j - 1]))
    p = {f"{pre}[{j}].effort_max": level}
    return Hidden("saturation", p, [j], {k: nominal[k] for k in p})


def _geometry_error(model, rng, eff, nominal, sign) -> Hidden:
    """A geometric error, added with ``sign`` to a parameter the core names for one: one per
    joint (a joint is drawn), else the first of the robot's list (derived lists: a random one)."""
    geo, per_joint = geometry_layout(model)
    if per_joint:
        j = int(rng.integers(1, model.ndof + 1))
        name, js = geo[j - 1], [j]
    elif model.facts.geometry_params:
        name, js = geo[0], []
    else:
        name, js = geo[int(rng.integers(len(geo)))], []
    return Hidden("geometry", {name: nominal[name] + sign * _uniform(rng, eff["geometry"])}, js, {name: nominal[name]})


#: forces in no effect of the library, for the discovery step's proof: kind -> what it is.
#: Sizes relative to the joint's RMS feed-forward effort E, position spread T and RMS rate V
#: along the case's reference; each is a combination of the core's generic joint force.
UNLISTED = {
    "constant_force": "a constant force on one joint (a cable carrier pulling one way)",
    "ripple": "a force periodic in the position on every joint (cogging, screw ripple)",
    "spring": "a spring towards the home position on one joint",
    "drag": "quadratic drag qd |qd| on one joint",
    "direction_coulomb": "Coulomb friction that differs by direction on one joint",
    "one_way_damper": "a damper acting only when the joint moves in its positive direction",
    "hardening_spring": "a cubic (hardening) spring about the home position on one joint",
}


def sample_unlisted(kind, model, rng, motion) -> Hidden:
    """Draw one force of :data:`UNLISTED` for ``model``; ``motion`` holds per joint ``E`` (RMS
    feed-forward effort), ``T`` (position spread), ``V`` (RMS rate), ``span`` (stroke used)
    and ``home`` (joint position at the home pose) of the case's reference, and ``q`` its joint
    positions (samples x joints)."""
    pre = joint_prefix(model)
    nd = model.ndof
    E, T, V, span, home = (np.asarray(motion[k], float) for k in ("E", "T", "V", "span", "home"))
    j = int(rng.integers(0, nd))
    size = float(rng.uniform(0.1, 0.2))
    name = lambda i, k: f"{pre}[{i + 1}].force_{k}"  # noqa: E731
    if kind == "constant_force":  # the drive's offset: the library's offset effect names it too
        p, js = {f"{pre}[{j + 1}].offset": float(rng.choice([-1, 1])) * size * E[j]}, [j]
    elif kind == "ripple":
        p, js = {}, list(range(nd))
        for i in js:
            ph = rng.uniform(0, 2 * math.pi)
            p.update({name(i, "period"): float(span[i] / rng.uniform(4, 8)),
                      name(i, "sin"): size * E[i] * math.cos(ph), name(i, "cos"): size * E[i] * math.sin(ph)})
    elif kind == "spring":
        p, js = {name(j, "qc"): float(home[j]), name(j, "k1"): 1.5 * size * E[j] / T[j]}, [j]
    elif kind == "drag":
        p, js = {name(j, "v2"): 1.5 * size * E[j] / V[j] ** 2}, [j]
    elif kind == "direction_coulomb":
        hi, lo = size * E[j], float(rng.uniform(0.0, 0.3)) * size * E[j]
        p, js = ({name(j, "cpos"): hi, name(j, "cneg"): lo} if rng.uniform() < 0.5 else
                 {name(j, "cpos"): lo, name(j, "cneg"): hi}), [j]
    elif kind == "one_way_damper":
        p, js = {name(j, "vpos"): 2.0 * size * E[j] / V[j]}, [j]
    elif kind == "hardening_spring":
        p, js = {name(j, "qc"): float(home[j]), name(j, "k3"): size * E[j] / T[j] ** 3}, [j]
    elif kind in FAMILY_KINDS:  # the term families' forces (families/generator.py)
        p, js = family_sample(kind, rng, motion, lambda i, k: f"{pre}[{i + 1}].{k}", nd)
    else:
        raise InputError(f"the generator cannot hide force {kind!r} (it can hide: {', '.join(UNLISTED)})")
    nominal = model.params()
    return Hidden(kind, {k: float(v) for k, v in p.items()}, [i + 1 for i in js], {k: nominal[k] for k in p})


#: the coefficients (core keys) each force of UNLISTED must be found with
UNLISTED_TERMS = {"constant_force": {"offset"}, "ripple": {"force_sin", "force_cos"}, "spring": {"force_k1"},
                  "drag": {"force_v2"}, "direction_coulomb": set(), "one_way_damper": {"force_vpos"},
                  "hardening_spring": {"force_k3"}}


def unlisted_errors(kind: str, term, truth: dict) -> list:
    """Relative errors of a discovered term's coefficients against a hidden force of
    :data:`UNLISTED` (``truth``: the key's effect entry); for a spring its stiffness and its
    rest position (its distance to the truth over the joint's position spread, the key's
    ``spread``, merged into ``truth``)."""
    p, t = truth["params"], term.params()
    j = term.joint
    pre = next(iter(p)).split("[")[0] + f"[{j}]."
    key_of = lambda k: pre + ("offset" if k == "c" else "force_" + k)  # noqa: E731 - the constant: the offset
    got = lambda k: t.get(key_of(k), 0.0)  # noqa: E731
    want = lambda k: p.get(key_of(k), 0.0)  # noqa: E731
    rel = lambda a, b: abs(a / b - 1) if b else float("inf")  # noqa: E731
    if kind == "ripple":
        return [rel(math.hypot(got("sin"), got("cos")), math.hypot(want("sin"), want("cos"))),
                rel(got("period"), want("period"))]
    if kind == "spring":
        k = got("k1")
        q0 = got("qc") - got("c") / k if k else float("inf")
        return [rel(k, want("k1")), abs(q0 - want("qc")) / truth["spread"][j - 1]]
    if kind == "direction_coulomb":
        side = "cpos" if want("cpos") > want("cneg") else "cneg"
        return [rel(got(side), want(side))]
    key = {"constant_force": "c", "drag": "v2", "one_way_damper": "vpos", "hardening_spring": "k3"}[kind]
    return [rel(got(key), want(key))]


def unlisted_structure_ok(kind: str, term, truth: dict) -> bool:
    """The term has the structure of the hidden force: its coefficients (for a Coulomb
    friction that differs by direction, the larger side's)."""
    need = set(UNLISTED_TERMS[kind])
    if kind == "direction_coulomb":
        hi = max(truth["params"], key=lambda n: truth["params"][n])
        need = {hi.rsplit(".", 1)[1]}
    return need <= {p.rsplit(".", 1)[1] for p in term.coefficients}
