"""The attribution engine: which effects of the library a recording's residual supports.

Data and free functions, each step returning a result and changing none of its arguments:

======================================  ===============================================
:func:`.fitstate.fit_state`             the :class:`.fitstate.FitState`: residual, split, scales
:func:`.regressors.candidates`          step 1: the ways each candidate group can enter
:func:`.noise.noise_model`              step 2: noise level and inflation per channel
:func:`.noise.weighted`                 the state with the channel weights
:func:`.selection.select`               step 3: forward selection with BIC
:func:`.inference.infer`                step 4: intervals, importance, look-alikes, detectability
======================================  ===============================================

:func:`prepare` and :func:`attribute` chain them; they are what the diagnosis
(:mod:`.diagnosis`) calls.
"""
from __future__ import annotations

import math

import numpy as np

from .fitstate import FitState, fit_state
from .inference import infer
from .noise import NoiseLevels, inflation, noise_model, weighted
from .regressors import candidates
from .selection import Selection, select


def prepare(pipe, groups, *, train_fraction: float = 0.7, threshold: float = 10.0,
            lookalike_margin: float = 10.0, max_groups: int = 8, instruments: bool = True,
            verbose: bool = False) -> FitState:
    """The fit state of a recording with its candidate options (no weights yet).

    Parameters
    ----------
    pipe : Pipeline
        The recording's residual pipeline (:class:`.residuals.Pipeline`).
    groups : sequence of Group
        The candidate groups (:func:`.effects.groups_for`).
    train_fraction, threshold, lookalike_margin, max_groups, instruments, verbose
        See :func:`.fitstate.fit_state`.

    Returns
    -------
    FitState

    Examples
    --------
    >>> from cosim.core import Model
    >>> from cosim.discrepancy.effects import groups_for
    >>> from cosim.discrepancy.residuals import Pipeline
    >>> m = Model("6pus")
    >>> st = prepare(Pipeline(rec, m), groups_for(m, True)[0])      # doctest: +SKIP
    >>> sorted(st.options)[:2]                                      # doctest: +SKIP
    ['actuator_delay', 'backlash[1]']
    """
    st = fit_state(pipe, groups, train_fraction=train_fraction, threshold=threshold,
                   lookalike_margin=lookalike_margin, max_groups=max_groups, instruments=instruments,
                   verbose=verbose)
    c = candidates(st)
    return st.with_candidates(c.options, c.instrument_cols)


def attribute(st: FitState) -> tuple[FitState, Selection]:
    """Noise model, weights, selection and inference of a prepared state.

    The selection runs with the noise of the fit with every linear candidate, then once
    more with the noise of the selected model when the two differ by more than 25 % on a
    channel (the second run starts again from every candidate).

    Parameters
    ----------
    st : FitState
        From :func:`prepare`.

    Returns
    -------
    state : FitState
        The weighted state of the last selection, with the options the inference compared
        against (the refused groups' left out when the noise settled).
    selection : Selection
        The inferred selection (:func:`.inference.infer`).

    Examples
    --------
    >>> st, sel = attribute(prepare(pipe, groups))     # doctest: +SKIP
    >>> sel.theta                                      # doctest: +SKIP
    {'rail[1].coulomb': 0.0298}
    """
    noise = noise_model(st)
    for _ in range(2):
        cur = weighted(st, noise)
        after, sel = select(cur)
        r = cur.R(sel.theta)[cur.train]
        used = cur.use[cur.train] > 0
        sig_f = np.maximum(np.sqrt(np.sum(r**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), cur.floor())
        if np.all(np.abs(np.log(sig_f / noise.sigma)) < math.log(1.25)):
            cur = after
            break
        phi = np.array([inflation(r[used[:, c], c], cur.pipe.window, cur.pipe.step) for c in range(cur.C)])
        noise = NoiseLevels(sig_f, phi)
    return cur, infer(cur, sel)
