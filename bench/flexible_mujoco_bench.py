"""The flexible stage (cosim.discrepancy.flexible) on forces hidden in MuJoCo's physics of the 6-PUS.

    .venv/bin/python bench/flexible_mujoco_bench.py [--seeds 3] [--clean 2] [--base 12000]

``--capture DIR`` keeps, per case, what the flexible stage was given and ``--replay DIR`` re-runs
only the stage on it, as ``bench/flexible_bench.py`` does (its ``_captured`` and ``replay``).

The MuJoCo model is bench/foreign/mujoco_blind.py's (the hand-written 6-PUS, PD + gravity, the
engine's exciting trajectory, the generator's sensor noise).  A force none of the discovery
step's families covers is computed in MuJoCo's step from MuJoCo's own state (``simulate(...,
hook=...)``: the rails' true positions, not the reference, unlike flexible/cases.py), so neither
the core nor flexible.cases computes it:

* ``position_threshold``: on rail j, zero below q0 (50-70 % of the way from the 10th to the 90th
  percentile of its position) and 2A tanh((q - q0) / w)^2 above it (w half the way to the 90th);
* ``cross_position``: on rail j, a bump 2A exp(-((q_k - c) / w)^2) keyed on another rail k's
  position (c between its 30th and 70th percentiles, w 15 % of its 10-90 % range);
* ``heating``: on rail j, a friction that falls as the drive warms, A tanh(qd / v) (1 - 0.6
  min(T / T_ref, 1)), qd the rail's true rate, T its dissipated power |u qd| (u the motor's
  command) low-passed over 1.5-3 s in MuJoCo's step, T_ref its RMS effort times its RMS rate;

A 15-30 % of the rail's RMS effort.  Each recording is diagnosed blind with the defaults; the
key is read afterwards.  Per case, as bench/flexible_bench.py: the inputs named against the true
ones, the share against the truth's (flexible.cases.truth_share, from the logged force).  No
threshold of the stage was set on these cases.

A second judgement, in its own column and line, as bench/foreign/mujoco_unlisted.py's: the true
inputs against what either stage models on the rail's channel (:func:`unlisted_common.judge_either`
on the diagnosis's :func:`unlisted_common.stage_reads`, with the discovery's confident terms and
with its partial ones too), the truth written as a declaration that needs and allows exactly the
true groups (:func:`declared`: the first judgement's set equality).  A replay has it where its
capture kept ``stage_reads``.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

from unlisted_common import either_cell, either_line, judge_either, stage_reads  # noqa: E402

KINDS = ("position_threshold", "cross_position", "heating")
#: the friction's rate scale [m/s] (as bench/foreign/mujoco_unnamed.py)
V_FRICTION = 3e-4
DURATION, LEAD = 9.0, 0.5


def draw(kind, rng, mo):
    """(hook, log of (t, force the drive spends on rail j), joint j (1-based), truth groups)."""
    n = len(mo["E"])
    j = int(rng.integers(n))
    a = float(rng.uniform(0.15, 0.3)) * mo["E"][j]
    log = []
    if kind == "position_threshold":
        lo, hi = mo["q10"][j], mo["q90"][j]
        q0 = lo + float(rng.uniform(0.5, 0.7)) * (hi - lo)
        w = 0.5 * (hi - q0)
        k, truth = j, [f"position of slider {j + 1}"]

        def cost(q):
            return 2 * a * math.tanh((q[j] - q0) / w) ** 2 if q[j] > q0 else 0.0
    elif kind == "heating":
        tc = float(rng.uniform(1.5, 3.0))
        t_ref = mo["E"][j] * mo["V"][j]
        state = {"T": 0.0, "t": None}
        truth = [f"rate of slider {j + 1}", f"history of slider {j + 1}"]

        def hook(model, data, t, q, qd, u):
            if state["t"] is not None:
                state["T"] += (1 - math.exp(-(t - state["t"]) / tc)) * (abs(u[j] * qd[j]) - state["T"])
            state["t"] = t
            f = np.zeros(n)
            f[j] = -a * math.tanh(qd[j] / V_FRICTION) * (1 - 0.6 * min(state["T"] / t_ref, 1.0))
            log.append((t - LEAD, -f[j]))
            return f
        return hook, log, j + 1, truth
    else:
        k = int((j + 1 + rng.integers(n - 1)) % n)
        lo, hi = mo["q10"][k], mo["q90"][k]
        c = float(np.interp(rng.uniform(0.3, 0.7), [0.1, 0.9], [lo, hi]))
        w = 0.15 * (hi - lo)
        truth = [f"position of slider {k + 1}"]

        def cost(q):
            return 2 * a * math.exp(-(((q[k] - c) / w) ** 2))

    def hook(model, data, t, q, qd, u):
        f = np.zeros(n)
        f[j] = -cost(q)  # pushes along -q: the drive spends +cost
        log.append((t - LEAD, -f[j]))
        return f
    return hook, log, j + 1, truth


def declared(truth) -> dict:
    """The true groups as a declaration of :func:`unlisted_common.judge_either`: every one needed,
    nothing else allowed (on one channel, the named set equal to the truth's, as ``inputs_ok``)."""
    return {"need": set(truth), "any": set(), "allowed": set(truth)}


def either(row, fits) -> dict:
    """``row`` (a mechanism's, with ``stage_reads``) with ``either_right``: per variant of
    :func:`unlisted_common.stage_reads`, whether either stage models the true inputs on the rail's
    channel (:func:`unlisted_common.judge_either`, :func:`declared`)."""
    row["either_right"] = {v: judge_either(fits, reads, declared(row["truth_inputs"]), row["joint"])
                           for v, reads in row["stage_reads"].items()}
    return row


def one(kind, seed, out, capture=None):
    import flexible_bench as fb
    import mujoco_blind as mb
    from discovery_mujoco_bench import motion
    from threadpoolctl import threadpool_limits

    from cosim.core import Model
    from cosim.discrepancy import blind, diagnose
    from cosim.discrepancy.flexible.cases import truth_share

    m = Model("6pus")
    hook, log, joint, truth = None, [], None, []
    if kind != "clean":
        hook, log, joint, truth = draw(kind, np.random.default_rng(seed), motion(m, seed, DURATION))
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, DURATION, blind.load_config()["noise"]["6pus"], hook=hook)
    csv = mb.write_case(m, rec, Path(out) / f"{kind}_{seed}.csv")
    with threadpool_limits(limits=1):
        t0 = time.process_time()
        d, kept = fb._captured(lambda: diagnose(csv, figures=False, replay=False))
        cpu = time.process_time() - t0
    row = {"kind": kind, "seed": seed, "cpu": cpu, "joint": joint, "truth": truth, "truth_inputs": truth,
           "flex_cpu": d.timings.get("flexible", 0.0)}
    if kind == "clean":
        row["claims"] = [(f.channel, round(f.share, 2), list(f.named)) for f in d.flexible if f.explained]
        fb._keep(capture, row, kept)
        return row
    lt = np.array(log)
    force = np.zeros((len(lt), 6))
    force[:, joint - 1] = lt[:, 1]
    key = {"joint": joint, "time": lt[:, 0], "force": force}
    fit = next((f for f in d.flexible if f.joint == joint), None)
    row["truth_share"] = truth_share(d, key, fit)
    row["share"] = fit.share if fit is not None and fit.explained else 0.0
    row["named"] = list(fit.named) if fit is not None else []
    row["inputs_ok"] = bool(row["named"]) and set(row["named"]) == set(truth)
    row["share_ok"] = abs(row["share"] - row["truth_share"]) <= 0.10
    row["others"] = [(f.channel, list(f.named)) for f in d.flexible if f.explained and f.joint != joint]
    row["stage_reads"] = stage_reads(d)
    either(row, d.flexible)
    fb._keep(capture, row, kept)
    return row


