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


def fitted_values(d, nominal: dict) -> dict:
    """The fitted model as the published one's four numbers, each (value, 95 % interval): the
    moving mass (the platform's mass plus the axis's rotor inertia, one physics on a single axis,
    whichever of the two the diagnosis named), viscous and Coulomb friction, the offset.  A
    friction is its part common to both directions, as the published model's: the library's
    level plus the mean of the direction-split levels a discovered term adds (through its
    velocity scale, for Coulomb levels that fade)."""
    th = d.plant_parameters()
    est = {p: v for e in d.effects for p, v in e["params"].items()}
    ci = {p: v["ci95"] for p, v in est.items()}
    split = {n: c for t in d.discovered for n, c in t.coefficients.items()}
    mass = th.get("platform.m", nominal["platform.m"]) + th.get("rail[1].rotor_inertia", nominal.get(
        "rail[1].rotor_inertia", 0.0))
    out = {"platform.m": (mass, float(np.hypot(ci.get("platform.m", 0.0), ci.get("rail[1].rotor_inertia", 0.0))))}
    for p in ("rail[1].viscous", "rail[1].coulomb", "rail[1].offset"):
        value, half = th.get(p, nominal.get(p, 0.0)), ci.get(p, 0.0 if p not in th else float("nan"))
        pair = [split.get(f"rail[1].force_{k}") for k in {"rail[1].viscous": ("vpos", "vneg"),
                                                           "rail[1].coulomb": ("cpos", "cneg")}.get(p, ())]
        if len(pair) == 2 and None not in pair:
            value += 0.5 * (pair[0].value + pair[1].value)
            half = float(np.hypot(half, 0.5 * np.hypot(pair[0].ci95, pair[1].ci95)))
        out[p] = (value, half if half > 0 else float("nan"))
    return out


def whole_file_replay(rec_path, plants: dict) -> dict:
    """Relative force error of each plant replayed over the whole file in the recorded loop."""
    from cosim.discrepancy.runs import closed_loop, controller_from, reference_from_recording
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
        # the recorded state (the carriage moves at the first sample); the controller has no
        # past to be primed with: its delay sample puts out 0 N there
        xd0 = m.pose_velocity(x0, rec.qd[0])
        res = closed_loop(m, ctrl, ref, x0=x0, xd0=xd0, start=0, rtol=1e-8, atol=1e-10)
        s = slice(0, len(res.time))
        out[name] = float(np.linalg.norm(res.tau_logged - rec.tau[s]) / np.linalg.norm(rec.tau[s]))
    return out


