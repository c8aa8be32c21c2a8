"""Attribution: which effects of the library the residual supports, with what parameters.

Step 3 of the engine (:mod:`.engine`): :func:`select`, forward selection over the candidate
groups with BIC and backward elimination, on a weighted :class:`.fitstate.FitState`.  Its
result, a :class:`Selection` of :class:`Attribution`, is completed by :func:`.inference.infer`
(a new :class:`Selection`; neither is changed after it is returned).

Method (docs/discrepancy.md gives the reasoning):

1. Regressors (:func:`.regressors.candidates`).  Every candidate group (an effect on a joint,
   or a global effect) gets its columns from the residual pipeline by finite differences over
   its core parameters at the nominal model: one-sided for the parameters the core's residual
   is linear in (friction amplitudes, masses, inertias, gravity, encoder offset, gap,
   compliance), central for the others (payload offset, geometry).  Drive-layer and
   sensor parameters act on their own joint only (pkm.h), so one evaluation with the
   parameter moved on every joint gives the columns of all joints.  Non-linear
   hyper-parameters are profiled on a grid: the Stribeck velocity (linear amplitude
   per grid value), the delays and the saturation level (the exact residual change per
   grid value, no free amplitude).  The columns built from the measured motion (masses,
   inertias, viscous friction) get instruments, the same columns along the reference
   motion, and are estimated by instrumental variables (:func:`.regressors.fit`): the
   noise of the measured accelerations would bias least squares low.
2. Weights (:func:`.noise.noise_model`, :func:`.noise.weighted`).  Each channel is divided by
   its noise level and the square root of its variance inflation ``phi = 1 + 2 sum rho_L``
   (autocorrelation of the residual of the fit with every linear candidate), so that the
   chi-square counts effectively independent samples: ``N_eff = sum_c n / phi_c``.
3. Forward selection over groups with BIC (:func:`select`): a group enters if it lowers
   ``chi2 + k log N_eff`` by more than ``threshold``; a physical magnitude fitted with
   the wrong sign does not enter.  After each entry the selected parameters are
   refined by Gauss-Newton on the exact residual (columns of the native parameters by
   finite differences through the core, :mod:`.fitting`).
4. Inference (:func:`.inference.infer`): confidence intervals from the final Jacobian (95 %,
   chi-square rescaled), the importance of each group (chi-square increase when it is
   removed), look-alikes (the best alternative group in its place: if its BIC is within
   ``lookalike_margin`` the two cannot be told apart with this data) and the detectability
   of every candidate (the smallest amplitude that would have entered).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .effects import Group
from .fitting import best_option, evaluable, fitted_jointly, jacobian, refine, removal
from .regressors import LINEARISED, VELOCITY_SCALED, Option, fit, reference_size


@dataclass(frozen=True)
class Attribution:
    """One selected group with its fitted core parameters.

    Attributes
    ----------
    group : Group
        The effect on its joint (or global).
    values : dict
        Core parameter -> fitted value (set by :func:`.inference.infer`).
    ci : dict
        Core parameter -> half width of the 95 % interval, same unit.
    delta_bic : float
        BIC change when it entered (negative).
    importance : float
        Chi-square increase when it is removed from the final model.
    lookalikes : list of dict
        The alternatives that could take its place (:func:`.inference.infer`).
    """

    group: Group
    values: dict
    ci: dict
    delta_bic: float
    importance: float = 0.0
    lookalikes: list = field(default_factory=list)


@dataclass(frozen=True)
class Selection:
    """The result of :func:`select`, completed by :func:`.inference.infer`.

    Attributes
    ----------
    selected : tuple of Attribution
        The selected groups (by decreasing importance once inferred).
    theta : dict
        All fitted core parameters (nominal values omitted).
    chi2_nominal, chi2_final : float
        Weighted chi-square of the nominal and the fitted model (fitted samples).
    n_eff : float
        Effectively independent fitted samples.
    sigma : numpy.ndarray, shape (C,)
        Noise level per channel (of the final fit once inferred).
    phi : numpy.ndarray, shape (C,)
        Variance inflation per channel.
    steps : tuple of dict
        Log of the forward steps (group, delta BIC, chi-square).
    last_delta_bic : dict
        Group label -> delta BIC of its best option at the last forward step (the evidence
        against the groups left out).
    detectability : dict
        Group label -> (smallest detectable size, reference size), set by the inference.
    threshold : float
        The entry threshold used.
    refused : dict
        Group label -> why it was refused.
    collinear : frozenset
        Labels of the groups whose signature lies in the span of the selected ones (set by
        the inference): not unexcited, indistinguishable from them.
    """

    selected: tuple
    theta: dict
    chi2_nominal: float
    chi2_final: float
    n_eff: float
    sigma: np.ndarray
    phi: np.ndarray
    steps: tuple
    last_delta_bic: dict
    detectability: dict
    threshold: float
    refused: dict = field(default_factory=dict)
    collinear: frozenset = frozenset()


def select(st) -> tuple:
    """Forward selection over groups with BIC, with backward elimination.

    A group enters if it lowers ``chi2 + k log N_eff`` by more than the threshold (a
    physical magnitude fitted with the wrong sign does not enter); after each entry the
    selected parameters are refined on the exact residual (:func:`.fitting.refine`), the
    groups whose removal costs less than the threshold are dropped, and the groups whose
    fitted size is negligible or whose velocity scale left the grid are refused.

    Parameters
    ----------
    st : FitState
        With its candidates and weights (:func:`.noise.weighted`).

    Returns
    -------
    state : FitState
        ``st`` without the options of the refused groups (what the inference compares with).
    selection : Selection
        The selected groups (values, intervals, importance and look-alikes not yet set:
        :func:`.inference.infer`), the parameters, the chi-squares, the step log.

    Examples
    --------
    >>> st, sel = select(weighted(st, noise_model(st)))     # doctest: +SKIP
    >>> [a.group.label for a in sel.selected]                # doctest: +SKIP
    ['coulomb[1]']
    """
    logn = math.log(st.n_eff)
    selected, theta, steps = [], {}, []
    refused = {}
    # A group backward elimination took out does not come back in this selection: with
    # instruments the entry's gain and the removal's cost are two different fits, and
    # a group between them would go in and out until the entries run out.
    removed = set()
    y = st.vec(st.R0)
    chi2_nom = chi2 = float(y @ y)
    if st.settings.verbose:
        print(f"  noise {st.sig}, phi {st.phi}, N_eff {st.n_eff:.0f}, chi2 {chi2:.1f}")
    last_best = {}
    while len(steps) < st.settings.max_groups:  # entries (an all-joints entry adds several groups)
        # Delays already in the model are held (their instrumental estimate is
        # refreshed by refine); least squares would pull them to the noise-biased value.
        J, names, Z = jacobian(st, fitted_jointly(st, selected), theta, instruments=True)
        y = st.vec(st.R(theta))
        Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
        y_perp = y - Q @ (Q.T @ y)
        # The candidates are fitted with the current parameters projected out by least
        # squares; with instruments the current chi-square is above that projection's,
        # so the baseline is the projection's, or every candidate would be credited
        # with the difference.
        chi2 = float(y_perp @ y_perp) if Z is not None else float(y @ y)
        best, last_best = _best_entry(st, selected, removed, (Q, y_perp, J, y), chi2, logn)
        if best is None or best[0] > -st.settings.threshold:
            break
        dbic, opt, c2 = best
        coef_all = _coef(st, opt, J, y, Z)
        new = _apply(st, theta, names, coef_all, opt)
        if st.try_R(new) is None:
            # The fit is not a valid parameter set of the core: refuse the group.
            refused[opt.group.label] = "its fitted parameters are not a valid parameter set of the core"
            st = st.without_options([opt.group.label] + [g.label for g in opt.expand or []])
            continue
        before_entry, entered = theta, [Attribution(g, {}, {}, float(dbic)) for g in opt.expand or [opt.group]]
        theta = refine(st, selected + entered, new)
        why = _unphysical_entry(st, selected, theta)
        if why:
            # An entry whose refinement takes a parameter selected before it out of the physical
            # ranges (an actuator limit at ~0 once a mass enters: with the force clipped at zero any
            # mass fits) is two nearly dependent effects fighting; it is refused alone and the fit
            # that stood before it stands.  An entry unphysical in its own parameters only is kept:
            # the whole fit is then refused (.verdict), the model itself being in question.
            refused[opt.group.label] = why
            st = st.without_options([opt.group.label] + [g.label for g in opt.expand or []])
            theta = before_entry
            continue
        selected += entered
        if st.settings.verbose:
            print(f"  + {opt.group.label}: dBIC {dbic:.1f} -> {theta}")
        steps.append({"group": opt.group.label, "delta_bic": float(dbic),
                      "chi2": float(st.chi2(theta))})
        before = {a.group.label for a in selected}
        selected, theta = _prune(st, selected, theta, logn)
        removed |= before - {a.group.label for a in selected}
        # Statistically supported but physically negligible (a tenth of a 'small'
        # effect, e.g. a 5 us delay): model misfit leaking into a candidate, not physics.
        for a in list(selected):
            why = _why_refused(st, a.group, theta)
            if why:
                selected.remove(a)
                for p in a.group.params:
                    theta.pop(p, None)
                st = st.without_options([a.group.label])
                refused[a.group.label] = why
                theta = refine(st, selected, theta)
    return st, Selection(tuple(selected), theta, chi2_nom, st.chi2(theta), st.n_eff, st.sig, st.phi, tuple(steps),
                         last_best, {}, st.settings.threshold, refused)


def _unphysical_entry(st, selected, theta):
    """Why the refined parameters of the groups ``selected`` before an entry are not physical
    after it (:func:`.verdict.fit_problems` on theirs), or None."""
    from .verdict import fit_problems

    params = {p for a in selected for p in a.group.params}
    problems = fit_problems(st, {p: v for p, v in theta.items() if p in params})
    return "its fit is not physical: " + "; ".join(problems) if problems else None


def _best_entry(st, selected, removed, projected, chi2, logn):
    """``(best, last_best)``: the entry that lowers the BIC most, ``(delta BIC, option,
    chi2)`` or None, among the groups not selected, not removed and sharing no parameter
    with a selected one, and every candidate's delta BIC by label.  ``projected`` is
    ``(Q, y_perp, J, y)`` of the current fit, ``chi2`` its baseline."""
    Q, y_perp, J, y = projected
    best = None
    last_best = {}
    taken = {a.group.label for a in selected} | removed
    # A group that shares a parameter with a selected one (a fading and a step
    # Coulomb friction of one joint) would fight over it: the first one in stays.
    held = {p for a in selected for p in a.group.params}
    for lab, opts in list(st.options.items()) + list(_joint_sets(st, taken).items()):
        if lab in taken or held & set(opts[0].group.params):
            continue
        c2, o2 = best_option(st, opts, Q, y_perp, J, y)
        if c2 is None:
            continue
        gbest = (c2 - chi2 + o2.k * logn, o2, c2)
        last_best[lab] = gbest[0]
        # Two candidates that are the same physics here (a dead zone under a command
        # of one sign that never enters the zone, and an offset of that sign) fit
        # equally to rounding: rounding does not choose.  The linear one is named (a
        # constant force is all the recording shows; the dead zone's behaviour near
        # zero command is nowhere in it), the other stays its tie; between two of a
        # kind, the first in the library's order.
        tol = 1e-9 * abs(chi2)
        if (best is None or gbest[0] < best[0] - tol
                or (gbest[0] <= best[0] + tol and _plainer(o2.group, best[1].group))):
            best = gbest
    return best, last_best


def _why_refused(st, group, theta):
    """Why a selected group is refused though statistically supported, or None: physically
    negligible (a tenth of a 'small' effect, e.g. a 5 us delay: model misfit leaking into a
    candidate, not physics), or a velocity scale above the recording's joint speeds."""
    size = _magnitude(st, group, theta)
    ref = reference_size(group, st.sc, st.model)
    why = None
    # (a saturation's parameter is its limit, not the size of what it does; a dead zone's is
    # the constant it takes off a one-signed command, an offset's size: both are judged)
    if group.key != "saturation" and ref > 0 and size < 0.1 * ref:
        why = f"fitted size {size:.3g} is below a tenth of a small one ({ref:.3g}): negligible"
    elif group.key in VELOCITY_SCALED:
        # A velocity scale that left the grid upwards is not resolved by this recording:
        # a fading friction never reaches its full value (friction proportional to
        # speed), a Stribeck peak never fades (a constant friction: Coulomb).
        v, top = theta.get(group.params[1], 0.0), float(st.velocity_grid()[-1])
        if v > 1.5 * top:
            what = ("a friction proportional to speed" if group.key == "smooth_coulomb" else
                    "a friction that never fades, Coulomb friction")
            why = (f"its velocity scale {v:.3g} is above the joint speeds of the recording "
                   f"({top:.3g}): on this recording it is {what}")
    return why


