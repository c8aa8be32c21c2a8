"""A damper or a spring between two joints, found once as a pair (:func:`paired`).

A damper linking joints j and k (a tendon with damping on q_j - q_k, a coupling) acts
c (qd_j - qd_k) against joint j and c (qd_k - qd_j) against joint k.  The per-channel search finds
it in halves: on j a viscous friction c qd_j and a force -c qd_k (``viscous_both`` and
``cross_v``), on k what is left of it beside a library viscous friction.  Where a channel's
discovered term holds both with its own coefficient minus the cross one within their intervals,
the pair term, one coefficient equal and opposite on both channels, is put against the two
channels' separate model (their discovered terms and the library viscous frictions on the two
joints): it replaces them when it pays the selection's criterion (BIC in effective samples, fewer
coefficients) and the separate model does not fit the held-out part significantly better
(:func:`.judgement.significant`).  The core holds the pair as each joint's ``force_vpos`` =
``force_vneg`` = c and ``force_xv`` = -c on the other joint (``force_xj``), so the plant, the
FMU and the replay simulate what is reported.  The pair's held-out chi-square change
(``delta_chi2_heldout``) is over both channels; its interval is the classical one of the
residual's own noise in effective samples (it is not bootstrapped).

A spring between joints j < k (a cable carrier or hose linking two carriages, stretched by their
difference) acts k (q_j - q_k - L) against joint j and its opposite on k: the halves are a spring
``force_k1`` and a cross position term ``force_xk1`` equal and opposite on one channel
(``spring`` and ``cross_q``), and the pair has two coefficients, the stiffness k and the
constant -k L equal and opposite on the two channels (the rest difference L).  It replaces the
separate terms' constants where the library held no offset; the library's offsets on the two
joints stay at their values (an equal and opposite pair of offsets is the same force as a change
of L, so L is the rest difference beside them).  The core holds it as each
joint's ``force_k1`` = k and ``force_xk1`` = -k, its own centre ``force_qc`` and the other
joint's ``force_xqc`` = ``force_qc`` - L on j and ``force_qc`` + L on k.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .terms import Coefficient, DiscoveredTerm

#: the pairs: kind -> (the own term, the cross term, the own coefficients, the cross coefficient)
KINDS = {"damper": ("viscous_both", "cross_v", ("force_vpos", "force_vneg"), "force_xv"),
         "spring": ("spring", "cross_q", ("force_k1",), "force_xk1")}


def _cross_partner(search, t, kind="damper"):
    """The 0-based joint whose rate (damper) or position (spring) ``t``'s cross term holds, or None."""
    if KINDS[kind][1] not in t.terms:
        return None
    k = t.shape.get(search.name(t.joint - 1, "force_xj"))
    return None if k is None else int(k) - 1


def _halves(search, t, kind="damper") -> bool:
    """Does ``t`` hold a term of its own (a viscous friction, a spring) equal and opposite to its
    cross term (each own level within the intervals of minus the cross coefficient)?"""
    c = t.joint - 1
    _, _, own_keys, cross_key = KINDS[kind]
    xv = t.coefficients.get(search.name(c, cross_key))
    own = [t.coefficients.get(search.name(c, k)) for k in own_keys]
    if xv is None or any(o is None for o in own):
        return False
    return all(abs(o.value + xv.value) <= math.hypot(o.ci95, xv.ci95) for o in own)


def _column(search, j, k, kind="damper"):
    """The pair's column (samples, joints): the residual's change per unit c (damper) or k
    (spring), from the search's columns of the core's own and cross coefficients (None when the
    search holds no cross column from j to k or from k to j)."""
    own, cross = KINDS[kind][:2]
    X = np.zeros(search.base_residual.shape)
    for a, b in ((j, k), (k, j)):
        opt = next((o for o, sh in enumerate(search.fam.get(cross, ()))
                    if int(sh["force_xj"][a]) == b + 1), None)
        if opt is None or (own, 0) not in search.cols:
            return None
        X[:, a] = search.cols[(own, 0)][:, a, :].sum(axis=1) - search.cols[(cross, opt)][:, a, 0]
    return X


def _columns(search, theta, j, k, kind):
    """``(columns, offsets)``: the damper's one column; the spring's stiffness, its constant
    equal and opposite on the two channels (+1 on the lower joint) and the offset of each of the
    two joints that ``theta`` holds (refitted with the pair), or, where both hold one, the
    stiffness and the two offsets (their equal and opposite part is the spring's constant,
    :func:`_spring_constant`).  ``offsets``: the refitted offsets' 0-based joints."""
    X = _column(search, j, k, kind)
    if X is None or kind == "damper":
        return (None if X is None else [X]), ()
    if ("constant", 0) not in search.cols:
        return None, ()
    lo, hi = min(j, k), max(j, k)
    one = search.cols[("constant", 0)]
    held = tuple(a for a in (lo, hi) if search.name(a, "offset") in theta)
    Os = []
    for a in held:
        O = np.zeros(X.shape)
        O[:, a] = one[:, a, 0]
        Os.append(O)
    if len(held) == 2:
        return [X] + Os, held
    C = np.zeros(X.shape)
    C[:, lo], C[:, hi] = one[:, lo, 0], -one[:, hi, 0]
    return [X, C] + Os, held


