"""A force a drive's effort scales (cosim.discrepancy.flexible.scaled): a friction on slider 1 whose
level is the drive's load times a misalignment along the stroke, mu |u1| |q1 - qa| tanh(qd1 / v),
with the load one-signed about a large mean (a rail holding the platform up: 1 +- 0.15, and +- 0.075), is to
within a few hundredths of its variance a function of the position and the rate; the trees on
them plus the effort gain under the bar that adds an input, the product |u1| g(q1, qd1) takes a
large part of what they leave.

Synthetic, truth in closed form; the effort is the load, or with an echo the load plus twice the
force the controller answers (then the reference's load, its counterpart, does not scale it); a
force of the position and the rate alone, the same shape, gains nothing from the product.
"""
import numpy as np
import sklearn.ensemble  # noqa: F401  (loaded before the limit is set: threadpoolctl limits loaded runtimes only)
import pytest
from threadpoolctl import threadpool_limits

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.own_state import beside_named
from cosim.discrepancy.flexible.scaled import candidates, scaled_by

COLS = [("q1", "position of slider 1", 1, "position", "m"), ("qd1", "rate of slider 1", 1, "rate", "m/s"),
        ("tau1", "effort of slider 1", 1, "effort", "N"), ("q2", "position of slider 2", 2, "position", "m"),
        ("tau2", "effort of slider 2", 2, "effort", "N")]
SIGMA = 0.01
NAMED = ("position of slider 1", "rate of slider 1")


@pytest.fixture(autouse=True)
def _one_thread():  # the stage's trees run on one thread (an unlimited fit spins threads on a busy machine)
    with threadpool_limits(limits=1):
        yield


def _rail(scaled=True, echo=0.0, n=1000, seed=3, swing=0.15):
    """``(X, reference, y)``: the columns :data:`COLS`, their counterparts along the reference (the
    efforts': the loads alone) and the residual on slider 1's channel."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 40.0, n)
    q1 = 0.2 * np.sin(2 * np.pi * 0.11 * t) + 0.05 * np.sin(2 * np.pi * 0.43 * t)
    qd1 = np.gradient(q1, t)
    load = 1.0 + swing * (np.sin(2 * np.pi * 0.17 * t + 0.7) + 0.5 * np.sin(2 * np.pi * 0.53 * t))
    q2 = 0.2 * np.sin(2 * np.pi * 0.07 * t + 1.0)
    load2 = 1.0 + 0.3 * np.sin(2 * np.pi * 0.23 * t + 2.0)
    level = np.abs(q1 + 0.2) * np.tanh(qd1 / 0.02)
    y = (load if scaled else 1.0) * level + rng.normal(0.0, SIGMA, n)
    X = np.column_stack([q1, qd1, load + echo * y, q2, load2])
    reference = X.copy()
    reference[:, 2] = load
    return X, reference, y


def _judged(y):
    var = float(np.var(y))

    def judged(mse):  # the stage's (share, chi-square, claimed), one independent sample a sample
        share = 1.0 - mse / var
        z = len(y) * (var - mse) / SIGMA ** 2
        return share, z, share >= 0.05 and z > 25.0
    return judged


def _named(X, reference, y, named=NAMED):
    groups = flexible.input_groups(COLS)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    use = sorted({i for g in named for i in groups[g]})
    cv = flexible.cross_validate(X[:, use], y, fold_rows)
    own = beside_named(list(named), use, cv, groups, 1, X, y, fold_rows, reference)[0]
    got = scaled_by(list(named), use, cv, groups, X, y, fold_rows, reference, _judged(y))[0]
    return sorted(own), sorted(got)


def test_the_load_a_friction_scales_is_named_where_the_trees_beside_it_gain_too_little():
    X, reference, y = _rail()
    own, got = _named(X, reference, y)
    assert own == sorted(NAMED)  # the trees on position, rate and effort: under the bar of an added input
    assert got == sorted(NAMED + ("effort of slider 1",))
    # without a reference motion the effort cannot be told from the controller's answer: not named
    assert _named(X, None, y)[1] == sorted(NAMED)


def test_no_effort_where_the_force_is_no_product_of_it():
    X, reference, y = _rail(scaled=False)
    assert _named(X, reference, y)[1] == sorted(NAMED)


def test_an_effort_that_only_echoes_the_force_is_not_named():
    X, reference, y = _rail(scaled=False, echo=2.0)
    assert _named(X, reference, y)[1] == sorted(NAMED)


def test_the_efforts_tried_are_those_of_the_named_positions_joints():
    groups = flexible.input_groups(COLS)
    assert candidates(list(NAMED), groups) == ["effort of slider 1"]
    assert candidates(["rate of slider 1", "position of slider 2"], groups) == ["effort of slider 2"]
    assert candidates(["rate of slider 1"], groups) == []
    assert candidates(["position of slider 1", "effort of slider 1"], groups) == []
