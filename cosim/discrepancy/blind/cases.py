"""A blind case: the config, the case's closed-loop recording of a plant with hidden effects
and its answer key (:func:`make_case`), and the plan of the benchmark's cases (:mod:`.blind`).
"""
from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ...errors import InputError
from .sampling import TYPES, UNLISTED, _Redraw, sample_effect, sample_unlisted
from ..effects import BY_KEY
from ..families.generator import KINDS as FAMILY_KINDS

REPO = Path(__file__).resolve().parents[3]
CONFIG = REPO / "scenarios" / "blind" / "config.toml"


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
    from ... import controllers as ctl
    from ...master import make_reference
    from ..excitation import excitation

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


def _controller(kind, model, cfg, dt):
    from ... import controllers as ctl

    wn = 2 * math.pi * cfg["general"].get("bandwidth_hz", 8.0)
    if kind == "computed_torque":
        return ctl.computed_torque(model, kp=wn**2, kd=2 * wn)
    mass = float(ctl.joint_mass(model, model.home()).diagonal().max())
    return ctl.pd_gravity(model, kp=mass * wn**2, kd=2 * wn * mass)


def simulate_case(spec: CaseSpec, cfg: dict | None = None):
    """Simulate one case: returns ``(recording, hidden effects, info)``.

    ``cfg`` is the generator configuration (default: ``scenarios/blind/config.toml``);
    tests pass a copy with a shorter duration."""
    from ...core.model import Model
    from ...master import make_reference
    from ..excitation import excitation
    from ..runs import closed_loop

    from ..._native import PkmError

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
                  "home": nominal.ik(nominal.home()), "q": ref.q[k0:]}
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
    rec = res.to_recording(effort="logged", start=k0, robot=nominal.robot, qref=ref.q,
                           extra={"label": ref.label.astype(float)},
                           controller=dict(ctrl.describe(), rate_hz=gen["rate"]),
                           notes=f"blind case {spec.case}: closed-loop recording of a plant that may hide effects "
                                 f"the model lacks (the answer key is elsewhere)")
    info = {"controller": kind, "noise": noise, "tau_peak": tau_peak[0].tolist(), "trajectory": traj.name,
            "spread": ref.q[k0:].std(axis=0).tolist(),
            "failed_attempts": failures}
    return rec, hidden, info


def make_case(spec: CaseSpec, out_dir, key_dir, cfg: dict | None = None):
    """Write the case's recording to ``out_dir/<case>.csv`` (+ sidecar) and its answer
    key to ``key_dir/<case>.json``; returns both paths."""
    from ...recording import write_recording

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
    from ...core.model import Model

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
