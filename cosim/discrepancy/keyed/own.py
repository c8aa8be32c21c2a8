"""A library effect whose level is keyed on its own joint's position or on the time since the
joint last reversed: the products the confidence rule of :mod:`.elsewhere` tries.

A friction of the library on joint j has one level over the whole stroke and at every moment.
A friction that rises over part of the stroke (a rough zone of a rail, an eddy-current brake
under part of it), or one that is larger just after the joint reverses and decays afterwards (a
seal, a stiction that relaxes), is fitted by the library's friction at its mean level, and the
rest can hide in the channel's own noise, the yardstick of the structure test.  Such a level is
the effect's own force g on the channel times a function of the joint's position, or of the time
s since the last reversal of its rate:

* :func:`stroke_basis`: bands of the stroke between the edges of ``EDGES - 1`` equal parts of
  the range the joint covers (from its 1st to its 99th percentile; every band of consecutive
  parts but the whole stroke, smooth edges) and the polynomials u, u^2, u^3 of the position
  scaled to that range: a zone, a step, a trend along the stroke;
* :func:`reversal_basis`: exp(-s / tau) for the time constants ``TAUS``, s the time since the
  smoothed rate last changed sign beyond a dead band (from the start of a stretch before the
  first reversal).

Each product is counted in the look-elsewhere cost of the rule (:func:`.elsewhere.modulations`).
The library's effects on the effort whose force is a function of position or of reversals are
the kinematic ones (an encoder offset, a backlash, an elasticity, a geometry error act through
the readings, and the readings' error moves the inverse dynamics with the pose and flips at
reversals): they are not tested here (``KINEMATIC``).  The products are zero on the samples
whose smoothing window is mostly at rest (``pipe.usable``), where the fit does not look either.
docs/discrepancy.md, section 4, "Nor where its level follows the joint's own position or its
reversals", states the bars and what they were measured on.
"""
from __future__ import annotations

import numpy as np

#: edges of the parts of the stroke (the bands are the runs of consecutive parts)
EDGES = 7
#: time constants [s] of the decay after a reversal
TAUS = (0.05, 0.1, 0.2, 0.5, 1.0)
#: library effects whose force on the effort is keyed on the position or on reversals by nature
KINEMATIC = frozenset({"encoder_offset", "backlash", "compliance", "geometry"})


def stroke_basis(q, name: str = "q", unit: str = "m", edges: int = EDGES) -> tuple:
    """Functions of a joint's position ``q`` (n,) over its stroke: ``(Z, names)``, Z (n, m).

    The stroke is [q_1 %, q_99 %]; the bands run between two of ``edges`` equally spaced edges
    (every pair but the whole stroke), their sides tanh ramps of 2 % of the stroke; then u, u^2,
    u^3 of u = (q - q_1 %) / stroke.  A position that does not move gives no column.

    Example
    -------
    >>> Z, names = stroke_basis(np.linspace(0.0, 0.1, 500), "q4")
    >>> Z.shape[1], names[0]
    (23, 'q4 in 0.001-0.0173 m')
    """
    q = np.asarray(q, float)
    lo, hi = (float(v) for v in np.quantile(q, [0.01, 0.99]))
    if not hi > lo:
        return np.zeros((len(q), 0)), []
    u = (q - lo) / (hi - lo)
    e = np.linspace(0.0, 1.0, edges)
    w = 0.02
    cols, names = [], []
    for a in range(edges - 1):
        for b in range(a + 1, edges):
            if a == 0 and b == edges - 1:
                continue
            left = 1.0 if a == 0 else 0.5 * (1.0 + np.tanh((u - e[a]) / w))
            right = 1.0 if b == edges - 1 else 0.5 * (1.0 - np.tanh((u - e[b]) / w))
            cols.append(left * right)
            names.append(f"{name} in {lo + e[a] * (hi - lo):.3g}-{lo + e[b] * (hi - lo):.3g} {unit}")
    for p in (1, 2, 3):
        cols.append(u ** p)
        names.append(f"{name}^{p} over the stroke" if p > 1 else f"{name} over the stroke")
    return np.column_stack(cols), names


