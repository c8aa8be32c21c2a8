"""The library's effects refitted beside the terms of the families (:func:`rejudge`).

The library's effects are selected before the discovery step, and the tie rule puts each on
trial against terms of the library of one joint's position and rate (:mod:`.judgement`); the
families' terms (``families/products.py``) are searched afterwards, on the model that stays.  A
library effect selected first may then hold part of a family term's force: a Coulomb friction
the part mu |tau| sign(qd) of a load-dependent friction holds at the recording's mean load, a
viscous friction the part (q_mean - q_c) qd of a damping over the stroke centred at q_c.  Named
with confidence, such an effect is a library name for physics outside the library.

Here each library effect of the effort family that acts on a channel whose discovered term holds
a family term is refitted together with the discovered terms (the terms' structure as found,
their coefficients free, the effect's size free: weighted least squares on the fitted part, each
channel weighted by its own noise in effective samples, as the discovery's search) and judged
again by the library's entry criterion: the effect must lower the chi-square by more than the
threshold plus its BIC price (log N_eff) beside the terms.

* It does not (the terms' own coefficients hold its share) and the held-out part does not need
  it either: **withdraw** (the caller searches its channels again without it and keeps the
  withdrawal when the terms found there fit the held-out part as well, else ties it).
* It does, but not beside the terms with their centres fitted (the position ``force_qc`` a
  damping or a Coulomb level over the stroke is centred on, the other joint's ``force_xqc``; the
  search holds them at the recording's mean), with the fitted centres no further than one
  recorded travel beyond its ends (:data:`CENTRE_REACH`): **tie** (named, not with confidence: a term centred there is the same force).
* Else **keep**.

Columns of a term that restate the effect (its direction-split pair of the same friction, an
added inertia for the rotor's, the offset refitted for the offset: :data:`SAME_PHYSICS`) are left
out on both sides: the question is whether the family's terms explain the effect.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .terms import TERMS
from ..families import acceptance
from ..structure import own_noise, samples_per_independent

#: per library effect, the coefficients of a discovered term that are its own column
SAME_PHYSICS = {"coulomb": ("force_cpos", "force_cneg"), "smooth_coulomb": ("force_cpos", "force_cneg"),
                "viscous": ("force_vpos", "force_vneg"), "rotor_inertia": ("force_inertia",),
                "offset": ("offset",)}
#: the shape parameters the search holds at the recording's mean position (the centres)
CENTRES = ("force_qc", "force_xqc")
#: how far beyond the recorded travel a fitted centre may lie, in recorded travels (hi - lo)
CENTRE_REACH = 1.0
#: a centre's finite-difference step, per unit of the joint's travel
CENTRE_STEP = 0.01


@dataclass(frozen=True)
class Verdict:
    """What the refit says of one library effect: ``kind`` "keep", "withdraw" or "tie"; the
    ``channels`` judged; the residuals (samples, channels) of the model with the effect refitted
    beside the terms (``R_with``) and without it (``R_without``); their free coefficients
    (``k_with``, ``k_without``); the fitted part's chi-square gain of the effect beside the terms
    (``gain``) and the bar it had to pass (``bar``); ``centres`` {core name: value} the terms'
    centres fitted where only they explain the effect, else {}."""
    kind: str
    channels: tuple
    R_with: np.ndarray
    R_without: np.ndarray
    k_with: int
    k_without: int
    gain: float
    bar: float
    centres: dict


def channel_noise(eng, R_lib) -> np.ndarray:
    """Each channel's own noise on the fitted part of ``R_lib``: the yardstick of "acts on a
    channel" (the engine's noise model is inflated by a missing force and would hide a small
    stand-in such as a gravity tilt)."""
    return np.array([own_noise(eng.pipe, R_lib[eng.train, c], eng.accuracy()[c]) for c in range(eng.nd)])


def acting_channels(eng, R_lib, R_minus, noise=None) -> list:
    """The channels an effect acts on: where its part of the residual (``R_lib - R_minus``)
    is above 0.3 of the residual's own noise (:func:`channel_noise`, computed when not given)."""
    noise = channel_noise(eng, R_lib) if noise is None else noise
    return [c for c in range(eng.nd) if np.sqrt(np.mean((R_lib[:, c] - R_minus[:, c]) ** 2)) > 0.3 * noise[c]]


def holds_family(term) -> bool:
    """Does the discovered ``term`` hold a term of the families?"""
    return term is not None and any(acceptance.is_family(n) for n in term.terms)


def _term_columns(search, term, key) -> np.ndarray:
    """The columns (samples, k) of ``term``'s coefficients on its channel, less those that are
    the library effect ``key``'s own (:data:`SAME_PHYSICS`)."""
    c = term.joint - 1
    same = SAME_PHYSICS.get(key, ())
    cols = []
    for name in term.terms:
        block = search.cols[(name, search.option_of(term, name))][:, c, :]
        for a, k in enumerate(TERMS[name][0]):
            if k not in same:
                cols.append(block[:, a])
    return np.column_stack(cols) if cols else np.zeros((block.shape[0], 0))


def _centre_columns(search, theta, term) -> tuple:
    """``(columns (samples, k), names, joints)``: the residual's slope on the term's channel over
    each centre (:data:`CENTRES`) the term holds (core names; the 0-based joint whose position
    it is), by finite differences through the core (the model ``theta`` with the term in it)."""
    eng, c = search.eng, term.joint - 1
    full = dict(theta, **term.params())
    names = [k for k in term.shape if k.rsplit(".", 1)[1] in CENTRES]
    if not names:
        return np.zeros((eng.test.shape[0], 0)), [], []
    R0 = eng.R(full)[:, c]
    cols, joints = [], []
    for k in names:
        j = int(term.shape.get(k.replace("force_xqc", "force_xj"), c + 1)) - 1 if k.endswith("force_xqc") else c
        d = CENTRE_STEP * float(search.travel[j])
        cols.append((eng.R(dict(full, **{k: full[k] + d}))[:, c] - R0) / d)
        joints.append(j)
    return np.column_stack(cols), names, joints


