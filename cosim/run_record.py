"""One closed-loop run as a record: :class:`RunRecord`, one row per sample, a unit and one
meaning per field.

Every closed-loop run gives one: :meth:`cosim.closed_loop.ClosedLoop.run` (the loop itself),
:func:`cosim.master.run` (a scenario's run: the same record with its reference, units and
descriptions filled in) and :func:`cosim.discrepancy.runs.closed_loop` (the blind generator's
and the replay's runs).  An error that stops a run (:class:`cosim.errors.MasterError`, the
core's errors raised by the loop, :class:`cosim.closed_loop.LoopInterrupted`) carries the
record of the samples before it in ``partial``.  :meth:`RunRecord.to_recording` makes it a
``pkm-recording/1`` :class:`cosim.recording.Recording`.

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl, trajectories as tr
>>> from cosim.master import CorePlant, make_reference, run
>>> m = Model("6pus")
>>> ref = make_reference(m, tr.step(m.home(), m.home() + [0, 0, 0.01, 0, 0, 0]), duration=0.2)
>>> rec = run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), ref)
>>> rec.tau_applied.shape, rec.units["tau_applied"]
((201, 6), 'N')
>>> rec.to_recording().tau.shape
(201, 6)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["RunRecord", "ROW_FIELDS", "REFERENCE_FIELDS"]

#: the fields with one row per sample, (n, nd) each but ``time`` (n,)
ROW_FIELDS = ("time", "q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd", "tau_applied", "tau_logged", "pose")
#: the reference's fields a run of :func:`cosim.master.run` keeps: (n, nd) each but ``label`` (n,)
REFERENCE_FIELDS = ("qref", "qdref", "xref", "label")


@dataclass
class RunRecord:
    """A closed-loop run, one row per sample (the first ``n`` rows filled while it runs).

    Attributes
    ----------
    time : ndarray, shape (n,)
        Sample times [s].
    q, qd : ndarray, shape (n, nd)
        The joint readings the controller saw [joint unit, per s]: the drive's reading model
        and delay, then the sensor noise.
    q_true, qd_true : ndarray, shape (n, nd)
        The plant's joints [joint unit, per s].
    x, xd : ndarray, shape (n, nd)
        The plant's true pose [m, rad] and its rate [per s].
    tau_cmd : ndarray, shape (n, nd)
        The controller's command [N or N m], held over the following step.
    tau_applied : ndarray, shape (n, nd)
        The effort the drive applied: the command after its saturation [N or N m] (the
        command itself without a drive).
    tau_logged : ndarray, shape (n, nd)
        The command as a rig logs it [N or N m]: ``tau_cmd`` plus the ``tau`` noise (a
        replay of a recording with an injected signal: with or without the signal's part,
        as the recording logs it; :func:`cosim.discrepancy.runs.closed_loop`).
    pose : ndarray, shape (n, nd)
        The pose an external tracker measures: ``x`` plus the ``pose`` noise [m, rad].
    tau_inj : ndarray, shape (n, nd), optional
        The part of ``tau_cmd`` an injected signal makes [N or N m] (zeros without one).
    n : int
        Rows filled.
    loop : str
        Which back end ran: "compiled" (``pkm_closed_loop``) or "python" (sample by sample).
    loop_note : str
        Why the stepwise back end ran ("" for the compiled one).
    saturated : int
        Samples whose command the controller's own saturation clipped.
    wall_time : float
        Wall time of the run [s].
    stopped : bool
        The run ended early because ``should_stop`` said so.
    robot : str
        The plant's robot ("" when the loop ran alone).
    step : float
        The sample period [s] (0 when the loop ran alone).
    units : dict
        The unit of each row field and reference field (filled by :func:`cosim.master.run`).
    qref, qdref, xref, label : ndarray, optional
        The reference at each sample: joints [joint unit, per s], pose [m, rad] and the
        segment tag (:func:`cosim.master.run`; None when the loop ran alone).
    plant, controller, noise : dict
        Descriptions of the plant, the controller and the noise (:func:`cosim.master.run`).
    reference_name : str
        The reference's name.

    ``record["q"]`` is the field ``q`` (row and reference fields), ``len(record)`` the rows.
    """

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_true: np.ndarray
    qd_true: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    tau_cmd: np.ndarray
    tau_applied: np.ndarray
    tau_logged: np.ndarray
    pose: np.ndarray
    tau_inj: np.ndarray | None = None
    n: int = 0
    loop: str = "python"
    loop_note: str = ""
    saturated: int = 0
    wall_time: float = 0.0
    stopped: bool = False
    robot: str = ""
    step: float = 0.0
    units: dict = field(default_factory=dict)
    qref: np.ndarray | None = None
    qdref: np.ndarray | None = None
    xref: np.ndarray | None = None
    label: np.ndarray | None = None
    plant: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)
    noise: dict = field(default_factory=dict)
    reference_name: str = ""

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in ROW_FIELDS + REFERENCE_FIELDS + ("tau_inj",):
            raise KeyError(f"{name!r} is not a field of the run record (fields: "
                           f"{', '.join(ROW_FIELDS + REFERENCE_FIELDS)}, tau_inj)")
        return getattr(self, name)

    def __len__(self) -> int:
        return self.n

    def head(self, k: int | None = None) -> "RunRecord":
        """The first ``k`` rows (default: the filled ones), the other fields as they are."""
        k = self.n if k is None else k
        cut = {f: getattr(self, f)[:k] for f in ROW_FIELDS}
        cut.update({f: None if getattr(self, f) is None else getattr(self, f)[:k]
                    for f in REFERENCE_FIELDS + ("tau_inj",)})
        keep = {f: getattr(self, f) for f in ("loop", "loop_note", "saturated", "wall_time", "stopped", "robot",
                                              "step", "units", "plant", "controller", "noise", "reference_name")}
        return RunRecord(**cut, **keep, n=k)

    def to_recording(self, parameters=None, notes: str = "", *, effort: str = "applied", start: int = 0,
                     robot: str | None = None, qref=None, controller: dict | None = None, extra: dict | None = None):
        """The rows from ``start`` as a ``pkm-recording/1`` :class:`cosim.recording.Recording`.

        Parameters
        ----------
        parameters : dict, optional
            The sidecar's nominal parameter overrides.
        notes : str
            The sidecar's notes.
        effort : {"applied", "logged"}
            The recording's ``tau``: the effort applied (a simulated rig that measures
            it; the commands go in ``tau_cmd<i>`` too when they differ) or the command as
            logged, noise included (a rig that logs its command).
        start : int
            First row.
        robot : str, optional
            The robot (default: the record's).
        qref : array_like, shape (n, nd), optional
            The joint reference, a row per row of the record (default: the record's ``qref``).
        controller : dict, optional
            The sidecar's controller description (default: the record's).
        extra : dict, optional
            Extra columns, name -> (n,) array, a value per row of the record (default: the
            reference's segment ``label`` when the record has one).

        Returns
        -------
        cosim.recording.Recording
            ``q``, ``qd`` the readings, ``tau`` as ``effort`` says, ``pose`` the tracker's.
        """
        from .recording import Recording

        s = slice(start, self.n)
        if effort not in ("applied", "logged"):
            raise ValueError(f"effort must be 'applied' or 'logged', got {effort!r}")
        tau = (self.tau_applied if effort == "applied" else self.tau_logged)[s].copy()
        if extra is not None:
            extra = {k: np.asarray(v)[s] for k, v in extra.items()}
        else:
            extra = {} if self.label is None else {"label": self.label[s].astype(float)}
            if effort == "applied" and np.any(self.tau_cmd[s] != self.tau_applied[s]):  # saturated: keep both
                extra.update({f"tau_cmd{i + 1}": self.tau_cmd[s, i].copy() for i in range(tau.shape[1])})
        qref = self.qref if qref is None else qref
        return Recording(robot=self.robot if robot is None else robot, time=self.time[s].copy(), q=self.q[s].copy(),
                         qd=self.qd[s].copy(), tau=tau, qref=None if qref is None else np.asarray(qref)[s].copy(),
                         pose=self.pose[s].copy(), extra=extra, parameters=dict(parameters or {}),
                         controller=dict(self.controller if controller is None else controller), notes=notes)
