"""Whether the confidence rule could have seen a library effect's level change: its power.

The rule of :mod:`.elsewhere` withholds an effect's confidence when its level changes with
another joint's input, its joint's position or the time since the joint reversed: a product of
the effect's force g and such an input z explains what is left beyond a look-elsewhere bar.  Near
the detection limit no product can pass: the effect itself is barely above the noise, and a level
that changes by its own size over the stroke explains less than the bar.  There the recording
cannot tell the library's constant level from a keyed one, and an effect named with confidence
there is a guess (measured on MuJoCo: a Coulomb friction named with confidence for a friction
that rises over a band of the stroke, or after each reversal, at a hundredth of the bench's
magnitudes; docs/discrepancy.md, section 4, "Nor where the recording is too weak to tell").

The power of one product: a level change of ``delta`` (a fraction of the effect's fitted level)
over the range of z (its 1st to 99th percentile) adds the force ``delta g (z - mean z) / span(z)``,
beyond g, whose chi-square is ``delta^2 |P|^2 / (span^2 var)`` (P the product beyond g, as the rule
fits it, ``var`` the noise variance per independent sample).  The smallest level change the rule
could see with it is the ``delta`` that brings that chi-square to the rule's bar (its bar plus
the coefficient's cost); of a kind of product (another joint's inputs, the position, the time
since the reversal), the smallest over the kind's products (:func:`smallest_change`).  A friction
of the library (:data:`FRICTIONS`) is too weak to be named with confidence when for some kind it
exceeds :data:`LEVEL_CHANGE`.

Power alone judges the kind's best product; the truth's change may live on another, weaker one.
So the products the recording leans on are judged too (:func:`leaning_change`): a product whose
chi-square, less the cost ln n_eff of its coefficient, exceeds the look-elsewhere cost 2 ln M of
the M products tried (significant among them, short of the structure test's threshold the bar
adds to name a key) and along which the level's interval at the rule's bar, |estimated change| +
the change the bar could see, reaches :data:`LEVEL_CHANGE`: the data lean to a keyed level and
cannot exclude one that changes by the level's own size.  Measured (docs/discrepancy.md, section
4, "Nor where the recording is too weak to tell"): on the library's true frictions (MuJoCo seeds
11 and 12, the own generator's) the products whose interval reaches the level read at most 4.1
against 2 ln M = 10.4; on the two unlisted frictions the power missed, 12.5 and 24.7, on the
truth's key.

Only the frictions: they are the library's forces of the joint's rate, whose level the unlisted
frictions key on something else (a zone of the stroke, a seal after a reversal, a neighbour's
speed or load); the level of an inertia, a dead zone, a saturation or an offset is not what such
a mechanism changes, and a kinematic effect's force has no level of its own (on MuJoCo's library
recordings they read 1.3-23 where they are the truth).
"""
from __future__ import annotations

import math

import numpy as np

#: the library's frictions (forces of the joint's rate), the effects the power is required of
FRICTIONS = frozenset({"coulomb", "viscous", "stribeck", "smooth_coulomb"})
#: the change of an effect's level (a fraction of its fitted level, over the range of an input)
#: the rule must be able to see for the effect to be named with confidence: the level itself (a
#: level that doubles, or vanishes, over the input's range: the unlisted frictions' changes are
#: of that size or more)
LEVEL_CHANGE = 1.0


def spans(Z) -> np.ndarray:
    """The range of each column of ``Z`` (n, m) from its 1st to its 99th percentile, (m,)."""
    Z = np.asarray(Z, float)
    if Z.shape[1] == 0:
        return np.zeros(0)
    lo, hi = np.quantile(Z, [0.01, 0.99], axis=0)
    return hi - lo


def smallest_change(P, span, wheres, var: float, bar: float) -> dict:
    """Per kind of product (``wheres``), the smallest change of the effect's level (a fraction
    of it, over an input's range ``span``) whose product, a column of ``P`` (the product beyond
    the effect's force g), would explain a chi-square of ``bar`` against the noise variance per
    independent sample ``var``: ``{where: (delta, column)}``; inf for a kind whose products are all
    zero or constant.

    Example
    -------
    >>> P = np.array([[1.0, 0.0], [-1.0, 0.0], [1.0, 0.0], [-1.0, 0.0]])
    >>> {w: round(d, 3) for w, (d, k) in smallest_change(P, np.ones(2), ["position", "reversal"],
    ...                                                   0.25, 4.0).items()}
    {'position': 0.5, 'reversal': inf}
    """
    P, span = np.asarray(P, float), np.asarray(span, float)
    norm = np.sqrt(np.einsum("ij,ij->j", P, P))
    ok = (norm > 0) & (span > 0)
    delta = np.full(len(norm), math.inf)
    delta[ok] = span[ok] * math.sqrt(bar * var) / norm[ok]
    out = {}
    for where in dict.fromkeys(wheres):
        at = [k for k, w in enumerate(wheres) if w == where]
        best = min(at, key=lambda k: delta[k])
        out[where] = (float(delta[best]), best)
    return out


def leaning_change(P, base, span, wheres, var: float, bar: float, cost: float, evidence: float) -> dict:
    """Per kind of product (``wheres``), the product the residual ``base`` leans on most whose
    level change the data cannot bound below the level itself: ``{where: (change, column, stat)}``
    for the kinds that have one.  A column of ``P`` (the product beyond the effect's force) leans
    when its chi-square against the noise variance ``var`` less ``cost`` (ln n_eff), ``stat``,
    exceeds ``evidence`` (the rule's look-elsewhere cost 2 ln M); its level change, a fraction of
    the level over the input's range ``span``, is estimated at d = span (P . base) / |P|^2 with
    the standard error s = span sqrt(var) / |P|, and
    ``change`` = |d| + sqrt(``bar``) s is the largest change the rule's bar (with the coefficient's
    cost) does not exclude; only products with ``change`` >= :data:`LEVEL_CHANGE` are listed.

    Example
    -------
    >>> P = np.array([[1.0, 0.0], [-1.0, 1.0], [1.0, 0.0], [-1.0, -1.0]])
    >>> out = leaning_change(P, np.array([0.5, -0.5, 0.5, -0.5]), np.ones(2), ["position", "reversal"],
    ...                      0.04, 36.0, 2.0, 10.0)
    >>> {w: (round(c, 2), k, round(st, 1)) for w, (c, k, st) in out.items()}
    {'position': (1.1, 0, 23.0)}
    """
    P, base, span = np.asarray(P, float), np.asarray(base, float), np.asarray(span, float)
    norm2 = np.einsum("ij,ij->j", P, P)
    ok = (norm2 > 0) & (span > 0)
    safe = np.where(ok, norm2, 1.0)
    proj = P.T @ base
    stat = np.where(ok, proj ** 2 / safe / var - cost, -math.inf)
    change = np.where(ok, span * (np.abs(proj) / safe + np.sqrt(bar * var / safe)), 0.0)
    out = {}
    for where in dict.fromkeys(wheres):
        at = [k for k, w in enumerate(wheres) if w == where and stat[k] > evidence and change[k] >= LEVEL_CHANGE]
        if at:
            k = max(at, key=lambda k: stat[k])
            out[where] = (float(change[k]), k, float(stat[k]))
    return out


def too_weak(changes: dict, limit: float = LEVEL_CHANGE) -> list:
    """The kinds of ``changes`` (:func:`smallest_change`) whose smallest visible change of the
    level exceeds ``limit``: ``[(where, delta)]``, in the order given."""
    return [(w, d) for w, (d, _) in changes.items() if not d <= limit]
