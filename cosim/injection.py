"""Signals injected into the loop: an identification test signal, a PRBS or chirp on the
command, a dither on the reference or on the measured position (docs/recording.md,
"Injected signals").

An :class:`Injection` is a signal ``w`` (one row per sample, one column per joint) and the
point where the rig added it:

=============================  =====================  =============================================
point                          unit of ``w``          what the loop does with it
=============================  =====================  =============================================
``command``                    N or N m               added to the controller's output before its
                                                      saturation (a rig controller in volts:
                                                      ``w / output_gain`` added to ``u``)
``command_after_saturation``   N or N m               the same, after the saturation
``reference``                  m or rad               added to the position reference ``qref``
``measurement``                m or rad               added to the position reading the
                                                      controller sees (the recorded reading is
                                                      the sensor's)
=============================  =====================  =============================================

and, for the command points, whether the recorded effort ``tau`` includes it
(``in_effort``).  The loop itself is the core's (``pkm_ctrl_update_injected``,
``pkm_closed_loop``'s ``inject``): :class:`cosim.closed_loop.ClosedLoop` hands the
signal over; this module checks it, reads it from a recording, and says what it changes in
the recorded effort.

A recording carries it as the columns ``inject<i>`` and the sidecar's ``injection``
object (``{"point": "command", "in_effort": true}``, its unit in ``units.inject``).

Example
-------
>>> import numpy as np
>>> from cosim.injection import Injection
>>> w = np.zeros((1001, 1)); w[200:400] = 5.0 * 212.0      # a 5 V pulse through a 212 N/V drive
>>> inj = Injection(w, point="command", in_effort=True)
>>> inj.point, inj.code
('command', 1)
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .core.controller import INJECT_POINTS, KINDS, CompiledController
from .errors import InjectionError

__all__ = ["Injection", "INJECT_POINTS", "COMMAND_POINTS", "from_recording", "declaration_errors"]

#: the points at which the signal is part of the command (an effort)
COMMAND_POINTS = ("command", "command_after_saturation")


def declaration_errors(decl, *, where: str = "injection") -> str:
    """The first problem of an ``injection`` declaration (a sidecar's or a map's), "" if none."""
    if not isinstance(decl, dict):
        return f"{where} must be a table {{point = ..., in_effort = ...}}, got {decl!r}"
    unknown = set(decl) - {"point", "in_effort", "unit"}
    if unknown:
        return f"{where}: unknown field(s) {sorted(unknown)} (fields: point, in_effort)"
    point = decl.get("point")
    if point not in INJECT_POINTS:
        return f"{where}.point = {point!r} is not one of {', '.join(INJECT_POINTS)}"
    if point in COMMAND_POINTS and not isinstance(decl.get("in_effort"), bool):
        return (f"{where}.in_effort must be true or false for a signal added to the command: does the recorded "
                f"effort include it?")
    if point not in COMMAND_POINTS and decl.get("in_effort") not in (None, False):
        return f"{where}.in_effort is for a signal added to the command; a {point} signal is not in the effort"
    return ""


@dataclass
class Injection:
    """A signal injected into the loop at one point (see the module's docstring).

    Parameters
    ----------
    signal : array_like, shape (n, nd)
        One row per sample of the reference (or recording) [N or N m at a command point,
        m or rad at the reference or the measurement].
    point : str
        ``command``, ``command_after_saturation``, ``reference`` or ``measurement``.
    in_effort : bool
        Command points: the recorded effort includes the signal (the total command was
        logged); False: the controller's output before the signal was added was logged.
    """

    signal: np.ndarray
    point: str = "command"
    in_effort: bool = True

    def __post_init__(self):
        self.signal = np.asarray(self.signal, dtype=float)
        if self.signal.ndim == 1:
            self.signal = self.signal[:, None]
        why = declaration_errors({"point": self.point, "in_effort": self.in_effort if self.point in COMMAND_POINTS
                                  else None})
        if why:
            raise InjectionError(why)

    @property
    def code(self) -> int:
        """``pkm_inject_point`` of the point."""
        return INJECT_POINTS[self.point]

    @property
    def on_command(self) -> bool:
        return self.point in COMMAND_POINTS

    def check(self, n: int, nd: int, time=None) -> None:
        """Refuse a signal that is not (n, nd) or not finite, naming the row (and time) and joint."""
        if self.signal.shape != (n, nd):
            raise InjectionError(f"the injected signal has shape {self.signal.shape}, the run ({n}, {nd}): one row per "
                                 f"sample, one column per joint")
        bad = np.argwhere(~np.isfinite(self.signal))
        if bad.size:
            r, j = (int(v) for v in bad[0])
            at = f" (t = {time[r]:.6g} s)" if time is not None else ""
            raise InjectionError(f"the injected signal at row {r}{at}, joint {j + 1} is {self.signal[r, j]}")

    def bind(self, n_ref: int, nd: int, start: int, n: int, time) -> "_Bound":
        """The signal checked against a run of ``n`` samples from reference row ``start``."""
        self.check(n_ref, nd, time)
        return _Bound(self, np.ascontiguousarray(self.signal[start:start + n]))

    def effort_seen(self, tau_cmd, tau_inj):
        """What the recorded effort of a loop would be: the command with the signal's part
        (``in_effort``) or without it.  Arrays (n, nd) [N or N m]."""
        if self.on_command and not self.in_effort:
            return np.asarray(tau_cmd) - np.asarray(tau_inj)
        return np.asarray(tau_cmd)

    def applied_from_recorded(self, tau_rec):
        """The command reaching the drive from a recorded effort (n, nd): the recorded one
        plus the signal when it was logged without it (the controller's own saturation
        taken as not clipping there)."""
        if self.on_command and not self.in_effort:
            return np.asarray(tau_rec) + self.signal
        return np.asarray(tau_rec)


@dataclass
class _Bound:
    """An injection checked against one run: its rows for the run and for the priming."""

    inj: Injection
    rows: np.ndarray
    #: the compiled copy of a Python controller the core implements, for the stepwise back end
    twin: CompiledController | None = None

    def loop_args(self) -> dict:
        """Keywords of :func:`cosim.core.loop.closed_loop_call`."""
        return {"inject": self.rows, "inject_point": self.inj.code}

    def prime_args(self, samples: range) -> dict:
        """Keywords of :meth:`cosim.core.controller.CompiledController.prime` for reference rows ``samples``."""
        return {"inject": np.ascontiguousarray(self.inj.signal[samples.start:samples.stop]), "point": self.inj.point}

    def refusal(self, ctrl) -> str:
        """Why the stepwise back end cannot inject into ``ctrl`` ("" if it can)."""
        if isinstance(ctrl, CompiledController) or getattr(ctrl, "kind", None) in KINDS:
            return ""  # the core's controller (pkm_ctrl_update_injected), or its compiled copy
        if self.inj.point == "command" and (getattr(ctrl, "saturation", None) is not None
                                            or getattr(ctrl, "limits", None) is not None):
            return (f"a signal injected before the saturation of a Python controller ({type(ctrl).__name__}) cannot "
                    f"be placed: run the loop compiled (the core plant and a controller the core implements)")
        return ""

    def start(self, ctrl, model, h: float, x0) -> None:
        """Before a stepwise run (after the controller's reset): a Python controller the core
        implements gets a compiled copy, reset at the pose ``x0``, which the signal enters
        (the core's law, ``pkm_ctrl_update_injected``; its own period, else ``h``)."""
        self.twin = None
        if not isinstance(ctrl, CompiledController) and getattr(ctrl, "kind", None) in KINDS:
            self.twin = CompiledController(ctrl, model=model, dt=getattr(ctrl, "dt", None) or h)
            self.twin.reset(x0)

    def stepwise(self, ctrl, t, q, qd, row, k):
        """``(tau, tau_inj)`` of one sample of the stepwise back end, the signal of reference row ``k`` injected."""
        w = self.inj.signal[k]
        law = self.twin if self.twin is not None else ctrl
        if isinstance(law, CompiledController):
            return law.update(t, q, qd, row, inject=w, point=self.inj.point)
        # A Python law: the signal is added where the law's inputs or output are (a law
        # without saturation has the same output before and after it).
        if self.inj.point == "reference":
            return np.asarray(ctrl(t, q, qd, dataclasses.replace(row, q=row.q + w)), float), np.zeros_like(w)
        if self.inj.point == "measurement":
            return np.asarray(ctrl(t, q + w, qd, row), float), np.zeros_like(w)
        return np.asarray(ctrl(t, q, qd, row), float) + w, w.copy()


def from_recording(rec) -> Injection | None:
    """The recording's injected signal (columns ``inject<i>`` and the sidecar's
    ``injection``), in the model's joint convention, or None.

    Raises
    ------
    InjectionError
        Columns without a declaration or the reverse, a declaration that is wrong, a
        unit that is not the column's.
    """
    nd = rec.ndof
    names = [f"inject{i}" for i in range(1, nd + 1)]
    have = [n in rec.extra for n in names]
    decl = rec.sidecar.get("injection")
    where = f"{rec.path}" if rec.path is not None else "the recording"
    if not any(have):
        if decl is not None:
            raise InjectionError(f"{where}: the sidecar declares an injection but the table has no inject1..inject{nd} "
                                 f"columns")
        return None
    if not all(have):
        raise InjectionError(f"{where}: inject columns must be given for all joints or none "
                             f"({names[have.index(False)]} is missing)")
    if decl is None:
        raise InjectionError(f'{where}: inject columns without the sidecar\'s "injection" '
                             f'({{"point": ..., "in_effort": ...}}): where was the signal added?')
    why = declaration_errors(decl, where=f"{where}: injection")
    if why:
        raise InjectionError(why)
    from .core.model import robot_facts

    facts = robot_facts(rec.robot)
    want = facts.effort_unit if decl["point"] in COMMAND_POINTS else facts.joint_unit
    unit = (rec.sidecar.get("units") or {}).get("inject", want if rec.path is None else None)
    if unit != want:  # a file states it; a recording made in memory is in the robot's units
        raise InjectionError(f"{where}: units.inject = {unit!r}: a {decl['point']} signal of robot {rec.robot} is "
                             f"in {want}; state it in the sidecar (\"units\": {{\"inject\": \"{want}\"}})")
    sign = np.asarray((rec.joint_convention or {}).get("sign", [1.0] * nd), float)
    w = sign * np.column_stack([np.asarray(rec.extra[n], float) for n in names])
    return Injection(w, point=decl["point"], in_effort=bool(decl.get("in_effort", False)))
