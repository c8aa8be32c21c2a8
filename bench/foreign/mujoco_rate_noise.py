"""Errors in variables: the engine on MuJoCo recordings with growing rate-reading noise,
masses and inertias fitted by least squares on the measured motion against instrumental
variables from the reference.

    .venv/bin/python bench/foreign/mujoco_rate_noise.py [--scales 1,5,15] [--seeds 3] [--seed 31]
        [--duration 9] [--out results/foreign_rate_noise]

The recordings are those of ``mujoco_blind.py`` (the 6-PUS in MuJoCo, PD + gravity at 1 kHz,
the generator's sensor noise) with the standard deviation of the rate readings multiplied by
each scale (1: 0.2 mm/s; 15: 3 mm/s, a velocity differentiated from a coarse encoder), for
the effects whose regressors carry the measured rates and accelerations (rotor inertia,
viscous friction, platform mass, payload) and clean runs.  Every recording is diagnosed twice,
``instruments=False`` and ``instruments=True``, blind; the truth stays in this process.
Prints one row per case and a summary per scale and estimator: right effect first (clean:
nothing named), parameter error (median and largest), spurious extra effects.  Nothing of the
engine is tuned on these cases.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402

#: the effect types whose columns are built from the measured motion (INSTRUMENTED), and clean
TYPES = ("rotor_inertia", "viscous", "platform_mass", "payload", None)


def cases(seed: int, n: int):
    """(effect, value, joint, case seed) drawn from scenarios/blind/config.toml's ranges."""
    cfg = blind.load_config()["effects"]["6pus"]
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        for i, e in enumerate(TYPES):
            v = 0.0 if e is None else mb._draw(e, cfg, rng)
            out.append((e, v, int(rng.integers(6)), seed * 1000 + 10 * k + i))
    return out


def score(d, effect, key, truth, nominal):
    named = d.named()
    if effect is None:
        return {"ok": not named, "err": None, "extra": len(named), "named": named}
    first = named[0] if named else None
    ok = first == effect or (first is not None and effect in d.ties(first))
    est = d.plant_parameters()
    err = None
    if key in est and key in truth:
        err = abs(est[key] - truth[key]) / max(abs(truth[key] - nominal.get(key, 0.0)), 1e-12)
    return {"ok": bool(ok), "err": err, "extra": max(len(named) - 1, 0), "named": named}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scales", default="1,5,15", help="rate-noise multipliers (default 1,5,15)")
    ap.add_argument("--seeds", type=int, default=3, help="cases per type and scale (default 3)")
    ap.add_argument("--seed", type=int, default=31, help="seed of the draws (default 31)")
    ap.add_argument("--duration", type=float, default=9.0, help="recorded seconds per case (default 9)")
    ap.add_argument("--out", type=Path, default=REPO / "results" / "foreign_rate_noise")
    a = ap.parse_args(argv)
    m = Model("6pus")
    nominal = m.params()
    base = blind.load_config()["noise"]["6pus"]
    a.out.mkdir(parents=True, exist_ok=True)
    rows, t0 = [], time.perf_counter()
    for scale in [float(s) for s in a.scales.split(",")]:
        noise = dict(base, qd=base["qd"] * scale)
        for effect, value, joint, seed in cases(a.seed, a.seeds):
            rec, truth = mb.simulate(m, effect, value, joint, seed, a.duration, noise)
            name = f"{effect or 'clean'}_x{scale:g}_{seed}"
            csv = mb.write_case(m, rec, a.out / f"{name}.csv")
            key = mb.EFFECTS[effect][1].format(j=joint + 1) if effect else None
            row = {"case": name, "scale": scale, "hidden": effect or "clean"}
            for est in ("least_squares", "instruments"):
                d = diagnose(csv, figures=False, replay=False, instruments=est == "instruments")
                row[est] = score(d, effect, key, truth, nominal)
            rows.append(row)
            cells = []
            for est in ("least_squares", "instruments"):
                s = row[est]
                e = "-" if s["err"] is None else f"{100 * s['err']:.1f} %"
                cells.append(f"{'ok ' if s['ok'] else 'MISS'} {e:>8s} +{s['extra']}")
            print(f"{name:28s} LS {cells[0]}   IV {cells[1]}", flush=True)
    print(f"\nrate noise x scale, {len(rows)} recordings, {time.perf_counter() - t0:.0f} s")
    print("| rate noise | estimator | right first (effects) | clean called clean | parameter error median / largest"
          " | within 10 % | extra effects named |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for scale in sorted({r["scale"] for r in rows}):
        for est in ("least_squares", "instruments"):
            rs = [r for r in rows if r["scale"] == scale]
            eff = [r[est] for r in rs if r["hidden"] != "clean"]
            cln = [r[est] for r in rs if r["hidden"] == "clean"]
            errs = [s["err"] for s in eff if s["err"] is not None]
            print(f"| {scale:g} x {base['qd'] * 1e3:g} mm/s | {est.replace('_', ' ')} | "
                  f"{sum(s['ok'] for s in eff)}/{len(eff)} | {sum(s['ok'] for s in cln)}/{len(cln)} | "
                  f"{100 * np.median(errs):.1f} % / {100 * max(errs):.1f} % | "
                  f"{sum(e < 0.1 for e in errs)}/{len(errs)} | {sum(s['extra'] for s in eff + cln)} |")
    (a.out / "summary.json").write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