def _spring_constant(search, theta, coef, cov, held, lo, hi):
    """``((k, m), covariance of (k, m), {offset parameter: (new value, 95 % half width)})``: the
    stiffness and the lower joint's constant m from the fitted coefficients; where both joints
    hold an offset the equal and opposite part of the two (refitted) offsets is m and each keeps
    the common part."""
    off = {a: theta[search.name(a, "offset")] + coef[-len(held) + i] for i, a in enumerate(held)}
    if len(held) < 2:
        T = np.eye(2, len(coef))
        return T @ coef, T @ cov @ T.T, {search.name(a, "offset"): (float(v), 1.96 * math.sqrt(max(
            float(cov[-1, -1]), 0.0))) for a, v in off.items()}
    T = np.array([[1.0, 0.0, 0.0], [0.0, 0.5, -0.5]])
    common = 0.5 * (off[lo] + off[hi])
    half = 1.96 * math.sqrt(max(0.25 * float(cov[1, 1] + cov[2, 2] + 2.0 * cov[1, 2]), 0.0))
    km = np.array([coef[0], 0.5 * (off[lo] - off[hi])])
    return km, T @ cov @ T.T, {search.name(a, "offset"): (float(common), half) for a in (lo, hi)}


def offsets_zeroed(sel, terms) -> list:
    """The library's offsets the spring pair refitted to zero (within their 95 % interval): they
    stood in for its constant, and are withdrawn (the plant holds the refitted value)."""
    out = []
    for a in sel.selected:
        g = a.group
        c = next((t.coefficients[g.params[0]] for t in terms if g.key == "offset" and g.params[0] in t.coefficients),
                 None)
        if c is None or abs(c.value) > c.ci95:
            continue
        out.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                    "params": {g.params[0]: float(sel.theta.get(g.params[0], float("nan")))},
                    "replaced_by": [t.channel for t in terms],
                    "refitted": {"value": c.value, "ci95": c.ci95, "unit": c.unit}})
    return out


def chi2_on(search, R, chans, rows):
    eng = search.eng
    return float(sum(np.sum((R[rows, c] * search.w[c] * eng.use[rows, c]) ** 2) for c in chans))


def held_rms(eng, R, a) -> float:
    """The RMS of channel a's held-out residual in ``R`` (NaN where it holds no sample, as a
    discovered term's)."""
    r = R[eng.test, a][eng.use[eng.test, a] > 0]
    return float(np.sqrt(np.mean(r ** 2))) if r.size else float("nan")


def _library_viscous(search, sel, theta, chans) -> list:
    """The library's viscous frictions selected on ``chans`` and still in ``theta``."""
    names = {search.name(c, "viscous") for c in chans}
    return [a.group for a in sel.selected
            if a.group.key == "viscous" and a.group.params[0] in names and a.group.params[0] in theta]


def kept(t, p, kind) -> bool:
    """Does the pair keep separate term ``t``'s parameter ``p``?  The library's offset a term
    refitted stays at its refitted value; a spring's constant is the pair's, so the offset a
    spring's separate terms found where the library held none (its base 0) goes with them."""
    if not p.endswith(".offset"):
        return False
    return kind == "damper" or p not in t.coefficients or t.coefficients[p].base != 0.0


def dropped(sep, libs, kind="damper") -> set:
    """The parameters the pair replaces: the separate terms' (but the offsets it keeps,
    :func:`kept`) and the library viscous frictions'."""
    return {p for t in sep for p in t.params() if not kept(t, p, kind)} | {g.params[0] for g in libs}


def _pair_terms(search, j, k, c, half, d_held, before, after) -> list:
    """The damper pair as the two channels' :class:`DiscoveredTerm` (``pair`` = the other joint)."""
    j, k = min(j, k), max(j, k)
    units = {p.name: p.unit for p in search.eng.model.param_info()}
    noun = search.eng.model.facts.joint_noun
    u = units.get(search.name(j, "force_xv"), "")
    eq = (f"a damper between {noun}s {j + 1} and {k + 1}: F_{j + 1} = -c (qd{j + 1} - qd{k + 1}), "
          f"F_{k + 1} = +c (qd{j + 1} - qd{k + 1}), c = {c:.3g} +- {half:.2g} {u}")
    out = []
    for a, b in ((j, k), (k, j)):
        coefs = {search.name(a, key): Coefficient(search.name(a, key), s * c, half, units.get(search.name(a, key), ""))
                 for key, s in (("force_vpos", 1.0), ("force_vneg", 1.0), ("force_xv", -1.0))}
        out.append(DiscoveredTerm(a + 1, search.pipe.channels[a], ["viscous_both", "cross_v"], eq, coefs,
                                  {search.name(a, "force_xj"): float(b + 1)},
                                  "a damper between two joints: a coupling, a tendon or belt with damping on the "
                                  "two joints' difference", {}, before[a], after[a], d_held, "velocity", pair=b + 1))
    return out


