"""The fewest rails' positions named in place of the pose where the pose does not beat them
(cosim.discrepancy.flexible.select.fewest_rails).

Synthetic, truth in closed form.  Six rails move independently; the platform pose is a
one-to-one linear function of their positions (six columns), one of its columns the gap of
rails 1 and 2 with a little of rails 3 and 4 (a tilt).  A cable carrier between rails 1 and 2
pulls once their gap passes a slack, 2 max(0, q2 - q1 - 0.2) N: a function of the pose, and
of slider 1's and slider 2's positions alone.  A magnet on the platform, 1 / (1.5 + |p - a|^2) N
with p three of the pose's columns that mix every rail: no one or two rails carry it.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible

PIPE = types.SimpleNamespace(channels=["tau1"], window=5, step=5)


def _rails(n=900, seed=7):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    f = rng.uniform(0.15, 0.9, (6, 2))
    ph = rng.uniform(0, 2 * np.pi, (6, 2))
    q = np.column_stack([np.sin(2 * np.pi * f[k, 0] * t + ph[k, 0]) + 0.5 * np.sin(2 * np.pi * f[k, 1] * t + ph[k, 1])
                         for k in range(6)])
    gaps = q[:, [0, 2, 4]] - q[:, [1, 3, 5]]  # the tilts: rails 1-2, 3-4, 5-6
    pose = np.column_stack([q.mean(axis=1), gaps[:, 0] + 0.1 * gaps[:, 1], gaps[:, 1] + 0.3 * gaps[:, 2],
                            gaps[:, 2] + 0.3 * gaps[:, 0], q[:, 0] + q[:, 1] - q[:, 2] - q[:, 3],
                            q[:, 2] + q[:, 3] - q[:, 4] - q[:, 5]])
    X = np.column_stack([q, pose, rng.uniform(-1, 1, n)])
    cols = [(f"q{k + 1}", f"position of slider {k + 1}", k + 1, "position", "m") for k in range(6)]
    cols += [(f"pose[{i}]", "the platform pose", None, "pose", "") for i in range(6)]
    cols += [("t", "time", None, "time", "s")]
    return rng, q, pose, X, cols


def test_a_force_on_two_rails_gap_is_named_on_their_positions_not_the_pose():
    # the pose's tilt column carries the gap: without the rule the pose is named
    rng, q, pose, X, cols = _rails()
    sigma = 0.05
    y = 2.0 * np.maximum(0.0, q[:, 1] - q[:, 0] - 0.2) + rng.normal(0.0, sigma, len(q))
    fit = flexible.fit_channel(PIPE, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.8
    assert sorted(d.group for d in fit.inputs) == ["position of slider 1", "position of slider 2"]


def test_a_force_on_the_platform_keeps_the_pose():
    rng, q, pose, X, cols = _rails()
    sigma = 0.02
    a = np.array([0.5, 0.8, -0.6])
    y = 1.0 / (1.5 + np.sum((pose[:, [0, 2, 4]] - a) ** 2, axis=1)) + rng.normal(0.0, sigma, len(q))
    fit = flexible.fit_channel(PIPE, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.6
    assert [d.group for d in fit.inputs] == ["the platform pose"]
