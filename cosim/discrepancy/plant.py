"""Closed-loop runs of a core plant with its drive and sensor models: the blind-case
generator's plant and the engine's replay.

The core's integrator (``pkm_sim``) integrates the mechanics with friction and rotor
inertia and applies the actuator dead zone, saturation (``<j>[i].effort_max``) and delay
(``actuator.delay``) to the held command.  The sensors are applied by the core's
``pkm_measure_joints`` (encoder offset, backlash, compliance) and the readings' delay line
(``sensor.delay``: the core's closed loop, or :meth:`cosim.master.CoreDrive.delayed` with
the same rule when this loop runs in Python).  The loop runs inside the core
(``pkm_closed_loop``) when the controller is one the core implements; the Python loop
here serves Python controllers and a compliance under an actuator delay (the reading
deflects under the delayed effort, which the compiled loop does not model).  No physics
is computed in Python.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import savgol_filter

from ..master import ReferenceTable
from ..simulate import Simulator
from . import _corecalls as cc

def controller_from(desc: dict, model):
    """Rebuild the recorded controller from its sidecar description.

    ``desc`` is what ``describe()`` of a controller writes:
    ``{"type": "pd" | "pd_gravity" | "computed_torque", "kp", "kd", ...}``,
    ``{"type": "pid", "kp", "ki", "kd", "dt", "deriv_filter", "saturation",
    "gravity_feedforward"}`` (:func:`cosim.controllers.pid`) or ``{"type": "lti", "dt",
    "A", "B", "C", "D", "saturation", "gravity_feedforward"}`` (a discrete LTI controller
    on the joint error, :func:`cosim.ssp.lti_controller`).  ``model`` is the model the
    controller believes in (the nominal one).  Returns None (and the reason) when it
    cannot be rebuilt.
    """
    from .. import controllers as ctl

    if not desc or "type" not in desc:
        return None, "the sidecar has no controller description"
    kind = desc["type"]
    sat = desc.get("saturation")
    if kind == "lti":
        from ..ssp import LTIController

        try:
            A, B, Cm, D = (np.atleast_2d(np.asarray(desc[k], float)) for k in ("A", "B", "C", "D"))
            dt = float(desc["dt"])
        except (KeyError, TypeError, ValueError) as e:
            return None, f"the LTI controller description needs numeric A, B, C, D and dt ({e})"
        nd, nx = model.ndof, A.shape[0]
        if A.shape != (nx, nx) or B.shape != (nx, nd) or Cm.shape != (nd, nx) or D.shape != (nd, nd):
            return None, (f"the LTI controller's matrices have shapes A {A.shape}, B {B.shape}, C {Cm.shape}, "
                          f"D {D.shape}; with {nx} states and {nd} joints they must be ({nx}, {nx}), ({nx}, {nd}), "
                          f"({nd}, {nx}), ({nd}, {nd})")
        return LTIController(A, B, Cm, D, dt=dt, model=model, saturation=sat,
                             gravity_feedforward=bool(desc.get("gravity_feedforward", False))), ""
    if kind == "pid":
        try:
            return ctl.pid(model, kp=np.asarray(desc["kp"], float), ki=np.asarray(desc["ki"], float),
                           kd=np.asarray(desc["kd"], float), dt=float(desc["dt"]),
                           deriv_filter=float(desc.get("deriv_filter", 0.0)), saturation=sat,
                           gravity_feedforward=bool(desc.get("gravity_feedforward", False))), ""
        except (KeyError, TypeError, ValueError) as e:
            return None, f"the PID controller description needs numeric kp, ki, kd and dt ({e})"
    try:
        kp, kd = np.asarray(desc["kp"], float), np.asarray(desc["kd"], float)
    except (KeyError, TypeError, ValueError):
        return None, "the controller description has no numeric kp/kd"
    if kind == "pd":
        return ctl.pd(ndof=model.ndof, kp=kp, kd=kd, saturation=sat), ""
    if kind == "pd_gravity":
        return ctl.pd_gravity(model, kp=kp, kd=kd, saturation=sat, gravity=desc.get("gravity", "measured")), ""
    if kind == "computed_torque":
        return ctl.computed_torque(model, kp=kp, kd=kd, saturation=sat), ""
    return None, f"controller type {kind!r} is not one the engine can rebuild"


def reference_from_recording(rec, model) -> ReferenceTable:
    """The joint reference of a recording: ``qref`` and its derivatives (a short
    Savitzky-Golay differentiator: the reference is smooth), the reference pose by the
    core's forward kinematics."""
    t = rec.time
    dt = (t[-1] - t[0]) / (len(t) - 1)
    qd = savgol_filter(rec.qref, 9, 4, deriv=1, delta=dt, axis=0)
    qdd = savgol_filter(rec.qref, 9, 4, deriv=2, delta=dt, axis=0)
    guess = rec.pose if rec.pose is not None else np.broadcast_to(model.home(), rec.qref.shape)
    x = model.fk(rec.qref, x_guess=np.ascontiguousarray(guess))
    return ReferenceTable(t, rec.qref, qd, qdd, x)


