"""What a recording gives the residual pipeline (:mod:`.residuals`), checked: its sampling step,
its joint readings within the model's limits, and the efforts that reached the mechanism.

Each refusal names the file's row (the header is row 1) or, on a working set of blocks, the
time, with what to do (docs/discrepancy.md).
"""
from __future__ import annotations

import numpy as np

from ..errors import DiagnosisError


def check_joint_limits(model, t, q, where, whole=True):
    """Refuse recorded joint positions outside the model's joint limits (a continuous joint
    has none, but its angle must be unwrapped: no jump of more than pi between samples),
    naming the first row (as the file counts it: the header is row 1; on a working
    set of blocks, the time alone), the time, the value and what to do."""
    lo, hi = model.joint_limits()
    for j in range(model.ndof):
        jump = np.flatnonzero(np.abs(np.diff(q[:, j])) > np.pi) if model.joint_unit == "rad" else []
        if len(jump) and np.isnan(lo[j]) and np.isnan(hi[j]):
            k = int(jump[0]) + 1
            at = f"row {k + 2} (t = {t[k]:.6g} s)" if whole else f"t = {t[k]:.6g} s"
            raise DiagnosisError(f"{where}: {at}: q{j + 1} of the continuous joint {j + 1} jumps by "
                                 f"{q[k, j] - q[k - 1, j]:.6g} rad in one sample ({len(jump)} jumps in all): a "
                                 f"wrapped angle; the toolkit's is unwrapped (import it with angle = \"unwrap\", "
                                 f"docs/importing.md)")
        out = np.flatnonzero((q[:, j] < lo[j]) | (q[:, j] > hi[j]))
        if out.size:
            k = int(out[0])
            unit = model.joint_unit
            at = f"row {k + 2} (t = {t[k]:.6g} s)" if whole else f"t = {t[k]:.6g} s"
            hint = ("declare the joint continuous (continuous = true, docs/robots.md) if it turns without limit, or "
                    "check the import map's unit, scale, offset or angle wrapping" if unit == "rad" else
                    "check the import map's unit, scale and offset, or the robot's stroke")
            raise DiagnosisError(f"{where}: {at}: joint {j + 1} q{j + 1} = {q[k, j]:.6g} {unit} is outside its "
                                 f"limits [{lo[j]:.6g}, {hi[j]:.6g}] {unit} ({out.size} rows outside in all); {hint}")


def uniform_step(t, segments, where, whole) -> float:
    """The sampling step [s] of the stretches ``segments`` ([start, stop) rows of ``t``),
    refusing a step more than 1 % off it (naming the rows, or the time on a working set of
    blocks: ``whole`` False)."""
    n = len(t)
    dt = (sum(t[b - 1] - t[a] for a, b in segments)
          / max(sum(b - a - 1 for a, b in segments), 1))
    inside = np.ones(n - 1, bool)
    inside[[a - 1 for a, _ in segments[1:]]] = False  # the jumps between stretches
    dev = np.where(inside, np.abs(np.diff(t) - dt), 0.0)
    if dev.max() > 0.01 * dt:
        k = int(np.argmax(dev))
        at = (f"rows {k + 2}-{k + 3}" if whole else f"t = {t[k]:.6g} s")
        raise DiagnosisError(f"{where}: the sampling is not uniform ({at}: step "
                             f"{t[k + 1] - t[k]:.6g} s, mean {dt:.6g} s); resample it to a constant step")
    return dt


def applied_efforts(rec, n, nd, zoh, where):
    """``(tau_c, f_ext)``: the command that reached the drives and the measured external
    effort per joint (None without f_ext columns), (n, nd) each, as the mean of the held values
    on both sides of a sample when ``zoh``."""
    tau = np.asarray(rec.tau, float)
    # A test signal added to the command and logged without it (cosim.injection) reached
    # the drive all the same: the command is the recorded one plus it.
    from ..injection import from_recording

    injected = from_recording(rec)
    if injected is not None:
        tau = injected.applied_from_recorded(tau)
    if zoh:
        tau = np.vstack([tau[:1], 0.5 * (tau[1:] + tau[:-1])])
    # A measured external effort per joint (f_ext columns) is a known input: the mechanism
    # feels the actuator's effort plus it, so it joins the effort side of the residual,
    # sampled and smoothed like the effort (never left for the engine to explain).
    f_ext = getattr(rec, "f_ext", None)
    if f_ext is not None:
        f_ext = np.asarray(f_ext, float)
        if f_ext.shape != (n, nd):
            raise DiagnosisError(f"{where}: f_ext has shape {f_ext.shape}, the recording ({n}, {nd})")
        if zoh:
            f_ext = np.vstack([f_ext[:1], 0.5 * (f_ext[1:] + f_ext[:-1])])
    return tau, f_ext