def case(kind, seed, a):
    """:func:`one`, or its stage re-run on the inputs ``--capture`` kept (``--replay``)."""
    if a.replay is None:
        return one(kind, seed, a.out, a.capture)
    import flexible_bench as fb

    row, fits = fb.replay(Path(a.replay) / f"{seed}.pkl", with_fits=True)
    row["truth"] = row["truth_inputs"]
    if kind == "clean":
        row["claims"] = [(c, round(s, 2), g) for c, s, g in row["claims"]]
    elif "stage_reads" in row:  # the rest of the diagnosis as captured, the flexible stage's fits re-run
        either(row, fits)
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--clean", type=int, default=2)
    ap.add_argument("--base", type=int, default=12000)
    ap.add_argument("--out", default="/tmp/flexible_mujoco")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--capture", default=None, help="keep each case's stage inputs in this directory")
    ap.add_argument("--replay", default=None, help="re-run only the stage on the inputs kept there (--capture)")
    a = ap.parse_args(argv)
    Path(a.out).mkdir(parents=True, exist_ok=True)
    rows = []
    for i in range(a.seeds):
        for k in a.kinds.split(","):
            r = case(k, a.base + 10 * i + KINDS.index(k), a)
            rows.append(r)
            print(f"{k:20s} seed {r['seed']} joint {r['joint']}: share {r['share']:.2f} truth {r['truth_share']:.2f} | "
                  f"named {r['named']} truth {r['truth']} | {'OK' if r['inputs_ok'] else 'wrong'} inputs, share "
                  f"{'OK' if r['share_ok'] else 'off'} | either stage (confident terms / with partial): "
                  f"{either_cell(r)} | cpu {r['cpu']:.1f} s (flexible stage {r['flex_cpu']:.2f} s) | "
                  f"other channels {r['others']}",
                  flush=True)
    for i in range(a.clean):
        r = case("clean", a.base + 500 + i, a)
        rows.append(r)
        print(f"{'clean':20s} seed {r['seed']}: claims {r['claims']} | cpu {r['cpu']:.1f} s", flush=True)
    print("\n" + "\n".join(summary(rows, a.base, a.clean)))


def summary(rows, base, clean) -> list:
    """The counts of a run's ``rows``: the flexible stage's line, then the either-stage judgement's
    (:func:`unlisted_common.either_line`, where the rows kept the whole diagnosis)."""
    eff = [r for r in rows if r["kind"] != "clean"]
    return ([f"MuJoCo, base {base}: inputs right {sum(r['inputs_ok'] for r in eff)} of {len(eff)}, shares within "
             f"10 points {sum(r['share_ok'] for r in eff)} of {len(eff)}; clean with no claim "
             f"{sum(not r['claims'] for r in rows if r['kind'] == 'clean')} of {clean}; "
             f"diagnosis CPU max {max(r['cpu'] for r in rows):.1f} s"] + either_line(eff))


if __name__ == "__main__":
    main()
