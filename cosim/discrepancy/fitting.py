"""The fits the selection (:mod:`.selection`) and the inference (:mod:`.inference`) share.

Free functions over a :class:`.fitstate.FitState` (its weights set): the weighted Jacobian of
the selected native parameters (:func:`jacobian`, finite differences through the core for the
non-linear ones), the refinement of the selected parameters on the exact residual
(:func:`refine`: Gauss-Newton, the delays by their instrumental root), the chi-square of a
candidate option against the current model (:func:`best_option`, :func:`try_option`,
:func:`try_delay`) and the cost of removing a selected group (:func:`without`).  None of them
changes its arguments.
"""
from __future__ import annotations

import math

import numpy as np

from .regressors import _NONNEGATIVE, LINEARISED, Option, fit

#: a delay's instrumental root must be this many standard errors from zero
DELAY_T = 3.0


def jacobian(st, selected, theta, mask=None, instruments=False):
    """Weighted Jacobian (N, p) of the residual with respect to the selected native
    parameters at theta: the precomputed columns for linear parameters, central
    differences through the core for the others.

    Parameters
    ----------
    st : FitState
        Weighted, with the options of the selected groups.
    selected : sequence of Attribution
        The groups whose native parameters are the columns.
    theta : dict
        Core parameter -> value (the others nominal).
    mask : numpy.ndarray of bool, optional
        Decimated samples of the rows (default: the fitted ones).
    instruments : bool
        Also return the instruments.

    Returns
    -------
    J : numpy.ndarray, shape (n C, p)
        Weighted columns, one per native parameter.
    names : list of str
        The core parameter of each column.
    Z : numpy.ndarray, shape (n C, p), or None
        With ``instruments`` only: J with the instrument in place of each column that has
        one (None when none has): a delay estimated by its instrumental root
        (:func:`try_delay`) has that instrument, the options with instruments theirs.
    """
    names, cols, zcols = [], [], []

    def add(p, col, z=None):
        # one place for a column and its instrument: Z must match J column for column
        names.append(p)
        cols.append(col)
        zcols.append(z)

    for a in selected:
        g = a.group
        o = st.options[g.label][0] if g.label in st.options else None
        if g.key in LINEARISED or (g.key == "payload" and len(g.params) == 1):
            for j, p in enumerate(g.params):
                add(p, st.vec_cols(o.cols[:, :, j:j + 1], mask=mask)[:, 0],
                    None if o.instr is None else st.vec_cols(o.instr[:, :, j:j + 1], mask=mask)[:, 0])
            continue
        for p in g.params:
            if g.key == "payload" and p != g.params[0] and theta.get(g.params[0], 0.0) <= 1e-9:
                continue  # no payload yet: its offset does nothing
            v = theta.get(p, st.nominal[p])
            h = _fd_step(st, g, p, v)
            if p.endswith(".delay"):
                lo, hi = max(v - h, 0.0), min(v + h, (st.pipe.max_shift - 2) * st.pipe.dt)
                col = (st.R(dict(theta, **{p: hi})) - st.R(dict(theta, **{p: lo}))) / (hi - lo)
                # estimated by its instrumental root where it has an instrument (refine):
                # its interval is that estimate's, with the same instrument
                add(p, st.vec(col, mask=mask),
                    st.vec(st.instrument_cols[g.label], mask=mask) if g.label in st.instruments else None)
                continue
            Rhi = st.try_R(dict(theta, **{p: v + h}))
            Rlo = None if p.endswith(_NONNEGATIVE) and v - h < 0 else st.try_R(dict(theta, **{p: v - h}))
            if Rhi is not None and Rlo is not None:
                col = (Rhi - Rlo) / (2 * h)
            elif Rhi is not None:
                col = (Rhi - st.R(theta)) / h  # at a bound: one-sided
            elif Rlo is not None:
                col = (st.R(theta) - Rlo) / h
            else:
                col = np.zeros_like(st.R0)
            # The instrument of a non-linear parameter (the payload's mass and offset) is
            # its option's column along the reference at the nominal model: an instrument
            # need not be the derivative at theta, only free of the noise and correlated
            # with it (the estimate does not depend on its scale).
            add(p, st.vec(col, mask=mask),
                None if o is None or o.instr is None
                else st.vec_cols(o.instr[:, :, g.params.index(p):g.params.index(p) + 1], mask=mask)[:, 0])
    if not cols:
        n = int((st.train if mask is None else mask).sum()) * st.C
        return (np.zeros((n, 0)), [], None) if instruments else (np.zeros((n, 0)), [])
    J = np.column_stack(cols)
    if not instruments:
        return J, names
    if all(z is None for z in zcols):
        return J, names, None
    return J, names, np.column_stack([c if z is None else z for c, z in zip(cols, zcols)])


