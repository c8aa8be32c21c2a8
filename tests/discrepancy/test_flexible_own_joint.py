"""The channel's own joint before another's (cosim.discrepancy.flexible.own_joint): another joint's
position, rate or history named on a channel gives way to the channel's own joint's of the same
quantity where the named inputs do not beat that significantly; an own joint's group beside
another joint's of the same quantity is judged by the copies' rule on the check's bar alone.

Synthetic, truth in closed form: a friction on slider 1 whose level rises with the joint's own
duty, the part a fitted Coulomb level leaves, tanh(qd1 / 0.05) 1.2 (h1 - mean h1) with h1 its
|rate| low-passed over 4 s; slider 2 moves along a reference close to slider 1's (its rate 0.9 qd1
plus a motion of its own), so its rate and history are correlated copies of slider 1's (0.97 and
0.90), which out of fold can stand in for them.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.beside import rules
from cosim.discrepancy.flexible.copies import copies
from cosim.discrepancy.flexible.own_joint import beside_another, counterpart, joint_of, own_first
from cosim.discrepancy.flexible.select import DROP_MIN, consequences, fold_gain, select


def _lowpassed(x, dt, tau):
    a = np.exp(-dt / tau)
    out = np.empty(len(x))
    out[0] = x[0]
    for i in range(1, len(x)):
        out[i] = a * out[i - 1] + (1 - a) * x[i]
    return out


def _two_rails(n=900, sigma=0.03, seed=5, keyed_on_other=False):
    """``(X, columns, y)``: the rates and histories of sliders 1 and 2 (the stage's columns) and a
    residual on slider 1's channel: the duty-keyed friction above, or with ``keyed_on_other`` a
    damper's force 0.8 qd2 that slider 2's motion sets on slider 1 (keyed on the other joint)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 30.0, n)
    dt = t[1] - t[0]
    duty = 0.6 + 0.4 * np.sin(2 * np.pi * 0.12 * t)  # the motion's amplitude swells and fades
    qd1 = duty * (np.sin(2 * np.pi * 0.7 * t) + 0.3 * np.sin(2 * np.pi * 1.9 * t + 0.4))
    qd2 = 0.9 * qd1 + 0.15 * np.sin(2 * np.pi * 0.45 * t + 1.1)
    h1, h2 = _lowpassed(np.abs(qd1), dt, 4.0), _lowpassed(np.abs(qd2), dt, 4.0)
    f = 0.8 * qd2 if keyed_on_other else np.tanh(qd1 / 0.05) * 1.2 * (h1 - np.mean(h1))
    X = np.column_stack([qd1, qd2, h1, h2])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("qd2", "rate of slider 2", 2, "rate", "m/s"),
            ("|qd1| low-passed 4 s", "history of slider 1", 1, "history", "m/s"),
            ("|qd2| low-passed 4 s", "history of slider 2", 2, "history", "m/s")]
    return X, cols, f + rng.normal(0.0, sigma, n)


def _named(X, cols, y, named, joint=1):
    groups = flexible.input_groups(cols)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    follow = consequences(cols, groups, joint)
    after = rules(X, y, fold_rows, groups, follow, None, flexible.cross_validate, joint=joint)
    return sorted(select(X, y, fold_rows, groups, named, float(np.var(y)), follow=follow,
                         cross_validate=flexible.cross_validate, after=after)[0])


def test_another_joints_correlated_history_gives_way_to_the_own_joints():
    # named as a noisy screen names them: the own rate with the other rail's rate and history.
    # The check drops the other rate (it adds nothing beside the own) and keeps the other history
    # (the only history named); its own counterpart explains as much, so the own joint's is named
    X, cols, y = _two_rails()
    assert np.corrcoef(X[:, 2], X[:, 3])[0, 1] > 0.75 # the other rail's history: a close copy
    named = ["rate of slider 1", "rate of slider 2", "history of slider 2"]
    assert _named(X, cols, y, named) == ["history of slider 1", "rate of slider 1"]
    # a channel of no joint (the platform's) is left as the check leaves it
    assert _named(X, cols, y, named, joint=None) == ["history of slider 2", "rate of slider 1"]


def test_a_force_keyed_on_the_other_joint_keeps_the_other_joints_input():
    X, cols, y = _two_rails(keyed_on_other=True)
    assert _named(X, cols, y, ["rate of slider 2"]) == ["rate of slider 2"]


def test_the_counterpart_is_the_own_joints_position_rate_or_history_never_a_consequence():
    cols = [(f"{q}{k}", f"{g} of slider {k}", k, g, "") for k in (1, 4) for q, g in
            (("q", "position"), ("qd", "rate"), ("qdd", "acceleration"), ("effort", "effort"), ("h", "history"))]
    groups = flexible.input_groups(cols)
    follow = consequences(cols, groups, 4)
    assert joint_of("rate of slider 12") == ("rate", 12)
    assert joint_of("the platform pose") is None and joint_of("time") is None
    assert counterpart("rate of slider 1", 4, groups, follow) == "rate of slider 4"
    assert counterpart("history of slider 1", 4, groups, follow) == "history of slider 4"
    assert counterpart("effort of slider 1", 4, groups, follow) is None  # the own effort: a copy of the force
    assert counterpart("rate of slider 4", 4, groups, follow) is None
    assert counterpart("rate of slider 1", None, groups, follow) is None
    assert beside_another(["effort of slider 1", "effort of slider 4", "rate of slider 4"], 4) == {"effort of slider 4"}
    assert beside_another(["effort of slider 4", "rate of slider 1"], 4) == set()
    assert own_first(["the platform pose", "time"], groups, 4, follow, None, 1.0, None) == ["the platform pose", "time"]


