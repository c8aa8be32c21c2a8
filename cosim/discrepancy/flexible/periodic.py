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
:data:`LINE_MIN` of the residual's variance (:func:`..lines.line_gain`).

A force on its own clock that is no sinusoid (a pump's pressure pulses, a fifth of the period
wide) is a comb: a line at its fundamental and lines at its multiples, which carry the force
together; the sinusoid at the highest of them carries a part (a third on a pump's rail), and the
fundamental may lie where the motion holds a share too.  Where a channel holds no line by its own
rule, its comb (:func:`comb`: the highest peak's fundamental and up to :data:`HARMONICS` of its
multiples, fitted per fold as the line is) is the column, "t along harmonics of 1.89 Hz", where it
predicts out of fold at least :data:`COMB_GAIN` more of the residual than the sinusoid at the
highest peak: any periodic shape of the force, to its eighth harmonic.

A force on the platform (a rotating unbalance) reaches every rail through the Jacobian, but a
channel whose residual something else carries holds the line below that share, or not at its
highest peak.  A line found on one channel, or one of the discrepancy's periodic report that
repeats on its channel (:func:`offered`), is offered to every channel: where the channel's own rule
finds none, the sinusoid at the offered frequency, refined and fitted per fold on that channel's
rows (:func:`..lines.at_offered`), is the column where it predicts anything out of fold
(:data:`OFFERED_MIN`), and the trees judge it as every input.  Measured on seen sets:
docs/records/flexible_mujoco_runs.md, "A force repeating at a fixed frequency".
"""
from __future__ import annotations

import math

import numpy as np

from ..lines import (LOW_CYCLES, MOTION_RATIO, at_offered, line_gain, motion_share, near, peak,  # noqa: F401
                     sinusoid, wave_at)
from .cv import FoldInputs

#: the line's column is added where the sinusoid fitted per fold explains, out of fold, this share
#: of the residual's variance: a force at a fixed frequency carries the channel.  A resonance the
#: motion sets ringing (a sloshing pendulum at 2.0-2.9 Hz) is a line too, whose phase the motion
#: sets: measured on seen MuJoCo sets, at most 0.51 on the pendulums' 36 channels against 0.89-1.00
#: on 16 of the 18 fan channels of sets 5-7 (docs/records/flexible_mujoco_runs.md)
LINE_MIN = 0.7
#: a line offered from elsewhere (:func:`offered`) is a column of a channel whose own rule finds
#: none where its sinusoid fitted per fold explains, out of fold, more than this share of the
#: residual's variance beyond the fitted rows' mean; it is then judged as every input (named only
#: where it adds out of fold)
OFFERED_MIN = 0.0
#: the column's name (followed by the frequency fitted on every sample)
LINE = "t along a line at"
#: a pulse train's column's name (followed by its fundamental fitted on every sample)
COMB = "t along harmonics of"
#: a comb's harmonics at most (its fundamental's multiples in the line rule's band)
HARMONICS = 8
#: a subharmonic of the highest peak (its half, its third) is the comb's fundamental where its
#: sinusoid explains at least this share of what the peak's does: a pulse train's highest line may
#: be a harmonic
SUB_SHARE = 0.1
#: a channel without a line of its own is given its comb's column where the comb fitted per fold
#: (:func:`comb`) predicts, out of fold, at least this share of the residual's variance more than
#: the sinusoid at the highest peak (nothing where that predicts less than nothing): the harmonics
#: carry the force together.  Measured on seen sets (docs/records/flexible_mujoco_runs.md): 0.64 and 0.17 on the two pulse
#: pumps' rails, at most 0.09 on the 613 other channels the stage was given (a fan's channel whose
#: highest peak is the harmonic; the sloshing pendulums' ringing at most 0.02)
COMB_GAIN = 0.15


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


def harmonics(t, f, count) -> np.ndarray:
    """``(n, 2 count)``: the cosine and sine of ``h`` times the phase at ``f`` [Hz] at the times
    ``t`` [s], ``h`` = 1 .. ``count``, in that order."""
    a = 2.0 * math.pi * f * np.asarray(t, float)
    return np.column_stack([g(h * a) for h in range(1, count + 1) for g in (np.cos, np.sin)])


def comb_at(t, y, f, count, at) -> np.ndarray:
    """The comb at ``f`` [Hz] (its first ``count`` harmonics) fitted to ``y`` at the times ``t``
    (beside a constant, least squares), evaluated at the times ``at`` (without the constant)."""
    beta, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(t)), harmonics(t, f, count)]), y, rcond=None)
    return harmonics(at, f, count) @ beta[1:]


def _comb_ss(t, y, f, count) -> float:
    """The sum of squares of ``y`` (centred) the comb at ``f`` [Hz] (its first ``count`` harmonics,
    beside a constant) explains: by the normal equations, the harmonics' powers of the phase's
    complex exponential (the refinement's grids ask for 22 of these per fit)."""
    z = np.exp(2j * math.pi * f * np.asarray(t, float))
    powers = np.cumprod(np.broadcast_to(z[:, None], (len(z), count)), axis=1)
    X = np.column_stack([np.ones(len(z)), powers.real, powers.imag])
    x = y - y.mean()
    beta = np.linalg.lstsq(X.T @ X, X.T @ y, rcond=None)[0]
    r = y - X @ beta
    return float(x @ x - r @ r)


def fundamental(t, y, rows=None) -> tuple:
    """``(fundamental [Hz], harmonics, the highest peak [Hz])`` of the comb ``y`` holds (on the
    samples ``rows`` where given): the highest periodogram peak in the line rule's band (:func:`..lines.peak`), or its
    half or third where that is in the band and its sinusoid explains at least :data:`SUB_SHARE`
    of what the peak's does (the lowest such), refined by least squares on the comb of its first
    :data:`HARMONICS` multiples in the band (11 frequencies over a quarter of the resolution on
    each side, then 11 over a fifth of that).  ``(None, 0, None)`` where the band is empty."""
    dt, lo, hi = _band(t)
    top = peak(t, y, dt, lo, hi, rows=rows)
    if top is None:
        return None, 0, None
    tr, yr = (t, y) if rows is None else (t[rows], y[rows])
    xr = yr - yr.mean()
    at_top, f = sinusoid(tr, xr, top)[2], top
    for k in (2, 3):
        if top / k >= lo and sinusoid(tr, xr, top / k)[2] >= SUB_SHARE * at_top:
            f = top / k
    count = max(1, min(HARMONICS, int(hi / f)))
    width = 0.25 / max(float(tr[-1] - tr[0]), 1e-9)
    for w in (width, width / 5.0):
        grid = f + np.linspace(-1.0, 1.0, 11) * w
        f = float(grid[np.argmax([_comb_ss(tr, yr, g, count) for g in grid])])
    return f, count, top


def comb(t, y, fold_rows) -> tuple:
    """``(fundamental [Hz], harmonics, per-fold combs)`` of a pulse train ``y`` holds: its comb
    (:func:`fundamental`), found and fitted per fold on the fold's fitted rows, predicts out of
    fold at least :data:`COMB_GAIN` of ``y``'s variance more than the sinusoid at the highest peak
    fitted per fold (:func:`per_fold`, counted as nothing where it predicts less); first checked on
    every sample (the comb's share beyond the sinusoid's, in sample, at least as much).  ``(None,
    0, None)`` elsewhere."""
    if len(t) < 64 or not np.var(y) > 0:
        return None, 0, None
    f, count, top = fundamental(t, y)
    x = y - y.mean()
    if f is None or (_comb_ss(t, y, f, count) - sinusoid(t, x, top)[2]) / float(x @ x) < COMB_GAIN:
        return None, 0, None
    waves = []
    for _, fit in fold_rows:
        g, k, _ = fundamental(t, y, rows=fit)
        waves.append(np.zeros(len(t)) if g is None else comb_at(t[fit], y[fit], g, k, t))
    beyond = line_gain(y, waves, fold_rows) - max(line_gain(y, per_fold(t, y, fold_rows), fold_rows), 0.0)
    return (f, count, waves) if beyond >= COMB_GAIN else (None, 0, None)


def _time_column(columns, p) -> int | None:
    """The index of the time column ``t`` among the first ``p`` of ``columns`` (None: none)."""
    return next((i for i, c in enumerate(columns[:p]) if c[0] == "t" and c[3] == "time"), None)


def time_and_positions(X, columns) -> tuple:
    """``(t, positions (n, joints))`` of the inputs ``X``: its time column ``t`` and its columns of
    quantity ``position`` (read from ``columns``); ``(None, None)`` without a time column."""
    whole = np.asarray(X)
    tcol = _time_column(columns, whole.shape[1])
    if tcol is None:
        return None, None
    return whole[:, tcol], whole[:, [i for i, c in enumerate(columns[:whole.shape[1]]) if c[3] == "position"]]


def own(t, y, pos, fold_rows) -> tuple:
    """``(frequency [Hz], per-fold sinusoids)`` of the line residual ``y`` holds by the channel's own
    rule: :func:`line`, predicted out of fold by :func:`per_fold` (:func:`..lines.line_gain` at least
    :data:`LINE_MIN`); ``(None, None)`` where it holds none."""
    f = line(t, y, pos)
    if f is None:
        return None, None
    waves = per_fold(t, y, fold_rows)
    return (f, waves) if line_gain(y, waves, fold_rows) >= LINE_MIN else (None, None)


def offered(t, R, pos, fold_rows, report=()) -> tuple:
    """The lines offered to every channel [Hz]: those the residuals ``R`` (n, channels, in the
    channels' order) hold by their own rule (:func:`own`), then those of the discrepancy's periodic
    report (``report``: entries of a ``joint`` (1-based column of ``R``) whose ``lines`` are
    ``(frequency [Hz], amplitude)``) whose sinusoid fitted per fold on their own channel predicts
    at least :data:`LINE_MIN` of it out of fold (:func:`..lines.at_offered`): a force at a fixed frequency,
    not a resonance the motion sets ringing, whose phase the motion sets; the strongest first, one
    per resolution (one over the recording's span).  A force on the platform reaches every rail
    through the Jacobian, also one whose residual something else carries, where the channel's own
    rule does not find it."""
    if t is None or len(t) < 64:
        return ()
    R = np.asarray(R, float).reshape(len(t), -1)
    resolution, out = 1.0 / max(float(t[-1] - t[0]), 1e-9), []

    def new(f):
        return all(abs(f - g) >= resolution for g in out)
    found = []
    for y in R.T:
        f, _ = own(t, y, pos, fold_rows)
        if f is not None:
            found.append((sinusoid(t, y - y.mean(), f)[1], f))
    for _, f in sorted(found, reverse=True):
        if new(f):
            out.append(f)
    listed = sorted(((float(a), float(f), e["joint"] - 1) for e in report for f, a in e.get("lines", ())
                     if 0 < e["joint"] <= R.shape[1]), reverse=True)
    for _, f, c in listed:
        if new(f) and line_gain(R[:, c], at_offered(t, R[:, c], fold_rows, f), fold_rows) >= LINE_MIN:
            out.append(f)
    return tuple(out)


def extend(X, columns, groups, y, fold_rows, lines=()) -> tuple:
    """``X`` (n, p; a :class:`~.cv.FoldInputs` or an array) with the line's column where the
    residual ``y`` holds one by its own rule (:func:`own`), else the comb's where it holds a pulse
    train (:func:`comb`), else where one of the lines ``lines`` offered from elsewhere
    (:func:`offered`, [Hz]), the sinusoid at it fitted per fold (:func:`..lines.at_offered`), predicts more
    than :data:`OFFERED_MIN` of ``y``'s variance out of fold beyond the fitted rows' mean (the best
    such): its time column ``t`` and positions (quantity ``position``) are read from ``columns``.
    Returns ``(X, columns, groups, lines)``, ``lines`` per added column ``(the time column (index
    into X), frequency [Hz], the cosine and sine coefficients of each harmonic in turn)`` fitted on
    every sample (:func:`extended`)."""
    y = np.asarray(y, float)
    t, pos = time_and_positions(X, columns)
    if t is None:
        return X, columns, groups, ()
    tcol, whole = _time_column(columns, X.shape[1]), np.asarray(X)
    f, waves = own(t, y, pos, fold_rows)
    count, name = 1, LINE
    if f is None:
        f, count, waves = comb(t, y, fold_rows)
        name = COMB
    if f is None:  # a line found elsewhere: judged beyond the fitted rows' mean, which the trees hold too
        count, name = 1, LINE
        mean_only = line_gain(y, [np.zeros(len(y))] * len(fold_rows), fold_rows)
        tried = [(line_gain(y, w, fold_rows) - mean_only, g, w)
                 for g in lines for w in [at_offered(t, y, fold_rows, g)]]
        gain, f, waves = max(tried, key=lambda x: x[0], default=(0.0, None, None))
        if f is None or not gain > OFFERED_MIN:
            return X, columns, groups, ()
        f = near(t, y, f)
    wave = wave_at(t, y, f, t) if count == 1 else comb_at(t, y, f, count, t)
    coef, *_ = np.linalg.lstsq(harmonics(t, f, count), _unit(wave), rcond=None)
    columns, groups = list(columns), {g: list(c) for g, c in groups.items()}
    groups.setdefault("time", []).append(X.shape[1])
    columns.append((f"{name} {f:.3g} Hz", "time", None, "time", ""))
    variants = getattr(X, "variants", None)
    if variants is None:
        variants = np.broadcast_to(whole, (len(fold_rows),) + whole.shape)
    variants = np.concatenate([variants, np.stack([_unit(w) for w in waves])[:, :, None]], axis=2)
    return (FoldInputs(np.column_stack([whole, _unit(wave)]), variants), columns, groups,
            ((tcol, f) + tuple(float(c) for c in coef),))


def extended(X, lines) -> np.ndarray:
    """The inputs ``X`` with the lines' columns fitted on every sample (``lines`` of
    :func:`extend`, their time columns indices into ``X``), in the order :func:`extend` added them."""
    X = np.asarray(X, float)
    if not lines:
        return X
    cols = []
    for tcol, f, *coef in lines:
        a = 2.0 * math.pi * f * X[:, tcol]
        cols.append(sum(coef[2 * h] * np.cos((h + 1) * a) + coef[2 * h + 1] * np.sin((h + 1) * a)
                        for h in range(len(coef) // 2)))
    return np.column_stack([X] + cols)
