"""Blind cases: recordings with hidden effects, their answer keys, and the benchmark.

A case is a closed-loop recording (:func:`cosim.discrepancy.plant.closed_loop`) of a
core plant in which one or two effects of the library are set (the "hidden" physics)
while the recording's sidecar gives the nominal model only.  The controller (PD +
gravity compensation or computed torque, designed on the nominal model) tracks an
exciting trajectory (:mod:`cosim.discrepancy.excitation`), so the positions track well
and the signature is in the effort and the readings.  The answer key goes to a
separate directory; :func:`cosim.discrepancy.diagnose` reads only the recording.

Magnitudes, noise and the controller come from ``scenarios/blind/config.toml``.

Example
-------
>>> from cosim.discrepancy import blind
>>> rec_path, key_path = blind.make_case(blind.CaseSpec("c1", "6pus", ["coulomb"], seed=1),
...                                      out_dir="/tmp/blind", key_dir="/tmp/blind_keys")
"""
from __future__ import annotations

import json
import math
import time
import tomllib
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .effects import BY_KEY, geometry_layout, joint_prefix
from .families.generator import KINDS as FAMILY_KINDS, sample as family_sample
from ..errors import InputError
from .diagnosis import UNEXPLAINED, tied

REPO = Path(__file__).resolve().parents[2]
CONFIG = REPO / "scenarios" / "blind" / "config.toml"

#: effect types the generator can hide, per robot (those with magnitudes in the config)
TYPES = ["coulomb", "viscous", "stribeck", "smooth_coulomb", "rotor_inertia", "payload", "platform_mass", "platform_inertia",
         "gravity_tilt", "actuator_delay", "sensor_delay", "saturation", "dead_zone", "encoder_offset", "backlash",
         "compliance", "geometry", "offset"]


def load_config(path=None) -> dict:
    """The generator configuration (TOML)."""
    with open(path or CONFIG, "rb") as f:
        return tomllib.load(f)


def with_robot(cfg: dict, model) -> dict:
    """``cfg`` with effect sizes and noise for ``model``'s robot: the configuration's own
    ``[effects.<robot>]`` / ``[noise.<robot>]``, or, for a robot it does not list, sizes derived
    from the core (:func:`derived_sizes`)."""
    if model.robot in cfg.get("effects", {}) and model.robot in cfg.get("noise", {}):
        return cfg
    effects, noise = derived_sizes(model)
    out = dict(cfg)
    out["effects"] = {**cfg.get("effects", {}), model.robot: effects}
    out["noise"] = {**cfg.get("noise", {}), model.robot: noise}
    return out


def derived_sizes(model) -> tuple[dict, dict]:
    """Effect sizes and sensor noise for a robot the configuration does not list, from the core.

    Along 4 s of the robot's exciting motion (:func:`cosim.discrepancy.excitation.excitation`),
    per joint: RMS effort E (inverse dynamics), RMS rate V, joint travel Q (standard deviation)
    and the joint-space mass at home m.  The sizes are the 6-PUS configuration's, relative:
    friction 2-6 % of E, rotor inertia 10-25 % of m, dead zone 3-8 % of E, a constant effort
    offset 3-10 % of E (sign random), encoder offsets and gaps
    0.2-1 % of Q, an elasticity deflecting 0.2-1 % of Q under E; noise 1e-4 Q on the readings,
    4e-3 V on the rates, 7e-3 E on the efforts, 5e-4 of the motion's amplitude on the tracker.
    Only effects whose parameters the robot has are listed.
    """
    from .. import controllers as ctl
    from ..master import make_reference
    from .excitation import excitation

    traj = excitation(model, 4.0, seed=0)
    ref = make_reference(model, traj, step=1e-3, duration=round(traj.duration / 1e-3) * 1e-3)
    tau = model.inverse_dynamics(ref.x, ref.xd, ref.xdd)
    E = float(np.sqrt(np.mean(tau ** 2)))
    V = float(np.sqrt(np.mean(ref.qd ** 2)))
    Q = float(np.mean(np.std(ref.q, axis=0)))
    m = float(np.max(np.diag(ctl.joint_mass(model, model.home()))))
    names = set(model.param_names())
    e = {"coulomb": [0.02 * E, 0.06 * E], "viscous": [0.02 * E / V, 0.06 * E / V],
         "stribeck": [0.04 * E, 0.08 * E], "stribeck_v": [0.04 * V, 0.12 * V],
         "smooth_coulomb": [0.03 * E, 0.07 * E], "smooth_coulomb_v": [0.05 * V, 0.15 * V],
         "rotor_inertia": [0.1 * m, 0.25 * m], "actuator_delay": [0.002, 0.006], "sensor_delay": [0.002, 0.006],
         "saturation": [0.8, 0.92], "encoder_offset": [0.002 * Q, 0.01 * Q], "backlash": [0.002 * Q, 0.01 * Q],
         "compliance": [0.002 * Q / E, 0.01 * Q / E], "dead_zone": [0.03 * E, 0.08 * E],
         "offset": [0.03 * E, 0.1 * E]}
    if "platform.m" in names:
        e["platform_mass"] = [0.06, 0.15]
    if "payload.m" in names and "platform.m" in names:
        e["payload_m"] = [0.1 * model.param("platform.m"), 0.2 * model.param("platform.m")]
    if {"gravity.x", "gravity.y"} <= names:
        e["gravity_tilt"] = [0.4, 1.2]
    amp = np.std(ref.x, axis=0)
    noise = {"q": 1e-4 * Q, "qd": 4e-3 * V, "tau": 7e-3 * E, "pose": (5e-4 * amp).tolist()}
    return e, noise


