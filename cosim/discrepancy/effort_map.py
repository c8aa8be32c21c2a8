"""Two effort channels: the drive's command-to-effort map, and the channel the physics is
fitted on (docs/recording.md, "Two effort channels").

A recording may carry the commanded effort (``tau<i>``) and a measured one
(``tau_meas<i>``: a torque sensor, or a motor current times its torque constant).  The
map from one to the other is the core's :func:`cosim.core.effort_map` (gain, offset,
first-order lag, limit); :func:`fit_effort_map` fits it per joint by least squares, with
95 % intervals from the fit's covariance (white residuals assumed: a coloured one makes
them optimistic).  The limit is kept only when the command drove the drive into it: the
fit with it must lower the sum of squares by more than the chi-square bar
:data:`LIMIT_BAR` (1 degree of freedom, p = 0.001); otherwise it is reported as not
reached.

:func:`effort_channels` is the diagnosis' step: with a measured effort, the physics is
fitted on it (what reached the mechanism), and the map says what the drive did to the
command, so that a drive delivering 55 % of its command is a gain of 0.55, not a
saturation or a heavier mass standing in for it.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.optimize import least_squares

from ..core.drive import effort_map
from .residuals import DiagnosisError

#: chi-square bar (1 degree of freedom, p = 0.001) a limit must beat to be kept
LIMIT_BAR = 10.83
#: the map's parameters, in the order of the fit, and their units ("E": the effort's)
PARAMS = (("gain", "-"), ("offset", "E"), ("lag", "s"), ("limit", "E"))


def _columns(rec, prefix):
    nd = rec.ndof
    names = [f"{prefix}{i}" for i in range(1, nd + 1)]
    have = [n in rec.extra for n in names]
    if not any(have):
        return None
    if not all(have):
        raise DiagnosisError(f"{rec.path or 'the recording'}: {prefix} columns must be given for all joints or none "
                             f"({names[have.index(False)]} is missing)")
    sign = np.asarray((rec.joint_convention or {}).get("sign", [1.0] * nd), float)
    return sign * np.column_stack([np.asarray(rec.extra[n], float) for n in names])


def measured_effort(rec):
    """The recording's measured effort (columns ``tau_meas<i>``) (n, nd) [N or N m], or None."""
    return _columns(rec, "tau_meas")


def _predict(p, u, dt, y0):
    """The effort read at each sample (``y[k-1]``, the first one ``y0``) for parameters p."""
    gain, offset, lag, limit = p
    y = effort_map(u, dt, gain=gain, offset=offset, lag=max(lag, 0.0), limit=limit, y0=y0)
    return np.concatenate([[y0], y[:-1]])


def _fit(u, m, dt, with_limit):
    """Least squares of the map on one joint: ``(params, covariance, ssr)``."""
    g0, o0 = np.polyfit(u, m, 1) if np.ptp(u) > 0 else (1.0, float(np.mean(m) - np.mean(u)))
    p0 = [g0, o0, 3 * dt]
    lo, hi = [-np.inf, -np.inf, 0.0], [np.inf, np.inf, np.inf]
    if with_limit:
        p0.append(0.95 * max(np.max(np.abs(g0 * u)), 1e-12))
        lo.append(0.0)
        hi.append(np.inf)

    def res(p):
        q = list(p) + ([] if with_limit else [np.inf])
        return _predict(q, u, dt, m[0]) - m

    sol = least_squares(res, p0, bounds=(lo, hi), x_scale="jac", method="trf")
    r = sol.fun
    dof = max(len(m) - len(p0), 1)
    s2 = float(r @ r) / dof
    cov = s2 * np.linalg.pinv(sol.jac.T @ sol.jac)
    return sol.x, cov, float(r @ r), s2


