"""The channel's own effort and rate beside the named inputs (cosim.discrepancy.flexible.own_state):
where the named position carries most of a force that the joint's own effort or rate scales, that
factor is named where it adds significantly; the effort only where its counterpart along the
reference motion adds too (a force the effort only echoes is not in the reference's effort).

Synthetic, truth in closed form, on slider 1's channel: a ripple of the position,
sin(2 pi q1 / 0.25), scaled by (1 + 0.6 load) with load the drive's effort along the reference
(a thrust ripple whose amplitude the current sets), or beside a damping 0.3 qd1 (a cushion's spring and
its air's drag) or a force 0.8 load, or alone; the effort is the load, or with an echo the load plus twice the force the
controller answers, which then holds a slow disturbance no other input carries.
"""
import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.own_state import beside_named, own_groups
from cosim.discrepancy.flexible.select import gain

COLS = [("q1", "position of slider 1", 1, "position", "m"), ("qd1", "rate of slider 1", 1, "rate", "m/s"),
        ("tau1", "effort of slider 1", 1, "effort", "N"), ("q2", "position of slider 2", 2, "position", "m")]


def _rail(scaled_by=None, echo=0.0, n=1200, sigma=0.05, seed=3):
    """``(X, reference, y)``: the columns :data:`COLS`, their counterparts along the reference (the
    effort's: the load alone) and the residual on slider 1's channel; with ``echo`` the residual
    holds a slow disturbance no input carries but the effort, which answers the whole force."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 40.0, n)
    q1 = 0.2 * np.sin(2 * np.pi * 0.05 * t) + 0.05 * np.sin(2 * np.pi * 0.31 * t)
    qd1 = np.gradient(q1, t) / 0.08
    load = np.sin(2 * np.pi * 0.13 * t + 0.7) + 0.4 * np.sin(2 * np.pi * 0.41 * t)
    q2 = 0.2 * np.sin(2 * np.pi * 0.07 * t + 1.0)
    scale = 1.0 + 0.6 * load if scaled_by == "effort" else 1.0
    damping = 0.3 * qd1 if scaled_by == "rate" else 0.8 * load if scaled_by == "load" else 0.0
    kernel = np.exp(-np.arange(60) / 15.0)
    disturbance = np.convolve(rng.normal(0.0, 1.0, n + 59), kernel / np.linalg.norm(kernel), "valid")
    y = np.sin(2 * np.pi * q1 / 0.25) * scale + damping + (0.5 * disturbance if echo else 0.0)
    y = y + rng.normal(0.0, sigma, n)
    X = np.column_stack([q1, qd1, load + echo * y, q2])
    reference = X.copy()
    reference[:, 2] = load
    return X, reference, y


def _named(X, reference, y, named=("position of slider 1",), passed=()):
    groups = flexible.input_groups(COLS)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    use = sorted({i for g in named for i in groups[g]})
    cv = flexible.cross_validate(X[:, use], y, fold_rows)
    got, cv_got, use_got = beside_named(list(named), use, cv, groups, 1, X, y, fold_rows, reference, passed)
    assert cv_got.mse <= cv.mse and set(use) <= set(use_got)
    return sorted(got)


def test_the_own_effort_a_force_scales_is_named_beside_its_position():
    X, reference, y = _rail(scaled_by="effort")
    assert _named(X, reference, y) == ["effort of slider 1", "position of slider 1"]
    # without a reference motion the effort cannot be told from the controller's answer: not named
    assert _named(X, None, y) == ["position of slider 1"]
    # an effort the screen passed was judged by the other rules: not tried again
    assert _named(X, reference, y, passed=("effort of slider 1",)) == ["position of slider 1"]


def test_the_effort_is_tried_only_beside_the_own_joints_position():
    # a force 0.8 load beside the ripple: the effort adds beside slider 1's position, and is not
    # tried beside another joint's position alone (a force on the platform reaches every effort)
    X, reference, y = _rail(scaled_by="load")
    assert _named(X, reference, y, passed=("rate of slider 1",)) == ["effort of slider 1", "position of slider 1"]
    assert _named(X, reference, y, ("position of slider 2",), passed=("rate of slider 1",)) == ["position of slider 2"]


def test_an_effort_that_only_echoes_the_force_is_not_named():
    # the effort carries the disturbance (it answers it) and predicts it out of fold, but its
    # counterpart along the reference (the load) adds nothing to the ripple of the position
    X, reference, y = _rail(echo=2.0)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    position, with_effort = (flexible.cross_validate(X[:, cols], y, fold_rows) for cols in ([0], [0, 2]))
    assert gain(position, with_effort, y, float(np.var(y)))[1]  # the echo adds out of fold beside the position
    assert _named(X, reference, y) == ["position of slider 1"]


def test_the_own_rate_a_damping_reads_is_named_and_a_force_of_the_position_alone_gains_nothing():
    X, reference, y = _rail(scaled_by="rate")
    assert _named(X, reference, y) == ["position of slider 1", "rate of slider 1"]
    X, reference, y = _rail()
    assert _named(X, reference, y) == ["position of slider 1"]


def test_only_the_channels_own_joint_and_what_is_not_named_is_tried():
    groups = flexible.input_groups(COLS)
    assert own_groups(groups, 1, ["rate of slider 1"]) == ["effort of slider 1"]
    assert own_groups(groups, 2, []) == []  # slider 2 has no rate or effort among the inputs
    assert own_groups(groups, None, []) == []  # a channel of no joint
