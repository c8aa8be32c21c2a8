"""The library of missing-physics effects the engine knows.

Each :class:`Effect` is a named physical term with its core parameter(s), unit, the
residual family it shows in, how its regressor is built, the sign it may take, the
motion that excites it, the effects it can be confused with, and how it enters the
plant.  Every regressor comes from the core: it is the change of the residual
pipeline (:mod:`cosim.discrepancy.residuals`) when the effect's core parameter is
moved, by finite differences, so no equation is re-derived here.

``<j>`` below is the robot's joint prefix ("rail" for the 6-PUS, "joint" for the
Quattro and the four-bar) and ``i`` the 1-based joint.  The families:

* ``effort``: tau_recorded - ID_core(motion) (N or N m);
* ``kinematic``: q_recorded - (sensor model of the core at the tracker pose) (m or
  rad), only when the recording has tracker pose columns.

Kinds of regressor:

* ``linear``: the core's residual is linear in the parameter (friction amplitudes,
  masses, inertias, gravity components, encoder offset, compliance, backlash gap): one
  one-sided difference gives the exact column;
* ``stribeck``: linear amplitude, the Stribeck velocity by a profile grid;
* ``payload``: linear in (m, m c) at m = 0, then Gauss-Newton on (m, c) through the core;
* ``geometry``: central differences of the core's IK (and of the dynamics at the
  moved pose), identifiable subspace by SVD;
* ``delay``: a profile over the delay (the recorded signals shifted in time);
* ``saturation``: a profile over an actuator level, the effort limit or the dead-zone
  width (both through the core's ``pkm_actuator_effort``).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Effect:
    """One missing-physics term of the library.

    Attributes
    ----------
    key : str
        Short identifier (``"coulomb"``).
    name : str
        Human name (``"Coulomb friction"``).
    family : str
        ``"effort"``, ``"kinematic"`` or ``"both"``.
    scope : str
        ``"joint"`` (one group per actuated joint) or ``"global"``.
    params : tuple of str
        Core parameter templates (``"{j}[{i}].coulomb"``); empty for the geometry effect,
        whose parameters the core names (:meth:`cosim.core.Model.geometry_params`).
    kind : str
        Regressor kind (see the module docstring).
    sign : str
        ``">=0"`` (a physical magnitude) or ``"any"`` (an error of a nominal value).
    requires : str
        What data and motion excite it (said when they are missing).
    lookalikes : tuple of str
        Keys of effects whose signature can be confused with this one.
    plant : str
        How the fitted effect enters the plant (core / FMU parameter or variant).
    regressor : str
        The signature, in words.
    """

    key: str
    name: str
    family: str
    scope: str
    params: tuple
    kind: str
    sign: str
    requires: str
    lookalikes: tuple = ()
    plant: str = ""
    regressor: str = ""


LIBRARY = [
    Effect("coulomb", "Coulomb friction", "effort", "joint", ("{j}[{i}].coulomb",), "linear", ">=0",
           "motion of the joint in both directions (velocity reversals)",
           ("stribeck", "viscous", "saturation", "smooth_coulomb"),
           "core/FMU parameter {j}[i].coulomb (inside the inverse and forward dynamics)",
           "F_c sgn(qd_i) on the effort of joint i"),
    Effect("viscous", "viscous friction", "effort", "joint", ("{j}[{i}].viscous",), "linear", ">=0",
           "a range of joint speeds (slow and fast motion of the joint)",
           ("coulomb", "actuator_delay"),
           "core/FMU parameter {j}[i].viscous",
           "b qd_i on the effort of joint i"),
    Effect("stribeck", "Stribeck friction", "effort", "joint", ("{j}[{i}].stribeck", "{j}[{i}].stribeck_v"),
           "stribeck", ">=0",
           "slow velocity reversals (joint speeds below and well above the Stribeck velocity)",
           ("coulomb",),
           "core/FMU parameters {j}[i].stribeck and {j}[i].stribeck_v",
           "F_s exp(-(qd_i/v_s)^2) sgn(qd_i) on the effort of joint i"),
    Effect("smooth_coulomb", "friction that fades at low speed (Coulomb with a velocity scale)", "effort", "joint",
           ("{j}[{i}].coulomb", "{j}[{i}].coulomb_v"), "stribeck", ">=0",
           "slow motion of the joint (speeds around the velocity scale) and fast motion",
           ("coulomb", "viscous", "stribeck"),
           "core/FMU parameters {j}[i].coulomb and {j}[i].coulomb_v",
           "F_c tanh(qd_i / v_c) on the effort of joint i (full friction only above a few v_c)"),
    Effect("rotor_inertia", "actuator (rotor) inertia", "effort", "joint", ("{j}[{i}].rotor_inertia",),
           "linear", ">=0",
           "joint accelerations",
           ("platform_mass", "actuator_delay"),
           "core/FMU parameter {j}[i].rotor_inertia (added to the mass matrix)",
           "J_r qdd_i on the effort of joint i (for the 6-PUS the same as a slider-mass error)"),
    Effect("payload", "payload (mass and offset)", "effort", "global", ("payload.m", "payload.x", "payload.y",
                                                                          "payload.z"),
           "payload", ">=0",
           "platform accelerations and rotations (an off-centre payload shows in moments)",
           ("platform_mass", "platform_inertia", "gravity_tilt"),
           "core/FMU parameters payload.m, payload.x/y/z",
           "d ID / d payload.m and d ID / d(m c) by central differences of the core"),
    Effect("platform_mass", "platform mass error", "effort", "global", ("platform.m",), "linear", "any",
           "vertical motion or accelerations of the platform",
           ("payload", "gravity_tilt"),
           "core/FMU parameter platform.m",
           "d ID / d platform.m"),
    Effect("platform_inertia", "platform inertia error", "effort", "global",
           ("platform.Ixx", "platform.Iyy", "platform.Izz"), "linear", "any",
           "angular accelerations of the platform about x, y and z",
           ("payload",),
           "core/FMU parameters platform.Ixx, .Iyy, .Izz",
           "d ID / d platform.I**"),
    Effect("gravity_tilt", "gravity direction tilt", "effort", "global", ("gravity.x", "gravity.y"), "linear",
           "any",
           "poses spread over the workspace (the tilt shows as a horizontal load that moves with the pose)",
           ("payload", "platform_mass"),
           "core/FMU parameters gravity.x, gravity.y (the base is tilted)",
           "d ID / d gravity.x, d ID / d gravity.y"),
    Effect("actuator_delay", "actuator time delay", "effort", "global", ("actuator.delay",), "delay", ">=0",
           "changing efforts (accelerations)",
           ("sensor_delay", "rotor_inertia", "viscous"),
           "core/FMU parameter actuator.delay (the integrator delays the applied effort)",
           "tau_rec(t) - tau_rec(t - d): about d dtau/dt"),
    Effect("sensor_delay", "sensor lag (delayed joint readings)", "both", "global", ("sensor.delay",), "delay",
           ">=0",
           "tracker pose columns and motion (without a tracker it looks exactly like an actuator delay)",
           ("actuator_delay",),
           "core/FMU parameter sensor.delay (the joint readings are delayed)",
           "effort: about d dtau/dt; kinematic: -d qd"),
    Effect("saturation", "actuator saturation", "effort", "joint", ("{j}[{i}].effort_max",), "saturation", ">=0",
           "commanded efforts reaching the limit",
           ("coulomb",),
           "core/FMU parameter {j}[i].effort_max (|tau| clipped)",
           "tau_cmd - clip(tau_cmd, +-L) where the command exceeds L"),
    Effect("dead_zone", "drive dead zone", "effort", "joint", ("{j}[{i}].dead_zone",), "saturation", ">=0",
           "commanded efforts of the joint on both sides of zero, and near it",
           ("coulomb", "payload", "saturation"),
           "core/FMU parameter {j}[i].dead_zone (the drive delivers nothing within +-u0 and u - u0 sgn(u) beyond)",
           "u0 sgn(tau_cmd) where |tau_cmd| > u0, tau_cmd within the band"),
    Effect("offset", "constant effort offset", "effort", "joint", ("{j}[{i}].offset",), "linear", "any",
           "motion of the joint (a constant effort shows against any motion; told from a payload or a tilt by "
           "accelerations and poses, from a dead zone by commands of both signs)",
           ("payload", "gravity_tilt", "dead_zone", "platform_mass"),
           "core/FMU parameter {j}[i].offset (the drive supplies inverse dynamics + friction + offset: a cable "
           "carrier, an unbalanced mass on a vertical axis, a bias of the effort measurement)",
           "a constant on the effort of joint i"),
    Effect("encoder_offset", "encoder offset", "kinematic", "joint", ("{j}[{i}].encoder_offset",), "linear", "any",
           "tracker pose columns",
           ("geometry",),
           "core/FMU parameter {j}[i].encoder_offset (sensor model)",
           "a constant on joint reading i"),
    Effect("backlash", "backlash (transmission gap, contact side set by the transmitted effort)", "kinematic", "joint",
           ("{j}[{i}].backlash",), "linear", ">=0",
           "tracker pose columns and sign changes of the joint's effort",
           ("encoder_offset", "compliance"),
           "core/FMU parameter {j}[i].backlash (sensor model)",
           "b/2 sgn(tau_i) on joint reading i (encoder on the drive side)"),
    Effect("compliance", "joint elasticity (transmission compliance)", "kinematic", "joint",
           ("{j}[{i}].compliance",), "linear", ">=0",
           "tracker pose columns and varying efforts on the joint",
           ("encoder_offset", "geometry", "backlash"),
           "core/FMU parameter {j}[i].compliance (sensor model: deflection c tau)",
           "c tau_i on joint reading i"),
    Effect("geometry", "geometric (kinematic) parameter error", "kinematic", "joint", (), "geometry",
           "any",
           "tracker pose columns and poses spread over the workspace",
           ("encoder_offset", "compliance"),
           "core/FMU geometry parameters as the core names them (pkm_model_geometry_param: the rod "
           "length leg[i].L of each leg of the 6-PUS and the Quattro; else every length that moves a joint)",
           "dIK/dp by central differences of the core's inverse kinematics"),
]

BY_KEY = {e.key: e for e in LIBRARY}

#: parameters the pipeline treats as geometry (the pose must be recomputed)
GEOMETRY_KINDS = ("geometry",)

#: which motion separates two look-alikes (unordered pairs)
SEPARATING_MOTION = {
    frozenset(("coulomb", "smooth_coulomb")): "slow motion of the joint, at speeds of the order of the velocity scale "
                                              "(a step friction is full there, a fading one is not)",
    frozenset(("viscous", "smooth_coulomb")): "constant-velocity phases at two or more speeds well above the velocity "
                                              "scale (viscous friction keeps growing, a fading Coulomb is flat)",
    frozenset(("stribeck", "smooth_coulomb")): "slow motion of the joint (a Stribeck peak is largest at low speed, a "
                                               "fading friction smallest)",
    frozenset(("coulomb", "stribeck")): "slow velocity reversals (joint speeds below the Stribeck velocity, then "
                                        "well above it)",
    frozenset(("coulomb", "viscous")): "constant-velocity phases at two or more different speeds",
    frozenset(("coulomb", "saturation")): "moves whose commanded effort stays well below the actuator limit",
    frozenset(("coulomb", "dead_zone")): "moves where the command changes sign while the joint keeps moving the same "
                                         "way (friction follows the velocity, a dead zone the command)",
    frozenset(("payload", "dead_zone")): "accelerations of the platform with the efforts far from zero (a payload "
                                         "scales with the motion, a dead zone is a constant band)",
    frozenset(("saturation", "dead_zone")): "efforts near zero and near the limit (a dead zone acts at small commands, "
                                            "a saturation at large ones)",
    frozenset(("coulomb", "backlash")): "a tracker (pose columns) with effort sign changes: backlash shows in the "
                                        "joint readings, friction in the effort",
    frozenset(("stribeck", "backlash")): "a tracker (pose columns) with slow effort sign changes",
    frozenset(("payload", "platform_mass")): "platform rotations with an off-centre payload (its moments), or "
                                             "weighing the platform",
    frozenset(("payload", "platform_inertia")): "translational accelerations (a payload adds mass, an inertia "
                                                "error does not)",
    frozenset(("offset", "payload")): "accelerations of the platform and poses spread over the workspace (a "
                                      "payload scales with the motion and the pose, an offset does not)",
    frozenset(("offset", "gravity_tilt")): "poses spread over the workspace (a tilt's load changes with the pose, "
                                           "an offset does not; on a single straight axis they are the same physics)",
    frozenset(("offset", "platform_mass")): "vertical accelerations (a mass error scales with them, an offset does "
                                            "not)",
    frozenset(("offset", "dead_zone")): "commands of both signs on the joint (a dead zone takes u0 off either "
                                        "side, an offset shifts both the same way; under a one-signed command they "
                                        "are the same constant)",
    frozenset(("payload", "gravity_tilt")): "vertical accelerations (a payload has inertia, a tilt does not)",
    frozenset(("platform_mass", "gravity_tilt")): "vertical accelerations and horizontal poses spread widely",
    frozenset(("actuator_delay", "sensor_delay")): "a tracker (pose columns): a sensor lag shows as q_rec - "
                                                   "IK(tracker) = -d qd, an actuator delay does not",
    frozenset(("actuator_delay", "rotor_inertia")): "accelerations at several frequencies (a delay grows with "
                                                    "frequency, an inertia with acceleration)",
    frozenset(("actuator_delay", "viscous")): "constant-velocity phases (no effort change, so no delay signature)",
    frozenset(("rotor_inertia", "platform_mass")): "moves of single joints (a rotor inertia acts on one joint only)",
    frozenset(("encoder_offset", "geometry")): "poses spread over the workspace (an offset is constant, a length "
                                               "error varies with the pose)",
    frozenset(("compliance", "encoder_offset")): "efforts that change sign on the joint",
    frozenset(("compliance", "geometry")): "the same poses reached with different loads",
    frozenset(("backlash", "encoder_offset")): "sign changes of the joint's effort (against gravity and with it)",
    frozenset(("backlash", "compliance")): "efforts of both signs and of several sizes (a gap jumps at the sign "
                                           "change, an elasticity grows with the effort)",
    frozenset(("backlash", "sensor_delay")): "reversals at different speeds (a lag scales with the speed, "
                                             "backlash does not)",
}


def separating_motion(a: str, b: str) -> str:
    return SEPARATING_MOTION.get(frozenset((a, b)), "motion that excites the two signatures differently")


def joint_prefix(model) -> str:
    """The drive-parameter prefix of a model's joints, as the core names it
    (``pkm_model_joint_prefix``: "rail" for the 6-PUS, "joint" for the Quattro, "arm" or
    "strut" for described robots)."""
    pre = model.facts.joint_prefix
    if pre and f"{pre}[1].coulomb" in set(model.param_names()):
        return pre
    names = set(model.param_names())
    for p in ("rail", "joint"):
        if f"{p}[1].coulomb" in names:
            return p
    return "joint"


@dataclass(eq=False)
class Group:
    """One candidate of the selection: an effect on one joint (or global).

    ``params`` are the resolved core parameter names; ``joint`` is 0-based or None.
    """

    effect: Effect
    joint: int | None
    params: tuple

    @property
    def key(self) -> str:
        return self.effect.key

    @property
    def label(self) -> str:
        return self.effect.key + ("" if self.joint is None else f"[{self.joint + 1}]")

    @property
    def title(self) -> str:
        return self.effect.name + ("" if self.joint is None else f", joint {self.joint + 1}")


def geometry_layout(model) -> tuple[list, bool]:
    """The geometry effect's parameters for ``model`` and whether there is one per joint
    (n-th name indexed ``[n]``, as the 6-PUS ``leg[n].L``)."""
    geo = model.geometry_params()
    return geo, len(geo) == model.ndof and all(f"[{i + 1}]" in n for i, n in enumerate(geo))


def groups_for(model, has_pose: bool, effects=None):
    """Candidate groups of the library for a model.

    Returns ``(groups, unavailable)``: the groups whose core parameters the model has
    and whose data is there, and a list of ``(effect, reason)`` for the others.
    """
    names = set(model.param_names())
    pre = joint_prefix(model)
    nd = model.ndof
    groups, unavailable = [], []
    for e in LIBRARY:
        if effects is not None and e.key not in effects:
            continue
        if e.family == "kinematic" and not has_pose:
            unavailable.append((e, "the recording has no tracker pose columns; this effect shows in the joint "
                                   "readings against an external pose measurement"))
            continue
        if e.kind == "geometry":
            # The core names them (one per joint where the error is per joint), or they are
            # every length that moves a joint.
            geo, per_joint = geometry_layout(model)
            if per_joint:
                groups += [Group(e, i, (n,)) for i, n in enumerate(geo)]
            elif geo:
                groups.append(Group(e, None, tuple(geo)))
            else:
                unavailable.append((e, f"the {model.robot} model has no length parameter that moves a joint"))
            continue
        tpl = e.params
        if e.scope == "joint" and any("{i}" in t for t in tpl):
            made = []
            for i in range(nd):
                ps = tuple(t.format(j=pre, i=i + 1) for t in tpl)
                if all(p in names for p in ps):
                    made.append(Group(e, i, ps))
            if not made:
                unavailable.append((e, f"the {model.robot} model has no parameter {tpl[0].format(j=pre, i=1)}"))
            groups += made
        else:
            ps = tuple(p for p in (t.format(j=pre, i=1) for t in tpl) if p in names)
            if not ps:
                unavailable.append((e, f"the {model.robot} model has none of {', '.join(tpl)}"))
                continue
            groups.append(Group(e, None, ps))
    return groups, unavailable
