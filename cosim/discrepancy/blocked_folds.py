"""Folds of contiguous blocks in time, for judging a fit out of fold on a smoothed residual.

The recording's decimated samples are cut into ``N_FOLDS x BLOCKS_PER_FOLD`` contiguous blocks
in time, dealt to :data:`N_FOLDS` folds in turn (each fold's blocks spread through the
recording); each fold is held out in turn and the fit is made on the others, less
:data:`GAP_INDEPENDENT` independent samples' worth on each side of each held-out block (the
smoothed residual is correlated over a smoothing window: a neighbour of a fitted sample is no
held-out sample).  The flexible stage's cross-validation (:mod:`.flexible.cv`) and the repeat
test of a spectral line (:func:`.lines.repeats`) use the same folds.
"""
from __future__ import annotations

import math

import numpy as np

#: folds of the cross-validation, and blocks in time per fold (spread through the recording:
#: fold i holds out blocks i, i + N_FOLDS, ...)
N_FOLDS, BLOCKS_PER_FOLD = 5, 4
#: independent samples' worth left out of the fit on each side of a held-out block
GAP_INDEPENDENT = 1.0


def folds(n: int, gap: int, k: int = N_FOLDS, per_fold: int = BLOCKS_PER_FOLD) -> tuple:
    """``k`` folds of ``range(n)``, each ``per_fold`` contiguous blocks spread through it (the
    blocks in time order dealt to the folds in turn): per fold (its rows, the rows fitted when
    it is held out: all others but ``gap`` on each side of each of its blocks).

    Example
    -------
    >>> rows = folds(40, gap=1, k=2, per_fold=2)
    >>> rows[0][0].tolist() == list(range(10)) + list(range(20, 30))
    True
    >>> rows[0][1].tolist() == list(range(11, 19)) + list(range(31, 40))
    True
    """
    edges = np.linspace(0, n, k * per_fold + 1).astype(int)
    every = np.arange(n)
    out = []
    for i in range(k):
        held, near = np.zeros(n, bool), np.zeros(n, bool)
        for a, b in zip(edges[i:-1:k], edges[i + 1::k]):
            held[a:b] = True
            near[max(0, a - gap):min(n, b + gap)] = True
        out.append((every[held], every[~near]))
    return tuple(out)


def gap_for(spi: float) -> int:
    """The gap in decimated samples for ``spi`` decimated samples per independent one."""
    return int(math.ceil(GAP_INDEPENDENT * spi))
