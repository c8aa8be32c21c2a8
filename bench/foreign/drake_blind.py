"""The discrepancy engine on recordings from Drake, a second simulator the project did not write.

    .venv/bin/python bench/foreign/drake_blind.py [--seed 90] [--clean 4] [--cables 2] [--duration 9]
        [--out results/foreign_drake] [--controller pd_gravity] [--only viscous,cable,clean] [--no-check]

Each case is a 6-PUS run on Drake (bench/foreign/drake_6pus.py: a discrete MultibodyPlant
built from the core's nominal parameters, loops closed by ball constraints, SAP at 0.1 ms),
driven at 1 kHz by the controller of bench/foreign/mujoco_blind.py (PD + gravity designed on
the nominal model, or a PID) along the engine's exciting trajectory, with the blind
configuration's sensor noise.  One effect per case is hidden in Drake's physics (joint
damping, an actuator's rotor inertia, a payload body welded to the platform, a heavier
platform, tilted gravity, a constant force on a rail) or in the drive around it (a command
delay, an encoder offset, a dead zone) or in a rail made two bodies (drake_6pus: a drive and
the carriage on a relative prismatic joint, a compliance as Drake's ``PrismaticSpring``, a
backlash as that joint's position limits; the backlash moved to a rail whose effort changes
sign by mujoco_blind's ``gap_joint``, and a gap read as the offset b/2 it is on a one-signed
rail counted right, as mujoco_blind does); magnitudes are drawn from the ranges of
``scenarios/blind/config.toml``.  Then ``--cables`` cases hide a cable of constant tension
(0.2-0.5 N) from the platform to an anchor 0.2-0.5 m away, to be found by the engine's
platform-force stage (its family ``cable``, tension and anchor within 15 %).
``cosim.discrepancy.diagnose`` runs on every recording knowing only its path; the answer
stays in this process and is compared afterwards.  Prints a line per case and the summary:
right effect named first, right and named with confidence, the parameter within 15 %, clean
cases called clean, cables found, CPU seconds per diagnosis.

First, the model check: on a clean run (the plan's first clean seed), the rail forces Drake
applied against the core's inverse dynamics along Drake's true motion (rails sampled at every
control instant: positions and rates at the period's middle, the period's mean acceleration),
RMS per rail as a multiple of the effort noise, at Drake's 0.1 ms step and at 1 ms.
"""
from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO / "bench" / "foreign"))

import drake_6pus as d6  # noqa: E402
import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.diagnosis import tied  # noqa: E402

#: the effect types of a Drake case drawn first: its physics' (drake_6pus.PHYSICS) and the drive's,
#: the two-body rails' (mujoco_blind.TWO_BODY) apart: they are drawn after the cables
TYPES = [e for e in mb.EFFECTS if (e in d6.PHYSICS and e not in mb.TWO_BODY)
         or e in ("actuator_delay", "encoder_offset", "dead_zone")]
#: the range of a hidden cable's tension [N] (the rails' efforts are 0.5-0.9 N)
CABLE_TENSION = (0.2, 0.5)


def plan(seed: int, n_clean: int, n_cable: int = 0):
    """The cases (type or None, value, joint 0-based, seed): every type of TYPES once, its
    magnitude and rail drawn from ``seed``, then ``n_cable`` platform cables (tension drawn
    from CABLE_TENSION [N], the anchor by the case's seed), then the two-body rails
    (mujoco_blind.TWO_BODY, drawn as TYPES), then ``n_clean`` clean ones."""
    cfg = blind.load_config()["effects"]["6pus"]
    rng = np.random.default_rng(seed)
    cases = [(effect, mb._draw(effect, cfg, rng), int(rng.integers(6)), seed * 100 + i)
             for i, effect in enumerate(TYPES)]
    cases += [("cable", float(rng.uniform(*CABLE_TENSION)), 0, seed * 100 + 40 + i) for i in range(n_cable)]
    cases += [(effect, mb._draw(effect, cfg, rng), int(rng.integers(6)), seed * 100 + 30 + i)
              for i, effect in enumerate(mb.TWO_BODY)]
    return cases + [(None, 0.0, 0, seed * 100 + 50 + i) for i in range(n_clean)]


