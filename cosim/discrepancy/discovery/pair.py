"""A damper between two joints, found once as a pair (:func:`paired`).

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
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .terms import Coefficient, DiscoveredTerm


def _cross_partner(search, t):
    """The 0-based joint whose rate ``t``'s ``cross_v`` term holds, or None."""
    if "cross_v" not in t.terms:
        return None
    k = t.shape.get(search.name(t.joint - 1, "force_xj"))
    return None if k is None else int(k) - 1


def _halves(search, t) -> bool:
    """Does ``t`` hold a viscous friction of its own equal and opposite to its cross rate term
    (each direction's level within the intervals of minus the cross coefficient)?"""
    c = t.joint - 1
    xv = t.coefficients.get(search.name(c, "force_xv"))
    own = [t.coefficients.get(search.name(c, k)) for k in ("force_vpos", "force_vneg")]
    if xv is None or any(o is None for o in own):
        return False
    return all(abs(o.value + xv.value) <= math.hypot(o.ci95, xv.ci95) for o in own)


def _column(search, j, k):
    """The pair's column (samples, joints): the residual's change per unit c, from the search's
    columns of the core's ``force_vpos``, ``force_vneg`` and ``force_xv`` (None when the search
    holds no cross rate column from j to k or from k to j)."""
    X = np.zeros(search.base_residual.shape)
    for a, b in ((j, k), (k, j)):
        opt = next((o for o, sh in enumerate(search.fam.get("cross_v", ()))
                    if int(sh["force_xj"][a]) == b + 1), None)
        if opt is None or ("viscous_both", 0) not in search.cols:
            return None
        X[:, a] = search.cols[("viscous_both", 0)][:, a, :].sum(axis=1) - search.cols[("cross_v", opt)][:, a, 0]
    return X


def _chi2(search, R, chans, rows):
    eng = search.eng
    return float(sum(np.sum((R[rows, c] * search.w[c] * eng.use[rows, c]) ** 2) for c in chans))


def _held_rms(eng, R, a) -> float:
    """The RMS of channel a's held-out residual in ``R`` (NaN where it holds no sample, as a
    discovered term's)."""
    r = R[eng.test, a][eng.use[eng.test, a] > 0]
    return float(np.sqrt(np.mean(r ** 2))) if r.size else float("nan")


def _library_viscous(search, sel, theta, chans) -> list:
    """The library's viscous frictions selected on ``chans`` and still in ``theta``."""
    names = {search.name(c, "viscous") for c in chans}
    return [a.group for a in sel.selected
            if a.group.key == "viscous" and a.group.params[0] in names and a.group.params[0] in theta]


def _dropped(sep, libs) -> set:
    """The parameters the pair replaces: the separate terms' (but the library's offset they
    refitted, which stays at its refitted value) and the library viscous frictions'."""
    return ({p for t in sep for p in t.params() if not p.endswith(".offset")} | {g.params[0] for g in libs})


def _pair_terms(search, j, k, c, half, d_held, before, after) -> list:
    """The pair as the two channels' :class:`DiscoveredTerm` (``pair`` = the other joint)."""
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


def _trial(eng, search, sel, theta, found, j, k, threshold):
    """``(pair terms, library groups they replace)`` when the pair j-k wins, else None."""
    from .judgement import significant
    from ..structure import samples_per_independent

    X = _column(search, j, k)
    if X is None:
        return None
    chans = (j, k)
    sep = [t for t in found if t.joint - 1 in chans]
    libs = _library_viscous(search, sel, theta, chans)
    drop = _dropped(sep, libs)
    R_sep = eng.try_R(theta)
    R0 = eng.try_R({p: v for p, v in theta.items() if p not in drop})
    if R_sep is None or R0 is None:
        return None
    train, test = eng.train, eng.test
    w = np.concatenate([X[train, c] * search.w[c] * eng.use[train, c] for c in chans])
    y = np.concatenate([R0[train, c] * search.w[c] * eng.use[train, c] for c in chans])
    if not w @ w > 0:
        return None
    c_hat = -float(w @ y) / float(w @ w)
    R_pair = R0 + c_hat * X
    phi = samples_per_independent(eng.pipe)
    n_eff = sum(float((eng.use[train, c] > 0).sum()) for c in chans) / phi
    if not n_eff > 1.0:
        return None
    chi_pair = _chi2(search, R_pair, chans, train)
    # the separate model's coefficients (the library offset a term refitted stays on both sides)
    k_sep = sum(not p.endswith(".offset") for t in sep for p in t.coefficients) + len(libs)
    # the selection's criterion: BIC in effective samples, one coefficient against the separate ones
    if not chi_pair + math.log(n_eff) < _chi2(search, R_sep, chans, train) + k_sep * math.log(n_eff):
        return None
    # the discovery's held-out check (the pair lowers the held-out chi-square by more than the
    # threshold), and the separate model not significantly better there
    d_held = _chi2(search, R0, chans, test) - _chi2(search, R_pair, chans, test)
    if not d_held > threshold or significant(search, R_pair, R_sep, chans, threshold)[0]:
        return None
    s2 = max(chi_pair / max(n_eff - 1.0, 1.0), 1.0)
    half = 1.96 * math.sqrt(s2 / float(w @ w))
    before = {a: _held_rms(eng, R0, a) for a in chans}
    after = {a: _held_rms(eng, R_pair, a) for a in chans}
    return _pair_terms(search, j, k, c_hat, half, d_held, before, after), libs


def paired(eng, search, sel, theta, found, withdrawn, threshold):
    """``(found, withdrawn, theta)`` with each damper between two joints found as one pair term:
    where a channel's discovered term holds a viscous friction and a cross rate term that are
    equal and opposite (:func:`_halves`), the pair is tried (:func:`_trial`); when it wins it
    replaces the two channels' discovered terms, and the library viscous frictions on the two
    joints are withdrawn (``replaced_by`` the pair's channels)."""
    for t in list(found):
        k = _cross_partner(search, t)
        if k is None or t.pair or not _halves(search, t) or not any(u is t for u in found):
            continue
        j = t.joint - 1
        won = _trial(eng, search, sel, theta, found, j, k, threshold)
        if won is None:
            continue
        terms, libs = won
        sep = [u for u in found if u.joint - 1 in (j, k)]
        gone = _dropped(sep, libs)
        theta = {p: v for p, v in theta.items() if p not in gone}
        for u in terms:
            theta.update(u.params())
        chans = [u.channel for u in terms]
        withdrawn = withdrawn + [{"group": g.label, "effect": g.effect.name, "title": g.title,
                                  "params": {g.params[0]: float(sel.theta.get(g.params[0], float("nan")))},
                                  "replaced_by": chans, "pair": True} for g in libs]
        terms = [replace(u, instead_of=[w for v in sep for w in v.instead_of]) for u in terms]
        found = [u for u in found if u.joint - 1 not in (j, k)] + terms
    return found, withdrawn, theta
