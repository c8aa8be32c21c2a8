"""Hour-long recordings: one hour at 1 kHz (3.6e6 rows) of the 6-PUS (25 columns) written
block by block, then read in blocks of rows and whole, as CSV, Parquet and HDF5.

    .venv/bin/python bench/long_recording.py [--minutes 60] [--robot 6pus] [--chunk 100000]
                                             [--formats csv,parquet,hdf5] [--no-whole]

Each measurement runs in a fresh process, which prints its wall time and its peak resident
memory (``ru_maxrss``: everything the process touched, Python, numpy, Arrow, HDF5 and the
core library included); the first row is that of a process that only imports the package.
``blocks`` reads with ``cosim.recording.iter_recording`` and computes the RMS effort per
joint; ``whole`` is ``read_recording`` (memory grows with the length; shown for scale).
"""
from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

EXT = {"csv": ".csv", "parquet": ".parquet", "hdf5": ".h5"}


def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _blocks(robot: str, rows: int, chunk: int):
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


def child(args) -> dict:
    t0 = time.perf_counter()
    import cosim.recording as R

    import h5py  # noqa: F401  (every child loads what the readers and writers load)
    import pyarrow.csv  # noqa: F401
    import pyarrow.parquet  # noqa: F401

    from cosim.core import robot_facts

    robot_facts(args.robot)
    out = {}
    if args.child == "write":
        R.write_recording_blocks(args.path, _blocks(args.robot, args.rows, args.chunk))
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


def run_child(kind, path, a) -> dict:
    cmd = [sys.executable, __file__, "--child", kind, "--path", str(path), "--rows", str(a.rows), "--robot", a.robot,
           "--chunk", str(a.chunk)]
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise SystemExit(f"{kind} {path}: {p.stderr.strip().splitlines()[-1] if p.stderr.strip() else p.returncode}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, default=60.0)
    ap.add_argument("--robot", default="6pus")
    ap.add_argument("--chunk", type=int, default=100_000, help="rows per block (default 100000)")
    ap.add_argument("--formats", default="csv,parquet,hdf5")
    ap.add_argument("--no-whole", action="store_true", help="skip reading each file whole")
    ap.add_argument("--child", choices=["baseline", "write", "blocks", "whole"], help=argparse.SUPPRESS)
    ap.add_argument("--path", help=argparse.SUPPRESS)
    ap.add_argument("--rows", type=int, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(child(a)))
        return 0
    a.rows = int(round(a.minutes * 60 * 1000))
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