def figures(d, rec_path, folder) -> list:
    """The held-out replays against the recorded force, and the residual left after the fit
    against the position (the structure the engine reports)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cosim.recording import read_recording

    rec = read_recording(rec_path)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out = []
    runs = (d.replay or {}).get("runs", {})
    if runs:
        fig, ax = plt.subplots(2, 1, figsize=(10, 6), sharex=True)
        k0 = int(np.searchsorted(rec.time, d.replay["start"]))
        for name, style in (("nominal", ":"), ("reference", "--"), ("fitted", "-")):
            run = runs.get(name, {})
            if "tau" not in run:
                continue
            s = slice(k0, k0 + len(run["time"]))
            ax[0].plot(run["time"], run["tau"][:, 0], style, lw=0.8,
                       label=f"{name} ({100 * run['rel_tau'][0]:.2f} %)")
            if name != "nominal":
                ax[1].plot(run["time"], run["tau"][:, 0] - rec.tau[s, 0], style, lw=0.6, label=name)
        ax[0].plot(rec.time[k0:], rec.tau[k0:, 0], "k", lw=0.5, alpha=0.6, label="recorded")
        ax[0].set_ylabel("force [N]")
        ax[0].legend(loc="upper right", fontsize=8)
        ax[1].set_ylabel("replayed - recorded [N]")
        ax[1].set_xlabel("time [s]")
        ax[1].legend(loc="upper right", fontsize=8)
        ax[0].set_title("EMPS, held-out part: closed-loop replay in the rig's controller (relative force error)")
        fig.tight_layout()
        out.append(folder / "emps_replay.png")
        fig.savefig(out[-1], dpi=110)
        plt.close(fig)
    t, r = d.residual["time"], d.residual["after"][:, 0]
    q = np.interp(t, rec.time, rec.q[:, 0])
    qd = np.interp(t, rec.time, rec.qd[:, 0])
    fig, ax = plt.subplots(figsize=(8, 4))
    for sgn, c in ((1, "tab:blue"), (-1, "tab:red")):
        m = np.sign(qd) == sgn
        ax.plot(1e3 * q[m], r[m], ".", ms=2, color=c, label="moving +q" if sgn > 0 else "moving -q")
    ax.set_xlabel("carriage position q [mm]")
    ax.set_ylabel("effort residual after the fit [N]")
    ax.set_title("EMPS: what the fitted model leaves, against the position")
    ax.legend(fontsize=8)
    fig.tight_layout()
    out.append(folder / "emps_residual_position.png")
    fig.savefig(out[-1], dpi=110)
    plt.close(fig)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--source", type=Path, default=REPO / "data" / "emps" / "DATA_EMPS.mat")
    ap.add_argument("--map", type=Path, default=REPO / "data" / "emps" / "emps_map.toml")
    ap.add_argument("--out", type=Path, default=REPO / "results" / "emps")
    ap.add_argument("--html", action="store_true", help="also write the interactive report (report.html)")
    ap.add_argument("--figures", type=Path, default=None,
                    help="also draw the replay and the residual left after the fit into this folder (docs/figures)")
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
    nominal = Model(d.robot).params()
    fit = fitted_values(d, nominal)
    print("| parameter | nominal | fitted (95 % interval) | published | difference |")
    print("| --- | --- | --- | --- | --- |")
    for p, ref in PUBLISHED.items():
        v, ci = fit[p]
        p = "moving mass (platform.m + rail[1].rotor_inertia)" if p == "platform.m" else p
        diff = f"{100 * (v - ref) / abs(ref):+.2f} %" if p != "rail[1].offset" else f"{v - ref:+.3f} N"
        print(f"| {p} | {nominal.get(p, nominal['platform.m']):.4g} | {v:.4f} +- {ci:.2g} | {ref} | {diff} |")
    runs = (d.replay or {}).get("runs", {})
    print("\nclosed-loop replay, relative force error (norm of the difference / norm of the measured force):")
    print("| plant | held-out part | held-out part after its first 0.1 s | whole file |")
    print("| --- | --- | --- | --- |")
    from cosim.recording import read_recording

    rec = read_recording(rec_path)
    t4 = time.perf_counter()
    plants = {"nominal": Model(d.robot), "fitted": Model(d.robot), "reference": Model(d.robot, "reference")}
    plants["fitted"].set_params(d.plant_parameters())
    whole = whole_file_replay(rec_path, plants)
    t5 = time.perf_counter()
    for name in ("nominal", "fitted", "reference"):
        run = runs.get(name, {})
        held = run.get("rel_tau", [float("nan")])[0]
        late = float("nan")
        if "tau" in run:
            # the replay starts with the controller's filter states at zero: its first samples are
            # that transient, the same for every plant
            k0 = int(np.searchsorted(rec.time, d.replay["start"]))
            sim, meas = run["tau"][100:, 0], rec.tau[k0 + 100:k0 + len(run["tau"]), 0]
            late = float(np.linalg.norm(sim - meas) / np.linalg.norm(meas))
        print(f"| {name} | {100 * held:.2f} % | {100 * late:.2f} % | {100 * whole[name]:.2f} % |")
    if a.figures:
        print("figures:", ", ".join(str(p) for p in figures(d, rec_path, a.figures)))
    print(f"\ntimes [s]: import {t1 - t0:.2f}, diagnose + held-out replay + report {t2 - t1:.2f}, "
          f"html {t3 - t2:.2f}; the path (import + diagnose + replay + report) {t3 - t0:.2f} s "
          f"(target < 30 s); whole-file replays {t5 - t4:.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
