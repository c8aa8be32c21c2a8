"""The discovery step on MuJoCo recordings of the 6-PUS, or of a described robot, hiding forces no library lists.

    .venv/bin/python bench/discovery_mujoco_bench.py [--robot 6pus] [--seeds 2] [--clean 4] [--jobs 2]
        [--kinds spring,drag] [--reuse]
    .venv/bin/python bench/discovery_mujoco_bench.py --robot linear_delta --seeds 2 --clean 4

Each case is a run of bench/foreign/mujoco_blind.py's MuJoCo model of the 6-PUS, or with
``--robot NAME`` of MuJoCo built from the description robots/NAME.toml by
bench/foreign/mujoco_described.py and recorded by bench/foreign/mujoco_described_blind.py
(PD + gravity, the engine's exciting trajectory, the generator's sensor noise), with one force
law hidden in MuJoCo's physics: a force on the actuated joint (``qfrc_applied``) computed here
at every MuJoCo step from the joint's true position and rate, so neither the core nor its
generic joint force computes it.  The kinds: the five of the engine's failure list (a constant force on one rail, a
force periodic in the stroke on every rail, a spring towards the home stroke, quadratic drag,
Coulomb friction that differs by direction) and three more (a damper acting one way, a cubic
hardening spring about home, a detent: a smooth step in position whose place and width are
drawn off the engine's grid of step positions).  Magnitudes: 10-20 % of the rail's RMS
feed-forward effort along the case's reference, drawn per case; the joint drawn per case.

Each recording is diagnosed blind with the default settings; the truth stays in this process.
Nothing of the engine was tuned on these cases: its thresholds (selection, look-elsewhere cost,
stability, held-out test) were set on the engine's own generator (bench/discovery_bench.py).

Printed: per case the truth, what the engine named (the discovered equation on the truth's
joint, library effects), the coefficient against the truth, whether the stated 95 % intervals
contain the truth, the held-out RMS of the joint's channel before and after the term, the
diagnosis time; then the totals against the acceptance figures (right joints and structure in
>= 80 % of cases, coefficients within 15 %, held-out residual >= 3x lower, no library effect
named first with confidence, clean recordings called clean).
"""
from __future__ import annotations

import argparse
import json
import math
import re
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

#: the hidden force laws: kind -> what it is
KINDS = {
    "constant_force": "a constant force on one rail (a cable carrier pulling one way)",
    "ripple": "a force periodic in the stroke on every rail (cogging, screw ripple)",
    "spring": "a spring towards the home stroke on one rail",
    "drag": "quadratic drag on one rail",
    "direction_coulomb": "Coulomb friction that differs by direction on one rail",
    "one_way_damper": "a damper acting only when the rail moves up its stroke",
    "hardening_spring": "a cubic hardening spring about home on one rail",
    "detent": "a detent: a smooth step of force at a position of the stroke on one rail",
}
#: MuJoCo's direction-split friction is smooth over this rate [m/s] (not the core's drive.v_eps)
V_FRICTION = 3e-4


def motion(m, seed, duration):
    """Per rail: RMS feed-forward effort E [N], position spread T [m], RMS rate V [m/s], stroke
    used span [m], 10th-90th percentile of the position (for a detent), along the case's reference."""
    from cosim.discrepancy.excitation import excitation
    from cosim.master import make_reference
    from mujoco_blind import DT

    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    k0 = int(round(0.5 / DT))
    tau = m.inverse_dynamics(ref.x[k0:], ref.xd[k0:], ref.xdd[k0:])
    q = ref.q[k0:]
    return {"E": np.sqrt(np.mean(tau ** 2, axis=0)), "T": q.std(axis=0),
            "V": np.sqrt(np.mean(np.gradient(q, DT, axis=0) ** 2, axis=0)), "span": np.ptp(q, axis=0),
            "q10": np.quantile(q, 0.1, axis=0), "q90": np.quantile(q, 0.9, axis=0)}


