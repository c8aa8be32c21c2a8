"""The readings' delay line on its own (pkm_reading_delay, cosim.core.reading_delay): the
values of its definition written here (the reading of t - delay, linear between the samples
around it, the first sample's before it) and its refusals."""
import numpy as np
import pytest

from cosim.core import Model
from cosim.core.reading_delay import ReadingDelay
from cosim.errors import ArgumentError


def test_the_line_gives_the_reading_of_t_minus_the_delay():
    m = Model("6pus", params={"sensor.delay": 2.5e-3})
    line = ReadingDelay(m)
    q = lambda k: np.full(6, 0.1 * k) + np.arange(6)      # noqa: E731 - a reading per sample
    qd = lambda k: -np.full(6, float(k))                  # noqa: E731
    got = [line.read(k * 1e-3, q(k), qd(k)) for k in range(8)]
    for k in range(8):
        s = k - 2.5
        want = q(0) if s <= 0 else 0.5 * (q(int(s)) + q(int(s) + 1))
        np.testing.assert_allclose(got[k][0], want, rtol=0, atol=1e-12)
        want_d = qd(0) if s <= 0 else 0.5 * (qd(int(s)) + qd(int(s) + 1))
        np.testing.assert_allclose(got[k][1], want_d, rtol=0, atol=1e-12)
    line.reset()
    np.testing.assert_array_equal(line.read(0.02, q(5), qd(5))[0], q(5))   # an empty line again


def test_no_delay_passes_the_reading_and_bad_input_is_named():
    line = ReadingDelay(Model("6pus"))
    q = np.arange(6.0)
    np.testing.assert_array_equal(line.read(0.0, q, q)[0], q)
    with pytest.raises(ArgumentError, match="qd has shape"):
        line.read(0.001, q, q[:3])
    with pytest.raises(ArgumentError, match=r"q\[3\]|joint 4|nan"):
        line.read(0.001, [0, 0, 0, np.nan, 0, 0], q)
    with pytest.raises(ArgumentError, match="before the last one"):
        line.read(-1.0, q, q)


def test_the_line_is_numpys_linear_interpolation_of_the_samples():
    # Oracle: numpy.interp of the samples at t - delay (the first sample before it), on
    # irregular readings and a delay that is not a multiple of the sample time
    m = Model("6pus", params={"sensor.delay": 3.7e-3})
    line = ReadingDelay(m)
    t = np.arange(40) * 1e-3
    rng = np.random.default_rng(2)
    Q, QD = rng.normal(size=(40, 6)), rng.normal(size=(40, 6))
    got = np.array([line.read(t[k], Q[k], QD[k])[0] for k in range(40)])
    for j in range(6):
        np.testing.assert_allclose(got[:, j], np.interp(t - 3.7e-3, t, Q[:, j]), rtol=0, atol=1e-12)
