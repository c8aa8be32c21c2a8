"""Noise model of the attribution: :func:`noise_model` and :func:`weighted` (step 2 of the
engine, see :mod:`.engine`).

Each channel is divided by its noise level and the square root of its variance inflation
``phi = 1 + 2 sum rho_L`` (autocorrelation of the residual of the fit with every linear
candidate), so that the chi-square counts effectively independent samples:
``N_eff = sum_c n / phi_c``; the floor is the pipeline's own accuracy
(:meth:`.fitstate.FitState.floor`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True, eq=False)
class NoiseLevels:
    """The result of :func:`noise_model`.

    Attributes
    ----------
    sigma : numpy.ndarray, shape (C,)
        Noise level per channel, in the channel's unit, at least the floor.
    phi : numpy.ndarray, shape (C,)
        Variance inflation per channel (>= 1).
    """

    sigma: np.ndarray
    phi: np.ndarray


def noise_model(st) -> NoiseLevels:
    """Per-channel noise level and variance inflation from the fit with every linear
    candidate column (first option of each group).

    Parameters
    ----------
    st : FitState
        With its candidates (:meth:`.fitstate.FitState.with_candidates`).

    Returns
    -------
    NoiseLevels

    Examples
    --------
    >>> nl = noise_model(st)          # doctest: +SKIP
    >>> st = weighted(st, nl)         # doctest: +SKIP
    """
    cols = [o[0].cols for o in st.options.values() if o[0].cols is not None]
    # Profile effects enter linearised: a delay by its smallest-step change, a
    # saturation by its change at a middle level (an unmodelled 5 ms delay would
    # otherwise pass for noise ten times the real one and hide a second effect).
    for opts in st.options.values():
        o = opts[0]
        if o.cols is None and o.group.key in ("actuator_delay", "sensor_delay"):
            d = list(o.hyper["params"].values())[0] - st.nominal[o.group.params[0]]
            cols.append((o.offset / d)[:, :, None])
        elif o.cols is None:
            cols.append(opts[len(opts) // 2].offset[:, :, None])
    r = st.R0[st.train]
    sig = np.maximum(1.4826 * np.median(np.abs(r - np.median(r, axis=0)), axis=0), 1e-15)
    res = r
    used = st.use[st.train] > 0
    if cols:
        A = np.concatenate(cols, axis=2)
        for _ in range(3):
            w = 1.0 / sig
            X = st.vec_cols(A, w=w)
            y = st.vec(st.R0, w=w)
            beta, *_ = np.linalg.lstsq(X, y, rcond=None)
            res = (y - X @ beta).reshape(st.C, -1).T / w
            sig = np.maximum(np.sqrt(np.sum(res**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
    phi = np.array([inflation(res[used[:, c], c], st.pipe.window, st.pipe.step) for c in range(st.C)])
    return NoiseLevels(np.maximum(sig, st.floor()), phi)


def weighted(st, noise: NoiseLevels):
    """The state with the channel weights ``1 / (sigma sqrt(phi))`` of ``noise``.

    Parameters
    ----------
    st : FitState
        With its candidates (the delays' instruments are weighted too).
    noise : NoiseLevels
        Noise level and inflation per channel.

    Returns
    -------
    FitState
        A copy with ``sig``, ``phi``, ``W``, ``n_eff`` (effectively independent fitted
        samples, ``sum_c n_c / phi_c``) and the weighted ``instruments`` set.
    """
    sig, phi = noise.sigma, noise.phi
    w = 1.0 / (sig * np.sqrt(phi))
    W = w[None, :] * st.use
    n = (st.use[st.train] > 0).sum(axis=0)
    st = replace(st, sig=sig, phi=phi, W=W, n_eff=float(np.sum(n / phi)))
    return replace(st, instruments=MappingProxyType({lab: st.vec(c) for lab, c in st.instrument_cols.items()}))


def inflation(r, window, step):
    """Variance inflation ``1 + 2 sum_L rho_L`` of a decimated smoothed residual.

    Parameters
    ----------
    r : numpy.ndarray, shape (n,)
        One channel's residual on the decimated samples it uses.
    window, step : int
        The smoothing window and the decimation [samples]: the sum runs to the first
        negative autocorrelation, over at most two windows' worth of lags.

    Returns
    -------
    float
        At least 1 (1 for white noise or a zero residual).

    Examples
    --------
    >>> import numpy as np
    >>> inflation(np.array([1.0, -1.0] * 50), window=20, step=10)
    1.0
    """
    r = r - r.mean()
    v = float(r @ r)
    if v <= 0:
        return 1.0
    lmax = max(1, int(math.ceil(2 * window / step)))
    s = 0.0
    for L in range(1, min(lmax, len(r) // 4) + 1):
        rho = float(r[:-L] @ r[L:]) / v
        if rho <= 0:
            break
        s += rho
    return max(1.0, 1.0 + 2.0 * s)