def draw(kind, rng, mo, home, pre="rail"):
    """(force law f(q, qd) -> the n joints' forces along +q [N or N m], truth in the core's
    joint-force keys ``<pre>[j].force_*`` (the drive spends F = -f), the joints it acts on
    (1-based))."""
    n = len(mo["E"])
    j = int(rng.integers(n))
    size = float(rng.uniform(0.1, 0.2))
    E, T, V = mo["E"], mo["T"], mo["V"]
    key = lambda i, k: f"{pre}[{i + 1}].force_{k}"  # noqa: E731
    one = lambda fj: (lambda q, qd: np.eye(n)[j] * fj(q[j], qd[j]))  # noqa: E731
    if kind == "constant_force":
        f0 = float(rng.choice([-1, 1])) * size * E[j]
        return one(lambda q, qd: f0), {key(j, "c"): -f0}, [j + 1]
    if kind == "ripple":
        A = size * E
        P = mo["span"] / rng.uniform(4, 8, n)
        ph = rng.uniform(0, 2 * math.pi, n)
        truth = {}
        for i in range(n):
            truth.update({key(i, "amplitude"): float(A[i]), key(i, "period"): float(P[i])})
        return (lambda q, qd: -A * np.sin(2 * np.pi * q / P + ph)), truth, list(range(1, n + 1))
    if kind == "spring":
        k = 1.5 * size * E[j] / T[j]
        return one(lambda q, qd: -k * (q - home[j])), {key(j, "k1"): k, key(j, "qc"): float(home[j])}, [j + 1]
    if kind == "drag":
        c = 1.5 * size * E[j] / V[j] ** 2
        return one(lambda q, qd: -c * qd * abs(qd)), {key(j, "v2"): c}, [j + 1]
    if kind == "direction_coulomb":
        hi, lo = size * E[j], float(rng.uniform(0.0, 0.3)) * size * E[j]
        cp, cn = (hi, lo) if rng.uniform() < 0.5 else (lo, hi)

        def f(q, qd):
            s = math.tanh(qd / V_FRICTION)
            return -(cp * max(s, 0.0) + cn * min(s, 0.0))
        return one(f), {key(j, "cpos"): cp, key(j, "cneg"): cn}, [j + 1]
    if kind == "one_way_damper":
        b = 2.0 * size * E[j] / V[j]
        return one(lambda q, qd: -b * max(qd, 0.0)), {key(j, "vpos"): b}, [j + 1]
    if kind == "hardening_spring":
        k3 = size * E[j] / T[j] ** 3
        return one(lambda q, qd: -k3 * (q - home[j]) ** 3), {key(j, "k3"): k3, key(j, "qc"): float(home[j])}, [j + 1]
    if kind == "detent":
        A = float(rng.choice([-1, 1])) * 1.5 * size * E[j]
        qs = float(rng.uniform(mo["q10"][j] + 0.2 * (mo["q90"][j] - mo["q10"][j]),
                               mo["q90"][j] - 0.2 * (mo["q90"][j] - mo["q10"][j])))
        w = float(rng.uniform(0.05, 0.2)) * T[j]
        return (one(lambda q, qd: -A * math.tanh((q - qs) / w)),
                {key(j, "step"): A, key(j, "step_q"): qs, key(j, "step_w"): w}, [j + 1])
    raise ValueError(f"unknown kind {kind!r} (known: {', '.join(KINDS)})")


#: the coefficient each kind is measured by (core key suffix), and the structure it needs
MEASURE = {"constant_force": ("c",), "ripple": ("amplitude", "period"), "spring": ("k1", "q0"), "drag": ("v2",),
           "direction_coulomb": ("larger",), "one_way_damper": ("vpos",), "hardening_spring": ("k3",),
           "detent": ("step", "step_w")}
NEEDS = {"constant_force": {"offset"}, "ripple": {"force_sin", "force_cos"}, "spring": {"force_k1"},
         "drag": {"force_v2"}, "one_way_damper": {"force_vpos"}, "hardening_spring": {"force_k3"},
         "detent": {"force_step"}}


def _found_values(term, j, pre="rail"):
    """The discovered term's figures on joint j: {name: (value, 95 % half width or None)}."""
    pre = f"{pre}[{j}]."
    co = {p[len(pre):]: c for p, c in term.coefficients.items()}
    sh = {p[len(pre):]: v for p, v in term.shape.items()}
    sh_ci = {p[len(pre):]: v for p, v in term.shape_ci95.items()}  # the shape the fit moved
    # the discovered constant is the joint's offset parameter: measured as "c"
    out = {("c" if k == "offset" else k[len("force_"):]): (c.value, c.ci95) for k, c in co.items()}
    if "force_sin" in co:
        s, c = co["force_sin"], co["force_cos"]
        out["amplitude"] = (math.hypot(s.value, c.value), math.hypot(s.ci95, c.ci95))
        out["period"] = (sh.get("force_period", float("nan")), sh_ci.get("force_period"))
    if "force_step" in co:
        for k in ("step_q", "step_w"):
            out[k] = (sh[f"force_{k}"], sh_ci.get(f"force_{k}"))
    if "force_k1" in co and co["force_k1"].value:
        c0 = co["offset"].value if "offset" in co else 0.0
        out["q0"] = (sh["force_qc"] - c0 / co["force_k1"].value, None)
    return out


