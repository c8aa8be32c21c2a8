"""Closed-loop throughput: the core's loops beside a MuJoCo loop of the same 6-PUS, one run.

    .venv/bin/python bench/closed_loop_bench.py [--seconds 10] [--repeats 5] [--fmu-seconds 2]

Rows (10 s of motion, joint PD at a 1 ms period, the reference of bench/loop_bench.cpp:
each stroke a 3 mm 1 Hz sine about home; medians of the repeats, one core):

* ``loop_bench`` (C, run as a subprocess in this run): the compiled loop
  (``pkm_closed_loop``) and the stepwise loop (``pkm_sim_advance`` per period, what an
  FMU's doStep does), explicit Runge-Kutta (the default) and CVODE BDF (the default
  before), with their pose error against an rtol 1e-12 reference and their loop-closure
  error;
* ``cosim.master.run`` on a ``CorePlant`` (compiled path) from Python;
* MuJoCo (PyPI ``mujoco``): a model of the same robot built from the core's parameters
  (platform with a free joint, six slide joints with their carriages, six legs as
  capsules on ball joints, each loop closed by a ``connect`` equality), ``mj_step`` with
  the PD applied per control period, at the controller's period (1 ms) and at MuJoCo's
  default time step (2 ms, the controller then at 2 ms); its loop-closure error is the
  largest distance between each leg's end and its platform point;
* an fmpy-driven Python loop over the plant FMU (FMU2Slave): the share of wall time spent
  inside ``doStep``.

The MuJoCo model is built here only as a peer for timing and closure; its dynamics are
MuJoCo's own (soft constraints, its integrator), not a check of the core's.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from cosim.core import Model  # noqa: E402

KP, KD, AMP, FREQ = 2000.0, 30.0, 0.003, 1.0


def reference(m: Model, seconds: float, dt: float):
    q0 = m.ik(m.home())
    n = int(round(seconds / dt)) + 1
    t = np.arange(n) * dt
    ph = 2 * np.pi * FREQ * t[:, None] + np.arange(6)[None, :] * np.pi / 3
    return t, q0 + AMP * np.sin(ph), AMP * 2 * np.pi * FREQ * np.cos(ph)


# ------------------------------------------------------------------ MuJoCo peer

def mujoco_xml(m: Model, servo: bool = False) -> str:
    """MJCF of the 6-PUS at its home pose from the core's parameters (SI units).

    ``servo``: the PD as MuJoCo actuators (a position servo with kp and kv per rail, plus
    a motor for the kd qdref feed-forward), so a whole run is one ``rollout`` call."""
    p = m.params()
    x0 = m.home()
    P, S = m.leg_points(x0)
    body = []
    for i in range(6):
        s = np.array([p[f"rail[{i + 1}].s{c}"] for c in "xyz"])
        a = P[i] - S[i]
        body.append(f"""
    <body name="slider{i}" pos="{S[i][0]:.17g} {S[i][1]:.17g} {S[i][2]:.17g}">
      <joint name="rail{i}" type="slide" axis="{s[0]:.17g} {s[1]:.17g} {s[2]:.17g}"/>
      <geom type="box" size="0.005 0.005 0.005" mass="{p[f'slider[{i + 1}].m']:.17g}" contype="0" conaffinity="0"/>
      <body name="leg{i}">
        <joint name="u{i}" type="ball"/>
        <geom type="capsule" fromto="0 0 0 {a[0]:.17g} {a[1]:.17g} {a[2]:.17g}" size="0.001"
              mass="{p[f'leg[{i + 1}].m']:.17g}" contype="0" conaffinity="0"/>
        <site name="end{i}" pos="{a[0]:.17g} {a[1]:.17g} {a[2]:.17g}"/>
      </body>
    </body>""")
    sites = "".join(
        f'\n      <site name="p{i}" pos="{p[f"leg[{i + 1}].px"]:.17g} {p[f"leg[{i + 1}].py"]:.17g} '
        f'{p[f"leg[{i + 1}].pz"]:.17g}"/>' for i in range(6))
    eq = "".join(f'\n    <connect body1="leg{i}" body2="platform" anchor="{(P[i] - S[i])[0]:.17g} '
                 f'{(P[i] - S[i])[1]:.17g} {(P[i] - S[i])[2]:.17g}"/>' for i in range(6))
    if servo:
        act = "".join(f'\n    <position joint="rail{i}" kp="{KP}" kv="{KD}"/>' for i in range(6))
        act += "".join(f'\n    <motor joint="rail{i}" gear="1"/>' for i in range(6))
    else:
        act = "".join(f'\n    <motor joint="rail{i}" gear="1"/>' for i in range(6))
    g = [p["gravity.x"], p["gravity.y"], p["gravity.z"]]
    return f"""<mujoco model="6pus">
  <option gravity="{g[0]} {g[1]} {g[2]}"/>
  <worldbody>{''.join(body)}
    <body name="platform" pos="{x0[0]:.17g} {x0[1]:.17g} {x0[2]:.17g}">
      <freejoint/>
      <inertial pos="0 0 0" mass="{p['platform.m']:.17g}"
                diaginertia="{p['platform.Ixx']:.17g} {p['platform.Iyy']:.17g} {p['platform.Izz']:.17g}"/>{sites}
    </body>
  </worldbody>
  <equality>{eq}
  </equality>
  <actuator>{act}
  </actuator>