@dataclass
class LoopResult:
    """A closed-loop run, one row per sample: readings ``q``, ``qd`` (what the
    controller saw, noise included), ``tau`` (commanded), ``pose`` (tracker), true
    ``x``, ``xd``, ``q_true``."""

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    pose: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    q_true: np.ndarray


def _compiled(plant, sim, controller, ref, start, t, x0, xd0, sig, rng, delay):
    """:func:`closed_loop` through the core's compiled loop (same draws of the noise), or
    None when the controller or the sensor model needs the Python loop."""
    from ..closed_loop import compile_controller, run_compiled
    from .effects import joint_prefix

    nd = plant.ndof
    if delay > 0 and any(plant.param(f"{joint_prefix(plant)}[{i + 1}].compliance") != 0 for i in range(nd)):
        return None  # compliance reads the delayed effort: the Python loop models that
    n, dt = len(t), float(t[1] - t[0])
    cc_, _ = compile_controller(controller, model=plant, dt=dt)
    if cc_ is None:
        return None
    groups = [k for k in ("q", "qd", "tau", "pose") if np.any(sig[k])]
    z = rng.normal(size=(n, len(groups) * nd)) if groups else np.zeros((n, 0))
    draw = {k: z[:, i * nd:(i + 1) * nd] * sig[k] for i, k in enumerate(groups)}
    sim.reset(float(t[0]), x0, xd0)
    cc_.reset(x0)
    sl = slice(start, start + n)
    qdd = getattr(ref, "qdd", None)
    rows, done, status, message = run_compiled(
        sim, cc_, time=t, dt=dt, qref=ref.q[sl], qdref=ref.qd[sl], qddref=None if qdd is None else qdd[sl],
        xref=None if getattr(ref, "x", None) is None else ref.x[sl], q_noise=draw.get("q"), qd_noise=draw.get("qd"),
        measure=True)
    if status != 0:
        from ..closed_loop import raise_status

        raise_status(status, message)
    tau = rows["tau_cmd"] + draw.get("tau", 0.0)
    pose = rows["x"] + draw.get("pose", 0.0)
    return LoopResult(t, rows["q"], rows["qd"], tau, pose, rows["x"], rows["xd"], rows["q_true"])


