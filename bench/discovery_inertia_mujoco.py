"""An inertia hidden on one joint of a MuJoCo recording: found by the discovery step as an
added inertia (``<j>[i].force_inertia``) with the library's rotor inertia held out, named as
the rotor inertia with the whole library.

    .venv/bin/python bench/discovery_inertia_mujoco.py [--robots linear_delta] [--seeds 3] [--jobs 2]

Each case is a run of MuJoCo built from the description robots/NAME.toml
(bench/foreign/mujoco_described.py, recorded by bench/foreign/mujoco_described_blind.py: PD +
gravity, the engine's exciting trajectory, the generator's sensor noise) with an armature added
to one actuated joint in MuJoCo's model (a rotor, a pulley, a mass riding on the carriage: in
MuJoCo's joint-space mass matrix, computed by neither the core nor its joint force).  Its size:
10-25 % of the joint's own inertia at home (the diagonal of the core's joint-space mass matrix),
the joint drawn per case.  Each recording is diagnosed blind twice, with the default settings:
with the library less its rotor inertia, and with the whole library.  Nothing of the engine was
tuned on these cases.

Printed per case: the truth, the terms discovered (held out) and their error, the held-out RMS
of the joint's channel before and after, library effects named with confidence, what the whole
library names and its error, and the times.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]
DURATION = 9.0


def joint_inertia(m) -> np.ndarray:
    """The diagonal of the joint-space mass matrix at home, J^-T M J^-1 (qd = J xd) [kg | kg m2]."""
    x = m.home()
    n = len(x)
    J = np.column_stack([m.joint_velocity(x, np.eye(n)[k]) for k in range(n)])
    Ji = np.linalg.inv(J)
    return np.diag(Ji.T @ m.mass_matrix(x) @ Ji)


def _run(job):
    import mujoco_described_blind as mdb

    from cosim.core import Model
    from cosim.discrepancy import diagnose
    from cosim.discrepancy.effects import groups_for, joint_prefix
    from cosim.recording import write_recording

    robot, seed, out = job
    m = Model(robot)
    pre = joint_prefix(m)
    rng = np.random.default_rng(seed)
    j = int(rng.integers(m.ndof))
    inertia = float(rng.uniform(0.1, 0.25)) * float(joint_inertia(m)[j])
    name = f"{pre}[{j + 1}]"
    csv = Path(out) / f"{robot}_inertia_{seed}.csv"
    try:
        write_recording(csv, mdb.simulate(robot, seed, DURATION, armature={j: inertia}))
    except Exception as e:  # noqa: BLE001 - a drawn case the controller cannot hold is reported
        return {"robot": robot, "seed": seed, "failed": str(e)}
    lib = sorted({g.effect.key for g in groups_for(m, True)[0]})
    row = {"robot": robot, "seed": seed, "joint": j + 1, "truth": inertia}
    t0 = time.perf_counter()
    d = diagnose(csv, figures=False, replay=False, effects=[e for e in lib if e != "rotor_inertia"])
    row["time_held_out"] = time.perf_counter() - t0
    found = {t.joint: t for t in d.discovered}
    t = found.get(j + 1)
    c = t.coefficients.get(f"{name}.force_inertia") if t else None
    row.update(discovered=[x.equation for x in d.discovered],
               right=bool(c is not None and set(found) == {j + 1}),
               error=abs(c.value / inertia - 1) if c else float("inf"),
               covered=bool(c is not None and abs(c.value - inertia) <= c.ci95),
               ratio=t.heldout_before / max(t.heldout_after, 1e-300) if t else 0.0,
               confident=[e["key"] for e in d.effects if not d.ties(e["key"])],
               unexplained=[u["channel"] for u in d.unexplained])
    t0 = time.perf_counter()
    full = diagnose(csv, figures=False, replay=False)
    row["time_full"] = time.perf_counter() - t0
    got = full.theta.get(f"{name}.rotor_inertia")
    row.update(full_named=full.named(), full_discovered=[x.equation for x in full.discovered],
               full_error=abs(got / inertia - 1) if got is not None else float("inf"),
               full_tied=bool(full.ties("rotor_inertia")))
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", default="linear_delta", help="description names, comma-separated")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--seed0", type=int, default=700)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=REPO / "results" / "discovery_inertia_mujoco")
    a = ap.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    jobs = [(r, a.seed0 + 17 * s, str(a.out)) for r in a.robots.split(",") for s in range(a.seeds)]
    with Pool(a.jobs) as pool:
        rows = list(pool.imap_unordered(_run, jobs))
    for r in rows:
        print(json.dumps(r, default=float), flush=True)
    ok = sorted([r for r in rows if "failed" not in r], key=lambda r: (r["robot"], r["seed"]))
    print("\n| robot | seed | truth | held out: discovered on the joint | error | 95 % interval holds | "
          "held-out RMS ratio | confident library names | whole library names | its error | time [s] |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in ok:
        eq = "; ".join(r["discovered"]) or "no term"
        print(f"| {r['robot']} | {r['seed']} | joint {r['joint']}: {r['truth']:.4g} | {eq} | {100 * r['error']:.1f} % | "
              f"{'yes' if r['covered'] else 'no'} | {r['ratio']:.1f} | {', '.join(r['confident']) or '-'} | "
              f"{', '.join(r['full_named']) or '-'}{' (tied)' if r['full_tied'] else ''}"
              f"{'; + ' + '; '.join(r['full_discovered']) if r['full_discovered'] else ''} | "
              f"{100 * r['full_error']:.1f} % | {r['time_held_out']:.1f} + {r['time_full']:.1f} |")
    for r in rows:
        if "failed" in r:
            print(f"| {r['robot']} | {r['seed']} | failed: {r['failed']} |")
    right = [r for r in ok if r["right"] and r["error"] < 0.15]
    print(f"\nheld out: right joint within 15 % in {len(right)}/{len(ok)}, confident library names in "
          f"{sum(bool(r['confident']) for r in ok)}; whole library: rotor inertia within 15 % in "
          f"{sum(r['full_error'] < 0.15 for r in ok)}/{len(ok)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