def score(kind, truth, joints, d, mo, pre="rail"):
    """Right joints and structure, coefficient errors, interval hits, held-out RMS before/after."""
    found = {t.joint: t for t in d.discovered}
    lib_offset = {}
    if kind == "constant_force":  # the library's constant effort offset is this physics
        for j in joints:
            v = d.theta.get(f"{pre}[{j}].offset")
            if v is not None and j not in found:
                lib_offset[j] = v
    need = joints if kind != "ripple" else [j for j in joints if j in found]
    ok = (kind != "ripple" or len(need) >= len(joints) - 1) and all(j in found or j in lib_offset for j in need)
    ok = ok and set(found) <= set(joints)
    errs, hits, ratios, before, after = [], [], [], [], []
    for j in need:
        if j in lib_offset:
            errs.append(abs(lib_offset[j] / truth[f"{pre}[{j}].force_c"] - 1))
            continue
        if j not in found:
            continue
        t = found[j]
        names = {p.rsplit(".", 1)[1] for p in t.coefficients}
        want = {k[len(f"{pre}[{j}]."):][len("force_"):]: v for k, v in truth.items() if k.startswith(f"{pre}[{j}].")}
        if kind == "direction_coulomb":
            side = "cpos" if want["cpos"] > want["cneg"] else "cneg"
            ok = ok and f"force_{side}" in names
            meas = (side,)
        else:
            ok = ok and NEEDS[kind] <= names
            meas = MEASURE[kind]
        got = _found_values(t, j, pre)
        for k in meas:
            if k not in got:
                errs.append(float("inf"))
                continue
            v, ci = got[k]
            if k == "q0":  # the rest position: its distance over the rail's position spread
                errs.append(abs(v - want["qc"]) / mo["T"][j - 1])
            else:
                errs.append(abs(v / want[k] - 1))
            if ci is not None:
                hits.append(bool(abs(v - want[k]) <= ci))
        # every other hidden coefficient the term carries (the smaller Coulomb side)
        for k, (v, ci) in got.items():
            if k in want and k not in meas and k != "qc" and ci is not None:
                hits.append(bool(abs(v - want[k]) <= ci))
        before.append(t.heldout_before)
        after.append(t.heldout_after)
        ratios.append(t.heldout_before / max(t.heldout_after, 1e-300))
    if lib_offset and not ratios:
        g = d.heldout.get("gain") if isinstance(d.heldout, dict) else None
        ratios = [g] if g else []
    return {"right": bool(ok), "errors": errs, "hits": hits, "ratio": min(ratios) if ratios else 0.0,
            "before": before, "after": after}


