"""Closed-loop runs of a core plant with its drive and sensor models: the blind-case
generator's plant and the engine's replay.

The loop is :class:`cosim.closed_loop.ClosedLoop` on the core plant with the plant's
drive and sensor model: the core's integrator (``pkm_sim``) integrates the mechanics with
friction and rotor inertia and applies the actuator dead zone, saturation
(``<j>[i].effort_max``) and delay (``actuator.delay``, its delay line) to the held
command; the sensors are the core's reading model and the readings' delay.  It runs
inside the core (``pkm_closed_loop``) when the controller is one the core implements.
No physics is computed in Python.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.signal import savgol_filter

from ..master import ReferenceTable
from ..run_record import RunRecord


def controller_from(desc: dict, model):
    """Rebuild the recorded controller from its sidecar description.

    ``desc`` is what ``describe()`` of a controller writes:
    ``{"type": "pd" | "pd_gravity" | "computed_torque", "kp", "kd", ...}``,
    ``{"type": "pid", "kp", "ki", "kd", "dt", "deriv_filter", "saturation",
    "gravity_feedforward"}`` (:func:`cosim.controllers.pid`), ``{"type": "lti", "dt",
    "A", "B", "C", "D", "saturation", "gravity_feedforward"}`` (a discrete LTI controller
    on the joint error, :func:`cosim.ssp.lti_controller`) or a rig's controller as data,
    ``{"kind": "discrete", "period", "law", ...}`` (:func:`cosim.controllers.discrete`).  ``model`` is the model the
    controller believes in (the nominal one).  Returns None (and the reason) when it
    cannot be rebuilt.
    """
    from .. import controllers as ctl

    if desc and (desc.get("kind") == "discrete" or desc.get("type") == "discrete"):
        try:
            return ctl.discrete(desc, ndof=model.ndof, model=model), ""
        except ctl.ControllerError as e:
            return None, f"the sidecar's discrete controller: {e}"
    if not desc or "type" not in desc:
        return None, "the sidecar has no controller description"
    kind = desc["type"]
    sat = desc.get("saturation")
    if kind == "lti":
        from ..controllers import LTIController

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


def closed_loop(plant, controller, ref, *, x0=None, xd0=None, noise: dict | None = None, seed=None,
                start: int = 0, rtol: float = 1e-9, atol: float = 1e-11, f_ext=None, history=None,
                inject=None) -> RunRecord:
    """Run ``controller`` on the core plant ``plant`` over the reference samples
    (:class:`cosim.closed_loop.ClosedLoop` with the plant's drive and sensor model).

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
    rtol, atol : float
        Tolerances of the plant's integrator.
    f_ext : array_like, shape (len(ref.time), nd), optional
        Known external effort per joint at every reference sample [N or N m], positive
        along +q (a recording's ``f_ext`` columns): an input of the plant, added to the
        actuator effort.
    history : tuple of array_like, optional
        ``(q, qd)``, the readings of the samples before ``start`` (each (m, nd), oldest
        first): the controller sees them first, so that it starts where the recorded
        controller was (:meth:`cosim.closed_loop.ClosedLoop.run`).
    inject : cosim.injection.Injection, optional
        A signal injected into the loop (a recording's, :func:`cosim.injection.from_recording`):
        the loop adds it at its point, and ``tau_logged`` is the command as the recording
        logs it (with the signal's part, or without it when the recorded effort excludes it).

    Returns
    -------
    cosim.run_record.RunRecord
        The run's rows (``tau_logged`` the command as logged, ``pose`` the tracker's), its
        ``robot`` and ``step``; ``to_recording(effort="logged")`` makes it a recording.

    Raises
    ------
    cosim.core's errors (``PkmError`` subclasses) when the plant stops (a limit, a
    singularity), the controller's errors otherwise.
    """
    from ..closed_loop import ClosedLoop
    from ..master import CoreDrive, CorePlant

    rec = ClosedLoop(CorePlant(plant, rtol=rtol, atol=atol), controller, drive=CoreDrive(plant), noise=noise,
                     seed=seed).run(ref, start=start, x0=x0, xd0=xd0, f_ext=f_ext, history=history, inject=inject)
    logged = rec.tau_logged if inject is None else inject.effort_seen(rec.tau_logged, rec.tau_inj)
    return replace(rec, tau_logged=logged, robot=plant.robot, step=float(ref.time[1] - ref.time[0]))