def _plainer(a, b) -> bool:
    """Of two groups that fit alike, ``a`` claims less beyond the recording: a linear
    effect (a column the recording shows) against a profiled non-linear one."""
    return a.effect.kind == "linear" and b.effect.kind != "linear"


def _joint_sets(st, taken):
    """All-joints candidates: a per-joint effect on every joint not yet selected (a
    friction or an offset on every rail enters in one step instead of a greedy chain
    that another multi-parameter group could cut short)."""
    out = {}
    by_key = {}
    for lab, opts in st.options.items():
        g = opts[0].group
        if g.joint is None or lab in taken or len(opts) != 1 or g.key not in LINEARISED:
            continue
        by_key.setdefault(g.key, []).append(opts[0])
    for key, opts in by_key.items():
        if len(opts) < 2:
            continue
        cols = np.concatenate([o.cols for o in opts], axis=2)
        # a joint whose instrument is too weak keeps its own column (least squares there)
        instr = None if all(o.instr is None for o in opts) else np.concatenate(
            [o.cols if o.instr is None else o.instr for o in opts], axis=2)
        groups = [o.group for o in opts]
        pseudo = Group(groups[0].effect, None, tuple(g.params[0] for g in groups))
        out[f"{key}[all]"] = [Option(pseudo, cols, None, {}, len(opts), expand=groups, instr=instr)]
    # A dead zone on every drive: the same width (as a fraction of each joint's typical
    # effort) enters on all at once, then refine sets each width; one joint at a time, a
    # payload's moments would take the common part first.  A drive's dead zone acts on
    # its own effort channel only, so the all-joints offset is the sum of the joints' own.
    by_frac = {}
    for lab, opts in st.options.items():
        g = opts[0].group
        if g.key != "dead_zone" or g.joint is None or lab in taken:
            continue
        for o in opts:
            by_frac.setdefault(o.hyper["fraction"], []).append(o)
    dz = []
    for f, opts in sorted(by_frac.items()):
        if len(opts) < 2:
            continue
        groups = [o.group for o in opts]
        pseudo = Group(groups[0].effect, None, tuple(g.params[0] for g in groups))
        params = {k: v for o in opts for k, v in o.hyper["params"].items()}
        dz.append(Option(pseudo, None, sum(o.offset for o in opts), {"params": params, "fraction": f},
                         len(opts), expand=groups))
    if dz:
        out["dead_zone[all]"] = dz
    return out


