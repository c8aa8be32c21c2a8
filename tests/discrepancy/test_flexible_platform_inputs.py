"""Inputs for forces on the platform: the platform pose projected on the direction of a linear fit
of the residual (cosim.discrepancy.flexible.oblique): a force keyed on an oblique direction of the
pose is named on the pose, not on a one-column proxy of it; the direction is fitted on each fold's
fitted rows.

Synthetic, truth in closed form: six pose columns (sums of three sines at random frequencies),
a force 0.5 tanh(3 s) on s, the pose along the oblique direction (1, -1, 1, 1, -1, 1) / sqrt(6)
(scaled to unit RMS), and a rail's model effort that moves with s (s plus its own motion at 0.6
of s's RMS): what gravity makes of the pose.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.cv import FoldInputs, at, folds
from cosim.discrepancy.flexible.oblique import extend, extended


def _sines(rng, t, k):
    return [sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(rng.uniform(0.05, 0.8, 3), rng.uniform(0.0, 6.3, 3)))
            for _ in range(k)]


def _sliders(quantity, unit, joints):
    """The stage's column tuples of ``quantity`` ("position", "rate", ...) for the 1-based ``joints``."""
    short = {"position": "q", "rate": "qd"}.get(quantity, quantity)
    return [(f"{short}{j}", f"{quantity} of slider {j}", j, quantity, unit) for j in joints]


#: what fit_channel reads of the pipeline: one channel, its window and decimation step
PIPE = types.SimpleNamespace(channels=["tau1"], window=5, step=5)


def _oblique(n=900, sigma=0.05, seed=5):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    pose = np.column_stack(_sines(rng, t, 6))
    s = pose @ np.array([1.0, -1.0, 1.0, 1.0, -1.0, 1.0])
    s /= np.std(s)
    y = 0.5 * np.tanh(3.0 * s) + rng.normal(0.0, sigma, n)
    own = _sines(rng, t, 1)[0]
    proxy = s + 0.6 * own / np.std(own)
    others = _sines(rng, t, 3)
    X = np.column_stack([proxy] + others + [pose[:, i] for i in range(6)])
    cols = _sliders("effort", "N", [2]) + _sliders("position", "m", range(3, 6))
    cols += [(f"pose[{i}]", "the platform pose", None, "pose", "") for i in range(6)]
    return PIPE, X, cols, y, sigma


def test_a_force_on_an_oblique_direction_of_the_pose_is_named_on_the_pose_not_on_a_rails_effort():
    # the trees split on one column at a time: on the six pose columns they explain 0.58 of it out
    # of fold, on the rail's effort alone 0.56 (measured).  With the pose's projected column the pose
    # alone is named (share 0.95); without it the rail's effort is named beside the pose (0.56)
    pipe, X, cols, y, sigma = _oblique()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.8
    assert [d.group for d in fit.inputs] == ["the platform pose"]


def test_the_direction_is_fitted_on_each_folds_fitted_rows_only():
    # the residual changed on a fold's held-out rows leaves that fold's projected column as it was
    # (no held-out row moves the column its trees are judged on); on every sample it moves
    pipe, X, cols, y, sigma = _oblique()
    rows = folds(len(y), 5)
    groups = flexible.input_groups(cols)
    Xe, cols_e, groups_e, proj = extend(X, cols, groups, y, rows)
    assert isinstance(Xe, FoldInputs) and Xe.shape[1] == X.shape[1] + 1
    assert groups_e["the platform pose"][-1] == X.shape[1] and cols_e[-1][1] == "the platform pose"
    held = rows[2][0]
    y2 = y.copy()
    y2[held] = np.random.default_rng(1).normal(0.0, 1.0, len(held))
    Xe2, _, _, proj2 = extend(X, cols, groups, y2, rows)
    assert np.array_equal(at(Xe, 2), at(Xe2, 2))
    assert not np.allclose(at(Xe, 1)[:, -1], at(Xe2, 1)[:, -1])  # fold 1 fits fold 2's rows
    assert not np.allclose(np.asarray(Xe)[:, -1], np.asarray(Xe2)[:, -1])
    # the final model's column is the one on every sample, rebuilt from the stage's inputs
    assert np.allclose(extended(X, proj)[:, -1], np.asarray(Xe)[:, -1])
    # selecting columns keeps the folds' variants, selecting rows gives the whole columns
    sub = Xe[:, [0, X.shape[1]]]
    assert isinstance(sub, FoldInputs) and np.array_equal(at(sub, 2)[:, 1], at(Xe, 2)[:, -1])
    assert type(Xe[held]) is np.ndarray


def _spindle(n=900, sigma=0.05, seed=7):
    """A moment linear in an oblique combination of six rails' rates (a gyroscopic H x omega):
    0.5 r, r the rates along (1, 0.8, -1, 0.6, -0.9, 1) scaled to unit RMS, beside the rails'
    positions (whose derivatives the rates are)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    q = np.column_stack(_sines(rng, t, 6))
    qd = np.gradient(q, t, axis=0)
    r = qd @ np.array([1.0, 0.8, -1.0, 0.6, -0.9, 1.0])
    y = 0.5 * r / np.std(r) + rng.normal(0.0, sigma, n)
    X = np.column_stack([q, qd])
    cols = _sliders("position", "m", range(1, 7)) + _sliders("rate", "m/s", range(1, 7))
    return PIPE, X, cols, y, sigma


def test_a_moment_linear_in_an_oblique_combination_of_the_rates_is_learnt_on_the_rates():
    # trees split on one column at a time: without the rates' projected column the stage claims 0.67
    # and names rail 3's rate beside rails 5's and 3's positions (measured); with it 0.99, on rates
    pipe, X, cols, y, sigma = _spindle()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.85
    assert fit.inputs and all(d.group.startswith("rate of slider") for d in fit.inputs)


def test_the_rates_are_projected_only_where_their_combination_beats_the_best_single_rate():
    # a force on one rail's rate (a friction, sign-like) is fitted on that rate alone: no projected
    # rates column (it would stand in the rate groups of the joints moving with that rail); the
    # spindle's moment needs the combination: projected
    from cosim.discrepancy.flexible.oblique import OBLIQUE_MIN, oblique_gain

    pipe, X, cols, y, sigma = _spindle()
    rows = folds(len(y), 5)
    groups = flexible.input_groups(cols)
    qd = X[:, 6:]
    friction = 0.3 * np.tanh(qd[:, 2] / (0.05 * np.std(qd[:, 2]))) + np.random.default_rng(2).normal(0.0, sigma, len(y))
    assert oblique_gain(qd, friction, rows) < OBLIQUE_MIN < oblique_gain(qd, y, rows)
    assert extend(X, cols, groups, friction, rows)[0].shape[1] == X.shape[1]
    assert extend(X, cols, groups, y, rows)[0].shape[1] == X.shape[1] + 1