def _run(job):
    import mujoco_blind as mb
    import mujoco_described_blind as mdb

    from cosim.core import Model
    from cosim.discrepancy import blind, diagnose
    from cosim.discrepancy.effects import joint_prefix
    from cosim.recording import write_recording

    robot, kind, seed, out, reuse = job
    m = Model(robot)
    pre = joint_prefix(m)
    duration = 9.0
    name = f"{kind}_{seed}" if robot == "6pus" else f"{robot}_{kind}_{seed}"
    force, truth, joints = None, {}, []
    if kind != "clean":
        rng = np.random.default_rng(seed)
        force, truth, joints = draw(kind, rng, motion(m, seed, duration), m.ik(m.home()), pre)
    csv = Path(out) / f"{name}.csv"
    if not (reuse and csv.exists()):  # MuJoCo's run is deterministic: --reuse diagnoses the same file again
        try:
            if robot == "6pus":  # the hand-written MuJoCo 6-PUS, recorded in MuJoCo's joint coordinates
                noise = blind.load_config()["noise"]["6pus"]
                rec, _ = mb.simulate(m, None, 0.0, 0, seed, duration, noise, force=force)
                csv = mb.write_case(m, rec, csv)
            else:  # MuJoCo built from the robot's description file
                csv, _ = write_recording(csv, mdb.simulate(robot, seed, duration, force=force))
        except Exception as e:  # noqa: BLE001 - a drawn case the controller cannot hold is reported
            return {"robot": robot, "case": name, "kind": kind, "failed": str(e)}
    t0 = time.perf_counter()
    d = diagnose(csv, figures=False, replay=False)  # blind, default settings
    wall = time.perf_counter() - t0
    from cosim.discrepancy.diagnosis import UNEXPLAINED, tied

    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    # without the look-alike that marks a fit leaving structure unexplained
    before = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"] if a["group"] != UNEXPLAINED)]
    if kind == "constant_force":  # the library's offset on the force's rail is the same physics
        confident, before = ([k for k in c if k != "offset" or not any(f"{pre}[{j}].offset" in d.theta
                                                                      for j in joints)] for c in (confident, before))
    row = {"robot": robot, "prefix": pre, "units": (m.facts.effort_unit, m.facts.joint_unit), "case": name, "kind": kind, "seed": seed, "time": wall, "joints": joints,
           "truth": {k: float(v) for k, v in truth.items()},
           "discovered": [t.equation for t in d.discovered], "library": d.named(), "confident": confident,
           "confident_before": before, "partial": [t.joint for t in d.discovered if t.partial],
           "unexplained": [u["channel"] for u in d.unexplained], "conclusion": d.conclusion}
    if kind == "clean":
        row["clean"] = not d.effects and not d.discovered and not d.unexplained
        return row
    row.update(score(kind, truth, joints, d, motion(m, seed, duration), pre))
    return row


