"""Which inputs the flexible stage names (cosim.discrepancy.flexible.select): on a weak channel
a consequence of the force is no answer by itself.

Synthetic, truth in closed form: a friction on slider 1 in proportion to another drive's effort,
sign(qd1) 0.25 (|effort2| - mean |effort2|) (a bearing preloaded by the neighbouring drive, its
mean level taken by a fitted Coulomb friction), and the channel's own model effort carrying the
motion's own load and a copy of that force lagged by 30 ms (what the drive's controller answers
in closed loop).
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible


def _preloaded(n=900, sigma=0.05, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    qd1 = np.sin(2 * np.pi * 0.41 * t) + 0.4 * np.sin(2 * np.pi * 1.3 * t + 0.5)
    effort2 = np.sin(2 * np.pi * 0.17 * t + 1.0) + 0.6 * np.sin(2 * np.pi * 0.53 * t)
    f = np.tanh(qd1 / 0.05) * 0.25 * (np.abs(effort2) - np.mean(np.abs(effort2)))
    a = np.exp(-(t[1] - t[0]) / 0.03)
    copy = np.empty(n)
    copy[0] = f[0]
    for i in range(1, n):
        copy[i] = a * copy[i - 1] + (1 - a) * f[i]
    y = f + rng.normal(0.0, sigma, n)
    load = 0.3 * np.sin(2 * np.pi * 0.29 * t + 2.0)
    X = np.column_stack([qd1, effort2, load + copy, rng.uniform(-1, 1, (n, 2))])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("effort2", "effort of slider 2", 2, "effort", "N"),
            ("effort1", "effort of slider 1", 1, "effort", "N"),
            ("q3", "position of slider 3", 3, "position", "m"), ("q4", "position of slider 4", 4, "position", "m")]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    return pipe, X, cols, y, sigma


def test_a_weak_channel_whose_strongest_input_is_a_consequence_gets_the_trees_on_every_input():
    # the strongest input alone is the channel's own model effort (a lagged copy of the force);
    # without the rule it is named alone; with it the trees on every input are judged, causes
    # before consequences, and the two causes of the product are named
    pipe, X, cols, y, sigma = _preloaded()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"), weak=True)
    assert fit.explained
    assert sorted(d.group for d in fit.inputs) == ["effort of slider 2", "rate of slider 1"]
