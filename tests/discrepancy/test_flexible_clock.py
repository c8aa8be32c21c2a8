"""A state set by time, not by the motion (cosim.discrepancy.flexible.clock).

Synthetic, truth in closed form: a force level over a window of time (2.6-5.4 s of 9 s) on a
channel whose inputs hold time and the low-passed |rate| of two other rails, one of which works
harder in the middle of the run (its history rises and falls over the window); and a force
that rail 3's work sets (its low-passed |rate|: it works and rests several times in the run).
Beside the platform pose: a force of the pose alone, on only where the pose comes near a point
(a tendon taut in a few stretches of a repeated motion), and the window in time, each with a
rail's low-passed |effort| that carries the force beside its own motion.  A brake dragging over
a window of time beside the rail's rate, whose group holds the rail's power history signed by the
direction: time takes the history's place and is judged beside the rate's own columns.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import beside, clock
from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.columns import (POWER_TIME_CONSTANTS, TIME_CONSTANTS, _lowpass, histories,
                                                input_groups)
from cosim.discrepancy.flexible.cv import cross_validate, folds

PIPE = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
COLUMNS = [("q1", "position of slider 1", 1, "position", "m"), ("qd1", "rate of slider 1", 1, "rate", "m/s"),
           ("|qd2| low-passed 1 s", "history of slider 2", 2, "history", "m/s"),
           ("|qd2| low-passed 4 s", "history of slider 2", 2, "history", "m/s"),
           ("|qd3| low-passed 4 s", "history of slider 3", 3, "history", "m/s"),
           ("t", "time", None, "time", "s")]


def _case(kind, seed, n=900, sigma=0.05):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    dt = t[1] - t[0]
    q1 = np.sin(2 * np.pi * 0.37 * t) + 0.5 * np.sin(2 * np.pi * 1.1 * t + 1.0)
    qd2 = (0.3 + np.exp(-0.5 * ((t - 4.0) / 1.3) ** 2)) * np.sin(2 * np.pi * 0.9 * t) + 0.1 * rng.normal(size=n)
    qd3 = (np.sin(2 * np.pi * 0.23 * t + 1.0) > 0) * np.sin(2 * np.pi * 1.3 * t)  # works and rests
    h = [_lowpass(np.abs(v)[:, None], dt, tc, {0})[:, 0] for v, tc in ((qd2, 1.0), (qd2, 4.0), (qd3, 4.0))]
    if kind == "window":  # edges 0.05 s
        f = 0.5 / (1.0 + np.exp(-(t - 2.6) / 0.05)) / (1.0 + np.exp((t - 5.4) / 0.05))
    else:
        f = 2.0 * h[2]
    X = np.column_stack([q1, np.gradient(q1, t)] + h + [t])
    return X, f + rng.normal(0.0, sigma, n), sigma


def test_a_window_in_time_is_named_on_time_not_on_a_history_that_follows_it():
    # trees on time alone explain 0.83-0.84 out of fold, on rail 2's history 0.62-0.70 (seeds 3,
    # 1, measured); the screen passes the history, whose importance time's takes in the trees on
    # every input.  Without the rule (time judged last) "history of slider 2" is named, seeds 1-4
    for seed in (1, 2, 3, 4):
        X, y, sigma = _case("window", seed)
        fit = flexible.fit_channel(PIPE, X, COLUMNS, y, sigma, ("N", "tau1"))
        assert fit.explained and fit.share > 0.8
        assert [d.group for d in fit.inputs] == ["time"]


def test_a_force_the_motion_sets_stays_on_its_history():
    # rail 3 works and rests four times: its low-passed |rate| beats time significantly
    for seed in (1, 2):
        X, y, sigma = _case("work", seed)
        fit = flexible.fit_channel(PIPE, X, COLUMNS, y, sigma, ("N", "tau1"))
        assert fit.explained and fit.share > 0.8
        assert [d.group for d in fit.inputs] == ["history of slider 3"]


def _beside_the_pose(kind, seed, n=900, sigma=0.05):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    px = np.sin(2 * np.pi * 0.23 * t) + 0.4 * np.sin(2 * np.pi * 0.71 * t + 1.0)
    py = np.sin(2 * np.pi * 0.31 * t + 2.0) + 0.4 * np.sin(2 * np.pi * 0.57 * t)
    if kind == "taut":  # on where the pose is within 1 of (1.2, 1.2): a few stretches of the run
        f = 1.5 * np.maximum(0.0, 1.0 - np.hypot(px - 1.2, py - 1.2))
    else:
        f = 0.5 / (1.0 + np.exp(-(t - 2.6) / 0.05)) / (1.0 + np.exp((t - 5.4) / 0.05))
    effort = np.sin(2 * np.pi * 0.43 * t) + 2.0 * f + 0.3 * rng.normal(size=n)
    history = _lowpass(np.abs(effort)[:, None], t[1] - t[0], 0.5, {0})[:, 0]
    y = f + rng.normal(0.0, sigma, n)
    X, rows = np.column_stack([px, py, history, t]), folds(n, 5)
    groups = {"the platform pose": [0, 1], "history of slider 1": [2], "time": [3]}

    def cv_on(gs):
        cols = sorted({i for g in gs for i in groups[g]})
        return cross_validate(X[:, cols], y, rows), cols
    return clock.on_time(["history of slider 1"], groups, y, float(np.var(y)), cv_on)


def test_in_the_place_of_a_history_the_pose_where_it_beats_time_and_time_where_it_beats_the_pose():
    # taut: trees on the pose explain 0.75-0.79 out of fold, on time 0.41-0.43, on the history
    # 0.23-0.32, which does not beat time significantly (measured, seeds 1-3); without the rule
    # time is named in its place.  The window: time 0.83-0.84, the pose none (-0.13 to -0.05)
    for seed in (1, 2):
        assert _beside_the_pose("taut", seed) == ["the platform pose"]
        assert _beside_the_pose("window", seed) == ["time"]


def _brake(seed, n=900, sigma=0.05):
    """A brake on rail 1 dragging over 2.6-5.4 s of 9 s (a Coulomb friction, smooth sign over
    0.05 m/s), on the residual folded by rail 1's direction (the stage's folded fit,
    :mod:`cosim.discrepancy.flexible.folded`): the target is the brake's level.  Rail 1's inputs
    are the stage's own (:func:`~cosim.discrepancy.flexible.columns.histories`, grouped by
    :func:`~cosim.discrepancy.flexible.columns.input_groups`): its low-passed dissipated power,
    signed by the direction, is a column of its rate's group too; its effort carries its own
    motion's and the brake's."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    q1 = np.sin(2 * np.pi * 0.2 * t) + 0.4 * np.sin(2 * np.pi * 0.7 * t + 1.0)
    qd1 = np.gradient(q1, t)
    window = 1.0 / (1.0 + np.exp(-(t - 2.6) / 0.05)) / (1.0 + np.exp((t - 5.4) / 0.05))
    f = 0.5 * np.tanh(qd1 / 0.05) * window
    effort = 0.3 * np.sin(2 * np.pi * 0.2 * t + 0.5) + f + 0.05 * rng.normal(size=n)
    y = np.sign(qd1) * (f + rng.normal(0.0, sigma, n))
    columns = [COLUMNS[0], COLUMNS[1]]
    for tc in TIME_CONSTANTS:
        columns += [(f"|qd1| low-passed {tc:g} s", "history of slider 1", 1, "history", "m/s"),
                    (f"effort1 low-passed {tc:g} s", "history of slider 1", 1, "history", "N")]
    for tc in POWER_TIME_CONSTANTS:
        columns += [(f"|effort1 qd1| low-passed {tc:g} s", "history of slider 1", 1, "history", "W"),
                    (f"sign(qd1) |effort1 qd1| low-passed {tc:g} s", "history of slider 1", 1,
                     "history x direction", "W")]
    X = np.column_stack([q1, qd1] + histories(qd1, effort, t[1] - t[0], {0}) + [t])
    return X, y, input_groups(columns + [COLUMNS[-1]])


