"""Forces no issue named, hidden in MuJoCo's physics of the 6-PUS, diagnosed blind with the defaults.

    .venv/bin/python bench/foreign/mujoco_unnamed.py --set tune|report [--kinds load_friction,...]
        [--seeds 2] [--clean 4] [--jobs 2] [--out results/mujoco_unnamed]

The MuJoCo model is bench/foreign/mujoco_blind.py's (the hand-written 6-PUS, PD + gravity, the
engine's exciting trajectory, the generator's sensor noise); this file hides one mechanism per
case in MuJoCo's step (``simulate(..., hook=...)``), computed here from MuJoCo's own state, so
neither the core nor its joint force computes it; each case is diagnosed with the defaults and
the term families (``diagnose(families=True)``, the default):

* ``load_friction``: a Coulomb friction mu |u| tanh(qd / v) on one rail, u the force the motor
  applies (MuJoCo's ``ctrl``): the engine's family ``load`` (force_cload = mu);
* ``friction_zone``: a Coulomb level c tanh(qd / v) (1 + tanh((q - q_z) / w)) / 2 over one side of
  a rail's stroke: the family ``stroke`` (force_czone = c);
* ``cable_link``: a force -k (q_k - q_k,home) on rail j from rail k's position (a cable carrier
  linking two carriages): the family ``cross`` (force_xk1 = k, read from joint k);
* ``platform_cable``: a cable of constant tension T from the platform's reference point to a
  fixed anchor, applied as MuJoCo's ``xfrc_applied`` on the platform body (force and the moment
  of its offset from the body's centre of mass): the platform force ``cable`` (cable.tension = T);
* ``friction_drift``: a viscous friction b(t) on one rail falling linearly by 30-50 % over the
  recording (a drive warming up): the library's viscous friction with a drift ``trend`` whose
  size is the change over the recording;
* ``payload_step``: a mass added to the platform body half way (MuJoCo's ``body_mass`` changed
  during the run): the library's platform mass with a drift ``step`` of that size.

Magnitudes are drawn per case (the joint too): the friction and link forces 10-20 % of the rail's
RMS effort, the cable 0.3-0.5 N (the rails' RMS efforts are 0.5-0.9 N), the payload 15-30 % of the
platform's mass.  A case is *modelled* when the engine writes the mechanism's structure on the
right joint (or the platform / the right parameter) with its coefficient within 15 %; a
*confident wrong name* is a library effect named without a declared tie on a case whose truth is
outside the library (the drifting parameter's own effect is the truth's mean, not a wrong name).

Seed sets: ``--set tune`` draws seeds from 51000, ``--set report`` from 77000; the engine's rules
were set on the tune set and the test seeds only.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

KINDS = ("load_friction", "friction_zone", "cable_link", "platform_cable", "friction_drift", "payload_step")
SEEDS = {"tune": 51000, "report": 77000}
#: MuJoCo's friction is smooth over this rate [m/s]
V_FRICTION = 3e-4
DURATION, LEAD = 9.0, 0.5  # s of MuJoCo run; the recording starts after the lead-in


def draw(kind, rng, mo, home, m):
    """(hook for mujoco_blind.simulate, truth {key: value}, joints (1-based)) of one case."""
    n = len(mo["E"])
    j = int(rng.integers(n))
    size = float(rng.uniform(0.1, 0.2))
    E, T = mo["E"], mo["T"]
    rail = lambda i, k: f"rail[{i + 1}].{k}"  # noqa: E731
    if kind == "load_friction":
        mu = size * E[j] / mo["absu"][j]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -mu * abs(u[j]) * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {rail(j, "force_cload"): mu}, [j + 1]
    if kind == "friction_zone":
        c = 1.5 * size * E[j]
        qz = float(rng.uniform(mo["q10"][j], mo["q90"][j]))
        w = float(rng.choice([-1, 1]) * rng.uniform(0.05, 0.2) * T[j])

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -c * math.tanh(qd[j] / V_FRICTION) * 0.5 * (1.0 + math.tanh((q[j] - qz) / w))
            return f
        return hook, {rail(j, "force_czone"): c, rail(j, "force_czone_q"): qz, rail(j, "force_czone_w"): w}, [j + 1]
    if kind == "cable_link":
        k_other = int((j + 1 + rng.integers(n - 1)) % n)
        k = 1.5 * size * E[j] / T[k_other]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -k * (q[k_other] - home[k_other])
            return f
        return hook, {rail(j, "force_xk1"): k, rail(j, "force_xj"): k_other + 1.0}, [j + 1]
    if kind == "platform_cable":
        tension = float(rng.uniform(0.3, 0.5))
        d = rng.normal(size=3)
        d[2] = abs(d[2])
        anchor = np.asarray(m.home()[:3]) + d / np.linalg.norm(d) * float(rng.uniform(0.25, 0.6))

        def hook(model, data, t, q, qd, u):
            b = model.body("platform").id
            p = data.xpos[b]
            f = tension * (anchor - p) / np.linalg.norm(anchor - p)
            data.xfrc_applied[b, :3] = f
            data.xfrc_applied[b, 3:] = np.cross(p - data.xipos[b], f)
            return None
        return hook, {"cable.tension": tension, **{f"cable.anchor_{a}": float(v) for a, v in zip("xyz", anchor)}}, []
    if kind == "friction_drift":
        b0 = 2.0 * size * E[j] / mo["V"][j]
        r = float(rng.uniform(0.3, 0.5))
        span = DURATION - LEAD

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -b0 * (1.0 - r * max(t - LEAD, 0.0) / span) * qd[j]
            return f
        return hook, {rail(j, "viscous"): b0 * (1 - 0.5 * r), "size": -r * b0}, [j + 1]
    if kind == "payload_step":
        dm = float(rng.uniform(0.15, 0.3)) * m.params()["platform.m"]
        t_s = LEAD + float(rng.uniform(0.35, 0.65)) * (DURATION - LEAD)
        state = {"done": False}

        def hook(model, data, t, q, qd, u):
            if not state["done"] and t >= t_s:
                model.body_mass[model.body("platform").id] += dm
                state["done"] = True
            return None
        return hook, {"platform.m": dm, "size": dm, "time": t_s - LEAD}, []
    raise ValueError(f"unknown kind {kind!r} (known: {', '.join(KINDS)})")


def motion(m, seed):
    """The discovery bench's per-rail motion figures plus the mean |feed-forward effort|."""
    from discovery_mujoco_bench import motion as mo
    from mujoco_blind import DT

    from cosim.discrepancy.excitation import excitation
    from cosim.master import make_reference

    out = mo(m, seed, DURATION)
    traj = excitation(m, DURATION, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    k0 = int(round(LEAD / DT))
    tau = m.inverse_dynamics(ref.x[k0:], ref.xd[k0:], ref.xdd[k0:])
    out["absu"] = np.mean(np.abs(tau), axis=0)
    return out


def _term_on(d, j):
    return next((t for t in d.discovered if t.joint == j), None)


def score(kind, truth, joints, d):
    """(modelled, coefficient error) of a case against the truth."""
    if kind in ("load_friction", "friction_zone", "cable_link"):
        (j,) = joints
        t = _term_on(d, j)
        need = {"load_friction": "force_cload", "friction_zone": "force_czone", "cable_link": "force_xk1"}[kind]
        key = f"rail[{j}].{need}"
        if t is None or key not in t.coefficients:
            return False, float("inf")
        if kind == "cable_link" and t.shape.get(f"rail[{j}].force_xj") != truth[f"rail[{j}].force_xj"]:
            return False, float("inf")
        err = abs(t.coefficients[key].value / truth[key] - 1)
        return err < 0.15, err
    if kind == "platform_cable":
        pf = d.platform_force
        if pf is None or pf.family.split("+")[0] != "cable":
            return False, float("inf")
        err = abs(pf.params["cable.tension"] / truth["cable.tension"] - 1)
        return err < 0.15, err
    param, want = ("rail[{}].viscous".format(joints[0]), "trend") if kind == "friction_drift" else ("platform.m", "step")
    dr = next((x for x in d.drifts if x.param == param), None)
    if dr is None or dr.kind != want:
        return False, float("inf")
    err = abs(dr.size / truth["size"] - 1)
    return err < 0.15, err


def _run(job):
    import mujoco_blind as mb

    from cosim.core import Model
    from cosim.discrepancy import blind, diagnose
    from cosim.discrepancy.diagnosis import tied

    kind, seed, out = job
    m = Model("6pus")
    hook, truth, joints = None, {}, []
    if kind != "clean":
        hook, truth, joints = draw(kind, np.random.default_rng(seed), motion(m, seed), m.ik(m.home()), m)
    csv = Path(out) / f"{kind}_{seed}.csv"
    noise = blind.load_config()["noise"]["6pus"]
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, DURATION, noise, hook=hook)
    csv = mb.write_case(m, rec, csv)
    t0 = time.process_time()
    d = diagnose(csv, figures=False, replay=False, families=True)  # blind, the defaults and the families
    cpu = time.process_time() - t0
    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    own = {"friction_drift": "viscous", "payload_step": "platform_mass"}.get(kind)
    wrong = [k for k in confident if k != own]
    row = {"case": f"{kind}_{seed}", "kind": kind, "seed": seed, "cpu": cpu, "joints": joints, "truth": truth,
           "discovered": [t.equation for t in d.discovered], "library": d.named(), "confident_wrong": wrong,
           "platform": d.platform_force.equation if d.platform_force else "",
           "drifts": [f"{x.param} {x.kind} {x.size:.4g}" for x in d.drifts], "conclusion": d.conclusion}
    if kind == "clean":
        row["clean"] = not (d.effects or d.discovered or d.unexplained or d.platform_force or d.drifts)
    else:
        row["modelled"], row["error"] = score(kind, truth, joints, d)
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--set", choices=tuple(SEEDS), required=True, help="the seed set: tune or report")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--seeds", type=int, default=2, help="cases per kind (default 2)")
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=REPO / "results" / "mujoco_unnamed")
    a = ap.parse_args(argv)
    kinds = a.kinds.split(",")
    bad = [k for k in kinds if k not in KINDS]
    if bad:
        ap.error(f"unknown kind(s) {', '.join(bad)}; known: {', '.join(KINDS)}")
    out = a.out / a.set
    out.mkdir(parents=True, exist_ok=True)
    s0 = SEEDS[a.set]
    jobs = [(k, s0 + 37 * s + i, str(out)) for s in range(a.seeds) for i, k in enumerate(kinds)]
    jobs += [("clean", s0 + 900 + s, str(out)) for s in range(a.clean)]
    rows = []
    with Pool(a.jobs) as pool:
        for row in pool.imap_unordered(_run, jobs):
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "conclusion"}, default=float), flush=True)
    (out / "rows.json").write_text(json.dumps(rows, indent=1, default=float))
    eff = sorted([r for r in rows if r["kind"] != "clean"], key=lambda r: (KINDS.index(r["kind"]), r["seed"]))
    clean = [r for r in rows if r["kind"] == "clean"]
    print(f"\nMuJoCo 6-PUS, set {a.set} (seeds from {s0}): {len(eff)} cases with a hidden mechanism, {len(clean)} clean\n")
    print("| case | modelled (error) | discovered / platform / drifts | library named with confidence, wrong | "
          "CPU [s] |")
    print("| --- | --- | --- | --- | --- |")
    for r in eff:
        what = "; ".join(r["discovered"] + ([r["platform"]] if r["platform"] else []) + r["drifts"]) or "nothing"
        err = f"{100 * r['error']:.1f} %" if math.isfinite(r["error"]) else "-"
        print(f"| {r['case']} | {'yes' if r['modelled'] else 'NO'} ({err}) | {what} | "
              f"{', '.join(r['confident_wrong']) or '-'} | {r['cpu']:.1f} |")
    for r in clean:
        print(f"| {r['case']} | {'clean' if r['clean'] else 'NOT CLEAN'} | "
              f"{'; '.join(r['discovered'] + r['library'] + r['drifts']) or 'nothing'} | - | {r['cpu']:.1f} |")
    if eff:
        n = len(eff)
        print(f"\nmodelled as their structure (coefficient within 15 %): {sum(r['modelled'] for r in eff)}/{n}")
        for k in kinds:
            rk = [r for r in eff if r["kind"] == k]
            print(f"  {k}: {sum(r['modelled'] for r in rk)}/{len(rk)}")
        print(f"cases with a library effect named with confidence that is not the truth: "
              f"{sum(bool(r['confident_wrong']) for r in eff)}/{n}")
    if clean:
        print(f"clean recordings called clean: {sum(r['clean'] for r in clean)}/{len(clean)}")
    print(f"diagnosis CPU: largest {max(r['cpu'] for r in rows):.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
