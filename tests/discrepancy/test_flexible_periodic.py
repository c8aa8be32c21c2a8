"""The time along a line of the residual's spectrum (cosim.discrepancy.flexible.periodic): a force
repeating at a fixed frequency is named on time, its line's column fitted on each fold's fitted rows;
a channel whose structure left is a line is fitted, against the own noise without the line; a line
found elsewhere in the recording is offered to every channel, a column where it predicts out of fold.

Synthetic, truth in closed form: 8.5 s at 100 samples per second, three positions (sums of three
sines at 0.05-0.8 Hz), a force 0.3 cos(2 pi 4.37 t + 0.7) N plus white noise of 0.03 N.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import periodic, stage as flexible
from cosim.discrepancy.flexible.cv import FoldInputs, at, folds
from cosim.discrepancy.flexible.periodic import LINE, extend, extended, line, offered

#: what fit_channel reads of the pipeline: one channel, its window and decimation step
PIPE = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
F, AMP, SIGMA = 4.37, 0.3, 0.03


def _case(n=850, seed=3, force=None):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    pos = [sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(rng.uniform(0.05, 0.8, 3), rng.uniform(0.0, 6.3, 3)))
           for _ in range(3)]
    y = (AMP * np.cos(2 * np.pi * F * t + 0.7) if force is None else force(t, pos)) + rng.normal(0.0, SIGMA, n)
    X = np.column_stack(pos + [t])
    cols = [(f"q{j}", f"position of slider {j}", j, "position", "m") for j in (1, 2, 3)]
    cols.append(("t", "time", None, "time", "s"))
    return X, cols, y


def test_a_force_at_a_fixed_frequency_is_named_on_time_with_its_line():
    # trees on t alone learn the fitted blocks' values, not the phase in the held-out ones: without
    # the line's column nothing is claimed on time (share out of fold below 0.05, measured); with it
    # the force is named on time alone, at its frequency, with nearly all of it explained
    X, cols, y = _case()
    fit = flexible.fit_channel(PIPE, X, cols, y, SIGMA, ("N", "tau1"))
    assert fit.explained and fit.share > 0.9
    assert [d.group for d in fit.inputs] == ["time"]
    assert "the time (a line at 4.37 Hz;" in flexible.statement(fit, "slider")
    # the black box's column, rebuilt from the stage's inputs, is the final model's
    assert fit.lines and abs(fit.lines[0][1] - F) < 0.01
    Xe = extended(X, fit.lines)
    assert np.allclose(fit.model.predict(Xe[:, list(fit.use)]), y, atol=6 * SIGMA)


def test_the_line_is_fitted_on_each_folds_fitted_rows_only():
    # the residual changed on a fold's held-out rows leaves that fold's column as it was; on every
    # sample it moves
    X, cols, y = _case()
    rows = folds(len(y), 1)
    groups = flexible.input_groups(cols)
    Xe, cols_e, groups_e, lines = extend(X, cols, groups, y, rows)
    assert isinstance(Xe, FoldInputs) and Xe.shape[1] == X.shape[1] + 1
    assert groups_e["time"] == [3, 4] and cols_e[-1][0].startswith(LINE)
    held = rows[2][0]
    y2 = y.copy()
    y2[held] += np.random.default_rng(1).normal(0.0, 0.05, len(held))
    Xe2, _, _, lines2 = extend(X, cols, groups, y2, rows)
    assert np.array_equal(at(Xe, 2), at(Xe2, 2))
    assert not np.allclose(at(Xe, 1)[:, -1], at(Xe2, 1)[:, -1])
    assert not np.allclose(np.asarray(Xe)[:, -1], np.asarray(Xe2)[:, -1])
    assert np.allclose(extended(X, lines)[:, -1], np.asarray(Xe)[:, -1])


def test_a_line_the_positions_hold_and_a_residual_without_one_get_no_column():
    # a force keyed on a position repeats at the position's frequencies: no line of time
    X, cols, y = _case(force=lambda t, pos: 0.3 * np.tanh(2.0 * pos[0]))
    assert line(X[:, 3], y, X[:, :3]) is None
    rows = folds(len(y), 1)
    assert extend(X, cols, flexible.input_groups(cols), y, rows)[3] == ()
    # noise alone: whatever its highest peak, the sinusoid predicts nothing out of fold
    X, cols, y = _case(force=lambda t, pos: 0.0 * t)
    assert extend(X, cols, flexible.input_groups(cols), y, rows)[3] == ()


def test_a_channel_whose_structure_is_a_line_is_fitted_against_the_noise_without_it():
    # the own noise of a residual holding a fast line reads the line: the channel holds nothing
    # beyond it and is no candidate; flagged by its line, with the noise without it, it is
    X, cols, y = _case()
    pipe = types.SimpleNamespace(channels=["tau1", "tau2"], nd=2, window=5, step=5)
    R = np.column_stack([y, np.random.default_rng(9).normal(0.0, SIGMA, len(y))])
    read = [0.22, SIGMA]  # the line's amplitude over sqrt(2), as the own noise reads it
    assert flexible.candidates(pipe, R, [], read) == []
    entry = {"channel": "tau1", "joint": 1, "signature": "periodic", "noise": SIGMA}
    left, noise = flexible.with_lines(pipe, [], [entry], read)
    assert flexible.candidates(pipe, R, left, noise) == [0] and noise == [SIGMA, SIGMA]
    assert flexible.with_lines(pipe, [], [], read) == ([], read)


def _carried_elsewhere(seed=3):
    """A channel whose residual a force keyed on position 1 carries (0.5 tanh(2 q1) N), beside the
    line 0.2 cos(2 pi 4.37 t + 0.7) N: about 10 % of its variance."""
    return _case(seed=seed, force=lambda t, pos: 0.5 * np.tanh(2.0 * pos[0])
                 + 0.2 * np.cos(2 * np.pi * F * t + 0.7))


def test_a_line_found_elsewhere_is_offered_and_named_where_it_adds():
    # the channel's own rule finds no line the sinusoid carries (out of fold below the bar); the line
    # offered from another channel is a column, and time is named beside the position
    X, cols, y = _carried_elsewhere()
    rows = folds(len(y), 1)
    groups = flexible.input_groups(cols)
    assert extend(X, cols, groups, y, rows)[3] == ()
    Xe, cols_e, _, lines = extend(X, cols, groups, y, rows, (F + 0.004,))
    assert cols_e[-1][0].startswith(LINE) and abs(lines[0][1] - F) < 0.01
    alone = flexible.fit_channel(PIPE, X, cols, y, SIGMA, ("N", "tau1"))
    assert "time" not in [d.group for d in alone.inputs]
    fit = flexible.fit_channel(PIPE, X, cols, y, SIGMA, ("N", "tau1"), offered=(F,))
    assert fit.explained and sorted(d.group for d in fit.inputs) == ["position of slider 1", "time"]
    assert fit.share > alone.share + 0.03


def test_a_line_offered_to_a_channel_without_the_force_is_no_column():
    # the position's force and noise, no line: the sinusoid at the offered frequency, fitted per
    # fold, predicts nothing out of fold; noise alone neither
    X, cols, y = _case(force=lambda t, pos: 0.5 * np.tanh(2.0 * pos[0]))
    rows = folds(len(y), 1)
    assert extend(X, cols, flexible.input_groups(cols), y, rows, (F,))[3] == ()
    X, cols, y = _case(force=lambda t, pos: 0.0 * t)
    assert extend(X, cols, flexible.input_groups(cols), y, rows, (F,))[3] == ()


def test_the_lines_offered_are_the_channels_own_and_the_reports_that_repeat(monkeypatch):
    # a channel holding the line by its own rule offers it; the report's lines follow where their
    # sinusoid fitted per fold predicts their own channel out of fold: its 4.40 Hz on tau2 is the
    # same line (one per resolution, 1 / 8.5 s), its 2.10 Hz on tau1 (noise alone there) is none
    X, cols, y = _case()
    quiet = np.random.default_rng(5).normal(0.0, SIGMA, len(y))
    rows = folds(len(y), 1)
    t, pos, R = X[:, 3], X[:, :3], np.column_stack([quiet, y])
    own = offered(t, R, pos, rows)
    assert len(own) == 1 and abs(own[0] - F) < 0.01
    report = [{"channel": "tau2", "joint": 2, "lines": [(4.40, 0.2)]}, {"channel": "tau1", "joint": 1,
                                                                        "lines": [(2.10, 0.05)]}]
    assert offered(t, R, pos, rows, report) == own
    assert offered(t, quiet[:, None], pos, rows) == ()
    # where the channels' own rule found nothing, the report's line that repeats on its channel is
    # offered (at the reported frequency: the column refines it per fold); the one that does not is not
    monkeypatch.setattr(periodic, "own", lambda *a: (None, None))
    assert offered(t, R, pos, rows, report) == (4.40,)
