#!/usr/bin/env python3
"""Benchmark of the discrepancy engine (docs/performance.md): a 10 s, 1 kHz recording diagnosed in < 10 s.

Single core (BLAS limited to one thread).  For each robot: one 10 s closed-loop
recording at 1 kHz of a plant hiding two effects, written as a pkm-recording/1 file;
then, each timed (best of --repeat):

* baseline: read the file and form the nominal effort residual once (forward
  kinematics, pose rates and accelerations, inverse dynamics of every sample);
* diagnose: the full diagnosis without replay or report (what the 10 s target is about),
  the discovery step included (its share printed, and the diagnosis without it);
* + replay: with the closed-loop replay of the held-out part (two core simulations);
* + report: with the Markdown report and its five figures.

With --per-row, the diagnosis is also timed with the core's per-row loop in place of its
batched calls over the samples (actuator effort, sensor readings, pose rates), the two
alternated, medians of --repeat: the same-run baseline of the batched calls.

With --instruments, the diagnosis is also timed without the instrumental variables of the
masses, inertias and viscous frictions (``diagnose(..., instruments=False)``: least squares)
and with them, the two alternated, medians of --repeat in CPU time (``time.process_time``,
which the machine's other processes change little) and elapsed time.

Usage: PKM_BUILD_DIR=build .venv/bin/python bench/discrepancy_bench.py [--repeat 3] [--robot 6pus quattro]
       [--per-row] [--instruments]
"""
from __future__ import annotations

import argparse
import os
import statistics
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


#: Model methods with a batched core call over the samples -> (per-row core function, its inputs)
PER_ROW = {"actuator_effort": ("pkm_actuator_effort", ["tau_cmd"]),
           "measure_joints": ("pkm_measure_joints", ["x", "xd", "tau"]),
           "pose_velocity": ("pkm_pose_velocity", ["x", "qd"]),
           "pose_acceleration": ("pkm_pose_acceleration", ["x", "xd", "qdd"])}


def _batched_vs_per_row(fn, repeat):
    """Wall times of fn with the per-row core loop and with the batched calls, alternated."""
    batched = {k: getattr(Model, k) for k in PER_ROW}

    def looped(name, inputs):
        return lambda self, *a, times=None, what="item": self._loop(name, list(a), inputs, (self.ndof,),
                                                                     times=times, what=what)

    loop, batch = [], []
    try:
        for _ in range(repeat):
            for k, (name, inputs) in PER_ROW.items():
                setattr(Model, k, looped(name, inputs))
            t = time.perf_counter()
            fn()
            loop.append(time.perf_counter() - t)
            for k, f in batched.items():
                setattr(Model, k, f)
            t = time.perf_counter()
            fn()
            batch.append(time.perf_counter() - t)
    finally:
        for k, f in batched.items():
            setattr(Model, k, f)
    return loop, batch


def _with_and_without_instruments(csv, repeat):
    """(CPU, elapsed) times of the diagnosis with and without instruments, alternated."""
    out = {True: ([], []), False: ([], [])}
    for _ in range(repeat):
        for instruments in (True, False):
            c, w = time.process_time(), time.perf_counter()
            diagnose(csv, replay=False, instruments=instruments)
            out[instruments][0].append(time.process_time() - c)
            out[instruments][1].append(time.perf_counter() - w)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--robot", nargs="+", default=["6pus", "quattro"])
    ap.add_argument("--per-row", action="store_true",
                    help="also time the diagnosis with per-row core calls instead of the batched ones (alternated)")
    ap.add_argument("--instruments", action="store_true",
                    help="also time the diagnosis with and without the instrumental variables (alternated)")
    args = ap.parse_args(argv)
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # single core
    except (AttributeError, OSError):
        pass
    cfg = blind.load_config()
    cfg["general"]["duration"] = 10.0
    cfg["general"]["two_effects"] = 0.0
    rows, per_row, instr = [], {}, {}
    with tempfile.TemporaryDirectory() as tmp, threadpool_limits(1, user_api="blas"):
        for robot in args.robot:
            spec = blind.CaseSpec(f"bench_{robot}", robot, HIDDEN[robot], seed=2024)
            t0 = time.perf_counter()
            csv, key = blind.make_case(spec, Path(tmp) / "rec", Path(tmp) / "key", cfg)
            t_gen = time.perf_counter() - t0
            n = len(read_recording(csv).time)
            base, _ = best(lambda: Pipeline(read_recording(csv), Model(robot)).evaluate({}), args.repeat)
            t_d, d = best(lambda: diagnose(csv, replay=False), args.repeat)
            t_nd, _ = best(lambda: diagnose(csv, replay=False, discovery=False), args.repeat)
            t_r, _ = best(lambda: diagnose(csv, replay=True), args.repeat)
            t_o, _ = best(lambda: diagnose(csv, replay=True, out=Path(tmp) / "rep"), 1)
            rows.append((robot, n, t_gen, base, t_d, t_r, t_o, ", ".join(d.named()) or "none", t_nd,
                         d.timings.get("discovery", float("nan"))))
            if args.per_row:
                per_row[robot] = _batched_vs_per_row(lambda: diagnose(csv, replay=False), args.repeat)
            if args.instruments:
                instr[robot] = _with_and_without_instruments(csv, args.repeat)
    print(f"{'robot':<8} {'samples':>7} {'generate':>9} {'baseline':>9} {'diagnose':>9} {'+replay':>9} "
          f"{'+report':>9}  target  {'no discovery':>12} {'discovery':>9}  named")
    ok = True
    for robot, n, g, b, dd, r, o, named, nd, disc in rows:
        flag = "met" if dd < TARGET else "MISSED"
        ok &= dd < TARGET
        print(f"{robot:<8} {n:>7} {g:>8.2f}s {b:>8.2f}s {dd:>8.2f}s {r:>8.2f}s {o:>8.2f}s  {flag:<6}  {nd:>11.2f}s "
              f"{disc:>8.2f}s  {named}")
    print(f"(single core, best of {args.repeat}; target: diagnose < {TARGET:g} s for a 10 s, 1 kHz recording)")
    for robot, (loop, batch) in per_row.items():
        print(f"{robot}: diagnose with per-row core calls median {statistics.median(loop):.2f} s "
              f"({min(loop):.2f}-{max(loop):.2f}), batched median {statistics.median(batch):.2f} s "
              f"({min(batch):.2f}-{max(batch):.2f}); alternated, {args.repeat} each")
    for robot, t in instr.items():
        med = {k: (statistics.median(c), statistics.median(w)) for k, (c, w) in t.items()}
        print(f"{robot}: diagnose with instruments CPU {med[True][0]:.2f} s (elapsed {med[True][1]:.2f} s), without "
              f"CPU {med[False][0]:.2f} s (elapsed {med[False][1]:.2f} s); alternated, medians of {args.repeat}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
