"""The regressors of a joint's structure families and the residual's own noise: what
:mod:`.structure` tests a residual channel with and :mod:`.lines` fits beside a spectral line."""
from __future__ import annotations

import math

import numpy as np

#: velocity scales of the low-speed family, per RMS rate of the joint: the sign less a sign
#: that builds up over each scale (also the discovery step's grid of fading frictions,
#: discovery.FADE_GRID)
LOW_SPEEDS = (0.02, 0.06, 0.2)


def families(pipe, j: int) -> dict:
    """Regressors of joint j on the decimated samples, per signature."""
    idx = pipe.idx
    qd, q = pipe.qd_s[idx, j], pipe.q_s[idx, j]
    qdd, tau = pipe.qdd_s[idx, j], pipe.tau_s[idx, j]
    v_eps = 3.0 * max(float(pipe.qd_noise[j]), 1e-12)
    t_eps = 0.02 * max(float(np.std(tau)), 1e-12)
    z = (q - q.mean()) / max(float(np.std(q)), 1e-12)
    sign = np.tanh(qd / v_eps)
    # scales below twice the sign's (six times the rate noise) are no low speed the rates resolve, and the
    # samples whose smoothing window is mostly at rest (``pipe.usable``) count for nothing here: a
    # sharp friction evaluated at noisy rates leaves a fading shape of the noise's scale there
    scales = sorted({max(f * float(np.sqrt(np.mean(qd ** 2))), 2.0 * v_eps) for f in LOW_SPEEDS})
    moving = pipe.usable[:, j].astype(float)
    return {
        "velocity_sign": sign[:, None],
        "low_speed": np.column_stack([moving * (sign - np.tanh(qd / v)) for v in scales]),
        "command_sign": np.tanh(tau / t_eps)[:, None],
        "position": np.column_stack([z, z * z, z ** 3]),
        # a length error of a leg moves its joint by a pose-dependent amount: linear in the pose
        "pose": _standardised(pipe.x_s[idx]),
        "velocity": np.column_stack([qd, qd * np.abs(qd)]),
        "acceleration": qdd[:, None],
    }


def _standardised(X):
    X = np.asarray(X, float)
    s = X.std(axis=0)
    return (X - X.mean(axis=0))[:, s > 0] / s[s > 0]


def own_noise(pipe, r, floor=0.0) -> float:
    """The residual r's own high-frequency noise level: the median absolute difference of
    samples one smoothing window apart (robust, blind to anything slower), at least
    ``floor``.  Unlike the engine's noise model it is not inflated by a force the model
    lacks."""
    lag = int(math.ceil(pipe.window / pipe.step)) + 1
    r = np.asarray(r, float) - float(np.mean(r))
    d = r[lag:] - r[:-lag]
    sigma = 1.4826 * float(np.median(np.abs(d - np.median(d)))) / math.sqrt(2.0) if len(d) else 0.0
    return max(sigma, float(floor))


def samples_per_independent(pipe) -> float:
    """Decimated samples per independent one: the smoother correlates a window's worth."""
    return max(1.0, pipe.window / pipe.step)
