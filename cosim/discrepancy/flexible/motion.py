"""The platform's acceleration through a resonance found per fold (:mod:`.flexible`).

A body the platform carries on a spring (a tuned mass damper, a pendulum, a sloshing liquid's
usual model) pushes on the platform with the force of a second-order system driven by the
platform's acceleration: ``m x'' + c x' + k x = -m a``, the force ``k x + c x'``.  Below the
resonance that force is ``m a``, near it the force lags and grows.  None of the stage's inputs
holds it (the joints' positions, rates and accelerations are the motion of one instant, and
trees split on one column at a time), so per channel the stage's inputs get one more column in
the group :data:`MOTION`: the platform's world-frame acceleration along the reference (the core's
kinematics of the commanded joints, the pose's length coordinates: :func:`platform_acceleration`) filtered by a
resonator ``(2 zeta w s + w^2) / (s^2 + 2 zeta w s + w^2)`` (:data:`DAMPING`) at the frequency
of :data:`FREQUENCIES` whose filtered accelerations a least-squares fit of the residual follows
best, projected on the direction of a ridge fit of the residual on them (:func:`.oblique.direction`).
Frequency and direction are fitted per fold of the cross-validation on that fold's fitted rows only
(:class:`~.cv.FoldInputs`), and once on every sample for the final model and the black box
(:func:`extended`).  Measured on seen sets: docs/records/flexible_mujoco_runs.md, "The platform's motion".
"""
from __future__ import annotations

import math
import weakref

import numpy as np

from .cv import FoldInputs
from .oblique import direction, projected

#: the group of the column (:func:`extend`)
MOTION = "the platform's motion"
#: the resonators' frequencies searched [Hz]: a carried body's resonance (a tuned mass damper at
#: 4-9 Hz, a pendulum of 2-25 cm at 1-2.2 Hz); above the motion's band the response is the acceleration
FREQUENCIES = tuple(float(f) for f in np.geomspace(1.0, 12.0, 24))
#: the resonators' damping ratio: a light one, whose peak tells one resonance from its neighbours
#: (0.05 to 0.2 measured on a tuned mass damper at 8.7 Hz, damping 0.07, MuJoCo 51703: the held-out
#: share of the linear fit falls from 0.57 to 0.31 on its largest channel)
DAMPING = 0.05
#: the column is added where the linear fit through the resonance (frequency and direction fitted
#: per fold) explains out of fold at least this share of the residual's variance: elsewhere it is
#: one more column the trees may split on by chance (seen sets, MuJoCo 34700-45700, 50700 and
#: 51700, per channel fitted: the pendulum 0.01-0.75, 52 of 54 channels at or above it, the tuned
#: mass damper 0.16-0.39, 9 of 9; clean at most 0; the rail kinds, the bellows, the tendon, the pad
#: and the magnet at most 0.15, one channel of 54 tendon channels at it; above it also 6 of 54
#: spindle channels (up to 0.29), 6 of 19 fan channels (0.47, a line the resonator rings at), 3 of 12
#: spin drag's and 1 of 3 pump's (0.27))
MOTION_MIN = 0.15


def platform_acceleration(pipe) -> np.ndarray | None:
    """The commanded platform's acceleration [m/s^2] at every recorded row: the world-frame
    acceleration of the pose's length coordinates along the reference (``pipe.ref_motion``, the
    core's kinematics of ``qref``); None without a reference, or with no length coordinate that
    moves.  The reference, not the measured motion: a force on the platform (an unbalanced fan)
    shakes the measured platform, whose acceleration then holds the force as its consequence; the
    commanded motion holds no force's response, and a carried body follows it as the platform does."""
    ref = getattr(pipe, "ref_motion", None)
    if ref is None:
        return None
    x, xdd = np.asarray(ref[0], float), np.asarray(ref[2], float)
    units = getattr(pipe.model.facts, "pose_units", ())
    lengths = [i for i, u in enumerate(units[:xdd.shape[1]]) if u == "m" and np.std(x[:, i]) > 0]
    if not lengths or len(xdd) != len(pipe.t) or not np.all(np.isfinite(xdd[:, lengths])):
        return None
    return xdd[:, lengths]


def resonated(a, dt, frequency, starts=(0,)) -> np.ndarray:
    """The accelerations ``a`` (rows x coordinates, sample step ``dt`` [s]) through the resonator at
    ``frequency`` [Hz] (:data:`DAMPING`; the bilinear transform), restarted at rest at the rows
    ``starts``: the force per unit carried mass [m/s^2]."""
    from scipy.signal import bilinear, lfilter

    w = 2.0 * math.pi * frequency
    b, den = bilinear([2.0 * DAMPING * w, w * w], [1.0, 2.0 * DAMPING * w, w * w], 1.0 / dt)
    out = np.empty_like(a)
    edges = sorted(set(starts) | {0}) + [len(a)]
    for lo, hi in zip(edges[:-1], edges[1:]):
        out[lo:hi] = lfilter(b, den, a[lo:hi], axis=0)
    return out


