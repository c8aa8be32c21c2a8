"""The closed loop: one definition of the sampled sequence plant - sensors - controller.

:class:`ClosedLoop` runs a plant and a controller over a reference table.  At each
sample ``t_k`` (``k = 0 .. n-1``):

1. the sensors read the plant: its joints through the drive's reading model
   (:class:`cosim.plants.CoreDrive`: encoder offset, backlash, compliance under the
   effort acting on the mechanism, a drive body's encoder) when a drive is given, then
   the readings' delay (``sensor.delay``), then the white noise on ``q`` and ``qd``;
2. the controller gives the command ``tau_cmd`` from the readings and reference row k;
3. the row is recorded: readings, true joints and pose, command, applied effort (the
   drive's saturation), the command as logged (plus ``tau`` noise) and the tracker's
   pose (plus ``pose`` noise);
   A signal injected into the loop (``inject``, :mod:`cosim.injection`) is added at
   its point: to the controller's output before or after its saturation, to the
   reference, or to the position reading the controller sees (the recorded reading
   stays the sensor's); ``RunRecord.tau_inj`` is the part of the command it makes;
4. the plant holds the command (saturation and ``actuator.delay`` are the plant's: the
   core keeps the delay line) and, if given, the known external effort of the sample
   (``f_ext``, added to the actuator effort), and advances to ``t_k + h`` (not after
   the last sample).

The noise is drawn once, before the run, in one block of shape (n, g nd) with the groups
``q, qd, tau, pose`` in that order (only those with a non-zero standard deviation), so
that both back ends see the same numbers.

Two back ends run the sequence:

* **compiled**: the core's ``pkm_closed_loop`` on a :class:`~cosim.plants.CorePlant`
  with a controller the core implements (``pkm_ctrl``: PD, PD + gravity, computed
  torque, PID, LTI, the discrete rig controller), in pieces of about 20 ms of wall time
  (the loop goes on exactly across pieces);
* **stepwise**: any :class:`~cosim.plants.Plant` (the core plant or an FMU), one sample
  at a time: a controller the core implements through its compiled copy
  (:class:`~cosim.core.CompiledController`, the same ``pkm_ctrl``), any other Python
  callable as it is; the readings' delay is the core's line (``pkm_reading_delay``).

By default the compiled back end runs whenever it can; ``RunRecord.loop_note`` says why
it did not.  :func:`cosim.master.run` (scenarios, sweeps) and the discrepancy replay and
blind generator (:func:`cosim.discrepancy.runs.closed_loop`) are this loop; each run gives
one :class:`cosim.run_record.RunRecord`.

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl, trajectories as tr
>>> from cosim.master import make_reference
>>> from cosim.plants import CoreDrive, CorePlant
>>> from cosim.closed_loop import ClosedLoop
>>> m = Model("6pus")
>>> ref = make_reference(m, tr.step(m.home(), m.home() + [0, 0, 0.01, 0, 0, 0]), duration=0.5)
>>> rec = ClosedLoop(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), drive=CoreDrive(m),
...                  noise={"q": 1e-6}, seed=1).run(ref)
>>> rec.loop, rec.q.shape
('compiled', (501, 6))
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass

import numpy as np

from ._native import STATUS, raise_for
# The controller's handle and the loop's C call live in the binding (cosim.core owns every
# foreign call); this module chains the calls and records.
from .core.controller import KINDS, CompiledController
from .core.loop import LOOP_FIELDS, closed_loop_call
from .plants import CoreDrive, CorePlant, _facts
from .errors import InputError, LoopInterrupted
from .run_record import RunRecord

__all__ = ["ClosedLoop", "RunRecord", "LoopInterrupted", "CompiledController", "compile_controller", "KINDS",
           "NOISE_CHANNELS"]

#: the noise channels, in the order of their draws
NOISE_CHANNELS = ("q", "qd", "tau", "pose")

#: wall time of one piece of the compiled loop [s]: how long a stop request may wait
PIECE_SECONDS = 0.02


def compile_controller(controller, *, model, dt: float):
    """``(CompiledController, "")`` for a controller the core implements, else ``(None, reason)``."""
    kind = getattr(controller, "kind", None)
    if kind not in KINDS:
        return None, (f"the controller ({type(controller).__name__}) is a Python callable the core does not "
                      f"implement (compiled kinds: {', '.join(KINDS)})")
    try:
        return CompiledController(controller, model=model, dt=dt), ""
    except ValueError as e:
        return None, str(e)


@dataclass(frozen=True)
class _Run:
    """What a back end needs of one run: the samples' times ``t`` [s] and period ``h`` [s],
    the reference rows ``ref``, the record ``rec`` it fills (its arrays are ``rows``), the
    noise ``draws``, the initial state ``x0``, ``xd0``, the callbacks, the external effort
    ``f_ext``, the ``past`` readings to prime the controller with and the bound ``inject``."""

    t: np.ndarray
    h: float
    ref: dict
    rows: dict
    draws: dict
    rec: RunRecord
    x0: np.ndarray
    xd0: object = None
    progress: object = None
    should_stop: object = None
    f_ext: object = None
    past: object = None
    inject: object = None
    reference: object = None
    start: int = 0


class ClosedLoop:
    """A plant, its sensors, a controller and the recorder, sampled at the reference's step.

    Parameters
    ----------
    plant : cosim.plants.Plant
        :class:`~cosim.plants.CorePlant` or :class:`~cosim.plants.FMUPlant` (or any object
        with that interface).
    controller : callable
        ``controller(t, q, qd, ref) -> tau`` (:mod:`cosim.controllers`), or a controller
        the core implements (then the compiled back end can run it).
    drive : cosim.plants.CoreDrive, optional
        The plant's drive and sensor model: readings through its reading model and delay,
        ``tau_applied`` the effort it applies.  Without it the readings are the plant's joints
        and ``tau_applied`` the command.
    noise : dict, optional
        Standard deviations of white noise, scalars or per joint/coordinate: ``q`` [m or
        rad] and ``qd`` [per s] on the readings the controller sees, ``tau`` [N or N m] on
        the logged command (not the applied one), ``pose`` [m, rad] on the tracker.
    seed : int, optional
        Seed of the noise generator.
    compiled : bool, optional
        None (default): the compiled back end whenever it can; True: raise
        ``ValueError`` if it cannot; False: the stepwise back end.

    Example
    -------
    See the module's docstring.
    """

    def __init__(self, plant, controller, *, drive=None, noise: dict | None = None, seed: int | None = 0,
                 compiled: bool | None = None):
        self.plant = plant
        self.controller = controller
        self.drive = drive
        nd = plant.ndof
        self.ndof = nd
        self.noise = {}
        for k in NOISE_CHANNELS:
            s = np.broadcast_to(np.asarray((noise or {}).get(k, 0.0), float), (nd,))
            if np.any(~np.isfinite(s)) or np.any(s < 0):
                raise InputError(f"noise {k!r} must be standard deviations >= 0, got {s.tolist()}")
            self.noise[k] = s
        unknown = set(noise or {}) - set(NOISE_CHANNELS)
        if unknown:
            raise InputError(f"noise: unknown channel(s) {sorted(unknown)} (channels: {', '.join(NOISE_CHANNELS)})")
        self.seed = seed
        self.compiled = compiled

    # ---------------------------------------------------------------- helpers
    def _draws(self, n):
        """The noise of every sample, drawn once: {channel: (n, nd)}."""
        nd = self.ndof
        groups = [k for k in NOISE_CHANNELS if np.any(self.noise[k])]
        rng = np.random.default_rng(self.seed)
        z = rng.normal(0.0, 1.0, (n, len(groups) * nd)) if groups else np.zeros((n, 0))
        return {k: z[:, i * nd:(i + 1) * nd] * self.noise[k] for i, k in enumerate(groups)}

    def _compiled_controller(self, h):
        """``(CompiledController, "")`` when the compiled back end can run, else ``(None, reason)``."""
        if self.compiled is False:
            return None, "compiled=False"
        plant, drive = self.plant, self.drive
        if not isinstance(plant, CorePlant):
            return None, f"the plant ({type(plant).__name__}) is not the core plant, the only one that runs compiled"
        if drive is not None and not (isinstance(drive, CoreDrive) and drive.model.params() == plant.model.params()):
            return None, "the drive's model is not the plant's"
        return compile_controller(self.controller, model=plant.model, dt=h)

    def _stepwise_law(self, h):
        """What the stepwise back end calls each sample: the compiled copy of a controller
        the core implements (on its own model, else the plant's or the drive's), else the
        controller itself (a Python callable, or one whose copy cannot be built here)."""
        if getattr(self.controller, "kind", None) not in KINDS:
            return self.controller
        model = next((m for m in (getattr(o, "model", None) for o in (self.controller, self.plant, self.drive))
                      if m is not None), None)
        robot = getattr(self.plant, "robot", None)
        if model is None and isinstance(robot, str) and _facts(robot) is not None:
            from .core.model import Model

            model = Model(self.plant.robot)
        cc, _ = compile_controller(self.controller, model=model, dt=h) if model is not None else (None, "")
        return cc if cc is not None else self.controller

    # -------------------------------------------------------------------- run
    def run(self, reference, *, start: int = 0, x0=None, xd0=None, progress=None, should_stop=None,
            f_ext=None, history=None, started=None, inject=None) -> RunRecord:
        """Run over the reference samples ``start:``.

        Parameters
        ----------
        reference : cosim.master.ReferenceTable
            ``time`` (its spacing is the sample period), ``q``, ``qd`` and optionally
            ``qdd`` and the pose ``x``.
        start : int
            First reference sample of the run.
        x0, xd0 : array_like, shape (nd,), optional
            Initial true pose [m, rad] and rate (default: the reference pose of sample
            ``start``, or the forward kinematics of its joints, at rest).
        progress : callable, optional
            ``progress(k)`` with the samples done, after each piece (compiled) or sample.
        should_stop : callable, optional
            ``should_stop() -> bool``, asked between pieces (compiled: about every 20 ms)
            or samples (stepwise); True ends the run there with the rows so far
            (``RunRecord.stopped``).
        f_ext : array_like, shape (len(reference.time), nd), optional
            A known external effort per joint at every reference sample [N or N m],
            positive along +q (e.g. a recording's measured force, ``Recording.f_ext``):
            the plant adds it to the actuator effort over the step after each sample,
            like the command (no saturation, no delay).
        history : tuple of array_like, optional
            ``(q, qd)``, each (m, nd): the readings of the m samples before ``start``
            (``m <= start``, oldest first), e.g. a recording's.  After its reset the
            controller is fed them with the reference rows ``start - m .. start - 1``
            (outputs discarded; ``CompiledController.prime``, ``pkm_ctrl_prime``), so that
            its filters, differences, integrators and computation delay start where the
            controller that saw them was, not at rest.  The plant's own delay lines
            (``actuator.delay``, ``sensor.delay``) start from the state ``x0``, ``xd0``.
        started : callable, optional
            ``started()``, called once when the set-up is done, right before the first
            step (the CLI gives ctrl-C back to the loop there).
        inject : cosim.injection.Injection, optional
            A signal injected into the loop, a row per reference sample, at its point
            (the controller's output before or after its saturation [N or N m], the
            reference or the position reading [m or rad]); its rows before ``start`` go
            into the ``history``'s priming too.  The stepwise back end gives it to a
            controller the core implements through a compiled copy of it (the core's
            ``pkm_ctrl_update_injected``); a Python law with its own saturation cannot
            take one before that saturation (``InputError``).

        Returns
        -------
        cosim.run_record.RunRecord
            The rows of the run (``robot``, ``step``, the reference and the descriptions
            are :func:`cosim.master.run`'s to fill).

        Raises
        ------
        Exception
            The plant's or the controller's error (the core's classes for the core's
            failures), with ``partial`` (the :class:`~cosim.run_record.RunRecord` of the rows before the
            failing sample) and ``loop_time`` (that sample's time [s]) attached.
        LoopInterrupted
            On ctrl-C, with ``partial``.
        """
        t = np.ascontiguousarray(reference.time[start:], dtype=float)
        n, nd = len(t), self.ndof
        if n < 2:
            raise InputError("the reference needs at least two samples")
        h = float(t[1] - t[0])
        if reference.q.shape[1] != nd:
            raise InputError(f"the reference has {reference.q.shape[1]} joints, the plant {nd}")
        if x0 is None:
            x0 = reference.x[start] if getattr(reference, "x", None) is not None \
                else self.plant.model.fk(reference.q[start])
        x0 = np.asarray(x0, float)
        rows = {f: np.full((n, nd), np.nan) for f in ("q", "qd", "q_true", "qd_true", "x", "xd", "tau_cmd",
                                                       "tau_applied", "tau_logged", "pose", "tau_inj")}
        draws = self._draws(n)
        f_ext = None if f_ext is None else self._f_ext_rows(f_ext, reference, start, t)
        past = self._history(reference, start, history)
        inj = None if inject is None else inject.bind(len(reference.time), nd, start, n, reference.time)
        rec = RunRecord(time=t, **rows)
        cc, rec.loop_note = self._compiled_controller(h)
        if self.compiled and cc is None:
            raise ValueError(f"the loop cannot run compiled: {rec.loop_note}")
        rec.loop = "compiled" if cc is not None else "python"
        if cc is None and inj is not None and inj.refusal(self.controller):
            raise InputError(inj.refusal(self.controller))
        ref = {k: (None if getattr(reference, k, None) is None
                   else np.ascontiguousarray(getattr(reference, k)[start:start + n], dtype=float))
               for k in ("q", "qd", "qdd", "x")}
        if started is not None:
            started()
        run = _Run(t=t, h=h, ref=ref, rows=rows, draws=draws, rec=rec, x0=x0, xd0=xd0, progress=progress,
                   should_stop=should_stop, f_ext=f_ext, past=past, inject=inj, reference=reference, start=start)
        return self._execute(cc, run)

    def _execute(self, cc, run: _Run) -> RunRecord:
        """The back end's run, timed and finished: the record of the rows (the failure
        raised with the rows before it as ``partial``)."""
        t, h, draws, rec, n = run.t, run.h, run.draws, run.rec, len(run.t)
        wall0 = _time.perf_counter()
        failure, law = None, None
        try:
            if cc is not None:
                failure = self._compiled(cc, run)
            else:
                law = self._stepwise_law(h)
                failure = self._stepwise(law, run)
        except KeyboardInterrupt:
            self._finish(rec, draws, wall0, cc or law)
            raise LoopInterrupted(rec.head()) from None
        self._finish(rec, draws, wall0, cc or law)
        if failure is not None:
            exc, k = failure
            exc.partial = rec.head()
            exc.loop_time = float(t[min(k, n - 1)])
            raise exc
        return rec.head() if rec.n < n else rec

    def _f_ext_rows(self, f_ext, reference, start, t):
        """``f_ext`` checked: its rows of the run's samples, C-contiguous (n, nd) [N or N m]."""
        n, nd = len(t), self.ndof
        f_ext = np.asarray(f_ext, float)
        if f_ext.ndim != 2 or f_ext.shape[1] != nd or f_ext.shape[0] < start + n:
            raise InputError(f"f_ext must have shape ({len(reference.time)}, {nd}) (a row per reference sample), "
                             f"got {f_ext.shape}")
        f_ext = np.ascontiguousarray(f_ext[start:start + n])
        bad = np.argwhere(~np.isfinite(f_ext))
        if bad.size:
            raise InputError(f"f_ext: row {start + bad[0][0]} (t = {t[bad[0][0]]:.6g} s), joint {bad[0][1] + 1} is "
                             f"{f_ext[tuple(bad[0])]}")
        if not hasattr(self.plant, "set_external"):
            raise InputError(f"the plant ({type(self.plant).__name__}) takes no external effort (f_ext)")
        return f_ext

    def _finish(self, rec, draws, wall0, law):
        k = rec.n
        rec.wall_time = _time.perf_counter() - wall0
        rec.tau_logged[:k] = rec.tau_cmd[:k] + (draws["tau"][:k] if "tau" in draws else 0.0)
        rec.pose[:k] = rec.x[:k] + (draws["pose"][:k] if "pose" in draws else 0.0)
        if isinstance(law, CompiledController):
            rec.saturated = law.saturated  # the run's own samples (prime keeps the count)
        else:
            rec.saturated = rec.saturated + getattr(law, "saturated", 0)

    def _history(self, reference, start, history):
        """``history`` checked: ``(rows, t, q, qd, ref)`` of the samples before ``start``, or None."""
        if history is None:
            return None
        try:
            q, qd = (np.ascontiguousarray(v, dtype=float) for v in history)
        except (TypeError, ValueError):
            raise InputError("history must be (q, qd), the readings before start, each (m, nd)") from None
        m, nd = (q.shape + (0,))[:2] if q.ndim == 2 else (-1, -1)
        if q.ndim != 2 or q.shape != qd.shape or nd != self.ndof or not 0 < m <= start:
            raise InputError(f"history: q and qd must both have shape (m, {self.ndof}) with 0 < m <= start = {start}, "
                             f"got {q.shape} and {qd.shape}")
        for name, v in (("q", q), ("qd", qd)):
            bad = np.argwhere(~np.isfinite(v))
            if bad.size:
                k = start - m + int(bad[0][0])
                raise InputError(f"history: {name} of sample {k} (t = {reference.time[k]:.6g} s), joint "
                                 f"{bad[0][1] + 1} is {v[tuple(bad[0])]}")
        s = slice(start - m, start)
        ref = {k: (None if getattr(reference, k, None) is None else np.ascontiguousarray(getattr(reference, k)[s]))
               for k in ("q", "qd", "qdd", "x")}
        return range(start - m, start), np.ascontiguousarray(reference.time[s], dtype=float), q, qd, ref

    # ------------------------------------------------------------ back ends
    def _compiled(self, cc, run: _Run):
        """``pkm_closed_loop`` in pieces of about :data:`PIECE_SECONDS`; returns None or
        ``(exception, sample)``."""
        t, h, ref, rows, draws, x0, xd0, rec = run.t, run.h, run.ref, run.rows, run.draws, run.x0, run.xd0, run.rec
        progress, should_stop, f_ext, past, inject = run.progress, run.should_stop, run.f_ext, run.past, run.inject
        n = len(t)
        plant = self.plant
        try:
            plant.initialize(float(t[0]), x0, xd0)
            cc.reset(plant.outputs().x)
            if past is not None:
                cc.prime(*past[1:], **({} if inject is None else inject.prime_args(past[0])))
        except Exception as e:  # noqa: BLE001 - reported as the loop's failure at sample 0
            return e, 0
        sim = plant.sim
        qn, qdn = draws.get("q"), draws.get("qd")
        qn = None if qn is None else np.ascontiguousarray(qn)
        qdn = None if qdn is None else np.ascontiguousarray(qdn)
        k0, piece = 0, 64
        while k0 < n:
            k1 = min(n, k0 + piece)
            # A piece ends on a recorded sample the plant has not advanced from: the next
            # piece starts at its successor after the advance below.
            before = None if k0 == 0 else rows["tau_applied"][k0 - 1]
            w = _time.perf_counter()
            st, done, message = closed_loop_call(sim, cc, t=t, dt=h, ref=ref, rows=rows, k0=k0, k1=k1,
                                                 tau_before=before, q_noise=qn, qd_noise=qdn,
                                                 measure=self.drive is not None, f_ext=f_ext,
                                                 **({} if inject is None else inject.loop_args()))
            rec.n = k0 + done
            if st != 0:
                return _core_error(st, message), rec.n
            if k1 == n:
                break
            sim.set_input(rows["tau_cmd"][k1 - 1])
            if f_ext is not None:
                sim.set_external(f_ext[k1 - 1])
            try:
                sim.advance(float(t[k1 - 1]) + h)
            except Exception as e:  # noqa: BLE001 - the loop's failure at this sample
                rec.n = k1 - 1
                e.args = (f"closed loop stopped at sample {k1 - 1} (t = {t[k1 - 1]:.6g} s): {e}",)
                return e, k1 - 1
            k0 = k1
            spent = _time.perf_counter() - w
            piece = int(min(max(16, piece * PIECE_SECONDS / max(spent, 1e-6)), 2 * piece, 100000))
            if progress is not None:
                progress(k0)
            if should_stop is not None and should_stop():
                rec.stopped = True
                # the last sample of the piece was recorded and advanced from: keep it
                break
        return None

    def _stepwise(self, ctrl, run: _Run):
        """One sample at a time through the Plant interface, ``ctrl`` the compiled copy of
        the controller (or the Python callable); returns None or ``(exception, sample)``."""
        t, h, rows, draws, x0, xd0, rec = run.t, run.h, run.rows, run.draws, run.x0, run.xd0, run.rec
        progress, should_stop, f_ext, past, inject = run.progress, run.should_stop, run.f_ext, run.past, run.inject
        reference, start = run.reference, run.start
        n = len(t)
        plant, drive = self.plant, self.drive
        compiled = isinstance(ctrl, CompiledController)
        k = 0
        try:
            plant.initialize(float(t[0]), x0, xd0)
            y = plant.outputs()
            if compiled:
                ctrl.reset(y.x)
            elif hasattr(ctrl, "reset"):
                ctrl.reset(float(t[0]), y.q, y.x)
            if inject is not None:
                inject.start(ctrl, getattr(plant, "model", None), h, y.x)
            if past is not None and compiled:
                ctrl.prime(*past[1:], **({} if inject is None else inject.prime_args(past[0])))
            elif past is not None:
                for j, k in enumerate(past[0]):
                    _law(ctrl, float(past[1][j]), past[2][j], past[3][j], reference.at(k), inject, k)
                # the run counts its own saturated samples only
                rec.saturated = -int(getattr(ctrl, "saturated", 0))
            if drive is not None:
                drive.reset_delay()
            acting_of = getattr(plant, "applied_effort", None)  # the core keeps the actuator delay line
            acting = np.zeros(self.ndof)
            for k in range(n):
                if drive is not None:
                    if acting_of is not None:
                        acting = acting_of()
                    q_read, qd_read = drive.read(y, acting)
                    q_read, qd_read = drive.delayed(float(t[k]), q_read, qd_read)
                else:
                    q_read, qd_read = y.q, y.qd
                qm = q_read + draws["q"][k] if "q" in draws else q_read
                qdm = qd_read + draws["qd"][k] if "qd" in draws else qd_read
                tau, rows["tau_inj"][k] = _law(ctrl, float(t[k]), qm, qdm, reference.at(start + k), inject, start + k)
                applied = drive.applied(tau) if drive is not None else tau
                rows["q"][k], rows["qd"][k], rows["q_true"][k], rows["qd_true"][k] = qm, qdm, y.q, y.qd
                rows["x"][k], rows["xd"][k] = y.x, y.xd
                rows["tau_cmd"][k], rows["tau_applied"][k] = tau, applied
                rec.n = k + 1
                if k == n - 1:
                    break
                acting = applied
                if f_ext is not None:
                    plant.set_external(f_ext[k])
                plant.set_input(tau)
                plant.do_step(float(t[k]), h)
                y = plant.outputs()
                if progress is not None:
                    progress(k + 1)
                if should_stop is not None and should_stop():
                    rec.stopped = True
                    break
        except Exception as e:  # noqa: BLE001 - reported with the rows so far
            rec.n = min(rec.n, k)
            return e, k
        return None


def _law(ctrl, t, q, qd, row, inject, k):
    """The controller's command at one sample and the part an injected signal makes of it."""
    if inject is None:
        tau = np.asarray(ctrl(t, q, qd, row), float)
        return tau, np.zeros_like(tau)
    return inject.stepwise(ctrl, t, q, qd, row, k)


def _core_error(status: int, message: str) -> Exception:
    """The core's exception for a loop failure (its class from the status)."""
    try:
        raise_for(status, message)
    except Exception as e:  # noqa: BLE001 - built to be returned
        return e
    name = STATUS.get(status, ("PKM_ERR_UNKNOWN", None))[0]
    return RuntimeError(f"{name}: {message}")
