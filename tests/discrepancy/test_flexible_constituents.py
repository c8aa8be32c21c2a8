"""A model effort named where what it is computed from says the same
(cosim.discrepancy.flexible.select.made_of_efforts).

Synthetic, truth in closed form.  A force on the platform (a tendon pulling once taut: a hinge of
the platform's distance from an anchor, two pose columns) read on slider 1's channel, beside
slider 4's model effort computed from the pose (its gravity load) and the slider's acceleration,
with a copy of the force lagged by 30 ms (the tracking error's acceleration the controller
answers in closed loop); and a friction on slider 1 in proportion to slider 2's load,
tanh(qd1 / 0.05) 0.25 |effort2|, where slider 2's effort is itself computed from the pose alone
(the load of a static posture), so that the pose could stand in for it.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.beside import passed_on
from cosim.discrepancy.flexible.select import select


def _lagged(f, t, tc):
    a = np.exp(-(t[1] - t[0]) / tc)
    out = np.empty(len(f))
    out[0] = f[0]
    for i in range(1, len(f)):
        out[i] = a * out[i - 1] + (1 - a) * f[i]
    return out


def _motion(n, seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    px = np.sin(2 * np.pi * 0.23 * t) + 0.4 * np.sin(2 * np.pi * 0.71 * t + 1.0)
    py = np.sin(2 * np.pi * 0.31 * t + 2.0) + 0.4 * np.sin(2 * np.pi * 0.57 * t)
    return rng, t, px, py


def _tendon(n=900, sigma=0.05, seed=5):
    rng, t, px, py = _motion(n, seed)
    stretch = np.hypot(px - 1.2, py - 1.2) - 1.6  # taut below 1.6 from the anchor (1.2, 1.2)
    f = 1.5 * np.maximum(0.0, -stretch)
    qdd4 = np.gradient(np.gradient(0.5 * px + 0.5 * py, t), t)
    effort4 = 0.02 * qdd4 + 0.1 * (px - py) + _lagged(f, t, 0.03)
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([px, py, effort4, qdd4, np.gradient(0.5 * px + 0.5 * py, t), rng.uniform(-1, 1, n)])
    cols = [("pose[0]", "the platform pose", None, "pose", ""), ("pose[1]", "the platform pose", None, "pose", ""),
            ("effort4", "effort of slider 4", 4, "effort", "N"),
            ("qdd4", "acceleration of slider 4", 4, "acceleration", "m/s^2"),
            ("qd4", "rate of slider 4", 4, "rate", "m/s"), ("q3", "position of slider 3", 3, "position", "m")]
    return X, cols, y, sigma


def _load_friction(n=900, sigma=0.05, seed=3):
    rng, t, px, py = _motion(n, seed)
    qd1 = np.sin(2 * np.pi * 0.41 * t) + 0.4 * np.sin(2 * np.pi * 1.3 * t + 0.5)
    effort2 = 1.0 + 0.8 * px + 0.3 * py  # the load of the posture: a function of the pose alone
    f = np.tanh(qd1 / 0.05) * 0.25 * np.abs(effort2)
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([qd1, effort2, px, py, rng.uniform(-1, 1, n)])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("effort2", "effort of slider 2", 2, "effort", "N"),
            ("pose[0]", "the platform pose", None, "pose", ""), ("pose[1]", "the platform pose", None, "pose", ""),
            ("q3", "position of slider 3", 3, "position", "m")]
    return X, cols, y, sigma


PIPE = types.SimpleNamespace(channels=["tau1"], window=5, step=5)


def test_a_force_on_the_platform_is_named_on_the_pose_not_on_a_rails_effort():
    # slider 4's effort carries the force (its lagged copy) and the pose; the trees on the pose
    # alone explain as much: the pose is named in its place.  Without the rule the effort is named
    # (alone, or beside the pose)
    X, cols, y, sigma = _tendon()
    for weak in (False, True):
        fit = flexible.fit_channel(PIPE, X, cols, y, sigma, ("N", "tau1"), weak=weak)
        assert fit.explained and fit.share > 0.6
        assert [d.group for d in fit.inputs] == ["the platform pose"]


def test_a_drives_load_beside_the_rate_stays_named_though_the_pose_sets_it():
    # a friction needs the direction of motion: beside the named rate the effort is the input,
    # even where the pose it is computed from would carry the same (the rule leaves it there)
    X, cols, y, sigma = _load_friction()
    fit = flexible.fit_channel(PIPE, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained
    assert sorted(d.group for d in fit.inputs) == ["effort of slider 2", "rate of slider 1"]


def test_a_drives_load_in_a_fit_folded_by_the_direction_stays_named():
    # folded by slider 1's direction (flexible/folded.py) the trees learn the level 0.25 |effort2|
    # on no rate: the direction is the rate, named already, and the effort stays; judged as a fit
    # with no direction the pose it is computed from takes its place
    X, level, groups, fold_rows, named = _folded_load_friction()
    var = float(np.var(level))
    assert select(X, level, fold_rows, groups, named, var, directed=True)[0] == named
    assert select(X, level, fold_rows, groups, named, var)[0] == ["the platform pose"]


def test_a_folded_fits_effort_stays_named_in_the_choice_made_without_the_fitted_levels():
    # the choice of the efforts made again on the residual without a fitted level (beside.passed_on;
    # here a level that took nothing): the folded fit's effort stays there too
    X, level, groups, fold_rows, named = _folded_load_friction()
    fitted = (np.zeros((len(level), 2)), ["limit", "limit (derivative)"])
    on = (X, level, fold_rows, fitted, flexible.cross_validate)
    assert passed_on(named, groups, (), *on, directed=True) == named
    assert passed_on(named, groups, (), *on) == ["the platform pose"]


def _folded_load_friction():
    """The load friction folded by slider 1's direction: ``(X, level, groups, fold_rows, named)``."""
    X, cols, y, _ = _load_friction()
    return (X, np.sign(X[:, 0]) * y, flexible.input_groups(cols), flexible.folds(len(y), flexible.gap_for(1.0)),
            ["effort of slider 2"])