def _one_fold_carries(n=500, k=5):
    """A fake cross-validation (the trees replaced by predictions in closed form) of a residual
    keyed on efforts 1 and 4 of a channel of slider 4: without effort 4 the prediction misses
    the force in one fold's rows only (a cost one fold carries: large, its spread over the folds
    as large); without effort 1 it misses it everywhere."""
    rng = np.random.default_rng(0)
    y = rng.normal(0.0, 1.0, n)
    fold_rows = tuple((np.arange(i, n, k), np.setdiff1d(np.arange(n), np.arange(i, n, k))) for i in range(k))
    cols = [("effort1", "effort of slider 1", 1, "effort", "N"), ("effort4", "effort of slider 4", 4, "effort", "N")]
    groups = flexible.input_groups(cols)

    def cross_validate(M, y_, rows):  # the columns told apart by their values: effort 1's are 1, effort 4's 4
        held = {float(v) for v in np.asarray(M)[0]}
        pred = 0.9 * y_ if 1.0 in held else np.zeros(len(y_))  # without effort 1: nothing explained
        if 4.0 not in held:  # without effort 4: fold 0's rows unexplained
            pred = pred.copy()
            pred[rows[0][0]] = 0.0
        return types.SimpleNamespace(pred=pred, folds=rows, mse=float(np.mean((y_ - pred) ** 2)))
    return y, fold_rows, groups, np.tile([1.0, 4.0], (n, 1)), cross_validate


def test_an_own_effort_beside_another_drives_effort_stays_where_leaving_it_out_costs_the_checks_bar():
    y, fold_rows, groups, X, cross_validate = _one_fold_carries()
    kept = ["effort of slider 1", "effort of slider 4"]
    # the situation: leaving effort 4 out costs well above DROP_MIN, not significantly over the folds
    full, without = cross_validate(X, y, fold_rows), cross_validate(X[:, :1], y, fold_rows)
    assert (without.mse - full.mse) / np.var(y) > 2 * DROP_MIN
    assert copies(kept, groups, X, X, y, fold_rows, cross_validate) == ["effort of slider 4"]
    assert copies(kept, groups, X, X, y, fold_rows, cross_validate, checked=beside_another(kept, 4)) == []


def _fake_cvs(n=500, k=5, seed=1):
    """Fake cross-validations by the groups they hold (``cv_on`` of :func:`select`): per set of
    groups a held-out prediction in closed form of a residual ``y`` (unit variance)."""
    rng = np.random.default_rng(seed)
    y = rng.normal(0.0, 1.0, n)
    fold_rows = tuple((np.arange(i, n, k), np.setdiff1d(np.arange(n), np.arange(i, n, k))) for i in range(k))

    def cv(explained, **in_fold):  # explains a share of y, in some folds' rows another (fold0=0.1)
        share = np.full(n, explained)
        for name, v in in_fold.items():
            share[fold_rows[int(name[4:])][0]] = v
        pred = (1.0 - np.sqrt(1.0 - share)) * y
        return types.SimpleNamespace(pred=pred, folds=fold_rows, mse=float(np.mean((y - pred) ** 2)))
    return y, cv


def test_the_own_joints_input_is_named_where_it_explains_as_much_and_claims_alike():
    cols = [(f"qd{k}", f"rate of slider {k}", k, "rate", "m/s") for k in (1, 2)]
    groups = flexible.input_groups(cols)
    y, cv = _fake_cvs()
    var = float(np.var(y))
    other, own = ["rate of slider 2"], ["rate of slider 1"]

    def run(by, claims=None):
        return own_first(other, groups, 1, (), y, var, lambda gs: (by[tuple(gs)],), claims)
    # the other joint's rate explains 0.60, the own 0.50 in every fold: a loss beyond the folds' bar
    assert run({tuple(other): cv(0.60), tuple(own): cv(0.50)}) == other
    # a loss of 0.07 between one and two standard errors (not significant by select.gain): kept
    near = cv(0.60, fold0=0.30, fold4=0.55)
    mean, se, _ = fold_gain(y, near.pred, cv(0.60).pred, near.folds, var, lambda m, s: True)
    assert se < mean < 2 * se
    assert run({tuple(other): cv(0.60), tuple(own): near}) == other
    # the own explains 0.62, but 0.10 in fold 0's rows: a loss over DROP_MIN within one standard error
    wide = cv(0.62, fold0=0.10)
    mean, se, _ = fold_gain(y, wide.pred, cv(0.60).pred, wide.folds, var, lambda m, s: True)
    assert (wide.mse - cv(0.60).mse) / var > DROP_MIN and 0 < mean <= se
    assert run({tuple(other): cv(0.60), tuple(own): wide}) == own
    # the own explains more, but only its trees would claim (a claim bar of 0.55): the other's stays
    assert run({tuple(other): cv(0.50), tuple(own): cv(0.60)}, claims=lambda c: c.mse < 0.45 * var) == other
    assert run({tuple(other): cv(0.50), tuple(own): cv(0.60)}) == own
