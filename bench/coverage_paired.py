"""What the spread across windows adds to the stated intervals, case by case.

    .venv/bin/python bench/coverage_paired.py results/coverage [--jobs 2]

Reads a run of ``bench/coverage_bench.py`` (its ``rows.json`` and the recordings under
``rec/``), diagnoses every recording that gave estimates again with
``cosim.discrepancy.intervals.WINDOW_SPREAD`` and ``SPEED_BANDS`` off (the library's intervals from the noise
alone: the wider of the classical and the HAC one), and prints per source and type how many of
the same estimates each statement holds, and how much wider the stated half widths are.  The
truths are the bench's (its answer keys), matched by parameter name.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]


def _noise_only(job):
    """(case, {parameter: (value, half width)}) of one recording with the spread off."""
    case, csv = job
    from cosim.discrepancy import diagnose, intervals
    from cosim.discrepancy.blind import stated_intervals

    intervals.WINDOW_SPREAD = intervals.SPEED_BANDS = False
    d = diagnose(csv, figures=False, replay=False)
    return case, {p: (float(v), float(h)) for p, (v, h) in stated_intervals(d, shapes=True).items()}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", type=Path, help="the --out folder of a coverage_bench.py run")
    ap.add_argument("--jobs", type=int, default=2)
    a = ap.parse_args(argv)
    rows = [r for r in json.loads((a.run / "rows.json").read_text()) if r["estimates"]]
    jobs = [(r["case"], str(a.run / "rec" / f"{r['case']}.csv")) for r in rows]
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(a.jobs) as pool:
        off = dict(pool.map(_noise_only, jobs))
    print("| source | type | estimates | holds (noise only) | holds (with the spread) | median width ratio |")
    print("| --- | --- | --- | --- | --- | --- |")
    import numpy as np

    tot = [0, 0, 0]
    for s in dict.fromkeys(r["source"] for r in rows):
        for kind in sorted({r.get("kind", "?") for r in rows if r["source"] == s}):
            n = k_off = k_on = 0
            ratio = []
            for r in (r for r in rows if r["source"] == s and r.get("kind") == kind):
                for p, v, h, t in r["estimates"]:
                    if p not in off[r["case"]]:
                        continue
                    v0, h0 = off[r["case"]][p]
                    n += 1
                    k_off += abs(v0 - t) <= h0
                    k_on += abs(v - t) <= h
                    ratio.append(h / h0 if h0 > 0 else float("nan"))
            if n:
                tot = [tot[0] + n, tot[1] + k_off, tot[2] + k_on]
                print(f"| {s} | {kind} | {n} | {k_off} | {k_on} | {np.nanmedian(ratio):.2f} |")
    print(f"| **all** | | {tot[0]} | {tot[1]} | {tot[2]} | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
