"""The smoothing at the decimated samples alone (cosim/discrepancy/_smooth_rows.py) gives the
values of scipy's whole convolution, bit for bit; the pipeline's evaluations read them and keep
entries of the whole smoothing's size in their cache."""
import numpy as np
import pytest
from scipy.ndimage import convolve1d
from scipy.signal import savgol_coeffs

from cosim.core import Model
from cosim.discrepancy._smooth_rows import smoothed_rows, symmetric
from cosim.discrepancy.residuals import Pipeline


@pytest.mark.parametrize("window, order, delta", [(51, 3, 1e-3), (7, 2, 1.0), (21, 3, 0.01), (101, 3, 5e-4)])
@pytest.mark.parametrize("start, step", [(60, 10), (55, 1), (53, 7)])
def test_rows_smoothed_alone_equal_the_whole_convolution_bit_for_bit(window, order, delta, start, step):
    rng = np.random.default_rng(window + step)
    a = rng.normal(size=(3000, 4)) * rng.uniform(1e-3, 1e3, size=4)
    w = savgol_coeffs(window, order, delta=delta)
    # a smoothing filter's weights are symmetric; scipy's least squares leaves some pairs a few
    # DBL_EPSILON apart on some CPUs (AVX-512: (21, 3, 0.01)), so they are mirrored exactly here
    # for the symmetric path to be the one tested
    w = (w + w[::-1]) / 2
    assert symmetric(w)
    rows = np.arange(start, 3000 - 60, step)
    whole = convolve1d(a, w, axis=0, mode="constant")
    assert np.array_equal(smoothed_rows(a, w, rows), whole[rows])
    assert np.array_equal(smoothed_rows(a[:, 1], w, rows), whole[rows, 1])  # one signal


def test_other_filters_and_rows_are_the_whole_convolution_indexed():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(500, 2))
    w = savgol_coeffs(21, 3)
    slope = savgol_coeffs(21, 3, deriv=1)  # antisymmetric: not the symmetric path
    wide = savgol_coeffs(101, 5)  # mirrored only to 3e-12: scipy's general path
    assert not symmetric(slope) and not symmetric(np.ones(4)) and not symmetric(wide)
    for weights, rows in [(slope, np.arange(30, 470, 10)), (wide, np.arange(60, 440, 10)), (w, np.array([40, 41, 57, 300])),  # uneven
                          (w, np.arange(0, 500, 10)), (w, np.arange(25, 495, 10))]:  # windows past the ends
        assert np.array_equal(smoothed_rows(a, weights, rows),
                              convolve1d(a, weights, axis=0, mode="constant")[rows])


def test_the_pipeline_smooths_the_samples_as_the_whole_and_caches_arrays_of_its_size(clean_runs):
    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    tau = pipe.model.inverse_dynamics(pipe.x_f, pipe.xd_f, pipe.xdd_f)
    whole = pipe.S_inner(tau)
    assert np.array_equal(pipe.S_rows(tau, pipe.idx), whole[pipe.idx])
    at = pipe._smoothed_at_samples(tau)
    assert at.shape == whole.shape and np.array_equal(at[pipe.idx], whole[pipe.idx])
    # the evaluation cache weighs an evaluation's smoothed efforts as the whole smoothing's
    pipe.evaluate({"rail[1].coulomb": 0.05})
    kept = [v for k, v in pipe._memo.entries.items() if k[0] == "B"]
    assert kept and all(v.shape == whole.shape for v in kept)
    # positions other than the samples: the whole smoothing's rows
    pos = pipe.idx[:50] + 3
    got = pipe.evaluate({"rail[1].coulomb": 0.05}, positions=pos).eff
    m = Model("6pus")
    m.set_params({"rail[1].coulomb": 0.05})
    direct = pipe.tau_s[pos] - pipe.S_inner(m.inverse_dynamics(pipe.x_f, pipe.xd_f, pipe.xdd_f))[pos]
    assert np.array_equal(got, direct)
