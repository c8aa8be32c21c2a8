"""Noise model of the attribution (part 2 of the engine, see :mod:`.selection`).

Each channel is divided by its noise level and the square root of its variance inflation
``phi = 1 + 2 sum rho_L`` (autocorrelation of the residual of the fit with every linear
candidate), so that the chi-square counts effectively independent samples:
``N_eff = sum_c n / phi_c``; the floor is the pipeline's own accuracy.
"""
from __future__ import annotations

import math

import numpy as np


class NoiseModel:
    """Noise levels, inflation and weights of the channels (mixed into :class:`Engine`)."""

    def noise_model(self):
        """Per-channel noise level and variance inflation from the fit with every
        linear candidate column (first option of each group)."""
        cols = [o[0].cols for o in self.options.values() if o[0].cols is not None]
        # Profile effects enter linearised: a delay by its smallest-step change, a
        # saturation by its change at a middle level (an unmodelled 5 ms delay would
        # otherwise pass for noise ten times the real one and hide a second effect).
        for opts in self.options.values():
            o = opts[0]
            if o.cols is None and o.group.key in ("actuator_delay", "sensor_delay"):
                d = list(o.hyper["params"].values())[0] - self.nominal[o.group.params[0]]
                cols.append((o.offset / d)[:, :, None])
            elif o.cols is None:
                cols.append(opts[len(opts) // 2].offset[:, :, None])
        r = self.R0[self.train]
        sig = np.maximum(1.4826 * np.median(np.abs(r - np.median(r, axis=0)), axis=0), 1e-15)
        res = r
        used = self.use[self.train] > 0
        if cols:
            A = np.concatenate(cols, axis=2)
            for _ in range(3):
                w = 1.0 / sig
                X = self.vec_cols(A, w=w)
                y = self.vec(self.R0, w=w)
                beta, *_ = np.linalg.lstsq(X, y, rcond=None)
                res = (y - X @ beta).reshape(self.C, -1).T / w
                sig = np.maximum(np.sqrt(np.sum(res**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
        phi = np.array([_inflation(res[used[:, c], c], self.pipe.window, self.pipe.step) for c in range(self.C)])
        return np.maximum(sig, self.floor()), phi

    def floor(self):
        """Smallest noise level a channel is given: the accuracy of the pipeline itself
        (integration tolerance, smoothing round-off: 2e-5 of the effort on noiseless
        closed-loop runs), so a noiseless recording does not turn round-off into physics."""
        eff = 1e-4 * self.sc.effort
        return np.concatenate([eff, np.full(self.C - self.nd, 1e-8)])

    def accuracy(self):
        """The smallest residual structure that counts as physics, per channel: 1e-3 of the
        largest smoothed effort of the channel, at least :meth:`floor`.  A noiseless
        recording of the nominal plant still has a residual of 1e-4 of that peak (the
        smoother and the central difference of the rates err at the jerk peaks: 7.9e-5 N
        on the 70 mm step of scenarios/6pus_step_pd.toml, whose interior efforts peak at
        0.7 N), and no force of 0.1 % of the peak effort matters to a model.  The structure
        test and the discovery step use it; the selection keeps :meth:`floor`."""
        peak = np.max(np.abs(self.pipe.tau_s[self.pipe.idx]), axis=0)
        return np.maximum(self.floor(), np.concatenate([1e-3 * peak, np.full(self.C - self.nd, 1e-8)]))

    # ---------------------------------------------------------------- select

    def _weights(self, sig, phi):
        self.sig, self.phi = sig, phi
        self.w = 1.0 / (sig * np.sqrt(phi))
        self.W = self.w[None, :] * self.use
        n = (self.use[self.train] > 0).sum(axis=0)
        self.n_eff = float(np.sum(n / phi))
        self.instruments = {lab: self.vec(c) for lab, c in self._instrument_cols.items()}


def _inflation(r, window, step):
    """Variance inflation 1 + 2 sum_L rho_L of a decimated smoothed residual (sum to the
    first negative autocorrelation, at most two smoothing windows)."""
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