def types_for(robot: str, cfg: dict) -> list:
    eff = cfg["effects"][robot]
    out = []
    for t in TYPES:
        key = {"payload": "payload_m"}.get(t, t)
        if key in eff:
            out.append(t)
    return out


@dataclass
class CaseSpec:
    """What to hide in one case (``hidden`` effect types, [] for a clean case)."""

    case: str
    robot: str
    hidden: list
    seed: int
    controller: str | None = None


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
        # tau_peak = (peak effort, largest gravity load) per joint: a limit below the
        # gravity load would drop the robot, so the level stays above it, on a joint whose
        # peaks are well above its gravity load.
        peak, static = tau_peak[:2]
        ok = [j for j in range(nd) if peak[j] > 1.25 * static[j]]
        if not ok:
            raise _Redraw("no joint's peak effort is well above its gravity load on this trajectory")
        j = int(rng.choice(ok)) + 1
        level = min(max(_uniform(rng, eff["saturation"]) * float(peak[j - 1]), 1.15 * float(static[j - 1])),
                    0.95 * float(peak[j - 1]))
        p = {f"{pre}[{j}].effort_max": level}
        return Hidden(kind, p, [j], {k: nominal[k] for k in p})
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
        # The parameters the core names for a geometric error: one per joint (a joint is
        # drawn), else the first of the robot's list (derived lists: a random one).
        geo, per_joint = geometry_layout(model)
        if per_joint:
            j = int(rng.integers(1, nd + 1))
            name, js = geo[j - 1], [j]
        elif model.facts.geometry_params:
            name, js = geo[0], []
        else:
            name, js = geo[int(rng.integers(len(geo)))], []
        return Hidden(kind, {name: nominal[name] + sign * _uniform(rng, eff[kind])}, js, {name: nominal[name]})
    raise InputError(f"the generator cannot hide effect type {kind!r} (it can hide: {', '.join(TYPES)})")


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
    and ``home`` (joint position at the home pose) of the case's reference."""
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


def _controller(kind, model, cfg, dt):
    from .. import controllers as ctl

    wn = 2 * math.pi * cfg["general"].get("bandwidth_hz", 8.0)
    if kind == "computed_torque":
        return ctl.computed_torque(model, kp=wn**2, kd=2 * wn)
    mass = float(ctl.joint_mass(model, model.home()).diagonal().max())
    return ctl.pd_gravity(model, kp=mass * wn**2, kd=2 * wn * mass)


