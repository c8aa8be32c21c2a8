"""Time along a line of the residual's spectrum (:mod:`.flexible`): a force repeating at a fixed frequency.

A force turning or pulsing at a fixed rate (a fan's unbalance: a line of the residual's spectrum
that the motion does not hold, :mod:`..lines`) is a function of time, but not one boosted trees
on the time column can predict in a held-out block of time: they learn the values of the blocks
they were fitted on, not the phase the force has in the others.  A column that is the force's
phase does: per channel, where the residual's highest periodogram peak in the line rule's band
(:func:`..lines.peak`) lies at a frequency the joints' positions do not hold (the line rule's
:data:`~..lines.MOTION_RATIO`), one more column in the time group, the sinusoid at that
frequency fitted to the residual (:func:`..lines.wave_at`), at unit amplitude.

Its frequency (the peak and its least-squares refinement), phase and amplitude are fitted per
fold of the cross-validation on that fold's fitted rows only (:class:`~.cv.FoldInputs`, as the
projected columns of :mod:`.oblique`: no held-out row moves the column its trees are judged on),
and once on every sample for the final model, its partial dependence and the black box
(:func:`extended`).  The column is added where the sinusoid alone explains, out of fold, at least
:data:`LINE_MIN` of the residual's variance (:func:`line_gain`).  Measured on seen sets:
docs/flexible.md, "A force repeating at a fixed frequency".
"""
from __future__ import annotations

import math

import numpy as np

from ..lines import LOW_CYCLES, MOTION_RATIO, motion_share, peak, sinusoid, wave_at
from .cv import FoldInputs

#: the line's column is added where the sinusoid fitted per fold explains, out of fold, this share
#: of the residual's variance: a force at a fixed frequency carries the channel.  A resonance the
#: motion sets ringing (a sloshing pendulum at 2.0-2.9 Hz) is a line too, whose phase the motion
#: sets: measured on seen MuJoCo sets, at most 0.51 on the pendulums' 36 channels against 0.89-1.00
#: on 16 of the 18 fan channels of sets 5-7 (docs/flexible.md)
LINE_MIN = 0.7
#: the column's name (followed by the frequency fitted on every sample)
LINE = "t along a line at"


def _band(t) -> tuple:
    """``(dt, lowest, highest frequency searched)`` [s, Hz, Hz]: the line rule's band."""
    dt = float(np.median(np.diff(t)))
    return dt, LOW_CYCLES / max(float(t[-1] - t[0]), dt), 0.45 / dt


def _unit(wave) -> np.ndarray:
    """``wave`` at unit amplitude (its peak's: sqrt(2) times its RMS)."""
    rms = float(np.sqrt(np.mean(wave ** 2)))
    return wave / (math.sqrt(2.0) * rms) if rms > 0 else wave


def line(t, y, pos) -> float | None:
    """The frequency [Hz] of the highest periodogram peak of ``y`` at the times ``t`` in the line
    rule's band, refined by least squares, where the positions ``pos`` (n, joints) do not hold
    it: the share of ``y``'s variance the sinusoid explains exceeds :data:`~..lines.MOTION_RATIO`
    times its largest share of a position.  None elsewhere."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    if len(t) < 64:
        return None
    dt, lo, hi = _band(t)
    x = y - y.mean()
    total = float(x @ x)
    f = peak(t, x, dt, lo, hi) if total > 0 else None
    if f is None:
        return None
    p = np.asarray(pos, float)
    p = p - p.mean(axis=0)
    ss = sinusoid(t, x, f)[2]
    return f if ss / total > MOTION_RATIO * (motion_share(t, p, f) if p.shape[1] else 0.0) else None


def per_fold(t, y, fold_rows) -> list:
    """Per fold, the line fitted on its fitted rows alone: the highest peak of their periodogram
    (the others as zero) refined on them, and the sinusoid fitted to them at that frequency,
    evaluated at every sample (unit amplitude where :func:`_unit`; here in ``y``'s unit)."""
    dt, lo, hi = _band(t)
    out = []
    for _, fit in fold_rows:
        f = peak(t, y, dt, lo, hi, rows=fit)
        out.append(np.zeros(len(t)) if f is None else wave_at(t[fit], y[fit], f, t))
    return out


def line_gain(y, waves, fold_rows) -> float:
    """The share of ``y``'s variance the per-fold sinusoids ``waves`` (:func:`per_fold`) explain
    on their held-out rows (beside the fitted rows' mean)."""
    var = float(np.var(y))
    if not var > 0:
        return 0.0
    sse = sum(float(np.sum((y[held] - y[fit].mean() - w[held]) ** 2)) for (held, fit), w in zip(fold_rows, waves))
    return 1.0 - sse / len(y) / var


def extend(X, columns, groups, y, fold_rows) -> tuple:
    """``X`` (n, p; a :class:`~.cv.FoldInputs` or an array) with the line's column where the
    residual ``y`` holds one (:func:`line`) that the sinusoid fitted per fold predicts out of fold
    (:func:`line_gain` at least :data:`LINE_MIN`): its time column ``t`` and positions (quantity
    ``position``) are read from ``columns``.  Returns ``(X, columns, groups, lines)``, ``lines``
    per added column ``(the time column (index into X), frequency [Hz], cos and sin coefficients)``
    fitted on every sample (:func:`extended`)."""
    y = np.asarray(y, float)
    tcol = next((i for i, c in enumerate(columns[:X.shape[1]]) if c[0] == "t" and c[3] == "time"), None)
    if tcol is None:
        return X, columns, groups, ()
    whole = np.asarray(X)
    t = whole[:, tcol]
    pos = whole[:, [i for i, c in enumerate(columns[:X.shape[1]]) if c[3] == "position"]]
    f = line(t, y, pos)
    if f is None:
        return X, columns, groups, ()
    waves = per_fold(t, y, fold_rows)
    if line_gain(y, waves, fold_rows) < LINE_MIN:
        return X, columns, groups, ()
    wave = wave_at(t, y, f, t)
    a = 2.0 * math.pi * f * t
    ab, *_ = np.linalg.lstsq(np.column_stack([np.cos(a), np.sin(a)]), _unit(wave), rcond=None)
    columns, groups = list(columns), {g: list(c) for g, c in groups.items()}
    groups.setdefault("time", []).append(X.shape[1])
    columns.append((f"{LINE} {f:.3g} Hz", "time", None, "time", ""))
    variants = getattr(X, "variants", None)
    if variants is None:
        variants = np.broadcast_to(whole, (len(fold_rows),) + whole.shape)
    variants = np.concatenate([variants, np.stack([_unit(w) for w in waves])[:, :, None]], axis=2)
    return (FoldInputs(np.column_stack([whole, _unit(wave)]), variants), columns, groups,
            ((tcol, f, float(ab[0]), float(ab[1])),))


def extended(X, lines) -> np.ndarray:
    """The inputs ``X`` with the lines' columns fitted on every sample (``lines`` of
    :func:`extend`, their time columns indices into ``X``), in the order :func:`extend` added them."""
    X = np.asarray(X, float)
    if not lines:
        return X
    cols = []
    for tcol, f, ca, cb in lines:
        a = 2.0 * math.pi * f * X[:, tcol]
        cols.append(ca * np.cos(a) + cb * np.sin(a))
    return np.column_stack([X] + cols)