def fit_effort_map(time, commanded, measured) -> list:
    """Fit the command-to-effort map of each joint.

    Parameters
    ----------
    time : array_like, shape (n,)
        Sample times [s] (uniform; blocks with gaps between them are taken as one run, the
        lag carried across each seam).
    commanded, measured : array_like, shape (n, nd)
        The commanded and the measured effort [N or N m].

    Returns
    -------
    list of dict
        Per joint: ``gain``, ``offset``, ``lag``, ``limit`` as ``(value, ci95)`` (the limit
        ``None`` when not reached, with ``limit_note``), ``rms`` of what the map leaves
        [N or N m], ``rms_measured`` (the measured effort's RMS).

    Example
    -------
    >>> import numpy as np
    >>> from cosim.core import effort_map
    >>> t = np.arange(2000) * 1e-3; u = np.sign(np.sin(2 * np.pi * 2 * t))[:, None]
    >>> m = effort_map(u[:, 0], 1e-3, gain=0.55, offset=0.01, lag=0.005)
    >>> fit = fit_effort_map(t, u, np.concatenate([[0.0], m[:-1]])[:, None])
    >>> round(fit[0]["gain"][0], 3), round(fit[0]["lag"][0], 4)
    (0.55, 0.005)
    """
    t = np.asarray(time, float)
    u = np.atleast_2d(np.asarray(commanded, float).T).T
    m = np.atleast_2d(np.asarray(measured, float).T).T
    dt = float(np.median(np.diff(t)))  # the sample period (a working set's blocks have gaps between them)
    out = []
    for j in range(u.shape[1]):
        p, cov, ssr, s2 = _fit(u[:, j], m[:, j], dt, False)
        row = {"limit": None}
        reach = float(np.max(np.abs(p[0] * u[:, j])))
        pl, covl, ssrl, s2l = _fit(u[:, j], m[:, j], dt, True)
        if (ssr - ssrl) / max(s2l, 1e-300) > LIMIT_BAR and pl[3] < reach:
            p, cov, ssr = pl, covl, ssrl
            row["limit"] = (float(p[3]), float(1.96 * np.sqrt(max(cov[3, 3], 0.0))))
        else:
            row["limit_note"] = f"not reached (|gain u| up to {reach:.4g})"
        for k, (name, _) in enumerate(PARAMS[:3]):
            row[name] = (float(p[k]), float(1.96 * np.sqrt(max(cov[k, k], 0.0))))
        pred = _predict(list(p) + ([] if len(p) == 4 else [np.inf]), u[:, j], dt, m[0, j])
        row["rms"] = float(np.sqrt(np.mean((pred - m[:, j]) ** 2)))
        row["rms_measured"] = float(np.sqrt(np.mean(m[:, j] ** 2)))
        out.append(row)
    return out


def sentence(fit, unit: str) -> str:
    """The map in words, one clause per joint."""
    parts = []
    for j, r in enumerate(fit):
        lim = (f"limit {r['limit'][0]:.4g} +- {r['limit'][1]:.2g} {unit}" if r["limit"] is not None
               else f"limit {r['limit_note']}")
        parts.append(f"joint {j + 1}: gain {r['gain'][0]:.4g} +- {r['gain'][1]:.2g}, offset {r['offset'][0]:.4g} "
                     f"+- {r['offset'][1]:.2g} {unit}, lag {r['lag'][0] * 1e3:.3g} +- {r['lag'][1] * 1e3:.2g} ms, "
                     f"{lim}")
    return "; ".join(parts)


def effort_channels(rec, unit: str):
    """``(recording for the physics, report)``: with a measured effort, the physics is
    fitted on it (the recording's ``tau`` replaced by it, the commanded one kept in
    ``extra`` as ``tau_cmd<i>``) and the report holds the fitted map; without one, the
    recording as it is and ``None``."""
    meas = measured_effort(rec)
    if meas is None:
        return rec, None
    fit = fit_effort_map(rec.time, rec.tau, meas)
    extra = dict(rec.extra)
    extra.update({f"tau_cmd{i + 1}": rec.tau[:, i] for i in range(rec.tau.shape[1])})
    physics = dataclasses.replace(rec, tau=meas, extra=extra)
    report = {"channel": "measured (tau_meas)", "map": fit,
              "statement": (f"physics fitted on the measured effort (tau_meas); the drive's command-to-effort map: "
                            f"{sentence(fit, unit)}")}
    return physics, report