def simulate_case(spec: CaseSpec, cfg: dict | None = None):
    """Simulate one case: returns ``(recording, hidden effects, info)``.

    ``cfg`` is the generator configuration (default: ``scenarios/blind/config.toml``);
    tests pass a copy with a shorter duration."""
    from ..core.model import Model
    from ..master import make_reference
    from ..recording import Recording
    from .excitation import excitation
    from .plant import closed_loop

    from .._native import PkmError

    nominal = Model(spec.robot)
    cfg = with_robot(cfg or load_config(), nominal)
    gen = cfg["general"]
    dt = 1.0 / gen["rate"]
    lead = gen.get("lead_in", 0.5)
    k0 = int(round(lead / dt))
    failures = []
    shrink = 0
    for attempt in range(10):
        # A plant the controller cannot hold (a tight saturation with a heavy payload
        # drives a leg to its stroke end) is drawn again, from a derived seed, with a
        # smaller motion; a trajectory that cannot carry the effect, with another seed.
        # The failures are kept in the answer key.
        seed = spec.seed + 1000003 * attempt
        rng = np.random.default_rng(seed)
        traj = excitation(nominal, gen["duration"], seed=seed, lead_in=lead, scale=0.85**shrink)
        ref = make_reference(nominal, traj, step=dt, duration=round(traj.duration / dt) * dt)
        # A saturation level relative to the smaller of the peak efforts before and after
        # the 70 % mark: the limit is reached in the fitted and in the held-out part alike.
        signed = nominal.inverse_dynamics(ref.x[k0:], ref.xd[k0:], ref.xdd[k0:])
        tau_ff = np.abs(signed)
        cut = int(0.7 * len(tau_ff))
        neg = np.mean(signed < 0, axis=0)
        tau_peak = (np.minimum(tau_ff[:cut].max(axis=0), tau_ff[cut:].max(axis=0)),
                    np.abs(nominal.gravity_load(ref.x[k0::50])).max(axis=0), np.minimum(neg, 1 - neg))
        qd_ref = np.gradient(ref.q[k0:], dt, axis=0)
        motion = {"E": np.sqrt(np.mean(signed**2, axis=0)), "T": ref.q[k0:].std(axis=0),
                  "V": np.sqrt(np.mean(qd_ref**2, axis=0)), "span": np.ptp(ref.q[k0:], axis=0),
                  "home": nominal.ik(nominal.home())}
        try:
            hidden = [sample_unlisted(k, nominal, rng, motion) if k in UNLISTED or k in FAMILY_KINDS else
                      sample_effect(k, nominal, rng, cfg, tau_peak) for k in spec.hidden]
        except _Redraw as e:
            failures.append(f"attempt {attempt + 1}: {e}")
            continue
        plant = nominal.copy()
        for h in hidden:
            plant.set_params(h.params)
        kind = spec.controller or str(rng.choice(gen.get("controllers", ["pd_gravity"])))
        ctrl = _controller(kind, nominal, cfg, dt)
        noise = cfg["noise"][nominal.robot]
        try:
            res = closed_loop(plant, ctrl, ref, noise=noise, seed=seed + 7919)
            break
        except PkmError as e:
            failures.append(f"attempt {attempt + 1}: {e}")
            shrink += 1
    else:
        raise RuntimeError(f"blind case {spec.case}: no closed-loop run succeeded: " + "; ".join(failures))
    s = slice(k0, None)
    rec = Recording(nominal.robot, res.time[s].copy(), res.q[s].copy(), res.qd[s].copy(), res.tau[s].copy(),
                    qref=ref.q[s].copy(), pose=res.pose[s].copy(),
                    extra={"label": ref.label[s].astype(float)},
                    controller=dict(ctrl.describe(), rate_hz=gen["rate"]),
                    notes=f"blind case {spec.case}: closed-loop recording of a plant that may hide effects the "
                          f"model lacks (the answer key is elsewhere)")
    info = {"controller": kind, "noise": noise, "tau_peak": tau_peak[0].tolist(), "trajectory": traj.name,
            "spread": ref.q[k0:].std(axis=0).tolist(),
            "failed_attempts": failures}
    return rec, hidden, info


def make_case(spec: CaseSpec, out_dir, key_dir, cfg: dict | None = None):
    """Write the case's recording to ``out_dir/<case>.csv`` (+ sidecar) and its answer
    key to ``key_dir/<case>.json``; returns both paths."""
    from ..recording import write_recording

    out_dir, key_dir = Path(out_dir), Path(key_dir)
    if out_dir.resolve() == key_dir.resolve():
        raise InputError("the answer keys must go to a directory apart from the recordings")
    rec, hidden, info = simulate_case(spec, cfg)
    csv, _ = write_recording(out_dir / f"{spec.case}.csv", rec)
    key_dir.mkdir(parents=True, exist_ok=True)
    key = {"case": spec.case, "robot": spec.robot, "seed": spec.seed, "recording": str(csv),
           "effects": [asdict(h) for h in hidden], **info}
    kp = key_dir / f"{spec.case}.json"
    kp.write_text(json.dumps(key, indent=2))
    return csv, kp


