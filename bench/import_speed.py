"""Speed of ``cosim import`` on large files: a 10^6-row rig file (1,000 s at 1 kHz) as MATLAB
v5, MATLAB v7.3 (HDF5) and CSV, imported through an EMPS-like map (position in mm, effort =
command * gain, velocities derived, an external force) into a one-joint recording.

    .venv/bin/python bench/import_speed.py [--rows 1000000] [--repeats 1]

Prints, per source format: the file's size, the time to read and convert it, the time to
write the recording (CSV with its sidecar, 7 columns at full precision) and the total, best
of the repeats, one core; and the process's peak resident memory at the end.
"""
from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.io

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cosim.importing import to_recording  # noqa: E402
from cosim.recording import write_recording  # noqa: E402

MAP = '''robot = "fourbar"
[columns]
time = { variable = "t", unit = "s" }
q1 = { variable = "qm", unit = "mrad" }
qd1 = { derive = "central_difference" }
qref1 = { variable = "qg", unit = "mrad" }
qdref1 = { derive = "central_difference" }
tau1 = { variable = "vir", scale = { variable = "gtau" }, unit = "N m" }
f_ext1 = { variable = "push", unit = "N m", optional = true }
'''


def make_files(folder: Path, n: int) -> dict:
    import h5py

    rng = np.random.default_rng(0)
    t = np.arange(n) * 1e-3
    qg = 100.0 * np.sin(0.5 * t)
    qm = np.round((qg + rng.normal(0, 0.1, n)) / 5e-5) * 5e-5
    vir = rng.normal(0, 2, n)
    push = np.where((t % 1.0) < 0.5, 5.0, 0.0)
    cols = {"t": t, "qm": qm, "qg": qg, "vir": vir, "push": push}
    files = {"MATLAB v5": folder / "rig_v5.mat", "MATLAB v7.3": folder / "rig_v73.mat", "CSV": folder / "rig.csv"}
    scipy.io.savemat(files["MATLAB v5"], {**{k: v[:, None] for k, v in cols.items()}, "gtau": 35.15})
    with h5py.File(files["MATLAB v7.3"], "w", userblock_size=512) as f:
        for k, v in {**cols, "gtau": np.array([35.15])}.items():
            f.create_dataset(k, data=v.reshape(1, -1)).attrs["MATLAB_class"] = np.bytes_("double")
    with open(files["MATLAB v7.3"], "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, HDF5 schema 1.00 .")
    data = np.column_stack([t, qm, qg, vir * 35.15, push])
    np.savetxt(files["CSV"], data, delimiter=",", header="t,qm,qg,vir,push", comments="", fmt="%.17g")
    return files


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--repeats", type=int, default=1)
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        t0 = time.perf_counter()
        files = make_files(d, a.rows)
        print(f"{a.rows} rows per file, written in {time.perf_counter() - t0:.1f} s")
        mp = d / "map.toml"
        mp.write_text(MAP)
        csv_map = d / "csv_map.toml"
        csv_map.write_text(MAP.replace('scale = { variable = "gtau" }', "scale = 1"))
        print(f"{'source':<12} {'size MB':>8} {'read s':>7} {'write s':>8} {'total s':>8}")
        for kind, path in files.items():
            best = None
            for _ in range(a.repeats):
                t0 = time.perf_counter()
                rec = to_recording(path, csv_map if kind == "CSV" else mp, progress=False)
                t1 = time.perf_counter()
                write_recording(d / "out" / f"{path.stem}.csv", rec, progress=False)
                t2 = time.perf_counter()
                if best is None or t2 - t0 < best[2]:
                    best = (t1 - t0, t2 - t1, t2 - t0)
                assert len(rec) == a.rows and rec.f_ext is not None
            print(f"{kind:<12} {path.stat().st_size / 1e6:8.1f} {best[0]:7.2f} {best[1]:8.2f} {best[2]:8.2f}")
    print(f"peak resident memory of the process: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
