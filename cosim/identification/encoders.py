"""Gear elasticity and backlash from a motor-side and a link-side encoder (:func:`drive_elasticity`).

A joint read on both sides of its transmission (the motor encoder's angle divided by the gear
ratio, and a secondary encoder on the link) shows the gear's twist: the motor side leads the link
side by the transmitted effort over the stiffness, plus half the backlash with the effort's sign.
That is the core's sensor model of the drive layer (``joint[i].compliance``: deflection per unit
effort, ``joint[i].backlash``: the reading +- gap / 2 by the sign of the transmitted effort;
``Model.measure_joints``), so the fit takes its columns from the core by linearity: the change of
``measure_joints`` per unit of each parameter, at the link-side positions and the transmitted
effort (on a working copy with the drive's friction and rotor inertia off: ``measure_joints``
otherwise takes the effort it is given as the motor's and takes their share off it itself).
The effort is referred to the link side (N m at the joint, as ``tau`` of a recording); a
recorded motor effort is first made the transmitted one by taking off the drive layer's own
share (rotor inertia, friction, offset of the model: ``Model.add_drive_efforts`` at the motor
side's motion).

Example
-------
>>> from cosim.identification.encoders import drive_elasticity
>>> est = drive_elasticity(model, time, q_motor, q_link, qd_motor, tau, joints=[1, 2, 3])  # doctest: +SKIP
>>> est[0]["stiffness"], est[0]["backlash"]  # doctest: +SKIP
"""
from __future__ import annotations

import numpy as np
import scipy.signal

from ..errors import InputError

_STEPS = (("compliance", 1e-6), ("backlash", 1e-3))


def _check(name, a, shape):
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise InputError(f"{name} has shape {a.shape}, expected {shape}")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        raise InputError(f"{name} row {bad[0][0] + 1}, joint {bad[0][1] + 1} is not a finite number")
    return a


def _effort_terms_off(model, pre, nd) -> dict:
    """The work copy's sensor terms, the drive's effort terms and rotor inertia set to zero:
    ``measure_joints`` takes the effort it is given as the motor's and deflects the reading by it
    less the drive's friction and the rotor's share of the acceleration, so with those off the
    effort it sees is the transmitted one given to it."""
    names = set(model.param_names())
    out = {}
    for j in range(1, nd + 1):
        for p in ("compliance", "backlash", "encoder_offset", "coulomb", "viscous", "stribeck", "offset", "dead_zone",
                  "rotor_inertia"):
            out[f"{pre}[{j}].{p}"] = 0.0
        for n in names:
            if n.startswith(f"{pre}[{j}].force_") and not n.endswith(("_qc", "_q", "_w", "_period", "_phase", "_v")):
                out[n] = 0.0
    return {k: v for k, v in out.items() if k in names}


def drive_elasticity(model, time, q_motor, q_link, qd_motor, tau, *, joints=None, effort: str = "transmitted",
                     cutoff: float | None = None, design: bool = False) -> list[dict]:
    """Stiffness and backlash of each joint's transmission from its two encoders.

    Parameters
    ----------
    model : cosim.core.Model
        The robot (its drive layer gives the rotor inertia and friction when ``effort="motor"``).
    time : array_like (n,)
        Sample times [s].
    q_motor, q_link : array_like (n, nd)
        Motor-side position in joint units (the motor angle over the gear ratio) and link-side
        position [rad or m].
    qd_motor : array_like (n, nd)
        The motor side's rate in joint units [rad/s or m/s].
    tau : array_like (n, nd)
        Effort referred to the link side [N m or N]: the transmitted one (``effort="transmitted"``)
        or the motor's (``effort="motor"``, gear ratio x motor torque).
    joints : list of int, optional
        Joints (from 1) read on both sides (default all).
    effort : {"transmitted", "motor"}
    cutoff : float, optional
        Zero-phase low-pass of the encoders' difference and the effort [Hz] (default none).
    design : bool
        Also return the fit's columns and residual (below).

    Returns
    -------
    list of dict, one per joint in ``joints``
        ``joint``, ``stiffness`` [N m/rad or N/m] (1 / compliance), ``compliance`` and its ``se``,
        ``backlash`` [rad or m] and its ``se``, ``offset`` (the encoders' relative zero),
        ``rms_difference`` and ``rms_residual`` [rad or m], ``effort_side`` ("link"); the ``se``
        are those of independent residuals.  With ``design``: ``columns`` (n, 3), the fit's columns
        (compliance, backlash, offset) and ``residual`` (n,), for a covariance that allows for the
        residual's serial correlation (``cosim.discrepancy.encoders_step``).
    """
    t = np.asarray(time, dtype=float)
    nd = model.ndof
    shape = (t.size, nd)
    qm, ql, qdm, tau = (_check(n, a, shape) for n, a in
                        (("q_motor", q_motor), ("q_link", q_link), ("qd_motor", qd_motor), ("tau", tau)))
    if effort not in ("transmitted", "motor"):
        raise InputError(f"effort must be 'transmitted' or 'motor', got {effort!r}")
    if effort == "motor":  # the drive layer's own share at the motor side's motion, taken off
        qddm = np.gradient(qdm, t, axis=0)
        tau = tau - model.add_drive_efforts(qm, qdm, qddm, np.zeros(shape))
    diff = qm - ql
    if cutoff:
        b, a = scipy.signal.butter(4, cutoff / (0.5 / float(np.median(np.diff(t)))))
        diff, tau = (scipy.signal.filtfilt(b, a, x, axis=0) for x in (diff, tau))
    work, pre = model.copy(), model.facts.joint_prefix  # joint, axis, leg, ...
    work.set_params(_effort_terms_off(work, pre, nd))
    base = work.measure_joints(ql, qdm, tau)
    out = []
    for j in joints or range(1, nd + 1):
        if not 1 <= j <= nd:
            raise InputError(f"joint {j}: the robot has joints 1 to {nd}")
        cols = []
        for p, step in _STEPS:
            w = work.copy()
            w.set_params({f"{pre}[{j}].{p}": step})
            cols.append((w.measure_joints(ql, qdm, tau)[:, j - 1] - base[:, j - 1]) / step)
        A = np.column_stack(cols + [np.ones(t.size)])
        y = diff[:, j - 1]
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        res = y - A @ coef
        cov = np.sum(res ** 2) / max(t.size - 3, 1) * np.linalg.inv(A.T @ A)
        se = np.sqrt(np.diag(cov))
        out.append({"joint": j, "compliance": float(coef[0]), "compliance_se": float(se[0]),
                    "stiffness": float(1.0 / coef[0]) if coef[0] > 0 else float("inf"),
                    "backlash": float(coef[1]), "backlash_se": float(se[1]), "offset": float(coef[2]),
                    "rms_difference": float(np.std(y)), "rms_residual": float(np.sqrt(np.mean(res ** 2))),
                    "effort_side": "link"})
        if design:
            out[-1].update(columns=A, residual=res)
    return out