def plan(n_effect: int, n_clean: int, seed: int, robots=("6pus",), cfg: dict | None = None) -> list:
    """Case specs: ``n_effect`` cases cycling over the effect types of each robot (so
    every type gets its share), a fraction with a second non-look-alike effect, and
    ``n_clean`` clean cases; robots alternate."""
    from ..core.model import Model

    cfg = cfg or load_config()
    for r in robots:
        cfg = with_robot(cfg, Model(r))
    rng = np.random.default_rng(seed)
    specs = []
    queues = {r: [] for r in robots}
    for k in range(n_effect):
        r = robots[k % len(robots)]
        if not queues[r]:
            queues[r] = list(rng.permutation(types_for(r, cfg)))
        first = str(queues[r].pop())
        hidden = [first]
        if rng.uniform() < cfg["general"].get("two_effects", 0.0):
            others = [t for t in types_for(r, cfg) if t != first and t not in BY_KEY[first].lookalikes
                      and first not in BY_KEY[t].lookalikes]
            hidden.append(str(rng.choice(others)))
        specs.append(CaseSpec(f"case{k + 1:03d}", r, hidden, int(rng.integers(1, 2**31 - 1))))
    for k in range(n_clean):
        r = robots[k % len(robots)]
        specs.append(CaseSpec(f"clean{k + 1:03d}", r, [], int(rng.integers(1, 2**31 - 1))))
    return specs


# ------------------------------------------------------------------- scoring

def _param_error(h: dict, values: dict) -> float:
    """Relative error of the estimated change of the hidden parameters (vector norm);
    for delays/saturation levels/... the parameter itself."""
    names = list(h["params"])
    true = np.array([h["params"][n] - h["nominal"].get(n, 0.0) for n in names])
    est = np.array([values.get(n, h["nominal"].get(n, 0.0)) - h["nominal"].get(n, 0.0) for n in names])
    if h["type"] in ("stribeck", "smooth_coulomb"):  # amplitude only; the velocity is reported apart
        true, est = true[:1], est[:1]
    if h["type"] in ("saturation", "dead_zone"):
        true = np.array([h["params"][n] for n in names])
        # a dead zone under a command of one sign is a constant offset of its width (the same
        # physics, which the engine declares a tie): its size then stands for the width
        est = np.array([values[n] if n in values else abs(values.get(n.replace(".dead_zone", ".offset"), 0.0))
                        if h["type"] == "dead_zone" else 0.0 for n in names])
    if h["type"] == "gravity_tilt":
        keep = [i for i, n in enumerate(names) if n != "gravity.z"]
        true, est = true[keep], est[keep]
    if h["type"] == "payload":
        true, est = true[:1], est[:1]
    nrm = np.linalg.norm(true)
    return float(np.linalg.norm(est - true) / nrm) if nrm > 0 else float("nan")


def stated_intervals(diag, shapes: bool = False) -> dict:
    """{core parameter: (value, 95 % half width)} of every parameter the diagnosis states: the
    library effects' and the discovered terms' coefficients, and with ``shapes`` the fitted
    shape parameters of the discovered terms (a step's position and width, a ripple's period)."""
    stated = {p: (v["value"], v["ci95"]) for e in diag.effects for p, v in e["params"].items()}
    for t in diag.discovered:
        stated.update({p: (c.value, c.ci95) for p, c in t.coefficients.items()})
        if shapes:
            stated.update({p: (t.shape[p], h) for p, h in t.shape_ci95.items()})
    return stated


def interval_holds(diag, truth: dict) -> list:
    """For every hidden parameter the diagnosis states a 95 % interval of (a library effect's
    or a discovered term's coefficient): does the interval contain the truth?"""
    stated = stated_intervals(diag)
    return [bool(abs(stated[p][0] - v) <= stated[p][1]) for p, v in truth.items()
            if p in stated and np.isfinite(stated[p][1])]