</mujoco>"""


def mujoco_run(m: Model, seconds: float, period: float, timestep: float | None):
    import mujoco

    model = mujoco.MjModel.from_xml_string(mujoco_xml(m))
    if timestep is not None:
        model.opt.timestep = timestep
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    q0 = m.ik(m.home())
    rails = [model.joint(f"rail{i}").qposadr[0] for i in range(6)]
    drails = [model.joint(f"rail{i}").dofadr[0] for i in range(6)]
    ends = [model.site(f"end{i}").id for i in range(6)]
    plats = [model.site(f"p{i}").id for i in range(6)]
    t, qref, qdref = reference(m, seconds, period)
    steps = max(1, int(round(period / model.opt.timestep)))
    closure = 0.0
    wall = time.perf_counter()
    for k in range(len(t) - 1):
        q = q0 + data.qpos[rails]
        qd = data.qvel[drails]
        data.ctrl[:] = KP * (qref[k] - q) + KD * (qdref[k] - qd)
        for _ in range(steps):
            mujoco.mj_step(model, data)
        if k % 10 == 0:
            closure = max(closure, float(np.max(np.linalg.norm(data.site_xpos[ends] - data.site_xpos[plats], axis=1))))
    wall = time.perf_counter() - wall
    return wall, closure, model.opt.timestep, mujoco.__version__


def mujoco_rollout(m: Model, seconds: float, period: float):
    """The same PD as MuJoCo actuators, the whole run in one ``mujoco.rollout`` call (C)."""
    import mujoco
    from mujoco import rollout

    model = mujoco.MjModel.from_xml_string(mujoco_xml(m, servo=True))
    model.opt.timestep = period
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    q0 = m.ik(m.home())
    t, qref, qdref = reference(m, seconds, period)
    ctrl = np.hstack([qref - q0, KD * qdref])[None, :-1, :]
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state0 = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state0, spec)
    wall = time.perf_counter()
    states, _ = rollout.rollout(model, data, state0[None], ctrl)
    wall = time.perf_counter() - wall
    ends = [model.site(f"end{i}").id for i in range(6)]
    plats = [model.site(f"p{i}").id for i in range(6)]
    closure = 0.0
    for st in states[0][::10]:
        mujoco.mj_setState(model, data, st, spec)
        mujoco.mj_kinematics(model, data)
        closure = max(closure, float(np.max(np.linalg.norm(data.site_xpos[ends] - data.site_xpos[plats], axis=1))))
    return wall, closure


# ------------------------------------------------------------------ the core

def master_run(m: Model, seconds: float, period: float) -> float:
    from cosim import controllers as ctl
    from cosim.master import CorePlant, ReferenceTable, run

    t, qref, qdref = reference(m, seconds, period)
    x = np.broadcast_to(m.home(), qref.shape).copy()
    ref = ReferenceTable(t, qref, qdref, np.zeros_like(qref), x, label=np.zeros(len(t), int), name="sine")
    res = run(CorePlant(m, rtol=1e-8, atol=1e-10), ctl.pd(ndof=6, kp=KP, kd=KD), ref, progress=False)
    assert res.loop == "compiled", res.loop_note
    return res.wall_time


def fmpy_share(m: Model, seconds: float, period: float, method: int = 2, rtol: float = 1e-8) -> tuple[float, float]:
    """(share of wall time inside doStep, wall time) of a Python loop over the plant FMU
    (``solver.method``: 2 explicit RK 5(4), the default; 3 explicit RK 3(2))."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave

    from cosim.fmu import fmu_path

    path = str(fmu_path("6pus"))
    md = read_model_description(path)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName="plant")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.setInteger([vr["solver.method"]], [method])
    fmu.setReal([vr["solver.rtol"], vr["solver.atol"]], [rtol, rtol * 1e-2])
    fmu.enterInitializationMode()
    fmu.exitInitializationMode()
    tau_vr = [vr[f"tau[{i}]"] for i in range(1, 7)]
    q_vr = [vr[f"q[{i}]"] for i in range(1, 7)] + [vr[f"qd[{i}]"] for i in range(1, 7)]
    t, qref, qdref = reference(m, seconds, period)
    in_step = 0.0
    wall = time.perf_counter()
    for k in range(len(t) - 1):
        y = np.asarray(fmu.getReal(q_vr))
        tau = KP * (qref[k] - y[:6]) + KD * (qdref[k] - y[6:])
        fmu.setReal(tau_vr, list(tau))
        a = time.perf_counter()
        fmu.doStep(currentCommunicationPoint=t[k], communicationStepSize=period)
        in_step += time.perf_counter() - a
    wall = time.perf_counter() - wall
    fmu.terminate()
    fmu.freeInstance()
    return in_step / wall, wall


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=10.0, help="simulated time per run [s] (default 10)")
    ap.add_argument("--period", type=float, default=1e-3, help="controller period [s] (default 0.001)")
    ap.add_argument("--repeats", type=int, default=5, help="repeats per row; medians are printed (default 5)")
    ap.add_argument("--fmu-seconds", type=float, default=2.0, help="simulated time of the fmpy loop [s] (default 2)")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    a = ap.parse_args(argv)
    m = Model("6pus")
    exe = REPO / "build" / "bin" / "loop_bench"
    out = subprocess.run([str(exe), "--json", "--seconds", str(a.seconds), "--period", str(a.period), "--repeats",
                          str(a.repeats)], capture_output=True, text=True, check=True)
    core = json.loads(out.stdout)
    rows = {r["key"]: r for r in core["rows"]}
    mj1 = [mujoco_run(m, a.seconds, a.period, a.period) for _ in range(a.repeats)]
    mj2 = [mujoco_run(m, a.seconds, 2e-3, None) for _ in range(a.repeats)]
    mj1_wall = statistics.median(r[0] for r in mj1)
    mj2_wall = statistics.median(r[0] for r in mj2)
    mjr = [mujoco_rollout(m, a.seconds, a.period) for _ in range(a.repeats)]
    mjr_wall = statistics.median(r[0] for r in mjr)
    py = statistics.median(master_run(m, a.seconds, a.period) for _ in range(a.repeats))
    shares = [fmpy_share(m, a.fmu_seconds, a.period) for _ in range(a.repeats)]
    share, fmu_wall = statistics.median(r[0] for r in shares), statistics.median(r[1] for r in shares)
    shares23 = [fmpy_share(m, a.fmu_seconds, a.period, method=3, rtol=1e-6) for _ in range(a.repeats)]
    share23, fmu_wall23 = statistics.median(r[0] for r in shares23), statistics.median(r[1] for r in shares23)

    table = [
        ("compiled loop, ERK (default) [C]", rows["compiled_erk"]["wall_s"], rows["compiled_erk"]["pose_error_m"],
         rows["compiled_erk"]["closure_error_m"]),
        ("cosim.master.run, compiled path [Python]", py, rows["compiled_erk"]["pose_error_m"],
         rows["compiled_erk"]["closure_error_m"]),
        ("stepwise loop (FMU doStep path), ERK [C]", rows["stepwise_erk"]["wall_s"],
         rows["stepwise_erk"]["pose_error_m"], rows["stepwise_erk"]["closure_error_m"]),
        ("compiled loop, ERK 3(2) at rtol 1e-6 [C]", rows["compiled_erk23"]["wall_s"],
         rows["compiled_erk23"]["pose_error_m"], rows["compiled_erk23"]["closure_error_m"]),
        ("stepwise loop (FMU doStep path), ERK 3(2) 1e-6 [C]", rows["stepwise_erk23"]["wall_s"],
         rows["stepwise_erk23"]["pose_error_m"], rows["stepwise_erk23"]["closure_error_m"]),
        ("compiled loop, CVODE BDF [C]", rows["compiled_bdf"]["wall_s"],
         rows["compiled_bdf"]["pose_error_m"], rows["compiled_bdf"]["closure_error_m"]),
        ("stepwise loop, CVODE BDF [C]", rows["stepwise_bdf"]["wall_s"],
         rows["stepwise_bdf"]["pose_error_m"], rows["stepwise_bdf"]["closure_error_m"]),
        (f"MuJoCo {mj1[0][3]} mj_step, timestep {a.period * 1e3:g} ms", mj1_wall, float("nan"), max(r[1] for r in mj1)),
        (f"MuJoCo {mj2[0][3]} mj_step, default timestep 2 ms", mj2_wall, float("nan"), max(r[1] for r in mj2)),
        (f"MuJoCo rollout (PD as actuators, one C call), {a.period * 1e3:g} ms", mjr_wall, float("nan"),
         max(r[1] for r in mjr)),
    ]
    print(f"6-PUS, joint PD (kp {KP:g} N/m, kd {KD:g} N s/m), {a.seconds:g} s at a {a.period * 1e3:g} ms period, "
          f"medians of {a.repeats}, one core")
    print(f"{'loop':50s} {'wall [s]':>9s} {'sim s/wall s':>12s} {'vs MuJoCo loop':>14s} {'pose err [m]':>12s} "
          f"{'closure [m]':>11s}")
    for label, wall, err, clo in table:
        print(f"{label:50s} {wall:9.4f} {a.seconds / wall:12.0f} {mj1_wall / wall:13.2f}x {err:12.2e} {clo:11.2e}")
    print(f"targets (docs/performance.md): compiled >= 8x MuJoCo and >= 1000 sim s/wall s; stepwise >= 2x MuJoCo; "
          f"fmpy doStep share < 25 %")
    print(f"fmpy Python loop over PKM_6PUS.fmu ({a.fmu_seconds:g} s, medians of {a.repeats}): ERK 5(4) (default) "
          f"{a.fmu_seconds / fmu_wall:.0f} sim s/wall s, {100 * share:.0f} % of the wall time inside doStep; "
          f"ERK 3(2) at rtol 1e-6 {a.fmu_seconds / fmu_wall23:.0f} sim s/wall s, {100 * share23:.0f} %")
    print(f"pose error: max |x - x_ref| over the run against BDF rtol 1e-12 (which differs from ERK rtol 1e-12 by "
          f"{core['reference_bdf_vs_erk']:.1e} m)")
    if a.json:
        a.json.write_text(json.dumps({"core": core, "mujoco_1ms": mj1_wall, "mujoco_2ms": mj2_wall,
                                      "mujoco_rollout": mjr_wall, "master_run": py, "fmpy_share": share,
                                      "fmpy_share_erk23": share23}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
