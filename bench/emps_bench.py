"""The EMPS drive, a real recording, end to end: import, diagnose, replay, report (docs/emps.md).

    .venv/bin/python bench/emps_bench.py [--out results/emps] [--html] [--source data/emps/DATA_EMPS.mat]

On one core (BLAS on one thread): ``cosim import`` of the MATLAB file through
``data/emps/emps_map.toml``, ``cosim diagnose`` from the nominal description (``robots/emps.toml``:
a round 90 kg moving mass, no friction, no offset) fitted on the first 60 % of the file and judged on
the rest, the closed-loop replay of the held-out part (the rig's own controller from the sidecar,
driven by the recorded reference) with the nominal, the fitted and the published reference model
(the robot's ``reference`` set), the same three replayed over the whole file, and the report.
Prints the fitted parameters against the published ones, the replays' relative force errors (norm
of the difference over the norm of the recorded force) and the time of each step.  Nothing here is
specific to the EMPS but the file names: a second recording of the rig goes through the same lines.
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import numpy as np  # noqa: E402

#: the benchmark's published model (docs/references.md: Janot, Gautier, Brunot 2019), written in the
#: core's convention (effort = M qdd + Fv qd + Fc sgn(qd) + offset: the published OF is the offset)
PUBLISHED = {"platform.m": 95.1089, "rail[1].viscous": 203.5034, "rail[1].coulomb": 20.3935,
             "rail[1].offset": -3.1648}


def fitted_values(d) -> dict:
    """The fitted model as the published one's four numbers: the moving mass (the platform's mass
    plus the rotor inertia of the axis, one physics on a single axis), viscous and Coulomb friction,
    the offset; each with its 95 % interval."""
    th, out = d.plant_parameters(), {}
    nominal = {}
    for e in d.effects:
        for p, v in e["params"].items():
            nominal[p] = (v["value"], v["ci95"], v["nominal"])
    mass = nominal.get("platform.m", (None, 0.0, None))
    rotor = nominal.get("rail[1].rotor_inertia", (0.0, 0.0, 0.0))
    m0 = mass[0] if mass[0] is not None else mass[2]
    out["platform.m"] = ((m0 or 0.0) + rotor[0], float(np.hypot(mass[1], rotor[1])))
    for p in ("rail[1].viscous", "rail[1].coulomb", "rail[1].offset"):
        out[p] = (th.get(p, 0.0), nominal.get(p, (0, float("nan")))[1])
    return out


def whole_file_replay(rec_path, plants: dict) -> dict:
    """Relative force error of each plant replayed over the whole file in the recorded loop."""
    from cosim.discrepancy.plant import closed_loop, controller_from, reference_from_recording
    from cosim.recording import read_recording

    rec = read_recording(rec_path)
    out = {}
    for name, m in plants.items():
        ctrl, why = controller_from(rec.controller, m)
        if ctrl is None:
            out[name] = float("nan")
            continue
        ref = reference_from_recording(rec, m)
        x0 = m.fk(rec.q[0], x_guess=m.home())
        res = closed_loop(m, ctrl, ref, x0=x0, xd0=np.zeros(m.ndof), start=0, rtol=1e-8, atol=1e-10)
        s = slice(0, len(res.time))
        out[name] = float(np.linalg.norm(res.tau - rec.tau[s]) / np.linalg.norm(rec.tau[s]))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--source", type=Path, default=REPO / "data" / "emps" / "DATA_EMPS.mat")
    ap.add_argument("--map", type=Path, default=REPO / "data" / "emps" / "emps_map.toml")
    ap.add_argument("--out", type=Path, default=REPO / "results" / "emps")
    ap.add_argument("--html", action="store_true", help="also write the interactive report (report.html)")
    a = ap.parse_args(argv)

    from cosim.core import Model
    from cosim.discrepancy import diagnose
    from cosim.importing import import_recording

    t0 = time.perf_counter()
    imp = import_recording(a.source, a.map, a.out, progress=False)
    rec_path = imp.table
    t1 = time.perf_counter()
    d = diagnose(rec_path, out=a.out / "diagnosis", train_fraction=0.6, compare=["reference"])
    t2 = time.perf_counter()
    if a.html:
        from cosim.report.pages import diagnosis_page

        diagnosis_page(d, a.out / "diagnosis" / "report.html")
    t3 = time.perf_counter()

    print(f"{rec_path.name}: {d.conclusion}\n")
    fit = fitted_values(d)
    print("| parameter | nominal | fitted (95 % interval) | published | difference |")
    print("| --- | --- | --- | --- | --- |")
    nominal = Model(d.robot).params()
    for p, ref in PUBLISHED.items():
        v, ci = fit[p]
        diff = f"{100 * (v - ref) / abs(ref):+.2f} %" if p != "rail[1].offset" else f"{v - ref:+.3f} N"
        print(f"| {p} | {nominal.get(p, 0.0):.4g} | {v:.4f} +- {ci:.2g} | {ref} | {diff} |")
    runs = (d.replay or {}).get("runs", {})
    print("\nclosed-loop replay, relative force error (norm of the difference / norm of the measured force):")
    print("| plant | held-out part | whole file |")
    print("| --- | --- | --- |")
    t4 = time.perf_counter()
    plants = {"nominal": Model(d.robot), "fitted": Model(d.robot), "reference": Model(d.robot, "reference")}
    plants["fitted"].set_params(d.plant_parameters())
    whole = whole_file_replay(rec_path, plants)
    t5 = time.perf_counter()
    for name in ("nominal", "fitted", "reference"):
        held = runs.get(name, {}).get("rel_tau", [float("nan")])[0]
        print(f"| {name} | {100 * held:.2f} % | {100 * whole[name]:.2f} % |")
    print(f"\ntimes [s]: import {t1 - t0:.2f}, diagnose + held-out replay + report {t2 - t1:.2f}, "
          f"html {t3 - t2:.2f}; the path (import + diagnose + replay + report) {t3 - t0:.2f} s "
          f"(target < 30 s); whole-file replays {t5 - t4:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