def score(diag, key: dict) -> dict:
    """Compare a diagnosis with the answer key of its case."""
    hidden = [h["type"] for h in key["effects"]]
    named = diag.named()
    values = diag.theta
    out = {"case": key["case"], "robot": key["robot"], "hidden": hidden, "named": named,
           "first": named[0] if named else "none"}
    if not hidden:
        out["clean_ok"] = not named
        return out
    out["first_ok"] = bool(named) and named[0] in hidden
    ties = diag.ties(named[0]) if named else []
    out["first_ok_or_tie"] = out["first_ok"] or any(t in hidden for t in ties)
    # named first with confidence: no tie among its look-alikes; "before" without the look-alike
    # that marks a fit leaving structure unexplained (what the rule costs)
    looks = diag.effects[0]["lookalikes"] if diag.effects else []
    out["first_confident"] = out["first_ok"] and not any(tied(a) for a in looks)
    out["first_confident_before"] = out["first_ok"] and not any(
        tied(a) for a in looks if a["group"] != UNEXPLAINED)
    out["all_found"] = all(t in named for t in hidden)
    errs = {}
    for h in key["effects"]:
        errs[h["type"]] = _param_error(h, values)
        if h["type"] == "payload" and "payload.x" in h["params"]:
            est = [values.get(f"payload.{c}", 0.0) for c in "xyz"]
            true = [h["params"][f"payload.{c}"] for c in "xyz"]
            out["payload_offset_error_mm"] = float(np.linalg.norm(np.subtract(est, true)) * 1e3)
    out["param_error"] = errs
    out["param_ok"] = all(e <= 0.15 for e in errs.values())
    out["holds"] = interval_holds(diag, {p: v for h in key["effects"] for p, v in h["params"].items()})
    out["gain"] = diag.heldout.get("gain", float("nan"))
    out["gain_windows"] = diag.heldout.get("gain_windows", float("nan"))
    # nan: the fitted effects do not act on the held-out part (nothing to measure)
    out["gain_ok"] = bool(out["gain"] >= 5.0)
    out["gain_windows_ok"] = bool(out["gain_windows"] >= 5.0)
    out["gain_measurable"] = bool(np.isfinite(out["gain"]))
    return out


#: held out together with a hidden type: a fading friction whose scale is below the rate
#: noise is the step friction itself (the generator's step is tanh(qd / drive.v_eps))
HOLD_OUT_WITH = {"coulomb": ("smooth_coulomb",)}


def same_physics_stand_in(kind: str, changes: dict, diag) -> bool:
    """With the type ``kind`` held out of the library, is the effect named first the same
    physics on this recording, at the size the truth implies?  Then no structure can
    remain and none is owed.  ``changes``: the hidden parameters' true changes from nominal.

    Three exact equivalences: a heavier platform is a payload at the platform's centre (its
    mass the platform's extra mass within 10 %, its offset under 1 cm); a gap on a joint whose
    effort keeps one sign (all but the engine's ``GAP_MINORITY`` of the samples) is an
    encoder offset of b/2 (within 10 %); a payload at the platform's centre is a heavier platform
    (its extra mass the payload's within 10 %)."""
    from ..recording import read_recording
    from .diagnosis import GAP_MINORITY

    est, named = diag.plant_parameters(), diag.named()
    first = named[0] if named else None
    if kind == "platform_mass" and first == "payload":
        dm = changes["platform.m"]
        off = math.sqrt(sum(est.get(f"payload.{c}", 0.0) ** 2 for c in "xyz"))
        return abs(est.get("payload.m", 0.0) - dm) < 0.1 * abs(dm) and off < 0.01
    if kind == "payload" and first == "platform_mass":  # the same, the other way round
        dm = changes["payload.m"]
        off = math.sqrt(sum(changes.get(f"payload.{c}", 0.0) ** 2 for c in "xyz"))
        nominal = diag.effects[0]["params"]["platform.m"]["nominal"]
        return abs(est.get("platform.m", nominal) - nominal - dm) < 0.1 * abs(dm) and off < 0.01
    if kind == "backlash" and first == "encoder_offset" and len(changes) == 1:
        (name, b), = changes.items()
        joint = int(name.split("[")[1].split("]")[0])
        tau = np.asarray(read_recording(diag.recording).tau, float)[:, joint - 1]
        one_signed = min(np.mean(tau < 0), np.mean(tau > 0)) < GAP_MINORITY
        off = est.get(name.replace(".backlash", ".encoder_offset"), 0.0)
        return bool(one_signed and abs(abs(off) - b / 2) < 0.1 * b / 2)
    return False


