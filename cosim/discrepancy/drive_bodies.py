"""A fitted backlash or compliance replayed as the physics it is: two bodies.

The selection fits a gap or a transmission compliance with the core's reading models (the
encoder reads the carriage shifted by half the gap on the side the carried effort pushes
to, plus the deflection).  In closed loop those readings are not the motion of a drive that
has to cross its gap: the core's two-body drive (``drive.two_body = 1``, docs/integration.md:
drive body with the rotor inertia and the command, carriage, dead-band spring) is.  This
module fits what the two bodies add to the reading models, the spring's damping and, for a
gap without a fitted compliance, the stiffness of its faces, on a window of the *fitted*
part of the recording by closed-loop replays on a small grid; the diagnosis then replays
the held-out part with them (``Diagnosis.replay["two_body"]``).
"""
from __future__ import annotations

import itertools
import math
import re

import numpy as np

from ..master import ReferenceTable

#: damping ratios of the drive body on its spring tried, a factor 3 apart (a first grid had
#: 0.3, the value of the MuJoCo recordings this is checked on; it is not a grid point now)
DAMPING_RATIOS = (0.05, 0.15, 0.5, 1.5)
#: a gap's faces: their deflection under the joint's RMS effort as a fraction of the gap
FACE_DEFLECTIONS = (1 / 10, 1 / 30, 1 / 100)
#: length of the fitting window at the end of the fitted part [s]
WINDOW = 1.0

_JOINT = re.compile(r"^(.+\[(\d+)\])\.(backlash|compliance)$")


def drive_joints(theta: dict, model) -> list:
    """(prefix, joint index, fitted gap, fitted compliance) of every joint with a fitted
    backlash or compliance (the core's parameter names: ``rail[6].backlash``)."""
    out = {}
    for k, v in theta.items():
        m = _JOINT.match(k)
        if m and v > 0:
            out.setdefault((m.group(1), int(m.group(2)) - 1), {})[m.group(3)] = float(v)
    return [(p, i, d.get("backlash", model.param(f"{p}.backlash")), d.get("compliance", model.param(f"{p}.compliance")))
            for (p, i), d in sorted(out.items(), key=lambda kv: kv[0][1])]


def two_body_params(plant, joints, effort_rms, zeta: float, face: float) -> dict:
    """The parameters that make ``joints`` two bodies on the fitted ``plant``: damping ratio
    ``zeta`` of the drive body (its rotor inertia) on the spring; a gap without compliance
    gets faces deflecting ``face`` times the gap under the joint's RMS effort [N or N m]."""
    out = {"drive.two_body": 1.0}
    for prefix, i, gap, comp in joints:
        if comp <= 0:
            comp = face * gap / max(float(effort_rms[i]), 1e-12)
            out[f"{prefix}.compliance"] = comp
        out[f"{prefix}.transmission_damping"] = 2.0 * zeta * math.sqrt(plant.param(f"{prefix}.rotor_inertia") / comp)
    return out


def fitting_window(pipe, joints, start: int, end: int) -> tuple[int, int]:
    """(first sample, length) of the WINDOW-long stretch of samples ``start .. end`` (the
    fitted part) where the drive joints' smoothed efforts change sign most often (a gap shows
    only when it is crossed), or, without a change of sign, vary most (a compliance shows in
    the changes of its load)."""
    n = min(int(round(WINDOW / pipe.dt)), end - start)
    tau = pipe.tau_s[start:end][:, [i for _, i, _, _ in joints]]
    flips = np.concatenate([np.zeros((1, tau.shape[1])), np.abs(np.diff(np.sign(tau), axis=0)) > 0]).sum(axis=1)
    step = max(1, n // 10)
    firsts = np.arange(0, len(tau) - n + 1, step)
    counts = np.array([flips[a:a + n].sum() for a in firsts])
    if counts.max() == 0:
        counts = np.array([float(np.sum(np.var(tau[a:a + n], axis=0))) for a in firsts])
    # the latest of the best (closest to the held-out part)
    best = firsts[np.flatnonzero(counts == counts.max())[-1]]
    return start + int(best), n


def _window(ref, end):
    return ReferenceTable(ref.time[:end], ref.q[:end], ref.qd[:end], ref.qdd[:end], ref.x[:end])


def fit_two_body(rec, pipe, plant, joints, run, ref, k_fit: int, n_fit: int):
    """Damping (and face stiffness) of the two-body drives: the grid point whose closed-loop
    replay of samples ``k_fit .. k_fit + n_fit`` of the recording comes closest on the drive
    joints' readings and efforts, each relative to the reading models' replay of the same
    window.  ``run(plant, ref, start)`` replays ``ref`` from its sample ``start`` (a closed
    loop from the recorded state).
    Returns (parameters, grid rows) or (None, why)."""
    missing = [p for p, _, _, _ in joints if plant.param(f"{p}.rotor_inertia") <= 0]
    if missing:
        return None, (f"a two-body replay needs the drive's inertia: {', '.join(missing)} "
                      f"{'has' if len(missing) == 1 else 'have'} no rotor_inertia (declare \"{missing[0]}.rotor_inertia\" "
                      f"in the sidecar's parameters)")
    ref = _window(ref, k_fit + n_fit)
    idx = [i for _, i, _, _ in joints]
    effort = np.sqrt(np.mean(pipe.tau_s[pipe.idx][:, idx] ** 2, axis=0))
    eff_all = np.zeros(pipe.nd)
    eff_all[idx] = effort

    def errors(p):
        res = run(p, ref, k_fit)
        s = slice(k_fit, k_fit + len(res.time))
        return (np.sqrt(np.mean((res.q - rec.q[s]) ** 2, axis=0))[idx],
                np.sqrt(np.mean((res.tau_logged - rec.tau[s]) ** 2, axis=0))[idx])

    try:
        q0, t0 = errors(plant)
    except Exception as e:  # noqa: BLE001 - reported by the diagnosis, not fatal
        return None, f"the reading model's replay of the fitting window failed: {e}"
    faces = FACE_DEFLECTIONS if any(comp <= 0 for _, _, _, comp in joints) else (None,)
    rows, best = [], None
    for zeta, face in itertools.product(DAMPING_RATIOS, faces):
        extra = two_body_params(plant, joints, eff_all, zeta, face or 0.0)
        p = plant.copy()
        p.set_params(extra)
        try:
            q, t = errors(p)
        except Exception as e:  # noqa: BLE001 - a grid point the integrator refuses is skipped, and listed
            rows.append({"damping_ratio": zeta, "face_deflection": face, "error": str(e)})
            continue
        score = float(np.sum(q / np.maximum(q0, 1e-15)) + np.sum(t / np.maximum(t0, 1e-15))) / (2 * len(idx))
        rows.append({"damping_ratio": zeta, "face_deflection": face, "score": score,
                     "rms_q": q.tolist(), "rms_tau": t.tolist()})
        if best is None or score < best[0]:
            best = (score, extra)
    if best is None:
        return None, "no two-body replay of the fitting window ran"
    return best[1], rows
