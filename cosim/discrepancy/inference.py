"""Inference of the attribution (part 4 of the engine, see :mod:`.selection`).

The Jacobian of the native parameters by finite differences through the core, Gauss-Newton
refinement of the selected parameters on the exact residual, confidence intervals (95 %,
chi-square rescaled), the importance of each group (chi-square increase when removed),
look-alikes (the best alternative group in its place, within ``lookalike_margin`` a tie)
and the detectability of every candidate (the smallest amplitude that would have entered).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .intervals import hac_covariance
from .regressors import _NONNEGATIVE, LINEARISED, fit, reference_size

if TYPE_CHECKING:
    from .selection import Selection


class Inference:
    """Jacobians, refinement, intervals, look-alikes, detectability (mixed into :class:`Engine`)."""

    def jacobian(self, selected, theta, mask=None, instruments=False):
        """Weighted Jacobian (N, p) of the residual with respect to the selected native
        parameters at theta: the precomputed columns for linear parameters, central
        differences through the core for the others.  Returns (J, names), with
        ``instruments`` (J, names, Z): Z is J with the instrument in place of each column
        that has one (None when none has)."""
        names, cols, zcols = [], [], []
        for a in selected:
            g = a.group
            o = self.options[g.label][0] if g.label in self.options else None
            if g.key in LINEARISED or (g.key == "payload" and len(g.params) == 1):
                for j, p in enumerate(g.params):
                    names.append(p)
                    cols.append(self.vec_cols(o.cols[:, :, j:j + 1], mask=mask)[:, 0])
                    zcols.append(None if o.instr is None else self.vec_cols(o.instr[:, :, j:j + 1], mask=mask)[:, 0])
                continue
            for p in g.params:
                if g.key == "payload" and p != g.params[0] and theta.get(g.params[0], 0.0) <= 1e-9:
                    continue  # no payload yet: its offset does nothing
                v = theta.get(p, self.nominal[p])
                h = self._fd_step(g, p, v)
                if p.endswith(".delay"):
                    lo, hi = max(v - h, 0.0), min(v + h, (self.pipe.max_shift - 2) * self.pipe.dt)
                    col = (self.R(dict(theta, **{p: hi})) - self.R(dict(theta, **{p: lo}))) / (hi - lo)
                    names.append(p)
                    cols.append(self.vec(col, mask=mask))
                    continue
                Rhi = self._try_R(dict(theta, **{p: v + h}))
                Rlo = None if p.endswith(_NONNEGATIVE) and v - h < 0 else self._try_R(dict(theta, **{p: v - h}))
                if Rhi is not None and Rlo is not None:
                    col = (Rhi - Rlo) / (2 * h)
                elif Rhi is not None:
                    col = (Rhi - self.R(theta)) / h  # at a bound: one-sided
                elif Rlo is not None:
                    col = (self.R(theta) - Rlo) / h
                else:
                    col = np.zeros_like(self.R0)
                names.append(p)
                cols.append(self.vec(col, mask=mask))
                # The instrument of a non-linear parameter (the payload's mass and offset) is
                # its option's column along the reference at the nominal model: an instrument
                # need not be the derivative at theta, only free of the noise and correlated
                # with it (the estimate does not depend on its scale).
                zcols.append(None if o is None or o.instr is None
                             else self.vec_cols(o.instr[:, :, g.params.index(p):g.params.index(p) + 1], mask=mask)[:, 0])
        if not cols:
            n = int((self.train if mask is None else mask).sum()) * self.C
            return (np.zeros((n, 0)), [], None) if instruments else (np.zeros((n, 0)), [])
        J = np.column_stack(cols)
        if not instruments:
            return J, names
        if all(z is None for z in zcols):
            return J, names, None
        return J, names, np.column_stack([c if z is None else z for c, z in zip(cols, zcols)])

    def _fd_step(self, g, p, v):
        if p.endswith(".delay"):
            return 0.2e-3
        if p.endswith((".stribeck_v", ".coulomb_v")):
            return 0.05 * max(v, 1e-9)
        if p.endswith(".effort_max"):
            return 0.005 * max(v, 1e-9)
        if p.endswith(".stribeck"):
            return 0.05 * self.sc.effort[g.joint]
        if p == "payload.m":
            return max(0.05 * v, 1e-3)
        if p.startswith("payload."):
            return 2e-3
        return self._step(g, p)

    def refine(self, selected, theta, iterations: int = 3):
        """Refine the selected parameters on the exact residual: Gauss-Newton (least
        squares) over all but the delays, then each delay again by its instrumental root
        with the others fixed; a few rounds."""
        delays = [a for a in selected if a.group.key in ("actuator_delay", "sensor_delay")
                  and a.group.label in self.instruments]
        others = [a for a in selected if a not in delays]
        linear = all(a.group.key in LINEARISED or (a.group.key == "payload" and len(a.group.params) == 1)
                     for a in others)
        if linear and not delays:
            return theta
        for _ in range(iterations if delays else 1):
            before = dict(theta)
            theta = self._gauss_newton(others, theta, 1 if linear else 4)
            for a in delays:
                p = a.group.params[0]
                rest = {k: v for k, v in theta.items() if k != p}
                y = self.vec(self.R(rest))
                _, opt = self._try_delay(self.options[a.group.label], np.zeros((len(y), 0)), y)
                if opt is not None:
                    theta = dict(rest, **opt.hyper["params"])
            if all(abs(theta.get(k, 0.0) - before.get(k, 0.0)) <= 1e-9 * max(abs(before.get(k, 0.0)), 1e-12)
                   for k in set(theta) | set(before)):
                break
        return theta

    def _gauss_newton(self, selected, theta, iterations):
        """Gauss-Newton on the exact residual over the native parameters of ``selected``
        (the others held), with step halving.  With instruments the step solves the
        instrumental equations and the objective is the residual's part in the span of the
        instruments (zero at the instrumental estimate), not the chi-square."""
        if not selected:
            return theta
        y = self.vec(self.R(theta))
        for _ in range(iterations):
            J, names, Z = self.jacobian(selected, theta, instruments=True)
            if J.shape[1] == 0:
                break
            if Z is None:
                def measure(v):
                    return float(v @ v)
            else:
                Qz = np.linalg.qr(Z)[0]

                def measure(v):
                    p = Qz.T @ v
                    return float(p @ p)
            obj = measure(y)
            d = fit(J, y, Z, rcond=1e-10) if Z is None else fit(J, y, Z)
            improved = False
            for scale in (1.0, 0.5, 0.25):
                cand = self._clip({**theta, **{n: theta.get(n, self.nominal[n]) + scale * dv
                                              for n, dv in zip(names, d)}})
                Rc = self._try_R(cand)
                if Rc is None:
                    continue
                yc = self.vec(Rc)
                c2 = measure(yc)
                if c2 < obj:
                    improved = obj - c2 > 1e-6 * max(obj, float(yc @ yc) * 1e-12)
                    theta, obj, y = cand, c2, yc
                    break
            if not improved:
                break
        return theta

    # ------------------------------------------------------------- reporting

    def finish(self, sel: Selection):
        theta = sel.theta
        # Noise of the final fit (all channels): for intervals and localisation bands.
        r = self.R(theta)[self.train]
        used = self.use[self.train] > 0
        sig = np.maximum(np.sqrt(np.sum(r**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
        sel.sigma = np.maximum(np.minimum(sig, self.sig * 10), self.floor())
        # Intervals from the final Jacobian.
        if sel.selected:
            J, names, Z = self.jacobian(sel.selected, theta, instruments=True)
            # The wider of two intervals: the classical one of the noise model in effective
            # samples (never narrower than the measured noise allows: s^2 >= 1), and the HAC one,
            # (Z'J)^-1 S (J'Z)^-1 with S the scores' autocovariances summed over the lags of the
            # residual's correlation in time (Z = J for least squares), which widens where the
            # residual drifts with the trajectory
            dof = max(self.n_eff - J.shape[1], 1.0)
            s2 = max(sel.chi2_final / dof, 1.0)
            Zc = J if Z is None else Z
            A = np.linalg.pinv(Zc.T @ J, rcond=1e-12)
            classical = A @ (Zc.T @ Zc) @ A.T * s2
            cov, z95 = hac_covariance(J, self.vec(self.R(theta)), Z, n_series=self.C)
            half = np.maximum(z95 * np.sqrt(np.maximum(np.diag(cov), 0.0)),
                              1.96 * np.sqrt(np.maximum(np.diag(classical), 0.0)))
            ci = dict(zip(names, half))
            for a in sel.selected:
                a.values = {p: theta.get(p, self.nominal[p]) for p in a.group.params}
                a.ci = {p: float(ci.get(p, float("nan"))) for p in a.group.params}
            # Importance: chi-square increase when the group is removed (others refitted).
            for a in sel.selected:
                a.importance = self._without(sel.selected, theta, a)[0]
            sel.selected.sort(key=lambda a: -a.importance)
            self.lookalikes(sel)
        sel.detectability = self.detectability(sel)

    def lookalikes(self, sel: Selection):
        """For each selected group, the best group that could take its place."""
        logn = math.log(self.n_eff)
        theta = sel.theta
        bic_final = sel.chi2_final + sum(self._k(a.group) for a in sel.selected) * logn
        for a in sel.selected:
            rest = [b for b in sel.selected if b is not a]
            th = {k: v for k, v in theta.items() if k not in a.group.params}
            J, _ = self.jacobian(rest, th)
            y = self.vec(self.R(th))
            Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
            y_perp = y - Q @ (Q.T @ y)
            k_rest = sum(self._k(b.group) for b in rest)
            base, base_chi2 = bic_final, sel.chi2_final
            if any(self.options[b.group.label][0].instr is not None for b in sel.selected if b.group.label in self.options):
                # with instruments the final chi-square is not a least-squares one: compare the
                # alternatives with the group itself fitted the same way as they are
                own = self._best_option(self.options[a.group.label], Q, y_perp, J, y)
                if own[0] is not None:
                    base, base_chi2 = own[0] + (k_rest + own[1].k) * logn, own[0]
            cands = []
            for lab, opts in self.options.items():
                g = opts[0].group
                if lab == a.group.label or any(b.group.label == lab for b in rest):
                    continue
                related = g.key in a.group.effect.lookalikes or a.group.key in g.effect.lookalikes
                same_place = g.joint is None or a.group.joint is None or g.joint == a.group.joint
                if not same_place:
                    continue
                best = self._best_option(opts, Q, y_perp, J, y)
                if best[0] is None:
                    continue
                bic_alt = best[0] + (k_rest + best[1].k) * logn
                dbic = bic_alt - base
                if related or dbic < self.lookalike_margin:
                    corr = self._correlation(a.group, g, Q)
                    # The fit apart from the parameter penalty: an alternative with more
                    # parameters that fits exactly as well is the same physics here, not worse.
                    cands.append({"group": g.label, "effect": g.key, "name": g.title, "delta_bic": float(dbic),
                                  "delta_chi2": float(best[0] - base_chi2),
                                  "extra_params": int(best[1].k - self._k(a.group)),
                                  "correlation": corr, "related": related})
            cands.sort(key=lambda c: c["delta_bic"])
            a.lookalikes = [c for c in cands if c["related"] or c["delta_bic"] < self.lookalike_margin][:4]

    def _correlation(self, g1, g2, Q):
        """Largest canonical correlation between the two groups' column spaces (first
        option of each), after removing the other selected groups."""
        def space(g):
            o = self.options[g.label][0]
            if o.cols is not None:
                X = self.vec_cols(o.cols)
            else:
                X = self.vec(o.offset)[:, None]
            X = X - Q @ (Q.T @ X)
            u, s, _ = np.linalg.svd(X, full_matrices=False)
            keep = s > 1e-9 * (s[0] if len(s) else 1)
            return u[:, keep]
        try:
            U1, U2 = space(g1), space(g2)
            if U1.shape[1] == 0 or U2.shape[1] == 0:
                return 0.0
            return float(np.clip(np.linalg.svd(U1.T @ U2, compute_uv=False)[0], 0.0, 1.0))
        except (np.linalg.LinAlgError, KeyError):
            return float("nan")

    def detectability(self, sel: Selection):
        """Smallest amplitude of each candidate that would have entered, against the
        effect's reference size: a group is 'not excited' if it is larger."""
        logn = math.log(self.n_eff)
        J, _ = self.jacobian(sel.selected, sel.theta)
        Q = np.linalg.qr(J)[0] if J.shape[1] else None
        out = {}
        #: groups whose signature lies in the span of the selected ones (a payload's mass on a
        #: single axis whose moving mass is fitted): not unexcited, indistinguishable from them
        self.collinear = set()
        for lab, opts in self.options.items():
            o = opts[len(opts) // 2]
            g = o.group
            need = math.sqrt(self.threshold + o.k * logn)
            if o.cols is not None:
                X = self.vec_cols(o.cols)
                n0 = float(np.linalg.norm(X[:, 0]))
                if Q is not None:
                    X = X - Q @ (Q.T @ X)
                    if n0 > 0 and float(np.linalg.norm(X[:, 0])) < 1e-6 * n0:
                        self.collinear.add(lab)
                s = np.linalg.svd(X, compute_uv=False)
                s_min = s[min(o.hyper.get("rank", len(s)), len(s)) - 1] if len(s) else 0.0
                # the amplitude column (first) for scalar summaries
                size = need / s_min if s_min > 0 else float("inf")
                if g.key == "payload" and len(g.params) == 4:
                    size = need / max(np.linalg.norm(X[:, 0]), 1e-300)
            else:
                # a profile option: its offset scales roughly with the hyper-parameter
                off = self.vec(o.offset)
                if Q is not None:
                    off = off - Q @ (Q.T @ off)
                val = list(o.hyper["params"].values())[0] - self.nominal[g.params[0]]
                nrm = np.linalg.norm(off)
                size = need * abs(val) / nrm if nrm > 0 else float("inf")
                if g.key in ("saturation", "dead_zone"):
                    size = float("nan")
            out[lab] = (float(size), float(reference_size(g, self.sc, self.model)))
        return out
