"""The flexible stage's low-passed histories (cosim.discrepancy.flexible.columns._lowpass), a
recursion on Python floats, equal the recursion written with numpy's row operations, bit for bit:
restarted at every block start, for one column or several, on values of every scale."""
import math

import numpy as np
import pytest

from cosim.discrepancy.flexible.columns import _lowpass


def _rows(x, dt, tau, starts):
    """The recursion on numpy's rows: the definition."""
    a = math.exp(-dt / tau)
    y = np.empty_like(x)
    for i in range(len(x)):
        y[i] = x[i] if i in starts else a * y[i - 1] + (1 - a) * x[i]
    return y


@pytest.mark.parametrize("shape", [(900,), (900, 1), (900, 2), (700, 5)])
@pytest.mark.parametrize("tau", [0.5, 4.0, 8.0])
def test_the_low_pass_on_python_floats_is_the_one_on_numpys_rows(shape, tau):
    rng = np.random.default_rng(len(shape) * 10 + int(tau))
    x = rng.normal(size=shape) * np.exp(rng.normal(scale=6.0, size=shape))  # magnitudes 1e-8 .. 1e8
    x.ravel()[::97] = 0.0
    starts = {0, 37, 400, shape[0] - 1}
    got, want = _lowpass(x, 0.01, tau, starts), _rows(x, 0.01, tau, starts)
    assert got.shape == want.shape and got.dtype == want.dtype
    assert np.array_equal(got, want)
    assert got.tobytes() == want.tobytes()  # signs of zeros too


def test_an_input_in_any_memory_layout_is_filtered_as_a_contiguous_one():
    # a column-major 3-D input: the output is written whole, not into a copy of a reshape
    x = np.asfortranarray(np.random.default_rng(3).normal(size=(300, 2, 3)))
    starts = {0, 120}
    got, want = _lowpass(x, 0.01, 0.5, starts), _rows(np.ascontiguousarray(x), 0.01, 0.5, starts)
    assert got.shape == x.shape and np.array_equal(got, want)
