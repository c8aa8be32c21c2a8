"""Spectral lines in a residual: a force that repeats at a fixed frequency, not keyed on the motion.

A deterministic fast force (a fan's or spindle's unbalance turning at a few hertz, a pump's
pulsation) passes the pipeline's smoother and is, to a yardstick built on differences of samples
some tens of milliseconds apart (:func:`.signatures.own_noise`), noise: that yardstick then reads
the force's amplitude, not the sensor's noise, and nothing is left to flag.  Such a force is a
narrow line in the residual's spectrum, at a frequency where the motion has none.

:func:`lines` finds them one channel at a time: the highest peak of the residual's periodogram
between ``LOW_CYCLES`` cycles over the recording and 0.45 of the decimated samples' rate, its
frequency refined by least squares on the samples' times, is a line when

* the sinusoid at that frequency, fitted beside the joint's own families of :mod:`.structure`
  (a friction's steps under a periodic motion repeat too), explains a share of the residual's
  variance (of what those families leave) more than
  ``MOTION_RATIO`` times the largest share it explains of any joint's position (a line the motion
  also holds is the motion's: an effect keyed on a periodic excitation), and
* its chi-square against the own noise of the residual without the lines found
  (:func:`.signatures.own_noise`), in independent samples, exceeds ``threshold`` plus the cost of
  its two coefficients (``2 ln n_eff``) and of the frequencies searched (``ln`` of their number).

A line found is taken out and the search repeated (an amplitude modulated by the pose leaves
side lines), at most ``MAX_LINES`` times.  A channel's lines count only where the strongest
repeats through the recording (:func:`repeats`): its sinusoid, refined and fitted on the fitted
rows of each fold of the flexible stage's blocked cross-validation (:func:`~.blocked_folds.folds`),
predicts at least ``REPEAT_MIN`` of the residual's variance on the held-out rows.  A chance
line among the harmonics of a misfit keyed on the motion (a saturated drive's shortfall: a line at
3.02 Hz holding 0.06 of the residual) passes the chi-square where the residual is far above its
noise, but does not repeat.
"""
from __future__ import annotations

import math

import numpy as np

from .blocked_folds import folds, gap_for

#: the lowest frequency searched, in cycles over the recording's span
LOW_CYCLES = 10.0
#: a line counts when its share of the residual's variance exceeds this many times its largest
#: share of a joint's position (in closed loop the force moves the joints too, by a far smaller share)
MOTION_RATIO = 20.0
#: lines taken out per channel at most
MAX_LINES = 6
#: a channel's lines count where the sinusoid at the strongest, fitted per fold, predicts at least
#: this share of the residual's variance out of fold (:func:`repeats`).  Measured on seen MuJoCo
#: sets (docs/records/flexible_mujoco_runs.md): 0.39-0.99 on the fans' channels with a line, 0.28 on a pulse pump's rail,
#: at most 0.10 where no force repeats (a saturated drive, a spindle, a magnet, a soft pad, an
#: effort-coupled friction, a bellows' friction)
REPEAT_MIN = 0.15


def sinusoid(t, y, f, F=None):
    """(the sinusoid's part, its amplitude, the sum of squares it explains) of a fit of y with a
    sinusoid at f beside the columns F (a constant when None)."""
    a = 2.0 * math.pi * f * t
    F = np.ones((len(t), 1)) if F is None else F
    X = np.column_stack([F, np.cos(a), np.sin(a)])
    beta, *_ = np.linalg.lstsq(X, y, rcond=None)
    fit = X[:, -2:] @ beta[-2:]
    r = y - X @ beta
    r0 = y - F @ np.linalg.lstsq(F, y, rcond=None)[0]
    return fit, float(math.hypot(beta[-2], beta[-1])), float(r0 @ r0 - r @ r)


def wave_at(t, y, f, at) -> np.ndarray:
    """The sinusoid at f [Hz] fitted to ``y`` at the times ``t`` (beside a constant, least
    squares), evaluated at the times ``at`` (without the constant)."""
    a = 2.0 * math.pi * f * np.asarray(t, float)
    beta, *_ = np.linalg.lstsq(np.column_stack([np.ones(len(a)), np.cos(a), np.sin(a)]), y, rcond=None)
    b = 2.0 * math.pi * f * np.asarray(at, float)
    return beta[1] * np.cos(b) + beta[2] * np.sin(b)


def motion_share(t, pos, f) -> float:
    """The largest share of a column of ``pos`` (positions, centred) a sinusoid at f explains."""
    ss = np.maximum(np.sum(pos ** 2, axis=0), 1e-300)
    return max(sinusoid(t, pos[:, j], f)[2] / ss[j] for j in range(pos.shape[1]))


def peak(t, x, dt, f_lo, f_hi, rows=None):
    """The frequency [Hz] of the highest periodogram peak of x in [f_lo, f_hi], refined by least
    squares over the bin around it (None when the band is empty).  ``rows``: of these samples only
    (the others count as zero in the periodogram and not at all in the refinement)."""
    n = len(x)
    if rows is not None:
        rows = np.asarray(rows)
        kept = np.zeros(n)
        kept[rows] = x[rows] - np.mean(x[rows])
        x = kept
    nfft = 1 << int(math.ceil(math.log2(4 * n)))
    P = np.abs(np.fft.rfft(x * np.hanning(n), nfft))
    f = np.fft.rfftfreq(nfft, dt)
    band = np.flatnonzero((f >= f_lo) & (f <= f_hi))
    if not len(band):
        return None
    k = band[np.argmax(P[band])]
    grid = f[k] + np.linspace(-1.0, 1.0, 21) * (f[1] - f[0])
    tr, xr = (t, x) if rows is None else (t[rows], x[rows])
    return float(grid[np.argmax([sinusoid(tr, xr, g)[2] for g in grid])])


