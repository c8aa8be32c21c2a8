"""The engine's steps as functions of data: each returns its result and changes nothing it was given."""
import dataclasses

import numpy as np
import pytest
from disc_helpers import run

from cosim.core import Model
from cosim.discrepancy._threads import one_blas_thread
from cosim.discrepancy.effects import groups_for
from cosim.discrepancy.engine import attribute, prepare
from cosim.discrepancy.inference import infer
from cosim.discrepancy.noise import noise_model, weighted
from cosim.discrepancy.residuals import Pipeline
from cosim.discrepancy.selection import select


@pytest.fixture(scope="module")
def prepared():
    rec = run("6pus", {"rail[2].coulomb": 0.04}, duration=4.0, seed=3)
    m = Model("6pus")
    pipe = Pipeline(rec, m)
    groups, _ = groups_for(m, pipe.has_pose)
    return prepare(pipe, groups)


def test_attribution_changes_neither_the_state_nor_its_results(prepared):
    st = prepared
    labels, W = list(st.options), st.W.copy()
    state, sel = attribute(st)
    # the plant holds a Coulomb friction on rail 2 (0.04 N): the engine names it
    assert [a.group.label for a in sel.selected] == ["coulomb[2]"]
    assert sel.theta["rail[2].coulomb"] == pytest.approx(0.04, rel=0.05)
    # the prepared state is as it was: every candidate, no weights
    assert list(st.options) == labels and st.sig is None and np.array_equal(st.W, W)
    assert state.sig is not None and not np.array_equal(state.W, W)
    # results and state cannot be changed after they are returned
    with pytest.raises(dataclasses.FrozenInstanceError):
        sel.theta = {}
    with pytest.raises(dataclasses.FrozenInstanceError):
        sel.selected[0].values = {}
    with pytest.raises(ValueError, match="read-only"):
        state.R0[0, 0] = 1.0
    with pytest.raises(TypeError):
        state.options["coulomb[2]"] = ()


def _figures(sel):
    """Every figure of a selection, as text (the detectability of a profiled effect is nan)."""
    return repr((sel.theta, sel.sigma.tolist(), sel.detectability, sel.collinear, sel.chi2_final,
            [(a.group.label, a.values, a.ci, a.importance, a.lookalikes) for a in sel.selected]))


def test_the_steps_depend_on_their_arguments_only(prepared):
    """No hidden state between the steps: a second attribution of the same state gives the
    same figures, and inference twice on one selection too, leaving that selection as
    select returned it."""
    st = prepared
    with one_blas_thread():  # as in a diagnosis: a threaded BLAS sums in a varying order
        assert _figures(attribute(st)[1]) == _figures(attribute(st)[1])
        w = weighted(st, noise_model(st))
        after, raw = select(w)
        first, second = infer(after, raw), infer(after, raw)
    assert np.array_equal(raw.sigma, w.sig)
    assert raw.detectability == {} and raw.selected[0].ci == {} and raw.selected[0].importance == 0.0
    assert first.detectability and first.selected[0].ci
    assert _figures(first) == _figures(second)