def _spring_terms(search, j, k, coef, cov, offsets, d_held, before, after) -> list:
    """The spring pair as the two channels' :class:`DiscoveredTerm`: ``coef`` = (k, m), the
    stiffness and the lower joint's constant on top of k ((q_j - qc_j) - (q_k - qc_k)), ``cov``
    their covariance; the rest difference L = qc_j - qc_k - m / k (j < k); ``offsets`` {the
    library's offset: (its value refitted with the pair, 95 % half width)} (a coefficient of its
    joint's term)."""
    j, k = min(j, k), max(j, k)
    stiff, m = float(coef[0]), float(coef[1])
    qc = search.q_centre
    rest = float(qc[j] - qc[k] - m / stiff)
    grad = np.array([m / stiff ** 2, -1.0 / stiff])  # dL / d(k, m)
    half = 1.96 * math.sqrt(max(float(cov[0, 0]), 0.0))
    half_rest = 1.96 * math.sqrt(max(float(grad @ cov @ grad), 0.0))
    units = {p.name: p.unit for p in search.eng.model.param_info()}
    facts = search.eng.model.facts
    u = units.get(search.name(j, "force_k1"), "")
    d = f"q{j + 1} - q{k + 1} - L"
    eq = (f"a spring between {facts.joint_noun}s {j + 1} and {k + 1}: F_{j + 1} = -k ({d}), F_{k + 1} = +k ({d}), "
          f"k = {stiff:.3g} +- {half:.2g} {u}, rest difference L = {rest:.5g} +- {half_rest:.2g} {facts.joint_unit}")
    out = []
    for a, b, sign in ((j, k, 1.0), (k, j, -1.0)):
        coefs = {n: Coefficient(n, s * stiff, half, units.get(n, ""))
                 for n, s in ((search.name(a, "force_k1"), 1.0), (search.name(a, "force_xk1"), -1.0))}
        o = search.name(a, "offset")
        if o in offsets:
            coefs[o] = Coefficient(o, *offsets[o], units.get(o, ""), base=float(search.theta.get(o, 0.0)))
        shape = {search.name(a, "force_xj"): float(b + 1), search.name(a, "force_qc"): float(qc[a]),
                 search.name(a, "force_xqc"): float(qc[a] - sign * rest)}
        out.append(DiscoveredTerm(a + 1, search.pipe.channels[a], ["spring", "cross_q"], eq, coefs, shape,
                                  "a spring between two joints: a cable carrier, hose or belt linking two carriages, "
                                  "stretched by their difference", {}, before[a], after[a], d_held, "position",
                                  shape_ci95={search.name(a, "force_xqc"): half_rest}, pair=b + 1))
    return out


def _solve(search, eng, R0, Xs, chans):
    """``(coefficients, A)``: the least-squares coefficients of ``Xs`` on the weighted training
    rows of ``chans`` (R0 + sum b X the smallest), and the weighted design A (None: no column)."""
    train = eng.train
    A = np.stack([np.concatenate([X[train, c] * search.w[c] * eng.use[train, c] for c in chans]) for X in Xs], 1)
    y = np.concatenate([R0[train, c] * search.w[c] * eng.use[train, c] for c in chans])
    if len(Xs) == 1:
        w = A[:, 0]
        return (np.array([-float(w @ y) / float(w @ w)]), A) if w @ w > 0 else (None, None)
    if np.linalg.matrix_rank(A) < len(Xs):
        return None, None
    return -np.linalg.lstsq(A, y, rcond=None)[0], A