def _fd_step(st, g, p, v):
    if p.endswith(".delay"):
        return 0.2e-3
    if p.endswith((".stribeck_v", ".coulomb_v")):
        return 0.05 * max(v, 1e-9)
    if p.endswith(".effort_max"):
        return 0.005 * max(v, 1e-9)
    if p.endswith(".stribeck"):
        return 0.05 * st.sc.effort[g.joint]
    if p == "payload.m":
        return max(0.05 * v, 1e-3)
    if p.startswith("payload."):
        return 2e-3
    return st.step(g, p)


def refine(st, selected, theta, iterations: int = 3):
    """Refine the selected parameters on the exact residual: Gauss-Newton (least
    squares) over all but the delays, then each delay again by its instrumental root
    with the others fixed; a few rounds.

    Parameters
    ----------
    st : FitState
        Weighted, with the options of the selected groups.
    selected : sequence of Attribution
        The groups whose parameters move.
    theta : dict
        Starting parameters; not changed.
    iterations : int
        Rounds when there are delays.

    Returns
    -------
    dict
        The refined parameters (``theta`` itself when every selected group is linear and
        there is no delay: nothing to refine).
    """
    delays = [a for a in selected if a.group.key in ("actuator_delay", "sensor_delay")
              and a.group.label in st.instruments]
    others = [a for a in selected if a not in delays]
    linear = all(a.group.key in LINEARISED or (a.group.key == "payload" and len(a.group.params) == 1)
                 for a in others)
    if linear and not delays:
        return theta
    for _ in range(iterations if delays else 1):
        before = dict(theta)
        theta = _gauss_newton(st, others, theta, 1 if linear else 4)
        for a in delays:
            p = a.group.params[0]
            rest = {k: v for k, v in theta.items() if k != p}
            y = st.vec(st.R(rest))
            _, opt = try_delay(st, st.options[a.group.label], np.zeros((len(y), 0)), y)
            if opt is not None:
                theta = dict(rest, **opt.hyper["params"])
        if all(abs(theta.get(k, 0.0) - before.get(k, 0.0)) <= 1e-9 * max(abs(before.get(k, 0.0)), 1e-12)
               for k in set(theta) | set(before)):
            break
    if delays and others:
        # The rounds above move one side with the other held; a delay and a look-alike of it
        # (viscous friction, a rotor inertia: the same phase shift of the effort) then zig-zag
        # towards their joint root by a factor of their squared correlation per round and stop
        # short of it (a Quattro's delay and four viscous frictions: 0.1 % and 1 % low, twice
        # the stated half widths, after three rounds).  The joint instrumental step solves the
        # equations the intervals are computed from (jacobian with instruments), all at once.
        theta = _gauss_newton(st, selected, theta, 3)
    return theta


def _gauss_newton(st, selected, theta, iterations):
    """Gauss-Newton on the exact residual over the native parameters of ``selected``
    (the others held), with step halving.  With instruments the step solves the
    instrumental equations and the objective is the residual's part in the span of the
    instruments (zero at the instrumental estimate), not the chi-square."""
    if not selected:
        return theta
    y = st.vec(st.R(theta))
    for _ in range(iterations):
        J, names, Z = jacobian(st, selected, theta, instruments=True)
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
            cand = st.clip({**theta, **{n: theta.get(n, st.nominal[n]) + scale * dv
                                          for n, dv in zip(names, d)}})
            Rc = st.try_R(cand)
            if Rc is None:
                continue
            yc = st.vec(Rc)
            c2 = measure(yc)
            if c2 < obj:
                improved = obj - c2 > 1e-6 * max(obj, float(yc @ yc) * 1e-12)
                theta, obj, y = cand, c2, yc
                break
        if not improved:
            break
    return theta


def fitted_jointly(st, selected):
    """The selected groups a linearised joint fit may move: all but the delays estimated
    by their instrumental root (held, refreshed by refine)."""
    return [a for a in selected if not (a.group.key.endswith("_delay") and a.group.label in st.instruments)]