def _run_one(args):
    spec, out_dir, key_dir, diag_kw, report, cfg, hold_out = args
    from . import diagnose
    from .effects import LIBRARY

    t0 = time.perf_counter()
    try:
        csv, kp = make_case(spec, out_dir, key_dir, cfg)
    except RuntimeError as e:  # the generator gave up on this case: reported, not scored
        return {"case": spec.case, "robot": spec.robot, "hidden": list(spec.hidden), "generation_failed": str(e)}
    t1 = time.perf_counter()
    key = json.loads(Path(kp).read_text())
    hidden = {h["type"] for h in key["effects"]}
    if hold_out and hidden:  # the hidden types taken out of the library: the structure must show
        out = hidden | {k for h in hidden for k in HOLD_OUT_WITH.get(h, ())}
        diag_kw = dict(diag_kw, effects=[e.key for e in LIBRARY if e.key not in out])
    try:
        d = diagnose(csv, out=(Path(out_dir) / f"{spec.case}_report") if report else None, **diag_kw)
    except Exception as e:  # noqa: BLE001 - a failed diagnosis is a failed case, not a stop
        return {"case": spec.case, "robot": spec.robot, "hidden": [h["type"] for h in key["effects"]],
                "diagnosis_failed": f"{type(e).__name__}: {e}"}
    t2 = time.perf_counter()
    s = score(d, key)
    s.update({"t_generate": t1 - t0, "t_diagnose": t2 - t1, "conclusion": d.conclusion,
              "held_out": bool(hold_out and hidden), "structure": [e["signature"] for e in d.unexplained]})
    if s["held_out"]:
        h = key["effects"][0]
        s["stand_in"] = (not s["structure"] and len(key["effects"]) == 1 and same_physics_stand_in(
            h["type"], {k: v - h["nominal"].get(k, 0.0) for k, v in h["params"].items()}, d))
    return s


def benchmark(n: int = 40, seed: int = 1, n_clean: int = 10, robots=("6pus",), out_dir="results/blind",
              jobs: int = 1, report: bool = False, progress=print, cfg: dict | None = None, hold_out: bool = False,
              **diag_kw) -> dict:
    """Generate and diagnose ``n`` effect cases and ``n_clean`` clean cases; score them.

    With ``hold_out``, each effect case is diagnosed with its hidden types taken out of
    the library, and the score is whether "structure left unexplained" is reported
    (``summary["structure_when_held_out"]``); the clean cases are diagnosed as usual.

    Returns a dict with the per-case scores (``cases``) and the summary figures; the
    recordings go to ``out_dir/cases``, the keys to ``out_dir/keys``.
    """
    out_dir = Path(out_dir)
    cfg = cfg or load_config()
    specs = plan(n, n_clean, seed, tuple(robots), cfg)
    args = [(s, out_dir / "cases", out_dir / "keys", diag_kw, report, cfg, hold_out) for s in specs]
    rows = []
    if jobs > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(jobs) as pool:
            for r in pool.imap(_run_one, args):
                rows.append(r)
                progress(_line(r))
    else:
        for a in args:
            r = _run_one(a)
            rows.append(r)
            progress(_line(r))
    summary = summarize(rows)
    (out_dir / "benchmark.json").write_text(json.dumps({"cases": rows, "summary": summary}, indent=2,
                                                       default=float))
    return {"cases": rows, "summary": summary}


def _line(r):
    if "generation_failed" in r:
        return f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} NOT GENERATED: {r['generation_failed']}"
    if "diagnosis_failed" in r:
        return f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']) or 'clean':<28} DIAGNOSIS FAILED: " \
               f"{r['diagnosis_failed']}"
    if not r["hidden"]:
        return f"{r['case']:>9} {r['robot']:>7}  clean -> {','.join(r['named']) or 'none':<28} " \
               f"{'ok' if r['clean_ok'] else 'FALSE ALARM'}  ({r['t_diagnose']:.1f} s)"
    if r.get("held_out"):
        return (f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} held out -> "
                f"{','.join(r['named'][:3]) or 'none':<34} "
                f"{'structure: ' + ','.join(r['structure']) if r['structure'] else 'NO STRUCTURE'}"
                f"{' (its same-physics stand-in, at the right size)' if r.get('stand_in') else ''}  "
                f"({r['t_diagnose']:.1f} s)")
    errs = " ".join(f"{k}:{v * 100:.1f}%" for k, v in r["param_error"].items())
    return (f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} -> {','.join(r['named'][:3]) or 'none':<34}"
            f" {'ok' if r['first_ok'] else ('tie' if r['first_ok_or_tie'] else 'WRONG')}  err {errs}  "
            f"gain {r['gain']:.1f} (windows {r['gain_windows']:.1f})  ({r['t_diagnose']:.1f} s)")


