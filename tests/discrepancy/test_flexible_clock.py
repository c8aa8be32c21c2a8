"""A state set by time, not by the motion (cosim.discrepancy.flexible.clock).

Synthetic, truth in closed form: a force level over a window of time (2.6-5.4 s of 9 s) on a
channel whose inputs hold time and the low-passed |rate| of two other rails, one of which works
harder in the middle of the run (its history rises and falls over the window); and a force
that rail 3's work sets (its low-passed |rate|: it works and rests several times in the run).
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.columns import _lowpass

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