def without(st, selected, theta, a):
    """The cost of removing a selected group.

    Parameters
    ----------
    st : FitState
        Weighted.
    selected : sequence of Attribution
        The selected groups, ``a`` among them.
    theta : dict
        Their parameters.
    a : Attribution
        The group removed.

    Returns
    -------
    increase : float
        Chi-square increase when ``a`` is removed and the others are refitted (linearised;
        ``inf`` when the core refuses the parameters without it).
    theta : dict
        The parameters of that refit.
    """
    increase, th, th2 = removal(st, selected, theta, a)
    return increase, evaluable(st, th, th2)


def evaluable(st, th, th2):
    """``th2`` (the others refitted after a removal, :func:`removal`) where the core can
    evaluate it, else ``th`` (the parameters without the removed group)."""
    return th if th2 is None or st.try_R(th2) is None else th2


def removal(st, selected, theta, a):
    """:func:`without` with the refit's parameters not yet tried: ``(increase, th, th2)``, ``th``
    the parameters without ``a`` and ``th2`` those of the others refitted (None without a refit),
    which :func:`without` returns when the core can evaluate them.  The increase does not depend
    on that: a caller that needs only it, or the parameters of one removal, tries one
    evaluation instead of one per group."""
    rest = [b for b in selected if b is not a]
    th = {k: v for k, v in theta.items() if k not in a.group.params}
    Rt = st.try_R(th)
    if Rt is None:
        return float("inf"), theta, None
    y = st.vec(Rt)
    # as in the selection: delays estimated by instruments are held (least squares
    # would pull them to the noise-biased value and credit the removal with that fit)
    Jr, names, Zr = jacobian(st, fitted_jointly(st, rest), th, instruments=True)
    th2 = None
    if Jr.shape[1]:
        d = fit(Jr, y, Zr)
        y = y + Jr @ d
        th2 = st.clip({**th, **{n: th.get(n, st.nominal[n]) + dv for n, dv in zip(names, d)}})
    return float(y @ y) - st.chi2(theta), th, th2


def best_option(st, opts, Q, y_perp, J, y):
    """The best way a group can enter the current model.

    Parameters
    ----------
    st : FitState
        Weighted.
    opts : sequence of Option
        The group's options.
    Q : numpy.ndarray, shape (n C, p)
        Orthonormal basis of the current parameters' columns (projected out).
    y_perp : numpy.ndarray, shape (n C,)
        The weighted residual with them projected out.
    J, y : numpy.ndarray
        The current columns and weighted residual.

    Returns
    -------
    (float, Option) or (None, None)
        Chi-square with the option and the option fitted; (None, None) when no option fits
        with a physical sign.
    """
    g = opts[0].group
    if g.key in ("actuator_delay", "sensor_delay") and g.label in st.instruments:
        return try_delay(st, opts, Q, y_perp)
    if g.key == "dead_zone":
        return _try_width(st, opts, Q, y_perp)
    best = (None, None)
    for o in opts:
        c2, _, o2 = try_option(st, o, Q, y_perp, J, y)
        if c2 is not None and (best[0] is None or c2 < best[0]):
            best = (c2, o2)
    return best


def try_option(st, o, Q, y_perp, J, y):
    """chi-square of the current model plus option o, its coefficients (parameter
    changes) and the option actually fitted; (None, None, o) if the fit has a
    non-physical sign.  An all-joints option of a non-negative effect keeps the
    joints whose coefficient is positive (active set).

    The residual after a change is ``y + offset + X c`` (+ ``J d`` for the current
    parameters, projected out through Q: least squares for them, also where they have
    instruments, so that every option is measured against the same baseline, the
    chi-square of ``y_perp``).  An option with instruments gets its coefficients by
    instrumental variables, the current parameters partialled out of both."""
    t = y_perp
    if o.offset is not None:
        off = st.vec(o.offset)
        t = t + (off - Q @ (Q.T @ off))
    if o.cols is None:
        return float(t @ t), np.zeros(0), o
    X = st.vec_cols(o.cols)
    Xp = X - Q @ (Q.T @ X)
    Zp = None
    if o.instr is not None:
        # instrumental variables, the current parameters partialled out of both
        Z = st.vec_cols(o.instr)
        Zp = Z - Q @ (Q.T @ Z)
    keep = np.arange(X.shape[1])
    while True:
        coef = fit(Xp[:, keep], t, None if Zp is None else Zp[:, keep])
        if o.expand is None or o.group.effect.sign != ">=0" or np.all(coef >= 0):
            break
        keep = keep[coef >= 0]
        if len(keep) == 0:
            return None, None, o
    if o.expand is not None and len(keep) < X.shape[1]:
        if len(keep) < 2:
            return None, None, o
        o = Option(o.group, o.cols[:, :, keep], None, o.hyper, len(keep), [o.expand[i] for i in keep],
                   None if o.instr is None else o.instr[:, :, keep])
    if not o.sign_ok(coef):
        return None, None, o
    r = t + Xp[:, keep] @ coef
    return float(r @ r), coef, o


