"""Every shipped scenario of every robot run without noise on the nominal plant, then diagnosed:
each must read clean ("no missing physics found": no effect, no discovered term, no structure).

A noiseless recording of the model itself has residuals at the pipeline's numerical accuracy;
this checks that the engine does not take them for physics.  Scenarios whose plant differs from
their model on purpose (a heavier payload, a hidden truth) and calibration campaigns are
listed as skipped.

    .venv/bin/python bench/noise_free_bench.py [--out results/noise_free]
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(argv=None):
    from cosim.discrepancy import diagnose
    from cosim.scenario import build_models, load_scenario, run_scenario

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/noise_free")
    a = ap.parse_args(argv)
    files = sorted(p for p in (REPO / "scenarios").rglob("*.toml")
                   if not {"blind", "sweeps"} & set(p.relative_to(REPO / "scenarios").parts))
    print("| scenario | robot | samples | diagnosis | time [s] |")
    print("| --- | --- | --- | --- | --- |")
    clean = total = 0
    for f in files:
        try:
            sc = load_scenario(f)
            spec = dict(sc.spec)
            spec["noise"] = {k: 0.0 for k in spec.get("noise", {})}
            sc = type(sc)(spec, sc.path)
            _, _, truth = build_models(sc)
        except Exception as e:  # noqa: BLE001 - not a run scenario (a calibration campaign...)
            print(f"| {f.relative_to(REPO)} | | | skipped: {str(e).splitlines()[0][:80]} | |")
            continue
        if truth:
            print(f"| {f.relative_to(REPO)} | {sc.spec['robot']} | | skipped: its plant differs from its model "
                  f"({', '.join(sorted(truth))[:60]}) | |")
            continue
        out = Path(a.out) / sc.name
        try:
            res = run_scenario(sc, plant="core", out_dir=out, figures=False, progress=False)
        except Exception as e:  # noqa: BLE001 - reported
            print(f"| {f.relative_to(REPO)} | {sc.spec['robot']} | | run failed: {str(e)[:80]} | |")
            continue
        t0 = time.perf_counter()
        try:
            d = diagnose(res.files["recording"], figures=False, replay=False)
            ok = d.conclusion == "no missing physics found" and not d.discovered and not d.unexplained
            what = d.conclusion[:160]
        except Exception as e:  # noqa: BLE001 - a recording the engine refuses (too short, standstill)
            ok, what = None, f"not diagnosable: {str(e)[:120]}"
        total += ok is not None
        clean += bool(ok)
        print(f"| {f.relative_to(REPO)} | {sc.spec['robot']} | {len(res.result.time)} | "
              f"{'clean' if ok else what} | {time.perf_counter() - t0:.1f} |", flush=True)
    print(f"\nclean: {clean}/{total}")


if __name__ == "__main__":
    main()