def closed_loop(plant, controller, ref, *, x0=None, xd0=None, noise: dict | None = None, seed=None,
                start: int = 0, rtol: float = 1e-9, atol: float = 1e-11) -> LoopResult:
    """Run ``controller`` on the core plant ``plant`` over the reference samples.

    Parameters
    ----------
    plant : cosim.core.Model
        The true robot, drive and sensor parameters included.
    controller : callable
        ``controller(t, q, qd, ref) -> tau`` (:mod:`cosim.controllers`).
    ref : cosim.master.ReferenceTable
        Reference on the sample grid (its time step is the controller's period).
    x0, xd0 : array_like, optional
        Initial true pose and rate (default: the reference pose of sample ``start``, at rest).
    noise : dict, optional
        Standard deviations of white noise: ``q`` (readings), ``qd``, ``tau`` (added to
        the recorded command, not to the applied one), ``pose`` (tracker, per coordinate).
    seed : int, optional
        Noise seed.
    start : int
        First reference sample of the run.

    Returns
    -------
    LoopResult
    """
    t = np.asarray(ref.time, float)[start:]
    n, nd = len(t), plant.ndof
    dt = float(t[1] - t[0])
    noise = noise or {}
    rng = np.random.default_rng(seed)
    sig = {k: np.broadcast_to(np.asarray(noise.get(k, 0.0), float), (nd,)) for k in ("q", "qd", "tau", "pose")}
    delay = plant.param("actuator.delay")
    sim = Simulator(plant, rtol=rtol, atol=atol)
    if x0 is None:
        x0 = ref.x[start] if getattr(ref, "x", None) is not None else plant.fk(ref.q[start])
    # The whole loop inside the core when the controller is one it implements.
    fast = _compiled(plant, sim, controller, ref, start, t, np.asarray(x0, float), xd0, sig, rng, delay)
    if fast is not None:
        return fast
    sim.reset(float(t[0]), np.asarray(x0, float), xd0)
    if hasattr(controller, "reset"):
        controller.reset(float(t[0]), ref.q[start], np.asarray(x0, float))

    from ..master import CoreDrive, PlantOutputs

    line = CoreDrive(plant)
    two_body = plant.two_body_joints() > 0  # drive bodies: the encoders read them (pkm_sim_drive_state)
    out = {k: np.zeros((n, nd)) for k in ("q", "qd", "tau", "pose", "x", "xd", "q_true")}
    cmds = []  # (time, command)

    def command_at(s):
        if not cmds or s < cmds[0][0] - 1e-12:
            return np.zeros(nd)
        k = len(cmds) - 1
        while k > 0 and cmds[k][0] > s + 1e-12:
            k -= 1
        return cmds[k][1]

    def applied_at(s):
        c = command_at(s - delay)[None, :]
        return cc.actuator_effort(plant, c)[0]

    for k in range(n):
        _, x, xd = sim.state
        tau_now = applied_at(t[k])
        qd_true = cc.per_sample(plant, "pkm_joint_velocity", x[None], xd[None])[0]
        # the sensors' rule, one for every loop (CoreDrive.read: the drive bodies where there are)
        y = PlantOutputs(None, qd_true, x, xd, sim.drive_state if two_body else None)
        q_meas, qd_read = line.read(y, tau_now)
        qr, qdr = line.delayed(float(t[k]), q_meas, qd_read)  # sensor.delay, as in the core's loop
        if np.any(sig["q"]):
            qr = qr + rng.normal(size=nd) * sig["q"]
        if np.any(sig["qd"]):
            qdr = qdr + rng.normal(size=nd) * sig["qd"]
        cmd = np.asarray(controller(float(t[k]), qr, qdr, ref.at(start + k)), float)
        cmds.append((float(t[k]), cmd))
        if len(cmds) > 4 + int(delay / dt) * 2:
            cmds.pop(0)
        out["q"][k], out["qd"][k] = qr, qdr
        out["tau"][k] = cmd + (rng.normal(size=nd) * sig["tau"] if np.any(sig["tau"]) else 0.0)
        out["pose"][k] = x + (rng.normal(size=nd) * sig["pose"] if np.any(sig["pose"]) else 0.0)
        out["x"][k], out["xd"][k] = x, xd
        out["q_true"][k] = plant.ik(x)
        if k == n - 1:
            break
        sim.set_input(cmd)
        sim.advance(float(t[k + 1]))
    return LoopResult(t, out["q"], out["qd"], out["tau"], out["pose"], out["x"], out["xd"], out["q_true"])