def _prune(st, selected, theta, logn):
    """Backward elimination: drop groups at the edge of their physical range, then,
    one at a time, the group whose removal costs less BIC than the threshold.  Returns
    ``(selected, theta)``, new ones (the given ones unchanged)."""
    selected, theta = list(selected), dict(theta)
    for a in list(selected):
        if a.group.effect.sign == ">=0" and all(theta.get(p, st.nominal[p]) <= 0 for p in a.group.params[:1]):
            selected.remove(a)
            for p in a.group.params:
                theta.pop(p, None)
    while len(selected) > 1:
        worst = None
        for a in selected:
            imp, th, th2 = removal(st, selected, theta, a)
            cost = imp - st.k(a.group) * logn
            if worst is None or cost < worst[0]:
                worst = (cost, a, th, th2)
        if worst[0] >= st.settings.threshold:
            break
        selected = [b for b in selected if b is not worst[1]]
        # the others refitted, where the core can evaluate them (tried for the group removed only)
        theta = refine(st, selected, evaluable(st, worst[2], worst[3]))
        if st.settings.verbose:
            print(f"  - {worst[1].group.label}: removal costs {worst[0]:.1f} in BIC")
    return selected, theta


def _magnitude(st, g, theta):
    """Size of a group's fitted change, in the unit of its reference size."""
    p = g.params
    if g.key == "payload" or g.key in VELOCITY_SCALED:
        p = p[:1]
    d = np.array([theta.get(n, st.nominal[n]) - st.nominal[n] for n in p])
    return float(np.linalg.norm(d))


def _coef(st, o, J, y, Z=None):
    """Joint fit: changes of the current parameters, then the option's coefficients
    (instrumental variables where the current parameters ``Z`` or the option have
    instruments, least squares otherwise)."""
    t = y.copy()
    if o.offset is not None:
        t += st.vec(o.offset)
    X = J if o.cols is None else np.hstack([J, st.vec_cols(o.cols)])
    if X.shape[1] == 0:
        return np.zeros(0)
    W = None
    if Z is not None or o.instr is not None:
        W = J if Z is None else Z
        if o.cols is not None:
            W = np.hstack([W, st.vec_cols(o.cols if o.instr is None else o.instr)])
    rank = o.hyper.get("rank")
    if rank is not None and o.cols is not None and rank < o.cols.shape[2]:
        return fit(X, t, W, rcond=1e-6)
    return fit(X, t, W)


def _apply(st, theta, names, coef_all, opt):
    theta = dict(theta)
    for nme, c in zip(names, coef_all[: len(names)]):
        theta[nme] = theta.get(nme, st.nominal[nme]) + c
    theta.update(opt.native(coef_all[len(names):], st.nominal))
    return st.clip(theta)