def test_a_window_in_time_takes_the_place_of_a_history_whose_signed_column_the_rate_holds():
    # the trees on rail 1's rate and history explain 0.52-0.55 out of fold, on its rate and time
    # 0.78-0.79, on the rate alone 0.09 and -0.11 (the rate's group holds the signed power), on its
    # rate's own columns alone -0.18 and -0.17 and those with time 0.82-0.85 (seeds 1, 3,
    # measured): time takes the history's place.  With the neighbouring blocks held out, time
    # beside the rate with the signed power adds 0.27 and 0.31 (1.96 and 1.5 standard errors over
    # the folds, under the bar), beside the rate's own columns 0.65 and 0.59 (5.1 and 4.3).
    # Without the rule (time judged beside the history's signed columns) the rate is named alone
    for seed in (1, 3):
        X, y, groups = _brake(seed)
        rows, done = folds(len(y), 5), {}

        def cv_on(gs):
            cols = sorted({i for g in gs for i in groups[g]})
            if tuple(cols) not in done:
                done[tuple(cols)] = cross_validate(X[:, cols], y, rows)
            return done[tuple(cols)], cols
        after = beside.rules(X, y, rows, groups, set(), None, cross_validate)
        assert after(["rate of slider 1", "history of slider 1"], cv_on) == ["rate of slider 1", "time"]