def cable_found(d, truth: dict) -> tuple[bool, float, float]:
    """(found as the engine's platform cable, tension error / tension, anchor error / the
    anchor's distance from home) of a diagnosis ``d`` of a cable case; errors NaN when not found."""
    pf = d.platform_force
    if pf is None or not pf.family.startswith("cable"):
        return False, math.nan, math.nan
    anchor = np.array([truth[f"cable.anchor_{a}"] for a in "xyz"])
    found = np.array([pf.params[f"cable.anchor_{a}"] for a in "xyz"])
    dist = np.linalg.norm(anchor - Model("6pus").home()[:3])
    tension = abs(pf.params["cable.tension"] / truth["cable.tension"] - 1)
    return True, tension, float(np.linalg.norm(found - anchor) / dist)


def model_check(m: Model, seed: int, duration: float, noise: dict, time_step: float = d6.TIME_STEP,
                physics: Model | None = None) -> np.ndarray:
    """RMS per rail of (force Drake applied - the core's inverse dynamics along Drake's true
    motion) over the recorded part of a clean run, as a multiple of the effort noise.

    Parameters
    ----------
    m : Model
        The nominal model (the inverse dynamics, the controller, the trajectory).
    seed, duration, noise
        As :func:`drake_6pus.simulate` (duration [s]).
    time_step : float
        Drake's step [s].
    physics : Model, optional
        The model Drake's plant is built from, when not ``m``.

    Returns
    -------
    numpy.ndarray
        Six ratios (RMS error [N] / effort noise [N]).
    """
    _, _, mo = d6.simulate(m, None, 0.0, 0, seed, duration, noise, physics=physics, time_step=time_step,
                           motion=True)
    q, qd, force = mo["q"], mo["qd"], mo["force"]
    k = slice(mo["k0"], len(force))
    q_mid = 0.5 * (q[:-1] + q[1:])[k]
    qd_mid = (q[1:] - q[:-1])[k] / mb.DT
    qdd = (qd[1:] - qd[:-1])[k] / mb.DT
    x = m.fk(q_mid)
    xd = m.pose_velocity(x, qd_mid)
    xdd = m.pose_acceleration(x, xd, qdd)
    err = force[k] - m.inverse_dynamics(x, xd, xdd)
    return np.sqrt(np.mean(err ** 2, axis=0)) / noise["tau"]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    mb.case_options(ap, 90, REPO / "results" / "foreign_drake")
    ap.add_argument("--only", default=None, metavar="TYPE[,TYPE]",
                    help="run only these cases of the plan (effect types, or 'clean'); the others are drawn as usual")
    ap.add_argument("--cables", type=int, default=2,
                    help="cases hiding a cable on the platform, found by the engine's platform-force stage (default 2)")
    ap.add_argument("--no-check", action="store_true", help="skip the model check")
    a = ap.parse_args(argv)
    only = None if a.only is None else set(a.only.split(","))
    known = set(TYPES) | set(mb.TWO_BODY) | {"cable", "clean"}
    if only and not only <= known:
        ap.error(f"--only: unknown type(s) {', '.join(sorted(only - known))}; "
                 f"known: {', '.join(TYPES + list(mb.TWO_BODY))}, cable, clean")
    import importlib.metadata

    version = importlib.metadata.version("drake")
    m = Model("6pus")
    noise = blind.load_config()["noise"]["6pus"]
    a.out.mkdir(parents=True, exist_ok=True)
    cases = plan(a.seed, a.clean, a.cables)
    check = {}
    if not a.no_check:
        seed = next(s for e, _, _, s in cases if e is None) if a.clean else a.seed * 100 + 50
        for step in (d6.TIME_STEP, 1e-3):
            t0 = time.perf_counter()
            check[step] = model_check(m, seed, a.duration, noise, time_step=step)
            print(f"model check (clean run {seed}, Drake step {step * 1e3:g} ms): effort error RMS per rail "
                  f"{', '.join(f'{r:.3f}' for r in check[step])} x noise ({noise['tau'] * 1e3:g} mN)  "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    rows, t_start = [], time.perf_counter()
    for effect, value, joint, seed in cases:
        name = f"{effect or 'clean'}_{seed}"
        if only and (effect or "clean") not in only:
            continue
        if effect == "backlash":
            joint = mb.gap_joint(m, seed, a.duration, joint)
        t0 = time.perf_counter()
        rec, truth = d6.simulate(m, effect, value, joint, seed, a.duration, noise, a.controller)
        sim_wall = time.perf_counter() - t0
        csv = mb.write_case(m, rec, a.out / f"{name}.csv")
        c0 = time.process_time()
        d = diagnose(csv, figures=False, replay=False)  # blind: the truth stays in this process
        cpu = time.process_time() - c0
        named = d.named()
        first = named[0] if named else None
        ok = (first == effect or (effect is not None and first is not None and effect in d.ties(first))) \
            if effect else first is None
        same = mb.gap_as_offset(d, effect, value, joint)  # a gap on a one-signed rail read as its offset b/2
        if same is not None:
            ok = same
        if effect == "cable":
            ok, t_err, a_err = cable_found(d, truth)
            first = "platform cable" if ok else first
            rows.append({"case": name, "hidden": effect, "value": value, "named": named, "ok": ok,
                         "tension_error": t_err, "anchor_error": a_err, "truth": truth,
                         "estimate": d.platform_force.params if d.platform_force else {},
                         "conclusion": d.conclusion, "cpu_s": cpu, "simulation_s": sim_wall})
            print(f"{name:22s} hidden cable {value:.3f} N   named {first or 'none':15s} {'ok ' if ok else 'MISS'}  "
                  f"tension err {100 * t_err:.1f} %, anchor err {100 * a_err:.1f} % of its distance  "
                  f"(Drake {sim_wall:.0f} s, diagnosis {cpu:.1f} s CPU)", flush=True)
            continue
        looks = d.effects[0]["lookalikes"] if d.effects else []
        confident = bool(ok and effect and not any(tied(x) for x in looks))
        est = d.plant_parameters()
        perr = None
        key = mb.EFFECTS[effect][1].format(j=joint + 1) if effect and mb.EFFECTS[effect][1] else None
        if key and key in est and key in truth:
            nominal = m.params().get(key, 0.0)
            perr = abs(est[key] - truth[key]) / max(abs(truth[key] - nominal), 1e-12)
        rows.append({"case": name, "hidden": effect or "clean", "value": value, "joint": joint + 1,
                     "named": named, "ok": bool(ok), "confident": confident, "param_error": perr,
                     "same_physics": same is not None,
                     "truth": truth, "estimate": {k: est[k] for k in truth if k in est},
                     "conclusion": d.conclusion, "cpu_s": cpu, "simulation_s": sim_wall})
        pe = "-" if perr is None else f"{100 * perr:.1f} %"
        print(f"{name:22s} hidden {effect or 'clean':15s} named {first or 'none':15s} "
              f"{'ok ' if ok else 'MISS'}{' confident' if confident else '          '}  param err {pe:>8s}  "
              f"(Drake {sim_wall:.0f} s, diagnosis {cpu:.1f} s CPU)"
              f"{'  [one-signed effort: the gap is an offset b/2]' if same is not None else ''}", flush=True)
    if not rows:
        return 0
    eff = [r for r in rows if r["hidden"] not in ("clean", "cable")]
    clean = [r for r in rows if r["hidden"] == "clean"]
    cables = [r for r in rows if r["hidden"] == "cable"]
    comparable = [r for r in eff if r["param_error"] is not None]
    cpu = [r["cpu_s"] for r in rows]
    print(f"\nDrake {version}, SAP at {d6.TIME_STEP * 1e3:g} ms, controller {a.controller}, seed {a.seed}: "
          f"{len(eff)} effect cases over {len(eff)} types, {len(clean)} clean; {time.perf_counter() - t_start:.0f} s")
    for step, r in check.items():
        print(f"model check at {step * 1e3:g} ms: effort error {r.min():.3f}-{r.max():.3f} x noise per rail")
    print(f"right effect named first:  {sum(r['ok'] for r in eff)}/{len(eff)} (of which a gap read as the offset "
          f"it is on a one-signed rail: {sum(r['same_physics'] and r['ok'] for r in eff)})")
    print(f"right and named with confidence: {sum(r['confident'] for r in eff)}/{len(eff)}")
    print(f"parameter within 15 %:     {sum(r['param_error'] < 0.15 for r in comparable)}/{len(comparable)} "
          f"comparable")
    print(f"clean cases called clean:  {sum(r['ok'] for r in clean)}/{len(clean)}")
    if cables:
        print(f"platform cable found as a cable: {sum(r['ok'] for r in cables)}/{len(cables)}, tension and anchor "
              f"within 15 %: {sum(r['ok'] and r['tension_error'] < 0.15 and r['anchor_error'] < 0.15 for r in cables)}"
              f"/{len(cables)}")
    print(f"CPU per diagnosis: {min(cpu):.1f}-{max(cpu):.1f} s, median {statistics.median(cpu):.1f} s")
    out = {"drake": version, "seed": a.seed, "controller": a.controller,
           "model_check": {f"{s:g}": r.tolist() for s, r in check.items()}, "cases": rows}
    (a.out / "summary.json").write_text(json.dumps(out, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