def bank(pipe) -> dict | None:
    """Per frequency of :data:`FREQUENCIES`, the platform's accelerations through its resonator at
    the decimated samples (decimated x coordinates, read-only), or None without a platform's
    acceleration.  A function of the pipeline alone (fixed once built), filtered once per pipeline
    (:data:`_BANKS`): the stage asks for it on every channel it fits."""
    try:
        got = _BANKS.get(pipe, _BANKS)
    except TypeError:  # an object no weak reference can name (a stand-in for a pipeline): filtered each time
        return _filtered(pipe)
    if got is _BANKS:
        got = _BANKS[pipe] = _filtered(pipe)
    return None if got is None else dict(got)


def _filtered(pipe) -> dict | None:
    """:func:`bank`'s filtering."""
    a = platform_acceleration(pipe)
    if a is None:
        return None
    starts = [a0 for a0, _ in pipe.segments]
    got = {f: resonated(a, pipe.dt, f, starts)[pipe.idx] for f in FREQUENCIES}
    for r in got.values():
        r.setflags(write=False)
    return got


#: the banks of the pipelines alive (:func:`bank`), let go with their pipeline
_BANKS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _best(responses, y, rows) -> float:
    """The frequency whose responses a least-squares fit (with a constant) of ``y`` follows best on ``rows``."""
    def sse(f):
        A = np.column_stack([responses[f][rows], np.ones(len(rows))])
        coef = np.linalg.lstsq(A, y[rows], rcond=None)[0]
        e = y[rows] - A @ coef
        return float(e @ e)
    return min(responses, key=sse)


def fitted(responses, y, rows) -> tuple:
    """``(frequency, mean, scale, weights)``: the resonance and the direction fitted on ``rows``."""
    f = _best(responses, y, rows)
    return (f,) + direction(responses[f][rows], y[rows])


def _held_out_share(responses, y, fold_rows, per_fold) -> float:
    """The share of ``y``'s variance the fits ``per_fold`` (:func:`fitted` on each fold's fitted
    rows) explain on the folds' held-out rows."""
    var = float(np.var(y))
    if not var > 0:
        return 0.0
    pred = np.zeros_like(y)
    for (held, fit), p in zip(fold_rows, per_fold):
        pred[held] = projected(responses[p[0]][held], p[1:]) + y[np.asarray(fit)].mean()
    return 1.0 - float(np.mean((y - pred) ** 2)) / var


def extend(X, columns, groups, y, fold_rows, responses) -> tuple:
    """``X`` (n, p) with the platform's acceleration through its resonance projected on its fit
    (:func:`fitted`) per fold on its fitted rows (``fold_rows``) and on every sample, in the group
    :data:`MOTION`, where that fit explains :data:`MOTION_MIN` out of fold; ``responses`` of
    :func:`bank` (None: nothing added).  Returns ``(X, columns,
    groups, resonance)``, ``resonance`` the fit on every sample (:func:`extended`) or ()."""
    if responses is None:
        return X, columns, groups, ()
    y = np.asarray(y, float)
    per_fold = [fitted(responses, y, np.asarray(fit)) for _, fit in fold_rows]
    if not _held_out_share(responses, y, fold_rows, per_fold) >= MOTION_MIN:
        return X, columns, groups, ()
    whole = fitted(responses, y, np.arange(len(y)))
    columns = list(columns) + [(f"platform acceleration through a resonance at {whole[0]:.2g} Hz",
                                MOTION, None, "motion", "m/s^2")]
    groups = {g: list(c) for g, c in groups.items()}
    groups[MOTION] = [X.shape[1]]
    added = projected(responses[whole[0]], whole[1:])
    variants = getattr(X, "variants", None)
    base = np.asarray(X, float)
    if variants is None:
        variants = np.stack([base] * len(fold_rows))
    out = np.stack([np.column_stack([variants[b], projected(responses[p[0]], p[1:])]) for b, p in enumerate(per_fold)])
    return FoldInputs(np.column_stack([base, added]), out), columns, groups, tuple(whole)


def extended(X, pipe, resonance) -> np.ndarray:
    """The inputs ``X`` with the column :func:`extend` added on every sample (``resonance``: its
    fit), or ``X`` itself without one."""
    X = np.asarray(X, float)
    if not resonance:
        return X
    a = platform_acceleration(pipe)
    f, mean, scale, w = resonance
    r = resonated(a, pipe.dt, f, [a0 for a0, _ in pipe.segments])[pipe.idx]
    return np.column_stack([X, projected(r, (mean, scale, w))])