def _trial(eng, search, sel, theta, found, j, k, threshold, kind="damper"):
    """``(pair terms, library groups they replace)`` when the pair j-k wins, else None."""
    from .judgement import significant
    from ..structure import samples_per_independent

    chans = (j, k)
    sep = [t for t in found if t.joint - 1 in chans]
    libs = _library_viscous(search, sel, theta, chans) if kind == "damper" else []
    drop = dropped(sep, libs, kind)
    rest = {p: v for p, v in theta.items() if p not in drop}
    Xs, held = _columns(search, rest, j, k, kind)
    if Xs is None:
        return None
    R_sep = eng.try_R(theta)
    R0 = eng.try_R(rest)
    if R_sep is None or R0 is None:
        return None
    train, test = eng.train, eng.test
    coef, A = _solve(search, eng, R0, Xs, chans)
    if coef is None:
        return None
    R_pair = R0 + sum(b * X for b, X in zip(coef, Xs))
    phi = samples_per_independent(eng.pipe)
    n_eff = sum(float((eng.use[train, c] > 0).sum()) for c in chans) / phi
    if not n_eff > 1.0:
        return None
    chi_pair = chi2_on(search, R_pair, chans, train)
    # the separate model's coefficients (the offsets the pair keeps stay on both sides)
    k_sep = sum(not kept(t, p, kind) for t in sep for p in t.coefficients) + len(libs)
    # the selection's criterion: BIC in effective samples, the pair's coefficients against the separate ones
    if not chi_pair + len(Xs) * math.log(n_eff) < chi2_on(search, R_sep, chans, train) + k_sep * math.log(n_eff):
        return None
    # the discovery's held-out check (the pair lowers the held-out chi-square by more than the
    # threshold), and the separate model not significantly better there
    d_held = chi2_on(search, R0, chans, test) - chi2_on(search, R_pair, chans, test)
    if not d_held > threshold or significant(search, R_pair, R_sep, chans, threshold)[0]:
        return None
    s2 = max(chi_pair / max(n_eff - len(Xs), 1.0), 1.0)
    before = {a: held_rms(eng, R0, a) for a in chans}
    after = {a: held_rms(eng, R_pair, a) for a in chans}
    if kind == "damper":
        half = 1.96 * math.sqrt(s2 / float(A[:, 0] @ A[:, 0]))
        return _pair_terms(search, j, k, float(coef[0]), half, d_held, before, after), libs
    if not coef[0] > 0:  # a spring's stiffness pulls the two joints together
        return None
    km, cov, offsets = _spring_constant(search, rest, coef, s2 * np.linalg.inv(A.T @ A), held, min(j, k), max(j, k))
    return _spring_terms(search, j, k, km, cov, offsets, d_held, before, after), libs


def paired(eng, search, sel, theta, found, withdrawn, threshold):
    """``(found, withdrawn, theta)`` with each damper or spring between two joints found as one
    pair term: where a channel's discovered term holds a term of its own (a viscous friction, a
    spring) and a cross term (on the other joint's rate, its position) that are equal and opposite
    (:func:`_halves`), the pair is tried (:func:`_trial`); when it wins it replaces the two
    channels' discovered terms, and the library viscous frictions on the two joints (a damper's)
    and the library offsets a spring refitted to zero (:func:`offsets_zeroed`) are withdrawn
    (``replaced_by`` the pair's channels)."""
    for t, kind in [(t, kind) for t in found for kind in KINDS]:
        k = _cross_partner(search, t, kind)
        if k is None or t.pair or not _halves(search, t, kind) or not any(u is t for u in found):
            continue
        j = t.joint - 1
        won = _trial(eng, search, sel, theta, found, j, k, threshold, kind)
        if won is None:
            continue
        terms, libs = won
        sep = [u for u in found if u.joint - 1 in (j, k)]
        found, withdrawn, theta = installed(sel, theta, found, withdrawn, terms, sep, libs, kind)
    return found, withdrawn, theta


def installed(sel, theta, found, withdrawn, terms, sep, libs, kind) -> tuple:
    """``(found, withdrawn, theta)`` with a won pair ``terms`` in place of the two joints'
    separate discovered terms ``sep`` and the library groups ``libs``: their parameters leave
    ``theta`` (but the offsets the pair keeps, :func:`kept`) and the pair's enter; the groups are
    withdrawn (``replaced_by`` the pair's channels, each parameter's value recorded) and, for a
    spring, the library offsets it refitted to zero (:func:`offsets_zeroed`), each group once;
    the pair's terms carry what the separate terms stood ``instead_of``."""
    gone = dropped(sep, libs, kind)
    theta = {p: v for p, v in theta.items() if p not in gone}
    for u in terms:
        theta.update(u.params())
    chans = [u.channel for u in terms]
    withdrawn = withdrawn + [{"group": g.label, "effect": g.effect.name, "title": g.title,
                              "params": {p: float(sel.theta.get(p, float("nan"))) for p in g.params},
                              "replaced_by": chans, "pair": True} for g in libs]
    if kind == "spring":
        known = {w["group"] for w in withdrawn}
        withdrawn = withdrawn + [w for w in offsets_zeroed(sel, terms) if w["group"] not in known]
    terms = [replace(u, instead_of=[x for v in sep for x in v.instead_of]) for u in terms]
    return [u for u in found if not any(u is v for v in sep)] + terms, withdrawn, theta