def near(t, y, f, rows=None) -> float:
    """``f`` [Hz] refined by least squares on the samples ``rows`` of ``y`` (all where None): the
    frequency within a quarter of the resolution (one over the samples' span) of ``f`` whose
    sinusoid explains the most of them."""
    tr, yr = (t, y) if rows is None else (t[rows], y[rows])
    grid = f + np.linspace(-1.0, 1.0, 21) * 0.25 / max(float(tr[-1] - tr[0]), 1e-9)
    return float(grid[np.argmax([sinusoid(tr, yr, g)[2] for g in grid])])


def at_offered(t, y, fold_rows, f) -> list:
    """Per fold of ``fold_rows`` ((held-out rows, fitted rows) each), the sinusoid at ``f`` [Hz]
    refined on the fold's fitted rows (:func:`near`) and fitted to them, evaluated at every sample."""
    return [wave_at(t[fit], y[fit], near(t, y, f, fit), t) for _, fit in fold_rows]


def line_gain(y, waves, fold_rows) -> float:
    """The share of ``y``'s variance the per-fold sinusoids ``waves`` explain on their held-out
    rows (beside the fitted rows' mean)."""
    var = float(np.var(y))
    if not var > 0:
        return 0.0
    sse = sum(float(np.sum((y[held] - y[fit].mean() - w[held]) ** 2)) for (held, fit), w in zip(fold_rows, waves))
    return 1.0 - sse / len(y) / var


def repeats(t, y, f, spi) -> float:
    """The share of ``y``'s variance the sinusoid at ``f`` [Hz] predicts out of fold: refined and
    fitted on each fold's fitted rows (:func:`at_offered`), over the flexible stage's blocked
    folds (:func:`~.blocked_folds.folds`, a gap of one independent sample, ``spi`` samples each)."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    rows = folds(len(y), gap_for(spi))
    return line_gain(y, at_offered(t, y, rows, f), rows)


def lines(pipe, R, floor=None, threshold: float = 25.0) -> list:
    """Spectral lines of each residual channel that the motion does not hold.

    Parameters
    ----------
    pipe : Pipeline
        The recording's pipeline (times, positions, smoothing window and decimation).
    R : numpy.ndarray, shape (n, C)
        The residual on the pipeline's decimated samples (``pipe.idx``), channels as
        ``pipe.channels``.
    floor : numpy.ndarray, shape (C,), optional
        The smallest noise level a channel is given (the engine's accuracy).
    threshold : float
        Chi-square (independent samples) a line must explain beyond its costs.

    Returns
    -------
    list of dict
        Per channel with lines: ``channel`` (index), ``lines`` (list of (frequency [Hz],
        amplitude [channel unit]), strongest first), ``chi2`` (explained by them, independent
        samples, against ``noise``), ``cost`` (of their coefficients and frequencies, in the
        same unit), ``clean`` (the residual without them) and ``noise`` (its own noise); only
        the channels whose strongest line repeats (:func:`repeats`, :data:`REPEAT_MIN`).

    Examples
    --------
    >>> found = lines(pipe, r_after, floor=eng.accuracy())     # doctest: +SKIP
    >>> [(x["channel"], x["lines"][0]) for x in found]          # doctest: +SKIP
    [(1, (5.39, 0.31))]
    """
    from .signatures import families, own_noise, samples_per_independent

    R = np.asarray(R, float)
    t = np.asarray(pipe.t[pipe.idx], float)
    n = len(t)
    if n < 64:
        return []
    dt = pipe.step * pipe.dt
    f_lo, f_hi = LOW_CYCLES / max(t[-1] - t[0], dt), 0.45 / dt
    phi = samples_per_independent(pipe)
    n_eff = n / phi
    cost = 2.0 * math.log(n_eff) + math.log(max((f_hi - f_lo) * (t[-1] - t[0]), 1.0))
    pos = np.asarray(pipe.q_s[pipe.idx], float)
    pos = pos - pos.mean(axis=0)
    out = []
    for c in range(R.shape[1]):
        x0 = R[:, c] - R[:, c].mean()
        # what the joint's own motion explains (a friction's steps under a periodic motion
        # repeat too) is fitted beside each line, not taken for it
        F = np.column_stack(list(families(pipe, c % pipe.nd).values()))
        F = np.column_stack([np.ones(n), F - F.mean(axis=0)])
        x, found, explained = x0, [], 0.0
        for _ in range(MAX_LINES):
            base = x - F @ np.linalg.lstsq(F, x, rcond=None)[0]
            total = float(base @ base)
            f = peak(t, base, dt, f_lo, f_hi) if total > 0 else None
            if f is None:
                break
            fit, amp, ss = sinusoid(t, base, f, F)
            motion = motion_share(t, pos, f)
            sigma = own_noise(pipe, x - fit, 0.0 if floor is None else floor[c])
            if not (sigma > 0 and ss / total > MOTION_RATIO * motion and ss / sigma ** 2 / phi - cost > threshold):
                break
            x = x - fit
            found.append((f, amp))
            explained += ss
        if found and repeats(t, R[:, c], found[0][0], phi) >= REPEAT_MIN:
            sigma = own_noise(pipe, x, 0.0 if floor is None else floor[c])
            out.append({"channel": c, "lines": found, "chi2": explained / sigma ** 2 / phi,
                        "cost": len(found) * cost, "clean": x + R[:, c].mean(), "noise": sigma})
    return out
