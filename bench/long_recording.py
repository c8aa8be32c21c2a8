"""Hour-long recordings: one hour at 1 kHz (3.6e6 rows) of the 6-PUS simulated with hidden
effects, written block by block, then diagnosed, beside the diagnosis of its first ten minutes.

    .venv/bin/python bench/long_recording.py [--minutes 60] [--first 10] [--seed 1]
                                             [--formats parquet,csv] [--max-samples 200000] [--keep DIR]
    .venv/bin/python bench/long_recording.py --io [--minutes 60] [--chunk 100000]
                                             [--formats csv,parquet,hdf5] [--no-whole]

The recording is the engine's own blind-case loop (:mod:`cosim.discrepancy.runs`: the core
plant, its drive and sensors, a PD + gravity controller at 1 kHz, the sensor noise of
``scenarios/blind/config.toml``) along one exciting trajectory of the whole length
(:mod:`cosim.discrepancy.excitation`), run in pieces of one minute, each from the true state
the previous one ended in, and written as it goes (memory one piece).  The plant hides
Coulomb friction on rail 3 and a payload of 50 g off the platform's centre (a centred one is the
same physics as a heavier platform, and either may be named); the sidecar gives
the nominal model only.  Everything is seeded.

Each diagnosis runs in a fresh process pinned to one core, which prints the time to read the
recording into its working set (:mod:`cosim.discrepancy.working_set`), the time of the
diagnosis proper (no figures, no report files; the replay of the held-out block included) and
its peak resident memory (``ru_maxrss``: Python, numpy, Arrow and the core library included).

``--io`` measures the formats alone: a synthetic run (slow sines, no physics) written block by
block, read in blocks of rows and whole, as CSV, Parquet and HDF5, each in a fresh process.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

EXT = {"csv": ".csv", "parquet": ".parquet", "hdf5": ".h5"}
#: what the plant hides (the recording's sidecar gives the nominal model only)
HIDDEN = {"rail[3].coulomb": 0.03, "payload.m": 0.05, "payload.x": 0.015, "payload.y": -0.01, "payload.z": 0.01}
PIECE_SECONDS = 60.0


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


# ---------------------------------------------------------------- the simulated hour
def simulated_blocks(minutes: float, seed: int = 1, robot: str = "6pus"):
    """The recording in pieces of :data:`PIECE_SECONDS` (``Recording`` objects, consecutive):
    one excitation of the whole length, each piece's closed loop started from the true pose
    and rate the previous one ended in (the controller is memoryless: PD + gravity)."""
    from cosim.core import Model
    from cosim.discrepancy import blind
    from cosim.discrepancy.excitation import excitation
    from cosim.discrepancy.runs import closed_loop
    from cosim.master import make_reference
    from cosim.recording import Recording

    nominal = Model(robot)
    cfg = blind.load_config()
    dt = 1.0 / cfg["general"]["rate"]
    total = minutes * 60.0
    traj = excitation(nominal, total, seed=seed, lead_in=0.5)
    plant = nominal.copy()
    plant.set_params(HIDDEN)
    ctrl = blind._controller("pd_gravity", nominal, cfg, dt)
    noise = cfg["noise"][robot]
    n_total = int(round(total / dt))
    k, x0, xd0, p = 0, None, None, 0
    while k < n_total:
        n = min(int(round(PIECE_SECONDS / dt)), n_total - k)
        ref = make_reference(nominal, traj, step=dt, duration=n * dt, t0=k * dt)  # n + 1 samples
        res = closed_loop(plant, ctrl, ref, x0=x0, xd0=xd0, noise=noise, seed=seed * 100003 + p)
        x0, xd0 = res.x[n], res.xd[n]  # the next piece starts where this one ends
        yield Recording(robot, res.time[:n].copy(), res.q[:n].copy(), res.qd[:n].copy(), res.tau[:n].copy(),
                        qref=ref.q[:n].copy(), pose=res.pose[:n].copy(),
                        controller=dict(ctrl.describe(), rate_hz=cfg["general"]["rate"]),
                        notes=f"bench/long_recording.py: {minutes:g} min of an exciting motion, seed {seed}; the "
                              f"plant hides effects the sidecar's model lacks")
        k, p = k + n, p + 1


def _synthetic_blocks(robot: str, rows: int, chunk: int):
    """A synthetic run in blocks: slow sines on every joint, efforts with noise, 1 kHz."""
    from cosim.core import robot_facts
    from cosim.recording import Recording

    nd = robot_facts(robot).ndof
    rng = np.random.default_rng(0)
    w = 0.5 + 0.1 * np.arange(nd)
    for k in range(0, rows, chunk):
        t = np.arange(k, min(k + chunk, rows)) * 1e-3
        q = 0.01 * np.sin(np.outer(t, w))
        yield Recording(robot=robot, time=t, q=q, qd=0.01 * w * np.cos(np.outer(t, w)),
                        tau=10 * q + rng.normal(0, 0.1, q.shape), qref=q)


# ------------------------------------------------------------------ child processes
def child(args) -> dict:
    t0 = time.perf_counter()
    import cosim.recording as R

    import h5py  # noqa: F401  (every child loads what the readers and writers load)
    import pyarrow.csv  # noqa: F401
    import pyarrow.parquet  # noqa: F401

    from cosim.core import robot_facts

    robot_facts(args.robot)
    out = {}
    if args.child == "simulate":
        paths = [Path(p) for p in args.path.split(",")]
        R.write_recording_blocks(paths[0], simulated_blocks(args.minutes, args.seed, args.robot), progress=None)
        out["simulate_s"] = time.perf_counter() - t0
        for p in paths[1:]:  # the other formats: the first file streamed into them
            t1 = time.perf_counter()
            R.write_recording_blocks(p, R.iter_recording(paths[0]))
            out[f"copy_{p.suffix}_s"] = time.perf_counter() - t1
        out["size_mb"] = {p.suffix: p.stat().st_size / 1e6 for p in paths}
    elif args.child == "diagnose":
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
        from cosim.discrepancy import diagnose
        from cosim.discrepancy.working_set import working_set

        t1 = time.perf_counter()
        ws = working_set(args.path, max_samples=args.max_samples, duration=args.first * 60 if args.first else None)
        out["read_s"] = time.perf_counter() - t1
        t2 = time.perf_counter()
        d = diagnose(ws, figures=False, replay=True)
        out["diagnose_s"] = time.perf_counter() - t2
        out["rows"] = ws.source_rows
        out["working_rows"] = len(ws.recording)
        out["blocks"] = len(ws.segments)
        out["effects"] = {k: {"value": v["value"], "ci95": v["ci95"], "unit": v["unit"], "title": e["title"]}
                          for e in d.effects for k, v in e["params"].items()}
        out["named"] = d.named()
        out["discovered"] = [t.equation for t in d.discovered]
        out["conclusion"] = d.conclusion
    elif args.child == "write":
        R.write_recording_blocks(args.path, _synthetic_blocks(args.robot, args.rows, args.chunk))
        out["size_mb"] = Path(args.path).stat().st_size / 1e6
    elif args.child == "blocks":
        n, ss = 0, 0.0
        for b in R.iter_recording(args.path, chunk_rows=args.chunk):
            n += len(b)
            ss = ss + np.sum(b.tau ** 2, axis=0)
        out["rows"] = n
        out["tau_rms"] = float(np.sqrt(ss / n).mean())
    elif args.child == "whole":
        rec = R.read_recording(args.path)
        out["rows"] = len(rec)
    out["seconds"] = time.perf_counter() - t0
    out["peak_mb"] = _peak_mb()
    return out


def run_child(kind, path, a, **extra) -> dict:
    cmd = [sys.executable, __file__, "--child", kind, "--path", str(path), "--rows", str(a.rows), "--robot", a.robot,
           "--chunk", str(a.chunk), "--minutes", str(a.minutes), "--seed", str(a.seed),
           "--max-samples", str(a.max_samples)]
    for k, v in extra.items():
        cmd += [f"--{k}", str(v)]
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=None if kind == "simulate" else subprocess.PIPE, text=True)
    if p.returncode != 0:
        err = (p.stderr or "").strip()
        raise SystemExit(f"{kind} {path}: {err.splitlines()[-1] if err else p.returncode}")
    return json.loads(p.stdout.strip().splitlines()[-1])


# ------------------------------------------------------------------------ tables
def io_table(a) -> None:
    print(f"{a.minutes:g} min at 1 kHz = {a.rows} rows of robot {a.robot}, blocks of {a.chunk} rows")
    with tempfile.TemporaryDirectory() as d:
        base = run_child("baseline", Path(d) / "none", a)
        print(f"{'format':<8} {'step':<7} {'size MB':>8} {'seconds':>8} {'peak MB':>8}")
        print(f"{'-':<8} {'import':<7} {'':>8} {base['seconds']:8.1f} {base['peak_mb']:8.0f}")
        for fmt in a.formats.split(","):
            path = Path(d) / f"long{EXT[fmt]}"
            w = run_child("write", path, a)
            print(f"{fmt:<8} {'write':<7} {w['size_mb']:8.0f} {w['seconds']:8.1f} {w['peak_mb']:8.0f}")
            b = run_child("blocks", path, a)
            assert b["rows"] == a.rows
            print(f"{fmt:<8} {'blocks':<7} {'':>8} {b['seconds']:8.1f} {b['peak_mb']:8.0f}")
            if not a.no_whole:
                r = run_child("whole", path, a)
                assert r["rows"] == a.rows
                print(f"{fmt:<8} {'whole':<7} {'':>8} {r['seconds']:8.1f} {r['peak_mb']:8.0f}")
            path.unlink()


def diagnosis_table(a, d: Path) -> int:
    fmts = a.formats.split(",")
    paths = [d / f"long{EXT[f]}" for f in fmts]
    if not all(p.exists() for p in paths):
        print(f"simulating {a.minutes:g} min at 1 kHz ({a.rows} rows) of the {a.robot}, hidden: "
              + ", ".join(f"{k} = {v:g}" for k, v in HIDDEN.items()), flush=True)
        g = run_child("simulate", ",".join(map(str, paths)), a)
        print(f"  simulated and written in {g['simulate_s']:.0f} s ({fmts[0]}), "
              + ", ".join(f"{k[5:-2]} copied in {v:.0f} s" for k, v in g.items() if k.startswith("copy_"))
              + f"; peak {g['peak_mb']:.0f} MB", flush=True)
    load = os.getloadavg()[0]
    rows = []
    for fmt, p in zip(fmts, paths):
        rows.append((fmt, f"{a.minutes:g} min", p.stat().st_size / 1e6, run_child("diagnose", p, a, first=0)))
    rows.append((fmts[0], f"first {a.first:g} min", paths[0].stat().st_size / 1e6,
                 run_child("diagnose", paths[0], a, first=a.first)))
    print(f"\nload average when the diagnoses started: {load:.1f} (2 cores); each diagnosis on one core")
    print(f"{'table':<8} {'span':<13} {'rows':>9} {'file MB':>8} {'kept rows':>10} {'blocks':>6} {'read s':>7} "
          f"{'diagnose s':>10} {'total s':>8} {'peak MB':>8}")
    for fmt, span, size, r in rows:
        print(f"{fmt:<8} {span:<13} {r['rows']:9d} {size:8.0f} {r['working_rows']:10d} {r['blocks']:6d} "
              f"{r['read_s']:7.1f} {r['diagnose_s']:10.1f} {r['read_s'] + r['diagnose_s']:8.1f} {r['peak_mb']:8.0f}")
    print("\neffects named (value +- 95 % interval):")
    keys = sorted({k for *_, r in rows for k in r["effects"]} | set(HIDDEN))
    head = [f"{fmt} {span}" for fmt, span, *_ in rows]
    print(f"{'parameter':<18} {'hidden':>8} " + " ".join(f"{h:>24}" for h in head))
    for k in keys:
        cells = []
        for *_, r in rows:
            e = r["effects"].get(k)
            cells.append(f"{e['value']:.4g} +- {e['ci95']:.2g} {e['unit']}" if e else "-")
        print(f"{k:<18} {HIDDEN.get(k, 0.0):8.4g} " + " ".join(f"{c:>24}" for c in cells))
    for (fmt, span, _, r) in rows:
        if r["discovered"]:
            print(f"  {fmt} {span}: discovered {r['discovered']}")
    named = [r["named"] for *_, r in rows]
    same = all(n == named[0] for n in named)
    within = all(abs(rows[0][3]["effects"][k]["value"] - r["effects"][k]["value"])
                 <= rows[0][3]["effects"][k]["ci95"] + r["effects"][k]["ci95"]
                 for *_, r in rows for k in rows[0][3]["effects"] if k in r["effects"])
    worst = max(r["read_s"] + r["diagnose_s"] for *_, r in rows)
    peak = max(r["peak_mb"] for *_, r in rows)
    print(f"\nsame effects named in every row: {'yes' if same else 'NO'} ({named[0]}); values within their joint "
          f"intervals: {'yes' if within else 'NO'}; slowest {worst:.0f} s (< 300 s: {'yes' if worst < 300 else 'NO'}); "
          f"largest peak {peak:.0f} MB (< 2048 MB: {'yes' if peak < 2048 else 'NO'})")
    return 0 if same and within and worst < 300 and peak < 2048 else 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--first", type=float, default=10.0, help="minutes of the short diagnosis (default 10)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--robot", default="6pus")
    ap.add_argument("--max-samples", type=int, default=None,
                    help="most rows of the working set (default: the diagnosis's, 100000)")
    ap.add_argument("--keep", help="directory to keep (and reuse) the simulated recording in")
    ap.add_argument("--io", action="store_true", help="the formats' write and read table instead")
    ap.add_argument("--chunk", type=int, default=100_000, help="rows per block of --io (default 100000)")
    ap.add_argument("--formats", default=None, help="default parquet,csv (--io: csv,parquet,hdf5)")
    ap.add_argument("--no-whole", action="store_true", help="--io: skip reading each file whole")
    ap.add_argument("--child", choices=["baseline", "write", "blocks", "whole", "simulate", "diagnose"],
                    help=argparse.SUPPRESS)
    ap.add_argument("--path", help=argparse.SUPPRESS)
    ap.add_argument("--rows", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(child(a)))
        return 0
    if a.max_samples is None:
        from cosim.discrepancy.working_set import MAX_SAMPLES

        a.max_samples = MAX_SAMPLES
    a.rows = int(round(a.minutes * 60 * 1000))
    if a.io:
        a.formats = a.formats or "csv,parquet,hdf5"
        io_table(a)
        return 0
    a.formats = a.formats or "parquet,csv"
    if a.keep:
        Path(a.keep).mkdir(parents=True, exist_ok=True)
        return diagnosis_table(a, Path(a.keep))
    with tempfile.TemporaryDirectory() as d:
        return diagnosis_table(a, Path(d))


if __name__ == "__main__":
    raise SystemExit(main())
