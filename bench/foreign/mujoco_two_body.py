"""The core's two-body transmission (``drive.two_body = 1``) against MuJoCo's two bodies.

    .venv/bin/python bench/foreign/mujoco_two_body.py [--seed 11] [--duration 4] [--cases backlash,compliance]

MuJoCo side: ``mujoco_blind.simulate`` (the 6-PUS built from the core's nominal parameters,
a rail made of a drive body of 0.05 kg carrying the carriage on a relative slide joint, the
gap's faces or the spring applied per 0.1 ms step, stiff ``connect`` loops, MuJoCo's
``implicitfast`` integrator), closed by the PD + gravity controller at 1 kHz along the
engine's exciting trajectory, without noise.  The encoder reads the drive body.

Core side, the same controller and reference through ``cosim.master.run`` on three plants:
``two_body`` (drive.two_body = 1, the drive body's inertia as the rail's rotor inertia, the
spring 1 / compliance or the faces' stiffness, their damping), ``reading`` (the same gap or
compliance as the quasi-static reading model, drive.two_body = 0) and ``rigid`` (no gap).
Printed per case: the RMS and largest difference of the joint readings (drive side) from
MuJoCo's on the gap's rail and on the others, after the 0.5 s lead-in; and the RMS of the
readings' difference from the rigid plant (the size of the effect).
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "bench" / "foreign"))

import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy.excitation import excitation  # noqa: E402
from cosim.master import CoreDrive, CorePlant, make_reference, run  # noqa: E402

NO_NOISE = {"q": 0.0, "qd": 0.0, "tau": 0.0, "pose": [0.0] * 6}
#: the cases: effect, size (gap [m] or compliance [m/N]), rail (0-based: rail 6's effort changes sign)
CASES = {"backlash": ("backlash", 40e-6, 5), "compliance": ("compliance", 2e-5, 5)}


def plant_params(kind: str, effect: str, value: float, j: int) -> dict:
    """The core parameters of one plant of the comparison."""
    k = 1.0 / value if effect == "compliance" else mb.CONTACT_K
    c = 2 * mb.DAMPING_RATIO * math.sqrt(k * mb.DRIVE_MASS)
    p = {f"rail[{j + 1}].rotor_inertia": mb.DRIVE_MASS}
    if kind == "rigid":
        return p
    if effect == "backlash":
        p.update({f"rail[{j + 1}].backlash": value, f"rail[{j + 1}].compliance": 1.0 / mb.CONTACT_K})
    else:
        p[f"rail[{j + 1}].compliance"] = value
    if kind == "two_body":
        p.update({"drive.two_body": 1.0, f"rail[{j + 1}].transmission_damping": c})
    return p


def compare(effect: str, value: float, j: int, seed: int, duration: float) -> dict:
    """MuJoCo's readings against the core plants' for one case; the figures."""
    m = Model("6pus")
    rec, _ = mb.simulate(m, effect, value, j, seed, duration, NO_NOISE)
    q0 = m.ik(m.home())
    k0 = int(round(0.5 / mb.DT))
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=mb.DT, duration=round(traj.duration / mb.DT) * mb.DT)
    out = {"effect": effect, "value": value, "rail": j + 1}
    q_mj = rec.q + q0  # MuJoCo's readings (drive side), from the end of the lead-in
    c_mj = m.ik(rec.pose)  # MuJoCo's carriages: the IK of its (noise-free) platform pose
    reads, carriages = {}, {}
    for kind in ("two_body", "reading", "rigid"):
        pm = Model("6pus")
        pm.set_params(plant_params(kind, effect, value, j))
        ctrl = mb.controller("pd_gravity", m)
        res = run(CorePlant(pm), ctrl, ref, drive=CoreDrive(pm), seed=None)
        q = np.asarray(res["q"])[k0:k0 + len(q_mj)]
        qc = np.asarray(res["q_true"])[k0:k0 + len(q_mj)]
        reads[kind], carriages[kind] = q, qc
        d, dc = q - q_mj, qc - c_mj
        others = [i for i in range(6) if i != j]
        rms = lambda a: float(np.sqrt(np.mean(a ** 2)))  # noqa: E731
        out[kind] = {"rms_rail": rms(d[:, j]), "max_rail": float(np.abs(d[:, j]).max()), "rms_others": rms(d[:, others]),
                     "carriage_rail": rms(dc[:, j]), "carriage_others": rms(dc[:, others]), "loop": res.loop}
    out["effect_rms"] = float(np.sqrt(np.mean((q_mj[:, j] - reads["rigid"][:, j]) ** 2)))
    out["effect_carriage"] = float(np.sqrt(np.mean((c_mj[:, j] - carriages["rigid"][:, j]) ** 2)))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--duration", type=float, default=4.0)
    ap.add_argument("--cases", default=",".join(CASES))
    a = ap.parse_args(argv)
    print(f"two-body transmission, core vs MuJoCo (6-PUS, PD + gravity at 1 kHz, seed {a.seed}, {a.duration} s)\n")
    print("| case | effect (MuJoCo - rigid core) on the rail's reading / carriage, RMS | core plant | "
          "reading - MuJoCo's on the rail, RMS / max | on the other rails, RMS | carriage - MuJoCo's on the rail, "
          "RMS | on the other rails, RMS |")
    print("|---|---:|---|---:|---:|---:|---:|")
    for name in a.cases.split(","):
        eff, val, j = CASES[name]
        r = compare(eff, val, j, a.seed, a.duration)
        for kind in ("two_body", "reading", "rigid"):
            f = r[kind]
            print(f"| {eff} {val:g} on rail {j + 1} | {r['effect_rms'] * 1e6:.2f} / {r['effect_carriage'] * 1e6:.2f} um "
                  f"| {kind} | {f['rms_rail'] * 1e6:.2f} / {f['max_rail'] * 1e6:.2f} um | {f['rms_others'] * 1e6:.2f} um "
                  f"| {f['carriage_rail'] * 1e6:.2f} um | {f['carriage_others'] * 1e6:.2f} um |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
