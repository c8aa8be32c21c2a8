"""The weighted stacking of a fit state (cosim/discrepancy/fitstate.py ``vec``, ``vec_cols``): its
fitted rows and their weights taken once give, bit for bit, the rows the mask selects times
their weights, channel after channel; a state with other weights stacks with those."""
from dataclasses import replace

import numpy as np

from cosim.core import Model
from cosim.discrepancy.effects import groups_for
from cosim.discrepancy.fitstate import fit_state
from cosim.discrepancy.residuals import Pipeline


def _stacked(R, W, mask):
    """The definition: each channel's fitted rows weighted, one channel after the other."""
    return np.concatenate([R[mask, c] * W[mask, c] for c in range(R.shape[1])])


def test_default_rows_and_weights_stack_as_the_mask_selects_them(clean_runs):
    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    st = fit_state(pipe, groups_for(pipe.model, pipe.has_pose)[0])
    rng = np.random.default_rng(2)
    W = rng.uniform(0.1, 3.0, size=st.R0.shape) * st.use
    st = replace(st, W=W)
    R = rng.normal(size=st.R0.shape)
    cols = rng.normal(size=st.R0.shape + (3,))
    for _ in range(2):  # the rows and weights once taken serve again
        assert np.array_equal(st.vec(R), _stacked(R, W, st.train))
        got = st.vec_cols(cols)
        assert got.shape == (int(st.train.sum()) * st.C, 3)
        for k in range(3):
            assert np.array_equal(got[:, k], _stacked(cols[:, :, k], W, st.train))
    other = replace(st, W=2.0 * W)  # a state of other weights takes its own
    assert np.array_equal(other.vec(R), _stacked(R, 2.0 * W, st.train))
    assert np.array_equal(other.vec_cols(cols)[:, 1], _stacked(cols[:, :, 1], 2.0 * W, st.train))
    test = st.test  # another mask, or weights given, as the definition
    assert np.array_equal(st.vec(R, test), _stacked(R, W, test))
    w = rng.uniform(size=st.C)
    assert np.array_equal(st.vec(R, w=w), _stacked(R, w * st.use, st.train))