def summarize(rows) -> dict:
    failed = [r for r in rows if "generation_failed" in r]
    rows = [r for r in rows if "generation_failed" not in r]
    # A diagnosis that raised counts as a wrong answer (nothing named, no gain).
    rows = [r if "diagnosis_failed" not in r else
            dict(r, named=[], first="failed", first_ok=False, first_ok_or_tie=False, all_found=False,
                 first_confident=False, first_confident_before=False,
                 clean_ok=False, param_error={h: float("inf") for h in r["hidden"]}, gain=float("nan"),
                 gain_windows=float("nan"), gain_ok=False, gain_windows_ok=False, gain_measurable=False,
                 t_diagnose=float("nan"), t_generate=float("nan")) for r in rows]
    eff = [r for r in rows if r["hidden"]]
    clean = [r for r in rows if not r["hidden"]]
    types = sorted({r["hidden"][0] for r in eff})
    confusion = {}
    for r in eff:
        # row: the hidden effect the first name matches (else the first hidden one)
        row = r["first"] if r["first"] in r["hidden"] else r["hidden"][0]
        confusion.setdefault(row, {}).setdefault(r["first"], 0)
        confusion[row][r["first"]] += 1
    per_type = {}
    for t in types:
        rs = [r for r in eff if r["hidden"][0] == t]
        errs = [r["param_error"][t] for r in rs]
        gains = [r["gain_windows"] for r in rs if np.isfinite(r["gain_windows"])]
        per_type[t] = {"cases": len(rs), "first_ok": sum(r["first_ok"] for r in rs),
                       "param_ok": sum(r["param_error"][t] <= 0.15 for r in rs),
                       "median_param_error": float(np.median(errs)),
                       "median_gain": float(np.median(gains)) if gains else float("nan")}
    held = [r for r in eff if r.get("held_out")]
    for t in types:
        rs = [r for r in held if r["hidden"][0] == t]
        if rs:
            per_type[t]["structure_when_held_out"] = sum(bool(r["structure"]) for r in rs)
            per_type[t]["stand_in"] = sum(bool(r.get("stand_in")) for r in rs)
    f = lambda k: (sum(bool(r[k]) for r in eff) / len(eff)) if eff else float("nan")  # noqa: E731
    meas = [r for r in eff if r.get("gain_measurable", True)]
    g = lambda k: (sum(bool(r[k]) for r in meas) / len(meas)) if meas else float("nan")  # noqa: E731
    return {
        "effect_cases": len(eff), "clean_cases": len(clean), "effect_types": len(types),
        "first_named_right": f("first_ok"), "first_named_right_or_tie": f("first_ok_or_tie"),
        "first_named_right_confident": f("first_confident"),
        "first_named_right_confident_before": f("first_confident_before"),
        "all_hidden_found": f("all_found"),
        "param_within_15pct": (sum(r["param_error"][r["hidden"][0]] <= 0.15 for r in eff) / len(eff)) if eff else
        float("nan"),
        "gain_measurable_cases": len(meas),
        "gain_at_least_5x": g("gain_ok"), "gain_windows_at_least_5x": g("gain_windows_ok"),
        "median_gain": float(np.median([r["gain"] for r in meas])) if meas else float("nan"),
        "median_gain_windows": float(np.median([r["gain_windows"] for r in meas])) if meas else float("nan"),
        "clean_no_missing_physics": (sum(r["clean_ok"] for r in clean) / len(clean)) if clean else float("nan"),
        "median_diagnose_s": float(np.nanmedian([r["t_diagnose"] for r in rows])) if rows else float("nan"),
        "max_diagnose_s": float(np.nanmax([r["t_diagnose"] for r in rows])) if rows else float("nan"),
        "diagnosis_failed": [r["case"] for r in rows if "diagnosis_failed" in r],
        "per_type": per_type, "confusion": confusion, "not_generated": [r["case"] for r in failed],
        "intervals_holding": [sum(sum(r.get("holds", [])) for r in eff), sum(len(r.get("holds", [])) for r in eff)],
        "structure_when_held_out": (sum(bool(r["structure"]) for r in held) / len(held)) if held else None,
        "stand_in_when_held_out": (sum(bool(r.get("stand_in")) for r in held) / len(held)) if held else None,
    }