def _truth_text(row):
    t, pre = row["truth"], row.get("prefix", "rail")
    F, Q = row.get("units", ("N", "m"))  # the joints' effort and position units
    mQ = "mm" if Q == "m" else "mrad"
    j = row["joints"][0]
    g = lambda k: t.get(f"{pre}[{j}].force_{k}")  # noqa: E731
    k = row["kind"]
    if k == "ripple":
        a = [t[f"{pre}[{i}].force_amplitude"] for i in row["joints"]]
        p = [t[f"{pre}[{i}].force_period"] for i in row["joints"]]
        return f"all: {min(a):.3g}-{max(a):.3g} {F}, P {1e3 * min(p):.1f}-{1e3 * max(p):.1f} {mQ}"
    text = {"constant_force": lambda: f"F={g('c'):.4g} {F}", "spring": lambda: f"k1={g('k1'):.4g} {F}/{Q}",
            "drag": lambda: f"v2={g('v2'):.4g} {F} s2/{Q}2",
            "direction_coulomb": lambda: f"cpos={g('cpos'):.3g}, cneg={g('cneg'):.3g} {F}",
            "one_way_damper": lambda: f"vpos={g('vpos'):.4g} {F} s/{Q}",
            "hardening_spring": lambda: f"k3={g('k3'):.4g} {F}/{Q}3",
            "detent": lambda: f"{g('step'):.3g} {F} at {g('step_q'):.4f} {Q}, w {1e3 * g('step_w'):.1f} {mQ}"}[k]()
    return f"{pre} {j}: {text}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robot", default="6pus", help="6pus (the hand-written MuJoCo 6-PUS) or a description "
                    "name (MuJoCo built from robots/NAME.toml by bench/foreign/mujoco_described.py), e.g. "
                    "linear_delta (default 6pus)")
    ap.add_argument("--kinds", default=",".join(KINDS), help="hidden force kinds (default: all)")
    ap.add_argument("--seeds", type=int, default=2, help="cases per kind (default 2)")
    ap.add_argument("--seed0", type=int, default=300, help="first seed (default 300)")
    ap.add_argument("--clean", type=int, default=4, help="clean MuJoCo recordings (default 4)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=REPO / "results" / "discovery_mujoco")
    ap.add_argument("--reuse", action="store_true", help="diagnose the recordings already in --out again "
                    "(the same cases: MuJoCo's runs are deterministic) instead of simulating them")
    a = ap.parse_args(argv)
    kinds = a.kinds.split(",")
    bad = [k for k in kinds if k not in KINDS]
    if bad:
        ap.error(f"unknown kind(s) {', '.join(bad)}; known: {', '.join(KINDS)}")
    a.out.mkdir(parents=True, exist_ok=True)
    jobs = [(a.robot, k, a.seed0 + 31 * s + i, str(a.out), a.reuse) for i, k in enumerate(kinds)
            for s in range(a.seeds)]
    jobs += [(a.robot, "clean", a.seed0 + 900 + s, str(a.out), a.reuse) for s in range(a.clean)]
    t_start = time.perf_counter()
    rows = []
    with Pool(a.jobs) as pool:
        for row in pool.imap_unordered(_run, jobs):
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "conclusion"}, default=float), flush=True)
    (a.out / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    ok = [r for r in rows if "failed" not in r]
    eff = sorted([r for r in ok if r["kind"] != "clean"], key=lambda r: (kinds.index(r["kind"]), r["seed"]))
    clean = [r for r in ok if r["kind"] == "clean"]
    print(f"\nMuJoCo {__import__('mujoco').__version__}, {a.robot}, PD + gravity, {len(eff)} cases with a hidden force, "
          f"{len(clean)} clean; {time.perf_counter() - t_start:.0f} s with {a.jobs} job(s)\n")
    print("| case | truth | named | right joints and structure | coefficient error | 95 % intervals hold | "
          "held-out RMS before -> after (ratio) | library named with confidence | time [s] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in eff:
        eqs = [e for e in r["discovered"] if any(re.match(rf"\w+ {j}:", e) for j in r["joints"])]
        named = "; ".join(eqs[:2]) + (f" (+{len(eqs) - 2} rails)" if len(eqs) > 2 else "")
        others = len(r["discovered"]) - len(eqs)
        named = (named or "no term") + (f"; + {others} term(s) on other rails" if others else "")
        if r["library"]:
            named += f"; library: {', '.join(r['library'])}"
        err = max(r["errors"]) if r["errors"] else float("inf")
        ba = (f"{max(r['before']):.3g} -> {max(r['after']):.3g} ({r['ratio']:.1f}x)" if r["before"]
              else f"({r['ratio']:.1f}x)")
        print(f"| {r['case']} | {_truth_text(r)} | {named} | {'yes' if r['right'] else 'NO'} | "
              f"{100 * err:.1f} % | {sum(r['hits'])}/{len(r['hits'])} | {ba} | "
              f"{', '.join(r['confident']) or '-'} | {r['time']:.1f} |")
    for r in clean:
        print(f"| {r['case']} | nothing | {'; '.join(r['discovered'] + r['library']) or 'nothing'} | "
              f"{'called clean' if r['clean'] else 'NOT CLEAN'} | | | | {', '.join(r['confident']) or '-'} | "
              f"{r['time']:.1f} |")
    n = len(eff)
    if n:
        right = sum(r["right"] for r in eff)
        within = sum(bool(r["errors"]) and max(r["errors"]) < 0.15 for r in eff)
        gain = sum(r["ratio"] >= 3 for r in eff)
        conf = sum(bool(r["confident"]) for r in eff)
        hits = [h for r in eff for h in r["hits"]]
        print(f"\nright rails and structure: {right}/{n} ({100 * right / n:.0f} %; acceptance >= 80 %)")
        print(f"coefficients within 15 %:  {within}/{n}")
        print(f"held-out RMS >= 3x lower:  {gain}/{n}")
        print(f"library effect named first with confidence: {conf} (acceptance 0; without the structure rule "
              f"{sum(bool(r['confident_before']) for r in eff)})")
        print(f"right rails whose term is flagged a partial fit: "
              f"{sum(r['right'] and bool(set(r['partial']) & set(r['joints'])) for r in eff)}/{right}")
        if hits:
            p = sum(hits) / len(hits)
            se = math.sqrt(p * (1 - p) / len(hits))
            print(f"stated 95 % intervals containing the truth: {sum(hits)}/{len(hits)} ({100 * p:.0f} +- "
                  f"{100 * se:.0f} %, binomial standard error)")
        print(f"diagnosis time: median {np.median([r['time'] for r in ok]):.1f} s, "
              f"largest {max(r['time'] for r in ok):.1f} s")
    if clean:
        print(f"clean recordings called clean: {sum(r['clean'] for r in clean)}/{len(clean)}, with a discovered term: "
              f"{sum(bool(r['discovered']) for r in clean)}")
    for r in rows:
        if "failed" in r:
            print(f"not generated: {r['case']}: {r['failed']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
