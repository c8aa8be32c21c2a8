"""Inference of the attribution: :func:`infer` (step 4 of the engine, see :mod:`.engine`).

From a :class:`.selection.Selection`: the noise of the final fit, confidence intervals
(95 %, the widest of the chi-square rescaled, the HAC one, the spread across windows and, for
a friction, the spread across its joint's speed bands), the importance of each group
(chi-square increase when removed), look-alikes (the best alternative group in its place,
within ``lookalike_margin`` a tie; two selected groups that are one column on the recording,
:data:`VIF_ONE_COLUMN`, each other's tied look-alikes) and the detectability of every
candidate (the smallest amplitude that would have entered).  The result is a new :class:`.selection.Selection`.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .fitting import best_option, jacobian, removal
from . import intervals
from .intervals import block_jackknife, hac_covariance
from .keyed.power import FRICTIONS
from .regressors import reference_size
from .selection import Selection


def infer(st, sel: Selection) -> Selection:
    """The selection with its noise, intervals, importances, look-alikes and detectability.

    Parameters
    ----------
    st : FitState
        The weighted state the selection was made on, with the options the inference
        compares against (:func:`.engine.attribute` says which).
    sel : Selection
        From :func:`.selection.select`; not changed.

    Returns
    -------
    Selection
        A new selection: ``sigma`` the noise of the final fit (all channels, between the
        floor and ten times the weights' noise), each attribution with its ``values``,
        ``ci`` (half widths of the 95 % intervals), ``importance`` and ``lookalikes``, sorted
        by decreasing importance; ``detectability`` and ``collinear`` for every candidate.

    Examples
    --------
    >>> sel = infer(st, sel)                           # doctest: +SKIP
    >>> sel.selected[0].ci                             # doctest: +SKIP
    {'rail[1].coulomb': 0.0012}
    """
    theta = sel.theta
    # Noise of the final fit (all channels): for intervals and localisation bands.
    r = st.R(theta)[st.train]
    used = st.use[st.train] > 0
    sig = np.maximum(np.sqrt(np.sum(r**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
    sel = replace(sel, sigma=np.maximum(np.minimum(sig, st.sig * 10), st.floor()))
    # Intervals from the final Jacobian.
    if sel.selected:
        J, names, Z = jacobian(st, sel.selected, theta, instruments=True)
        # The wider of two intervals: the classical one of the noise model in effective
        # samples (never narrower than the measured noise allows: s^2 >= 1), and the HAC one,
        # (Z'J)^-1 S (J'Z)^-1 with S the scores' autocovariances summed over the lags of the
        # residual's correlation in time (Z = J for least squares), which widens where the
        # residual drifts with the trajectory
        dof = max(st.n_eff - J.shape[1], 1.0)
        s2 = max(sel.chi2_final / dof, 1.0)
        Zc = J if Z is None else Z
        A = np.linalg.pinv(Zc.T @ J, rcond=1e-12)
        classical = A @ (Zc.T @ Zc) @ A.T * s2
        e = st.vec(st.R(theta))
        cov, z95 = hac_covariance(J, e, Z, n_series=st.C)
        half = np.maximum(z95 * np.sqrt(np.maximum(np.diag(cov), 0.0)),
                          1.96 * np.sqrt(np.maximum(np.diag(classical), 0.0)))
        # and the model-form error the data show: the estimate's spread across the
        # recording's windows (a block jackknife), which a model that is not the plant's
        # widens however white its residual looks
        if intervals.WINDOW_SPREAD:
            cov_j, t95 = block_jackknife(J, e, Z, n_series=st.C)
            if np.all(np.isfinite(np.diag(cov_j))):
                half = np.maximum(half, t95 * np.sqrt(np.maximum(np.diag(cov_j), 0.0)))
        if intervals.SPEED_BANDS:
            half = _speed_bands(st, sel, J, e, Z, names, half)
        ci = dict(zip(names, half))
        selected = [replace(a, values={p: theta.get(p, st.nominal[p]) for p in a.group.params},
                            ci={p: float(ci.get(p, float("nan"))) for p in a.group.params})
                    for a in sel.selected]
        # Importance: chi-square increase when the group is removed (others refitted).
        importance = [removal(st, selected, theta, a)[0] for a in selected]
        selected = [replace(a, importance=i) for a, i in zip(selected, importance)]
        selected.sort(key=lambda a: -a.importance)
        sel = replace(sel, selected=tuple(selected))
        sel = replace(sel, selected=tuple(replace(a, lookalikes=looks)
                                          for a, looks in zip(sel.selected, _lookalikes(st, sel))))
        sel = replace(sel, selected=tuple(replace(a, lookalikes=looks + a.lookalikes)
                                          for a, looks in zip(sel.selected, _one_column(st, sel))))
    detectability, collinear = _detectability(st, sel)
    return replace(sel, detectability=detectability, collinear=collinear)


def _speed_bands(st, sel: Selection, J, e, Z, names, half):
    """``half`` with each friction's half widths at least those of its estimate's spread across
    its joint's speed bands (:func:`.intervals.block_jackknife` over the tenths of the joint's
    speed, the fitted samples).

    A friction is a law of its joint's speed.  Where the plant's law has another shape (MuJoCo's
    friction loss, a soft constraint, gives 0.31 of its level below 0.1 mm/s and 0.91 at
    0.3-1 mm/s, under the smallest velocity scale the rate noise resolves), the level fitted on
    the slow samples differs from that on the fast ones.  Every window in time holds slow and
    fast samples, so the spread across windows does not show it; the spread across speed bands
    does."""
    speed = np.abs(st.pipe.qd_s[st.pipe.idx][st.train])
    half = np.array(half, dtype=float)
    per_joint = {}  # one jackknife per joint: its frictions (Coulomb and viscous) share the bands
    for a in sel.selected:
        if a.group.key not in FRICTIONS or a.group.joint is None:
            continue
        if a.group.joint not in per_joint:
            per_joint[a.group.joint] = block_jackknife(J, e, Z, n_series=st.C, order=speed[:, a.group.joint])
        cov, t95 = per_joint[a.group.joint]
        for p in a.group.params:
            i = names.index(p) if p in names else None
            if i is not None and math.isfinite(cov[i, i]):
                half[i] = max(half[i], t95 * math.sqrt(max(cov[i, i], 0.0)))
    return half


def _lookalikes(st, sel: Selection) -> list:
    """For each selected group, the groups that could take its place (a list per group, in
    the order of ``sel.selected``): related effects and those within the look-alike margin."""
    logn = math.log(st.n_eff)
    theta = sel.theta
    bic_final = sel.chi2_final + sum(st.k(a.group) for a in sel.selected) * logn
    out = []
    for a in sel.selected:
        rest = [b for b in sel.selected if b is not a]
        th = {k: v for k, v in theta.items() if k not in a.group.params}
        J, _ = jacobian(st, rest, th)
        y = st.vec(st.R(th))
        Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
        y_perp = y - Q @ (Q.T @ y)
        k_rest = sum(st.k(b.group) for b in rest)
        base, base_chi2 = bic_final, sel.chi2_final
        if any(st.options[b.group.label][0].instr is not None for b in sel.selected if b.group.label in st.options):
            # with instruments the final chi-square is not a least-squares one: compare the
            # alternatives with the group itself fitted the same way as they are
            own = best_option(st, st.options[a.group.label], Q, y_perp, J, y)
            if own[0] is not None:
                base, base_chi2 = own[0] + (k_rest + own[1].k) * logn, own[0]
        cands = []
        for lab, opts in st.options.items():
            g = opts[0].group
            if lab == a.group.label or any(b.group.label == lab for b in rest):
                continue
            related = g.key in a.group.effect.lookalikes or a.group.key in g.effect.lookalikes
            same_place = g.joint is None or a.group.joint is None or g.joint == a.group.joint
            if not same_place:
                continue
            best = best_option(st, opts, Q, y_perp, J, y)
            if best[0] is None:
                continue
            bic_alt = best[0] + (k_rest + best[1].k) * logn
            dbic = bic_alt - base
            if related or dbic < st.settings.lookalike_margin:
                corr = _correlation(st, a.group, g, Q)
                # The fit apart from the parameter penalty: an alternative with more
                # parameters that fits exactly as well is the same physics here, not worse.
                cands.append({"group": g.label, "effect": g.key, "name": g.title, "delta_bic": float(dbic),
                              "delta_chi2": float(best[0] - base_chi2),
                              "extra_params": int(best[1].k - st.k(a.group)),
                              "correlation": corr, "related": related})
        cands.sort(key=lambda c: c["delta_bic"])
        out.append([c for c in cands if c["related"] or c["delta_bic"] < st.settings.lookalike_margin][:4])
    return out


#: variance inflation above which two selected groups are one column: the textbook level of
#: harmful collinearity (Kutner et al. 2005 sec. 10.5, docs/references.md), i.e. a squared
#: partial correlation above 0.9; not chosen on any recording
VIF_ONE_COLUMN = 10.0


def _one_column(st, sel: Selection) -> list:
    """For each selected group, the other selected groups it is (nearly) one column with.

    Two selected groups whose regressors, over the weighted samples the fit used and with the
    other selected groups taken out, have a largest canonical correlation rho with
    ``1 / (1 - rho^2) > VIF_ONE_COLUMN`` are one column on this recording (a dead zone under an
    effort that keeps one sign is a constant: the drive's offset): their split is set by the
    few samples where they differ, and whatever else the residual holds there, not by
    physics.  Each is listed as the other's look-alike with ``collinear`` set, a tie: neither
    is named with confidence.  The figures are those of taking it out with the other kept
    (``delta_chi2``, ``delta_bic``)."""
    out = [[] for _ in sel.selected]
    if len(sel.selected) < 2:
        return out
    J, names = jacobian(st, sel.selected, sel.theta)
    logn = math.log(st.n_eff)
    block = [[i for i, p in enumerate(names) if p in a.group.params] for a in sel.selected]
    for i, a in enumerate(sel.selected):
        for j, b in enumerate(sel.selected):
            if j <= i or not block[i] or not block[j]:
                continue
            rest = [k for m, blk in enumerate(block) if m not in (i, j) for k in blk]
            Q = np.linalg.qr(J[:, rest])[0] if rest else np.zeros((J.shape[0], 0))
            rho = _canonical(J[:, block[i]], J[:, block[j]], Q)
            if not rho < math.sqrt(1.0 - 1.0 / VIF_ONE_COLUMN):
                for (x, y, k) in ((a, b, i), (b, a, j)):
                    out[k].append({"group": y.group.label, "effect": y.group.key, "name": y.group.title,
                                   "delta_bic": float(x.importance - st.k(x.group) * logn),
                                   "delta_chi2": float(x.importance), "extra_params": 0,
                                   "correlation": float(rho), "related": True, "collinear": True})
    return out


def _canonical(X1, X2, Q):
    """Largest canonical correlation between the column spaces of X1 and X2 after removing the
    span of the orthonormal columns Q."""
    def basis(X):
        X = X - Q @ (Q.T @ X)
        u, s, _ = np.linalg.svd(X, full_matrices=False)
        return u[:, s > 1e-9 * (s[0] if len(s) else 1.0)]

    U1, U2 = basis(X1), basis(X2)
    if U1.shape[1] == 0 or U2.shape[1] == 0:
        return 0.0
    return float(np.clip(np.linalg.svd(U1.T @ U2, compute_uv=False)[0], 0.0, 1.0))


def _correlation(st, g1, g2, Q):
    """Largest canonical correlation between the two groups' column spaces (first
    option of each), after removing the other selected groups."""
    def signature(g):
        o = st.options[g.label][0]
        return st.vec_cols(o.cols) if o.cols is not None else st.vec(o.offset)[:, None]
    try:
        return _canonical(signature(g1), signature(g2), Q)
    except (np.linalg.LinAlgError, KeyError):
        return float("nan")


def _detectability(st, sel: Selection) -> tuple:
    """Smallest amplitude of each candidate that would have entered, against the
    effect's reference size: a group is 'not excited' if it is larger.  Returns
    (label -> (size, reference size), the labels collinear with the selected groups)."""
    logn = math.log(st.n_eff)
    J, _ = jacobian(st, sel.selected, sel.theta)
    Q = np.linalg.qr(J)[0] if J.shape[1] else None
    out = {}
    # groups whose signature lies in the span of the selected ones (a payload's mass on a
    # single axis whose moving mass is fitted): not unexcited, indistinguishable from them
    collinear = set()
    for lab, opts in st.options.items():
        o = opts[len(opts) // 2]
        g = o.group
        need = math.sqrt(st.settings.threshold + o.k * logn)
        if o.cols is not None:
            X = st.vec_cols(o.cols)
            n0 = float(np.linalg.norm(X[:, 0]))
            if Q is not None:
                X = X - Q @ (Q.T @ X)
                if n0 > 0 and float(np.linalg.norm(X[:, 0])) < 1e-6 * n0:
                    collinear.add(lab)
            s = np.linalg.svd(X, compute_uv=False)
            s_min = s[min(o.hyper.get("rank", len(s)), len(s)) - 1] if len(s) else 0.0
            # the amplitude column (first) for scalar summaries
            size = need / s_min if s_min > 0 else float("inf")
            if g.key == "payload" and len(g.params) == 4:
                size = need / max(np.linalg.norm(X[:, 0]), 1e-300)
        else:
            # a profile option: its offset scales roughly with the hyper-parameter
            off = st.vec(o.offset)
            if Q is not None:
                off = off - Q @ (Q.T @ off)
            val = list(o.hyper["params"].values())[0] - st.nominal[g.params[0]]
            nrm = np.linalg.norm(off)
            size = need * abs(val) / nrm if nrm > 0 else float("inf")
            if g.key in ("saturation", "dead_zone"):
                size = float("nan")
        out[lab] = (float(size), float(reference_size(g, st.sc, st.model)))
    return out, frozenset(collinear)