def _coverage_line(holding) -> str:
    k, n = holding
    if not n:
        return "95 % intervals holding the truth:  none stated for a hidden parameter"
    p = k / n
    return (f"95 % intervals holding the truth:  {k}/{n} hidden parameters ({p * 100:.1f} % +- "
            f"{100 * math.sqrt(p * (1 - p) / n):.1f} %, binomial standard error)")


def format_summary(summary: dict) -> str:
    """The benchmark summary as text: rates, the confusion matrix, per-type figures."""
    s = summary
    if s.get("structure_when_held_out") is not None:
        lines = [f"effect cases: {s['effect_cases']} over {s['effect_types']} primary types, each diagnosed with "
                 f"its hidden types held out of the library; clean cases: {s['clean_cases']}",
                 f"structure left unexplained reported: {s['structure_when_held_out'] * 100:5.1f} %",
                 f"else its same-physics stand-in named at the right size: "
                 f"{s['stand_in_when_held_out'] * 100:.1f} %",
                 f"clean cases, no missing physics:     {s['clean_no_missing_physics'] * 100:5.1f} %"
                 if s["clean_cases"] else "clean cases, no missing physics:     none run",
                 f"diagnosis time:                      median {s['median_diagnose_s']:.2f} s, max "
                 f"{s['max_diagnose_s']:.2f} s", "",
                 "per primary hidden type: cases, structure reported, same-physics stand-in, named first instead"]
        for t, v in s["per_type"].items():
            firsts = sorted(s["confusion"].get(t, {}))  # held out: the row is the hidden type
            lines.append(f"  {t:<17} {v['cases']:>3} {v.get('structure_when_held_out', 0):>4} {v.get('stand_in', 0):>4}   "
                         f"{', '.join(firsts) or '-'}")
        return "\n".join(lines)
    lines = [
        f"effect cases: {s['effect_cases']} over {s['effect_types']} primary types; clean cases: {s['clean_cases']}"
        + (f"; not generated: {', '.join(s['not_generated'])}" if s.get("not_generated") else "")
        + (f"; diagnosis failed: {', '.join(s['diagnosis_failed'])}" if s.get("diagnosis_failed") else ""),
        f"right effect named first:          {s['first_named_right'] * 100:5.1f} %  "
        f"(counting declared ties: {s['first_named_right_or_tie'] * 100:.1f} %)",
        f"right and named with confidence:   {s['first_named_right_confident'] * 100:5.1f} %  (without the "
        f"structure rule: {s['first_named_right_confident_before'] * 100:.1f} %)",
        f"every hidden effect named:         {s['all_hidden_found'] * 100:5.1f} %",
        f"parameter within 15 %:             {s['param_within_15pct'] * 100:5.1f} %",
        f"held-out residual reduced >= 5x:   {s['gain_at_least_5x'] * 100:5.1f} % over all samples (median "
        f"{s['median_gain']:.1f}x), {s['gain_windows_at_least_5x'] * 100:.1f} % in the out-of-band windows (median "
        f"{s['median_gain_windows']:.1f}x); {s['effect_cases'] - s['gain_measurable_cases']} case(s) whose "
        f"effect does not act on the held-out part",
        f"clean cases, no missing physics:   {s['clean_no_missing_physics'] * 100:5.1f} %",
        _coverage_line(s.get("intervals_holding", [0, 0])),
        f"diagnosis time:                    median {s['median_diagnose_s']:.2f} s, max {s['max_diagnose_s']:.2f} s",
        "",
        "per primary hidden type: cases, named first, parameter within 15 %, median parameter error, median gain "
        "(out-of-band windows)",
    ]
    for t, v in s["per_type"].items():
        lines.append(f"  {t:<17} {v['cases']:>3} {v['first_ok']:>4} {v['param_ok']:>4}   "
                     f"{v['median_param_error'] * 100:7.1f} %  {v['median_gain']:7.1f}x")
    cols = sorted({c for row in s["confusion"].values() for c in row})
    lines += ["", "confusion (rows: hidden effect, the one named first if it is hidden; columns: named first)",
              " " * 18 + " ".join(f"{c[:8]:>8}" for c in cols)]
    for t, row in s["confusion"].items():
        lines.append(f"  {t:<16}" + " ".join(f"{row.get(c, 0):>8}" for c in cols))
    return "\n".join(lines)
