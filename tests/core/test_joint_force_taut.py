"""The joint force's one-sided spring (``<j>[i].force_taut``, ``force_taut_q``, ``force_taut_w`` read
from the other joint ``force_xj``, joint_force.hpp): a cable carrier or hose between two carriages
that pulls once taut.  Checked against the formula written here, k w ln(1 + e^x), x = (q_i - q_k - s)
/ w, at chosen states (slack, onset and taut), its reaction on the other joint, its slope by
finite differences (smooth: the logistic, bounded by k), the forward dynamics inverting the
inverse, and a spring set without its other joint refused."""
import math

import numpy as np
import pytest

from cosim.core import Model

K, S, W = 80.0, 0.004, 0.0015  # N/m, m, m
J, OTHER = 2, 5  # 1-based: the cable pulls slider 2 back once q2 - q5 passes S


def _model(k=K, s=S, w=W):
    return Model("6pus", params={f"rail[{J}].force_xj": OTHER, f"rail[{J}].force_taut": k,
                                 f"rail[{J}].force_taut_q": s, f"rail[{J}].force_taut_w": w,
                                 f"rail[{OTHER}].force_xj": J, f"rail[{OTHER}].force_taut": k,
                                 f"rail[{OTHER}].force_taut_q": -s, f"rail[{OTHER}].force_taut_w": -w})


def _tension(d):
    """The cable's tension at q_J - q_OTHER = d, written out: k w ln(1 + e^((d - s) / w))."""
    return K * W * math.log(1.0 + math.exp((d - S) / W))


def _state_at(m, d):
    """A pose near home whose joint difference q_J - q_OTHER is d (moved along the coordinate that
    moves the two rails apart most), its rates and accelerations."""
    x0 = m.home()
    q0 = m.ik(x0)
    steps = 1e-4 * np.eye(6)
    slopes = [(m.ik(x0 + e) - q0)[J - 1] - (m.ik(x0 + e) - q0)[OTHER - 1] for e in steps]
    i = int(np.argmax(np.abs(slopes)))  # the coordinate that moves the two rails apart most
    x = x0.copy()
    diff = lambda x: (lambda q: q[J - 1] - q[OTHER - 1])(m.ik(x))  # noqa: E731
    for _ in range(8):  # Newton steps on that coordinate, the slope taken again at each
        slope = (diff(x + steps[i]) - diff(x)) / 1e-4
        x[i] += (d - diff(x)) / slope
    return x, np.array([0.02, -0.01, 0.015, 0.1, -0.05, 0.2]), np.array([0.3, -0.2, 0.1, 1.0, 0.5, -0.7])


@pytest.mark.parametrize("d", [S - 8 * W, S - W, S, S + 0.5 * W, S + 6 * W])
def test_the_tension_acts_on_both_joints_as_written(d):
    nominal, m = Model("6pus"), _model()
    x, xd, xdd = _state_at(m, d)
    q = m.ik(x)
    assert abs(q[J - 1] - q[OTHER - 1] - d) < 1e-9
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    want = np.zeros(6)
    want[J - 1], want[OTHER - 1] = _tension(d), -_tension(d)
    np.testing.assert_allclose(dtau, want, rtol=1e-9, atol=1e-12)
    # the forward dynamics subtract it from the applied effort: the acceleration back
    np.testing.assert_allclose(m.forward_dynamics(x, xd, m.inverse_dynamics(x, xd, xdd)), xdd, rtol=1e-8, atol=1e-8)


def test_smooth_its_slope_the_logistic_by_finite_differences():
    nominal, m = Model("6pus"), _model()
    h = 1e-6
    for d in np.linspace(S - 4 * W, S + 4 * W, 9):
        f = []
        for dd in (d - h, d + h):
            x, xd, xdd = _state_at(m, dd)
            f.append((m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd))[J - 1])
        slope = (f[1] - f[0]) / (2 * h)
        assert abs(slope - K / (1.0 + math.exp(-(d - S) / W))) < 1e-4 * K, (d, slope)
        assert 0.0 < slope < K


def test_large_arguments_stay_finite():
    # 1000 widths past the slack: k (d - s) exactly, no overflow of e^x
    nominal, m = Model("6pus"), _model(w=1e-6)
    x, xd, xdd = _state_at(m, S + 1e-3)
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    np.testing.assert_allclose(dtau[J - 1], K * 1e-3, rtol=1e-6)
    assert np.all(np.isfinite(dtau))


def test_a_one_sided_spring_without_its_other_joint_is_refused_and_zero_width_is_none():
    with pytest.raises(Exception, match=r"rail\[2\]\.force_xj"):
        Model("6pus", params={"rail[2].force_taut": 50.0, "rail[2].force_taut_w": 0.001})
    m = Model("6pus", params={"rail[2].force_xj": 5, "rail[2].force_taut": 50.0, "rail[2].force_taut_q": 0.01})
    x, xd, xdd = _state_at(m, 0.0)
    np.testing.assert_array_equal(m.inverse_dynamics(x, xd, xdd), Model("6pus").inverse_dynamics(x, xd, xdd))
