"""Blind recordings of a described robot made by MuJoCo built from the same description file.

The MuJoCo model is bench/foreign/mujoco_described.py's (it reads the TOML itself, lays the
legs out with its own inverse kinematics; MuJoCo does all the dynamics).  The recording is
made as bench/foreign/mujoco_blind.py makes the 6-PUS's: the engine's exciting trajectory
(``cosim.discrepancy.excitation``), the generator's PD + gravity controller designed on the
nominal core model at 1 kHz, the generator's sensor noise for the robot (configured or derived
from the core, ``blind.with_robot``), the first 0.5 s (standstill) dropped.  A force law may
be hidden in MuJoCo's physics: ``force(q, qd)`` of the actuated joints' true positions and
rates gives the forces pushing them along +q, applied at every MuJoCo step (``qfrc_applied``),
so neither the core nor its generic joint force computes it.  So may an inertia on an actuated
joint: ``armature`` {joint (0-based): kg or kg m2} adds to MuJoCo's armature of that joint (a
rotor, pulley or a mass riding on the carriage, in MuJoCo's joint-space mass matrix).

MuJoCo's actuated joints carry the description's q itself (their ``ref`` is the home value),
so the recording is in the core's joint coordinates; the pose columns are the platform's
declared coordinates (the robot's tracker columns).
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench" / "foreign")]

DT, SUBSTEPS = 1e-3, 10  # controller / recording period [s], MuJoCo RK4 steps per period (0.1 ms)
LEAD_IN = 0.5            # standstill dropped from the recording [s], as the engine's own generator


def simulate(robot: str, seed: int, duration: float, force=None, armature=None):
    """One run of ``robot`` (a description name): a ``Recording`` in the core's coordinates.

    ``force(q, qd) -> (n,)`` [N or N m along +q], if given, is hidden in MuJoCo's physics, and
    so is ``armature`` {actuated joint, 0-based: inertia [kg or kg m2]} added to the joints'.
    Raises RuntimeError if MuJoCo's run diverges or leaves the description's strokes."""
    import mujoco
    import mujoco_described as md

    from cosim.controllers import Reference
    from cosim.core import Model
    from cosim.discrepancy import blind
    from cosim.discrepancy.excitation import excitation
    from cosim.master import make_reference
    from cosim.recording import Recording

    m = Model(robot)
    cfg = blind.with_robot(blind.load_config(), m)
    noise = cfg["noise"][m.robot]
    rob = md.read(md.resolve(robot))
    if rob.dependent or rob.articulated or md.single_axis(rob):
        raise ValueError(f"{robot}: only robots whose pose is their declared coordinates are supported here")
    xml, q0 = md.mjcf(rob, DT / SUBSTEPS, "RK4", 5e-4, "0.9999 0.9999 0.001 0.5 2")
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    aq = [model.joint(md.actuated_joint(rob, i)).qposadr[0] for i in range(rob.n)]
    av = [model.joint(md.actuated_joint(rob, i)).dofadr[0] for i in range(rob.n)]
    for j, inertia in (armature or {}).items():
        model.dof_armature[av[j]] += inertia
    pq = [model.joint(md.COORDS[c]).qposadr[0] for c in rob.coords]
    data.qpos[pq] = rob.home
    mujoco.mj_forward(model, data)
    rng = np.random.default_rng(seed)
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    ctrl = blind._controller("pd_gravity", m, cfg, DT)
    ctrl.reset(0.0, data.qpos[aq].copy(), m.home())
    n, nj = len(ref.time), rob.n
    rows = {k: np.empty((n, w)) for k, w in (("q", nj), ("qd", nj), ("tau", nj), ("pose", len(pq)))}
    sig_pose = np.broadcast_to(np.asarray(noise["pose"], float), (len(pq),))
    lo, hi = np.array([leg.stroke for leg in rob.legs]).T
    for k in range(n):
        q_true, qd_true = data.qpos[aq].copy(), data.qvel[av].copy()
        if not (np.all(np.isfinite(q_true)) and np.all(q_true >= lo) and np.all(q_true <= hi)):
            raise RuntimeError(f"{robot} seed {seed}: MuJoCo's joints left the strokes at t = {k * DT:.3f} s")
        q_read = q_true + rng.normal(0, noise["q"], nj)
        qd_read = qd_true + rng.normal(0, noise["qd"], nj)
        tau = ctrl(k * DT, q_read, qd_read, Reference(ref.q[k], ref.qd[k], ref.qdd[k], ref.x[k]))
        rows["q"][k], rows["qd"][k] = q_read, qd_read
        rows["tau"][k] = tau + rng.normal(0, noise["tau"], nj)
        rows["pose"][k] = data.qpos[pq] + rng.normal(0, 1, len(pq)) * sig_pose
        data.ctrl[:] = tau
        for _ in range(SUBSTEPS):
            if force is not None:
                data.qfrc_applied[av] = force(data.qpos[aq], data.qvel[av])
            mujoco.mj_step(model, data)
    s = slice(int(round(LEAD_IN / DT)), n)
    return Recording(m.robot, ref.time[s] - ref.time[s.start], rows["q"][s], rows["qd"][s], rows["tau"][s],
                     qref=ref.q[s], pose=rows["pose"][s], controller=dict(ctrl.describe(), rate_hz=1.0 / DT),
                     notes="MuJoCo run of the description (bench/foreign/mujoco_described_blind.py)")
