"""Benchmark of the 6-PUS plant FMU: simulated seconds per wall-clock second.

    .venv/bin/python bench/fmu_bench.py [--seconds 5] [--step 1e-3] [--repeat 3]

Rows (single core, the core's default integrator; the plant is open-loop unstable, so the
stepped rows close a joint-space PD loop around a 2 mm, 2 Hz sine reference per slider):
  core, PD loop      pkm_sim driven directly (ctypes): ik + joint velocity + PD + advance
  core, advance      the time spent inside pkm_sim_advance alone: the core's own figure
  FMU CS, FMU2Slave  the FMU driven by fmpy's FMU2Slave at the communication step:
                     setReal(tau) + doStep + getReal(pose, q, qd) per step, the same PD
  FMU CS, simulate   fmpy.simulate_fmu (Co-Simulation, output every step), from rest
  FMU ME, simulate   fmpy.simulate_fmu (Model Exchange, fmpy's CVode, rtol 1e-8), from rest
                     (no controller: the plant drifts off its unstable rest and stops at a
                     limit, so these rows report the simulated time they reached)
Target: the plant simulation >= 1000x real time inside the FMU.  Uses
$PKM_BUILD_DIR (default build/) for libpkm.so and fmu/PKM_6PUS.fmu.
"""
from __future__ import annotations

import argparse
import ctypes as C
import shutil
import time

import numpy as np


KP, KD = 2000.0, 20.0  # joint-space PD gains [N/m, N s/m]: keeps the open-loop-unstable plant moving around home


def reference(q_home, n, h):
    """Joint references [m] per step: each slider follows a 2 mm, 2 Hz sine around home."""
    t = (np.arange(n) + 1) * h
    phase = np.arange(6) * np.pi / 3
    return q_home[None, :] + 2e-3 * np.sin(2 * np.pi * 2.0 * t[:, None] + phase[None, :])


def pd(g, qref, q, qd):
    return g + KP * (qref - q) - KD * qd


def bench_core(model, qrefs, g, h):
    """pkm_sim in the PD loop; returns (wall of the whole loop, wall inside pkm_sim_advance, pose)."""
    from cosim._native import lib, pkm_sim_options, ptr

    o = pkm_sim_options()
    lib.pkm_sim_default_options(C.byref(o))
    err = C.create_string_buffer(512)
    m, d = model._m, model._d
    sim = C.c_void_p(lib.pkm_sim_create(m, C.byref(o), err, len(err)))
    x, xd, q, qd, tau = model.home(), np.zeros(6), np.zeros(6), np.zeros(6), np.zeros(6)
    lib.pkm_sim_reset(sim, 0.0, ptr(x), ptr(xd))
    t = C.c_double()
    inside = 0.0
    t0 = time.perf_counter()
    for k in range(len(qrefs)):
        lib.pkm_ik(m, d, ptr(x), ptr(q))
        lib.pkm_joint_velocity(m, d, ptr(x), ptr(xd), ptr(qd))
        tau[:] = pd(g, qrefs[k], q, qd)
        lib.pkm_sim_set_input(sim, ptr(tau))
        a = time.perf_counter()
        s = lib.pkm_sim_advance(sim, (k + 1) * h)
        inside += time.perf_counter() - a
        if s:
            raise RuntimeError(lib.pkm_sim_error(sim).decode())
        lib.pkm_sim_get_state(sim, C.byref(t), ptr(x), ptr(xd))
    wall = time.perf_counter() - t0
    lib.pkm_sim_destroy(sim)
    return wall, inside, x


def bench_slave(path, qrefs, g, h):
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    tau_vr = [vr[f"tau[{i}]"] for i in range(1, 7)]
    out_vr = ([vr[n] for n in ("x", "y", "z", "rx", "ry", "rz")] + [vr[f"q[{i}]"] for i in range(1, 7)]
              + [vr[f"qd[{i}]"] for i in range(1, 7)])
    d = extract(str(path))
    f = FMU2Slave(guid=md.guid, unzipDirectory=d, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="bench")
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    f.enterInitializationMode()
    f.exitInitializationMode()
    y = np.array(f.getReal(out_vr))
    t = 0.0
    t0 = time.perf_counter()
    for k in range(len(qrefs)):
        f.setReal(tau_vr, pd(g, qrefs[k], y[6:12], y[12:]).tolist())
        f.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t = (k + 1) * h
        y = np.array(f.getReal(out_vr))
    wall = time.perf_counter() - t0
    f.terminate()
    f.freeInstance()
    shutil.rmtree(d, ignore_errors=True)
    return wall, y[:6]


def bench_simulate(path, kind, tau, seconds, h):
    """Wall time and simulated time reached (the plant at rest under its gravity load is an
    unstable equilibrium: round-off makes it drift off and stop at a limit eventually)."""
    from cosim import fmu

    log = []
    t0 = time.perf_counter()
    r = fmu.simulate(path, fmi_type=kind, stop_time=seconds, step=h, tau=tau,
                     rtol=1e-8 if kind == "ModelExchange" else None, logger=lambda *a: log.append(a))
    return time.perf_counter() - t0, float(r["time"][-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=5.0, help="simulated time per run [s]")
    ap.add_argument("--step", type=float, default=1e-3, help="communication step [s]")
    ap.add_argument("--repeat", type=int, default=3, help="runs per row (the best is kept)")
    a = ap.parse_args(argv)

    from cosim import fmu
    from cosim.core import Model

    path = fmu.fmu_path("6pus")
    model = Model("6pus")
    n = int(round(a.seconds / a.step))
    tau0 = model.gravity_load(model.home())

    qrefs = reference(model.ik(model.home()), n, a.step)
    rows = []
    core = [bench_core(model, qrefs, tau0, a.step) for _ in range(a.repeat)]
    rows.append(("core: PD loop + pkm_sim (ctypes)", min(c[0] for c in core), a.seconds))
    rows.append(("core: inside pkm_sim_advance only", min(c[1] for c in core), a.seconds))
    runs = [bench_slave(path, qrefs, tau0, a.step) for _ in range(a.repeat)]
    rows.append(("FMU CS: PD loop + fmpy FMU2Slave", min(w for w, _ in runs), a.seconds))
    dx = np.max(np.abs(runs[0][1] - core[0][2]))
    # simulate_fmu has no controller in the loop: the plant starts at rest under its gravity load.
    for kind, label in (("CoSimulation", "FMU CS: fmpy simulate_fmu"), ("ModelExchange", "FMU ME: fmpy simulate_fmu")):
        runs = [bench_simulate(path, kind, tau0, a.seconds, a.step) for _ in range(a.repeat)]
        wall, reached = min(runs)
        rows.append((f"{label} (to t = {reached:.2f} s)", wall, reached))

    print(f"6-PUS plant, {a.seconds:g} s simulated, communication step {a.step * 1e3:g} ms, best of {a.repeat}")
    print(f"{'run':44s} {'wall [s]':>9s} {'sim s / wall s':>15s} {'us / step':>10s}")
    for name, wall, simulated in rows:
        steps = simulated / a.step
        print(f"{name:44s} {wall:9.3f} {simulated / wall:15.1f} {wall / steps * 1e6:10.1f}")
    print(f"final pose, FMU (FMU2Slave) vs core: max |dx| = {dx:.1e}")
    print("Target: >= 1000 simulated s per wall s inside the FMU")


if __name__ == "__main__":
    main()
