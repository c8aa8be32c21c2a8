"""Co-simulation master: a plant and a controller over a reference, at a fixed communication step.

:func:`run` steps a plant (:mod:`cosim.plants`: the core itself, :class:`CorePlant`, or a
robot's Co-Simulation FMU, :class:`FMUPlant`) under a controller through the one closed
loop (:class:`cosim.closed_loop.ClosedLoop`: inside the core when the plant is the core and
the controller one the core implements, else sample by sample in Python).  At each
communication point ``t_k = t0 + k h`` the loop reads the plant's joints, adds the optional
sensor noise, asks the controller for the efforts, holds them as inputs over the step and
advances the plant to ``t_k + h``.  The result is the run's record
(:class:`cosim.run_record.RunRecord`): one row per communication point, a unit per field.

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl, trajectories as tr
>>> from cosim.master import CorePlant, run, make_reference
>>> m = Model("6pus")
>>> x0 = m.home(); x1 = x0 + [0, 0, -0.01, 0, 0, 0]
>>> ref = make_reference(m, tr.step(x0, x1), step=1e-3, duration=0.5)
>>> res = run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), ref, x0=x0)
>>> res["q"].shape                                     # (501, 6)
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .controllers import Reference
# the plants a run steps, named by the master's interface too (``from cosim.master import CorePlant``)
from .errors import MasterError
from .plants import CoreDrive, CorePlant, FMUPlant, Plant, PlantOutputs, _facts  # noqa: F401
from .run_record import RunRecord


# -------------------------------------------------------------------- reference

@dataclass
class ReferenceTable:
    """A reference sampled at the communication points.

    ``time`` (n,) [s]; ``q, qd, qdd`` (n, nd) joint reference from the controller's
    model; ``x, xd, xdd`` (n, nd) pose reference; ``label`` (n,) int segment tags.
    The pose fields and labels may be None for a joint-only reference (e.g. one
    rebuilt from a recording's ``qref``); :func:`run` needs ``x`` and ``label``.
    """

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    x: np.ndarray | None = None
    xd: np.ndarray | None = None
    xdd: np.ndarray | None = None
    label: np.ndarray | None = None
    name: str = ""

    def at(self, k) -> Reference:
        def pick(a):
            return None if a is None else a[k]

        return Reference(self.q[k], self.qd[k], self.qdd[k], pick(self.x), pick(self.xd), pick(self.xdd))


def make_reference(model, trajectory, *, step: float = 1e-3, duration: float, t0: float = 0.0) -> ReferenceTable:
    """Sample a task-space trajectory at the communication points and map it to joints.

    Parameters
    ----------
    model : cosim.core.Model
        The controller's model: joint references are its inverse kinematics and
        velocity/acceleration kinematics.
    trajectory : cosim.trajectories.Trajectory
        The pose reference.
    step : float
        Communication step [s].
    duration : float
        Length of the run [s]; ``round(duration / step) + 1`` samples.
    t0 : float
        Start time [s].
    """
    from .trajectories import joint_reference

    n = _nsteps(duration, step)
    t = t0 + np.arange(n + 1) * step
    x, xd, xdd = trajectory.evaluate(t)
    try:
        q, qd, qdd = joint_reference(model, x, xd, xdd)
    except Exception as e:
        raise MasterError(f"reference {trajectory.name!r}: the controller's model cannot map it to joints: {e}") from e
    return ReferenceTable(t, q, qd, qdd, x, xd, xdd, trajectory.label(t), trajectory.name)


def _nsteps(duration, step):
    if not (step > 0 and np.isfinite(step)):
        raise MasterError(f"communication step must be a positive time, got {step} s")
    if not (duration > 0 and np.isfinite(duration)):
        raise MasterError(f"duration must be a positive time, got {duration} s")
    n = int(round(duration / step))
    if abs(n * step - duration) > 1e-9 * max(1.0, duration):
        raise MasterError(f"duration {duration} s is not a whole number of steps of {step} s")
    return n


# ------------------------------------------------------------------------ run

def _units(robot, nd):
    facts = _facts(robot)
    j = facts.joint_unit if facts else "m or rad"
    effort = facts.effort_unit if facts else "N or N m"
    pose = list(facts.pose_units) if facts else ["m or rad"] * nd
    return {"time": "s", "q": j, "qd": f"{j}/s", "q_true": j, "qd_true": f"{j}/s", "tau_applied": effort,
            "tau_cmd": effort, "tau_logged": effort, "tau_inj": effort, "qref": j, "qdref": f"{j}/s", "x": pose,
            "pose": pose, "xd": [f"{u}/s" for u in pose], "xref": pose, "label": "-"}


def _recorder(plant, controller, reference, sig, seed):
    """``result(rec)``: the loop's record with what :func:`run` adds to it (the reference's
    rows, the units, the robot, the step and the descriptions)."""
    h = float(reference.time[1] - reference.time[0])
    units = _units(plant.robot, plant.ndof)
    ctrl_desc = controller.describe() if hasattr(controller, "describe") else {"type": type(controller).__name__}
    noise = {"q": sig["q"].tolist(), "qd": sig["qd"].tolist(), "pose": sig["pose"].tolist(), "seed": seed}

    def result(rec):
        k = rec.n
        return replace(rec.head(k), robot=plant.robot, step=h, units=units, qref=reference.q[:k].copy(),
                       qdref=reference.qd[:k].copy(), xref=reference.x[:k].copy(),
                       label=np.asarray(reference.label[:k], dtype=np.int32), plant=plant.describe(),
                       controller=ctrl_desc, noise=noise, reference_name=reference.name)

    return result


def _stopped(plant, t, h, why) -> str:
    """The message of a run that stopped in the communication step from ``t`` [s]: the
    step's two ends (the cause names the time inside it), and a word on a step that is long
    for a sampled controller."""
    import re

    why = re.sub(r"^closed loop stopped at sample \d+ \(t = [^)]*\): ", "", str(why))
    hint = (f" (the controller holds each command for step = {h:g} s: a sampled controller needs a step well "
            f"inside the loop's time constants, e.g. 0.001 s)" if h >= 0.1 else "")
    return f"{plant.kind} run stopped in the step from t = {t:.6g} s to {t + h:.6g} s: {why}{hint}"


def run(plant: Plant, controller, reference: ReferenceTable, *, x0=None, xd0=None, q_noise=0.0, qd_noise=0.0,
        pose_noise=0.0, seed: int | None = 0, drive=None, progress: bool | None = None,
        compiled: bool | None = None, should_stop=None, f_ext=None, started=None) -> RunRecord:
    """Step ``plant`` and ``controller`` together over the reference's time grid
    (:class:`cosim.closed_loop.ClosedLoop`).

    Parameters
    ----------
    plant : Plant
        :class:`FMUPlant` or :class:`CorePlant` (or any object with that interface).
    controller : callable
        ``controller(t, q, qd, ref) -> tau`` (see :mod:`cosim.controllers`), called at
        every communication point with the joint readings.
    reference : ReferenceTable
        The reference on the time grid (:func:`make_reference`); its spacing is the
        communication step.
    x0, xd0 : array_like, shape (nd,), optional
        Initial pose [m, rad] and rate (default: the first reference pose, at rest).
    q_noise, qd_noise : float or array_like
        Standard deviation of the white noise on the joint readings the controller
        sees and the recording keeps [m or rad, per second].
    pose_noise : float or array_like, shape (nd,)
        Standard deviation of the external tracker's noise on each pose coordinate
        [m, rad].
    seed : int, optional
        Seed of the noise generator.
    drive : CoreDrive, optional
        The plant's drive and sensor model: the recorded ``tau_applied`` is the effort it
        applies (saturation) and the joint readings go through its encoder model
        (offset, backlash, compliance) and delay before the noise.  Without it the
        readings are the plant's joints and ``tau_applied`` the command.
    progress : bool, optional
        Show a tqdm progress bar; by default it appears on a terminal when the run
        lasts more than two seconds of wall time.
    compiled : bool, optional
        Run the whole loop inside the core (one C call per piece of about 20 ms, no
        Python per sample).  By default it does whenever it can: a :class:`CorePlant`
        and a controller the core implements (PD, PD + gravity, computed torque, PID,
        LTI, discrete); otherwise the stepwise loop runs and ``RunRecord.loop_note``
        says why.  ``True`` raises if it cannot, ``False`` forces the stepwise loop.
    should_stop : callable, optional
        ``should_stop() -> bool``, asked between pieces or samples; True ends the run
        there with the rows so far.
    f_ext : array_like, shape (n, nd), optional
        Known external effort per joint and reference sample [N or N m], positive along
        +q, added to the actuator effort over the step after each sample.
    started : callable, optional
        ``started()``, called once right before the first step (the set-up done).

    Returns
    -------
    cosim.run_record.RunRecord
        The rows with the reference (``qref``, ``qdref``, ``xref``, ``label``), units, robot,
        step and descriptions; ``loop`` says which loop ran ("compiled" or "python").

    Raises
    ------
    MasterError
        When the plant or the controller fails; says at which time, and carries the
        samples taken so far in ``partial``.
    cosim.closed_loop.LoopInterrupted
        On ctrl-C, with the samples taken so far (a :class:`~cosim.run_record.RunRecord`) in ``partial``.
    """
    from tqdm import tqdm

    from .closed_loop import ClosedLoop, LoopInterrupted

    n = len(reference.time)
    if n < 2:
        raise MasterError("the reference needs at least two communication points")
    h = float(reference.time[1] - reference.time[0])
    nd = plant.ndof
    if reference.q.shape[1] != nd:
        raise MasterError(f"reference has {reference.q.shape[1]} joints, the plant {nd}")
    x0 = reference.x[0] if x0 is None else np.asarray(x0, float)
    try:
        loop = ClosedLoop(plant, controller, drive=drive, seed=seed, compiled=compiled,
                          noise={"q": q_noise, "qd": qd_noise, "pose": pose_noise})
    except ValueError as e:
        raise MasterError(str(e).replace("noise 'pose'", "pose_noise").replace("noise 'q'", "q_noise")
                          .replace("noise 'qd'", "qd_noise")) from e
    result = _recorder(plant, controller, reference, loop.noise, seed)

    # default: a bar only on a terminal and only once the run has taken two seconds
    bar = tqdm(total=n - 1, unit="step", delay=2.0, disable=None if progress is None else not progress, leave=False,
               desc=f"{plant.kind} {reference.name}".strip())
    try:
        rec = loop.run(reference, x0=x0, xd0=xd0, progress=lambda k: bar.update(k - bar.n), should_stop=should_stop,
                       f_ext=f_ext, started=started)
    except LoopInterrupted as e:
        raise LoopInterrupted(result(e.partial)) from None
    except Exception as e:
        if hasattr(e, "partial"):
            raise MasterError(_stopped(plant, e.loop_time, h, e), result(e.partial)) from e
        if isinstance(e, ValueError):
            raise MasterError(str(e)) from e
        raise
    finally:
        bar.close()
    return result(rec)