def _try_width(st, opts, Q, y_perp):
    """A dead zone's width between its profile grid's values: the residual change is
    interpolated linearly between neighbouring widths (from no dead zone to the
    smallest, then grid value to grid value) and the chi-square minimised on each
    segment.  Where the joint's command keeps one sign the change is exactly linear in
    the width (a constant u0 on the command's side), so the dead zone then fits exactly
    as well as a constant effort offset of that sign, its look-alike, instead of losing
    to it by the grid's spacing."""
    g = opts[0].group
    ts = [y_perp]
    for o in opts:
        off = st.vec(o.offset)  # (once: the same weighted offset on both sides)
        ts.append(y_perp + (off - Q @ (Q.T @ off)))
    best, where = None, None
    for i in range(len(opts)):
        d = ts[i + 1] - ts[i]
        dd = float(d @ d)
        a = min(max(-float(ts[i] @ d) / dd, 0.0), 1.0) if dd > 0 else 1.0
        if i == 0 and a == 0.0:
            continue  # no dead zone at all is not an option
        r = ts[i] + a * d
        c2 = float(r @ r)
        if best is None or c2 < best:
            best, where = c2, (i, a)
    if best is None:
        return None, None
    i, a = where
    hi = opts[i]
    lo_off = np.zeros_like(hi.offset) if i == 0 else opts[i - 1].offset
    lo_par = {k: st.nominal[k] for k in hi.hyper["params"]} if i == 0 else opts[i - 1].hyper["params"]
    lo_f = 0.0 if i == 0 else opts[i - 1].hyper["fraction"]
    params = {k: (1 - a) * lo_par[k] + a * v for k, v in hi.hyper["params"].items()}
    off = (1 - a) * lo_off + a * hi.offset
    return best, Option(g, None, off, {"params": params, "fraction": (1 - a) * lo_f + a * hi.hyper["fraction"]},
                        hi.k, expand=hi.expand)


def try_delay(st, opts, Q, y_perp):
    """A delay by instrumental variables: the delay d where the instrument (the
    reference effort's signature, free of rate noise) is orthogonal to the exact
    residual, then the exact chi-square there.  Least squares on the recorded
    command would instead fit the closed loop's reaction to the rate noise (a
    spurious delay of about M/kd times the noise share of the effort changes)."""
    z = st.instruments[opts[0].group.label]
    z = z - Q @ (Q.T @ z)
    ds, f, c2 = [0.0], [float(z @ y_perp)], [float(y_perp @ y_perp)]
    for o in opts:
        off = st.vec(o.offset)
        t = y_perp + (off - Q @ (Q.T @ off))
        ds.append(list(o.hyper["params"].values())[0] - st.nominal[o.group.params[0]])
        f.append(float(z @ t))
        c2.append(float(t @ t))
    best = (None, None)
    p = opts[0].group.params[0]
    for i in range(len(ds) - 1):
        if f[i] == 0 or np.sign(f[i]) == np.sign(f[i + 1]):
            continue
        a = f[i] / (f[i] - f[i + 1])  # linear interpolation of the root
        d = ds[i] + a * (ds[i + 1] - ds[i])
        if d <= 0:
            continue
        lo = opts[i - 1].offset if i > 0 else np.zeros_like(opts[0].offset)
        off = (1 - a) * lo + a * opts[i].offset
        t = y_perp + (st.vec(off) - Q @ (Q.T @ st.vec(off)))
        chi = float(t @ t)
        # The root's standard error, sqrt(z'z s2) / |d(z't)/dd|: a root within
        # DELAY_T of them of zero is the noise's (the root drifts off zero as the rate
        # noise grows: 14 us, 85 us, 212 us at 0.2, 1, 3 mm/s on a clean MuJoCo run).
        slope = abs(f[i + 1] - f[i]) / (ds[i + 1] - ds[i])
        se = math.sqrt(float(z @ z) * max(chi / st.n_eff, 1.0)) / slope if slope > 0 else float("inf")
        if d < DELAY_T * se:
            continue
        if best[0] is None or chi < best[0]:
            best = (chi, Option(opts[0].group, None, off, {"params": {p: st.nominal[p] + d}}, 1))
    return best
