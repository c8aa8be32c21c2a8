"""The discovery's search is a value: a channel's search and a shape fitted off the grid return
a new Search and leave the one they were given as it was (cosim/discrepancy/discovery/search.py)."""
import dataclasses

import numpy as np
import pytest
from disc_helpers import run

from cosim.core import Model
from cosim.discrepancy._threads import one_blas_thread
from cosim.discrepancy.discovery import discover_channel, make_search
from cosim.discrepancy.effects import groups_for
from cosim.discrepancy.engine import attribute, prepare
from cosim.discrepancy.residuals import Pipeline

DRAG = 300.0  # N s^2/m^2 (0.2 N at the joint's RMS rate): quadratic drag on rail 4, no library effect


@pytest.fixture(scope="module")
def fitted():
    rec = run("6pus", {"rail[2].coulomb": 0.04, "rail[4].force_v2": DRAG}, duration=4.0, seed=3)
    m = Model("6pus")
    pipe = Pipeline(rec, m)
    groups, _ = groups_for(m, pipe.has_pose)
    with one_blas_thread():
        eng, sel = attribute(prepare(pipe, groups))
        return eng, sel, make_search(eng, sel.theta)


def _snapshot(s):
    return (s.w.copy(), list(s.cols), list(s.instr), dict(s.periods), len(s.fades), len(s.steps),
            {t: len(o) for t, o in s.fam.items()}, set(s.off_grid), s.fam_on)


def _same(a, b):
    return np.array_equal(a[0], b[0]) and a[1:3] == b[1:3] and a[4:] == b[4:] and \
        list(a[3]) == list(b[3]) and all(np.array_equal(a[3][k], b[3][k]) for k in a[3])


def test_a_channels_search_returns_a_new_search_and_changes_none(fitted):
    eng, sel, search = fitted
    before = _snapshot(search)
    c = 3
    with one_blas_thread():
        term, after = discover_channel(search, c, eng.R(sel.theta)[:, c], 10.0)
    assert _same(_snapshot(search), before)
    # the new search holds the channel's noise weight, no other
    assert after.w[c] > 0 and not np.any(np.delete(after.w, c))
    # the hidden drag is found on its joint (oracle: the plant's parameter)
    assert term is not None and "drag" in term.terms
    v2 = term.coefficients["rail[4].force_v2"]
    assert abs(v2.value - DRAG) <= max(v2.ci95, 0.1 * DRAG)


def test_a_shape_off_the_grid_is_a_new_option_of_a_new_search(fitted):
    eng, _, search = fitted
    before = _snapshot(search)
    c = 1
    q = float(search.steps[0][0][c]) + 0.5 * float(search.travel[c])
    after, o = search.with_step(c, q, float(search.steps[0][1][c]))
    assert _same(_snapshot(search), before) and ("step", o) not in search.cols
    assert o == len(search.steps) and ("step", o) in after.off_grid and ("step", o) not in after.candidates()
    # joint c's column is taken again at the new position, the other joints' are the grid's
    new, old = after.cols[("step", o)], search.cols[("step", 0)]
    assert not np.allclose(new[:, c], old[:, c])
    assert np.array_equal(np.delete(new, c, axis=1), np.delete(old, c, axis=1))
    assert after.shape("step", c, o)["rail[2].force_step_q"] == q


def test_the_search_cannot_be_changed(fitted):
    _, _, search = fitted
    with pytest.raises(dataclasses.FrozenInstanceError):
        search.fam_on = False
    with pytest.raises(ValueError, match="read-only"):
        search.w[0] = 1.0
    with pytest.raises(ValueError, match="read-only"):
        search.cols[("constant", 0)][0, 0, 0] = 1.0
    with pytest.raises(TypeError):
        search.cols[("constant", 1)] = None