def time_since_reversal(qd, t, deadband: float, starts=(0,)) -> np.ndarray:
    """The time [s] since the rate ``qd`` last changed sign, at each sample of ``t``: a sign
    counts once |qd| exceeds ``deadband``; at a stretch's start (``starts``, sample indices) the
    clock starts again with no sign.

    Example
    -------
    >>> t = np.arange(6) * 0.1
    >>> time_since_reversal(np.array([1., 1., -1., -1., -1., 1.]), t, 0.5).round(2).tolist()
    [0.0, 0.1, 0.0, 0.1, 0.2, 0.0]
    """
    qd, t = np.asarray(qd, float), np.asarray(t, float)
    out = np.empty(len(qd))
    begin = set(int(s) for s in starts) | {0}
    sign, since = 0.0, float(t[0]) if len(t) else 0.0
    for i in range(len(qd)):
        if i in begin:
            sign, since = 0.0, float(t[i])
        if abs(qd[i]) > deadband:
            s = 1.0 if qd[i] > 0 else -1.0
            if s != sign:
                sign, since = s, float(t[i])
        out[i] = t[i] - since
    return out


def reversal_basis(s, name: str = "q", taus=TAUS) -> tuple:
    """``(Z, names)``: exp(-s / tau) for each time constant of ``taus`` [s], ``s`` the time since
    the last reversal (:func:`time_since_reversal`)."""
    s = np.asarray(s, float)
    return (np.column_stack([np.exp(-s / tau) for tau in taus]),
            [f"exp(-s / {tau:g} s), s the time since {name} last reversed" for tau in taus])


def own_products(pipe, j: int) -> tuple:
    """The functions of joint ``j``'s (1-based) own motion the rule multiplies an effect's force
    by, at the decimated samples: ``(Z, names, wheres)``, ``wheres`` "position" or "reversal"
    per column; zero where the joint's smoothing window is mostly at rest."""
    k = j - 1
    idx = pipe.idx
    facts = pipe.model.facts
    Zp, names_p = stroke_basis(pipe.q_s[idx, k], f"q{j}", facts.joint_unit)
    starts = [0] + [int(a) for a, _ in pipe.segments[1:]]
    deadband = 3.0 * max(float(pipe.qd_noise[k]), 1e-12)
    s = time_since_reversal(pipe.qd_s[:, k], pipe.t, deadband, starts)[idx]
    Zr, names_r = reversal_basis(s, f"q{j}")
    Z = np.column_stack([Zp, Zr]) * pipe.usable[:, k].astype(float)[:, None]
    return Z, names_p + names_r, ["position"] * len(names_p) + ["reversal"] * len(names_r)


def beyond(g, Z) -> np.ndarray:
    """The products g z (z a column of ``Z``), centred, with what the effect's own (centred)
    force g explains of them taken out: what each adds to g, (n, m).  A product that is g
    itself comes out as zeros."""
    g = np.asarray(g, float)
    gc = g - g.mean()
    gg = float(gc @ gc)
    P = g[:, None] * np.asarray(Z, float)
    scale = np.einsum("ij,ij->j", P, P)
    P = P - P.mean(axis=0)
    if gg > 0:
        P = P - gc[:, None] * ((gc @ P) / gg)[None, :]
    P[:, np.einsum("ij,ij->j", P, P) <= 1e-9 * np.maximum(scale, 1e-300)] = 0.0
    return P


def gains(P, base) -> np.ndarray:
    """The sum of squares each column of ``P`` explains of ``base`` alone (0 for a zero column)."""
    norm = np.einsum("ij,ij->j", P, P)
    return np.where(norm > 0, (P.T @ base) ** 2 / np.where(norm > 0, norm, 1.0), 0.0)