def _fit(search, R0, chans, blocks, rows):
    """Weighted least squares of ``R0 + X p`` over ``rows`` of ``chans`` (``blocks``: per channel
    its columns (samples, k_c) in a common parameter order, zero where a parameter is not on the
    channel): ``(p, chi2 on rows, residual (samples, nd))``, chi-square in effective samples."""
    eng = search.eng
    X = np.concatenate([blocks[c][rows] * (search.w[c] * eng.use[rows, c])[:, None] for c in chans])
    y = np.concatenate([R0[rows, c] * search.w[c] * eng.use[rows, c] for c in chans])
    p = np.linalg.lstsq(X, -y, rcond=None)[0] if X.shape[1] else np.zeros(0)
    r = y + X @ p
    R = R0.copy()
    for c in chans:
        R[:, c] = R0[:, c] + blocks[c] @ p
    return p, float(r @ r), R


def _blocks(eng, chans, shared, separate):
    """Per channel of ``chans``, its design (samples, k): the columns of ``shared`` ({channel:
    columns}, one parameter each over all channels: the effect's size) then, for each part of
    ``separate`` (a list of {channel: columns}), every channel's columns as parameters of their
    own (zero on the other channels)."""
    n = eng.test.shape[0]
    k_shared = max((v.shape[1] for v in shared.values()), default=0)
    layout = [(c, v) for part in separate for c, v in part.items()]
    k = k_shared + sum(v.shape[1] for _, v in layout)
    out = {}
    for c in chans:
        X = np.zeros((n, k))
        if c in shared:
            X[:, :k_shared] = shared[c]
        at = k_shared
        for c2, v in layout:
            if c2 == c:
                X[:, at:at + v.shape[1]] = v
            at += v.shape[1]
        out[c] = X
    return out


def rejudge(search, theta, R_lib, R_minus, g, base, threshold) -> Verdict | None:
    """The verdict on library group ``g`` (:class:`Verdict`), refitted beside the terms
    ``base`` (channel -> discovered term or None) of the model ``theta`` (residual ``R_lib``;
    ``R_minus`` without g), or None where g acts on no channel whose term holds a family term."""
    eng = search.eng
    chans = acting_channels(eng, R_lib, R_minus)
    terms = [base.get(c) for c in chans]
    if not any(holds_family(t) for t in terms):
        return None
    train = eng.train
    own = {c: (R_lib - R_minus)[:, c][:, None] for c in chans}  # the effect at its size: scale free
    cols = {t.joint - 1: _term_columns(search, t, g.key) for t in terms if t is not None}
    n_eff = sum(float((eng.use[train, c] > 0).sum()) / samples_per_independent(eng.pipe) for c in chans)
    bar = threshold + math.log(max(n_eff, 2.0))
    _, chi_a, R_a = _fit(search, R_minus, chans, _blocks(eng, chans, own, [cols]), train)
    _, chi_b, R_b = _fit(search, R_minus, chans, _blocks(eng, chans, {}, [cols]), train)
    k_b = sum(v.shape[1] for v in cols.values())
    if chi_b - chi_a <= bar:
        return Verdict("withdraw", tuple(chans), R_a, R_b, k_b + 1, k_b, chi_b - chi_a, bar, {})
    centres, names, joints = {}, [], []
    for t in terms:
        if t is not None and holds_family(t):
            X, ns, js = _centre_columns(search, theta, t)
            if ns:
                centres[t.joint - 1] = X
                names += ns
                joints += js
    if centres:
        _, chi_a1, _ = _fit(search, R_minus, chans, _blocks(eng, chans, own, [cols, centres]), train)
        p_b1, chi_b1, R_b1 = _fit(search, R_minus, chans, _blocks(eng, chans, {}, [cols, centres]), train)
        moved = {k: float(theta_of(base, k)) + float(s) for k, s in zip(names, p_b1[k_b:])}
        inside = all(_near_travel(search, j, moved[k]) for k, j in zip(names, joints))
        if chi_b1 - chi_a1 <= bar and inside:
            return Verdict("tie", tuple(chans), R_a, R_b1, k_b + 1, k_b + len(names), chi_b1 - chi_a1, bar, moved)
    return Verdict("keep", tuple(chans), R_a, R_b, k_b + 1, k_b, chi_b - chi_a, bar, {})


def _near_travel(search, j, q) -> bool:
    """Is the position ``q`` of joint j within :data:`CENTRE_REACH` recorded travels of the
    travel?  A term centred further away is, over the travel, its library column with a slope
    in all but name."""
    lo, hi = float(search.q_range[0][j]), float(search.q_range[1][j])
    reach = CENTRE_REACH * (hi - lo)
    return lo - reach <= q <= hi + reach


def theta_of(base, key) -> float:
    """The shape parameter ``key`` as the discovered terms of ``base`` hold it."""
    for t in base.values():
        if t is not None and key in t.shape:
            return t.shape[key]
    raise KeyError(key)


@dataclass(frozen=True)
class _Stated:
    """A discovered term as a tie record states it (its equation)."""
    equation: str


def centred(term, centres, unit) -> _Stated:
    """``term`` as the tie states it: its equation, with the centres ``centres`` ({core name:
    value}) it holds where they were fitted."""
    moved = [f"{k.rsplit('.', 1)[1]} = {x:.5g} {unit}" for k, x in centres.items() if k in term.shape]
    return _Stated(term.equation + (f", centred at {', '.join(moved)}" if moved else ""))
