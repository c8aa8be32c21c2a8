#!/usr/bin/env python3
"""Benchmark of the discrepancy engine (SPEC 7): a 10 s, 1 kHz recording diagnosed in < 10 s.

Single core (BLAS limited to one thread).  For each robot: one 10 s closed-loop
recording at 1 kHz of a plant hiding two effects, written as a pkm-recording/1 file;
then, each timed (best of --repeat):

* baseline: read the file and form the nominal effort residual once (forward
  kinematics, pose rates and accelerations, inverse dynamics of every sample);
* diagnose: the full diagnosis without replay or report (what the 10 s target is about);
* + replay: with the closed-loop replay of the held-out part (two core simulations);
* + report: with the Markdown report and its five figures.

Usage: PKM_BUILD_DIR=build .venv/bin/python bench/discrepancy_bench.py [--repeat 3] [--robot 6pus quattro]
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from threadpoolctl import threadpool_limits  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.residuals import Pipeline  # noqa: E402
from cosim.recording import read_recording  # noqa: E402

HIDDEN = {"6pus": ["coulomb", "payload"], "quattro": ["viscous", "actuator_delay"]}
TARGET = 10.0


def best(fn, repeat):
    times = []
    out = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return min(times), out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--robot", nargs="+", default=["6pus", "quattro"])
    args = ap.parse_args(argv)
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # single core
    except (AttributeError, OSError):
        pass
    cfg = blind.load_config()
    cfg["general"]["duration"] = 10.0
    cfg["general"]["two_effects"] = 0.0
    rows = []
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(1, user_api="blas"):
        for robot in args.robot:
            spec = blind.CaseSpec(f"bench_{robot}", robot, HIDDEN[robot], seed=2024)
            t0 = time.perf_counter()
            csv, key = blind.make_case(spec, Path(tmp) / "rec", Path(tmp) / "key", cfg)
            t_gen = time.perf_counter() - t0
            n = len(read_recording(csv).time)
            base, _ = best(lambda: Pipeline(read_recording(csv), Model(robot)).evaluate({}), args.repeat)
            t_d, d = best(lambda: diagnose(csv, replay=False), args.repeat)
            t_r, _ = best(lambda: diagnose(csv, replay=True), args.repeat)
            t_o, _ = best(lambda: diagnose(csv, replay=True, out=Path(tmp) / "rep"), 1)
            rows.append((robot, n, t_gen, base, t_d, t_r, t_o, ", ".join(d.named()) or "none"))
    print(f"{'robot':<8} {'samples':>7} {'generate':>9} {'baseline':>9} {'diagnose':>9} {'+replay':>9} "
          f"{'+report':>9}  target  named")
    ok = True
    for robot, n, g, b, dd, r, o, named in rows:
        flag = "met" if dd < TARGET else "MISSED"
        ok &= dd < TARGET
        print(f"{robot:<8} {n:>7} {g:>8.2f}s {b:>8.2f}s {dd:>8.2f}s {r:>8.2f}s {o:>8.2f}s  {flag:<6}  {named}")
    print(f"(single core, best of {args.repeat}; target: diagnose < {TARGET:g} s for a 10 s, 1 kHz recording)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
