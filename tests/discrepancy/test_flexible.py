"""The flexible stage (cosim.discrepancy.flexible): what is left, how much of it is explainable
and on which inputs it depends.

The synthetic checks know their truth in closed form (a force of known variance on one input,
white noise of known variance); the recordings hide a force of flexible.cases (keyed on another
joint's acceleration, which no family of the discovery step covers) or none.
"""
import dataclasses
import types

import numpy as np
import pytest

from cosim.discrepancy.flexible import cv as flexible_cv
from cosim.discrepancy.flexible import stage as flexible


def _synthetic(force, n=1200, sigma=0.05, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 1.0, (n, 6))
    f = force(X)
    y = f + rng.normal(0.0, sigma, n)
    cols = [(f"x{i}", f"input {i}", None, "position", "m") for i in range(6)]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    truth = float(np.var(f) / (np.var(f) + sigma ** 2))
    return pipe, X, cols, y, truth


def test_names_the_one_input_and_its_share_on_a_known_force():
    # a force on input 2 only above 0.6 (smooth, not a polynomial); share var(f) / (var(f) + sigma^2)
    pipe, X, cols, y, truth = _synthetic(lambda X: np.where(X[:, 2] > 0.6, np.tanh((X[:, 2] - 0.6) / 0.15) ** 2,
                                                                  0.0) * 0.3)
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    assert fit.explained
    assert [d.group for d in fit.inputs] == ["input 2"]
    assert abs(fit.share - truth) < 0.1
    assert fit.inputs[0].where.startswith("above")
    assert 0.55 <= float(fit.inputs[0].where.split()[1]) <= 0.7


def test_noise_alone_is_not_claimed():
    pipe, X, cols, y, _ = _synthetic(lambda X: np.zeros(len(X)))
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    assert not fit.explained and fit.inputs == ()


def test_folds_hold_every_sample_out_once_spread_through_the_recording():
    n, gap = 1000, 3
    rows = flexible_cv.folds(n, gap)
    held = np.concatenate([h for h, _ in rows])
    assert sorted(held.tolist()) == list(range(n))
    for h, fit in rows:
        assert h.min() < n // 4 and h.max() > 3 * n // 4  # blocks in both ends of the recording
        d = np.abs(fit[:, None] - h[None, :]).min(axis=1)
        assert d.min() > gap  # no fitted sample within the gap of a held-out one
        assert len(h) + len(fit) >= n - 2 * gap * flexible_cv.BLOCKS_PER_FOLD


def test_a_slow_input_that_rises_once_is_learned_out_of_fold():
    # a force on an input that rises once through the recording (a drive warming up) and on the
    # direction of motion: at the end of the recording the input is beyond anything earlier, so a
    # split that holds out the end leaves it outside the fitted range; the blocks spread through
    # the recording cover it.  Truth share var(f) / (var(f) + sigma^2) in closed form.
    n, sigma = 700, 0.05
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 1.0, n)
    slow = 1.0 - np.exp(-3.0 * t) + rng.normal(0.0, 0.01, n)
    X = np.column_stack([slow, rng.uniform(-1, 1, (n, 3))])
    f = 0.5 * slow ** 2
    y = f + rng.normal(0.0, sigma, n)
    cols = [("T", "slow input", None, "history", "K")] + [(f"x{i}", f"input {i}", None, "position", "m")
                                                          for i in range(3)]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    truth = float(np.var(f) / (np.var(f) + sigma ** 2))
    assert fit.explained and [d.group for d in fit.inputs] == ["slow input"]
    assert abs(fit.share - truth) < 0.1
    assert fit.outside < 0.1  # only the first and last blocks reach beyond the others


def test_outside_counts_the_held_out_samples_beyond_the_fitted_range():
    n = 400
    rows = flexible_cv.folds(n, 2)
    X = np.zeros((n, 1))
    h0 = rows[0][0]
    first = h0[h0 < n // (flexible_cv.N_FOLDS * flexible_cv.BLOCKS_PER_FOLD) + 1]
    X[first, 0] = 1.0  # one block's values never seen by the trees that predict it
    cv = flexible_cv.CV(rows, (), 1, np.zeros(n), 0.0)
    assert flexible_cv.outside(X, cv, [0]) == pytest.approx(len(first) / n)
    assert flexible_cv.outside(np.zeros((n, 1)), cv, [0]) == 0.0


def test_a_signed_history_belongs_to_the_rate_and_the_history():
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("P1", "history of slider 1", 1, "history", "W"),
            ("sign(qd1) P1", "history of slider 1", 1, "history x direction", "W")]
    groups = flexible.input_groups(cols)
    assert groups == {"rate of slider 1": [0, 2], "history of slider 1": [1, 2]}


def test_the_statement_says_when_the_inputs_were_extrapolated():
    d = flexible.Dependence("position of slider 2", "q2", 2, "position", 0.5, "m", (0.0, 0.1, 0.2, 0.3),
                            (0.0, 0.0, 0.5, 1.0))
    fit = flexible.FlexibleFit("tau2", 2, "N", 0.6, 100.0, True, 1.0, 0.1, (d,), outside=0.3)
    assert "outside the range" in flexible.statement(fit, "slider")
    assert "outside the range" not in flexible.statement(dataclasses.replace(fit, outside=0.02), "slider")


def test_the_statement_gives_a_direction_as_the_direction_of_motion():
    # a force keyed on the smoothed commanded direction, peaking where the smoother overshoots -1
    d = flexible.Dependence("rate of slider 1", "sign(qd1 reference) smoothed", 1, "rate", 0.9, "",
                            (-1.12, -0.5, 0.0, 0.5, 1.0), (-18.6, -9.0, 0.0, 9.0, 17.0))
    fit = flexible.FlexibleFit("tau1", 1, "N", 0.99, 900.0, True, 1.0, 0.1, (d,))
    s = flexible.statement(fit, "carriage")
    assert "up to 18.6 N at motion in the negative direction" in s
    assert "overshoots" in s and "= -1.12" in s
    d1 = dataclasses.replace(d, grid=(-1.0, -0.5, 0.0, 0.5, 1.0))
    s1 = flexible.statement(dataclasses.replace(fit, inputs=(d1,)), "carriage")
    assert "at motion in the negative direction;" in s1 and "overshoots" not in s1


@pytest.mark.parametrize("curve, expect", [((0, 0, 0, 0, 0, 0, 1, 2, 3, 4), "above"),
                                           ((4, 3, 2, 1, 0, 0, 0, 0, 0, 0), "below"),
                                           ((0, 1, 2, 3, 4, 5, 6, 7, 8, 9), "over")])
def test_where_a_curve_acts(curve, expect):
    grid = np.linspace(0.0, 0.9, 10)
    assert flexible._where(grid, np.asarray(curve, float), "m").startswith(expect)


@pytest.fixture(scope="module")
def cross_case():
    from cosim.discrepancy.flexible.cases import simulate

    return simulate("cross_acceleration", 7112)


def test_a_force_keyed_on_another_joints_acceleration(cross_case):
    from cosim.discrepancy import diagnose
    from cosim.discrepancy.flexible.cases import truth_share

    rec, key = cross_case
    d = diagnose(rec, replay=False, figures=False)
    fit = next(f for f in d.flexible if f.joint == key["joint"])
    assert fit.explained
    assert [x.group for x in fit.inputs] == key["truth"]
    assert abs(fit.share - truth_share(d, key, fit)) <= 0.10
    assert "where no equation was found" in d.conclusion + d.details
    assert d.to_dict()["flexible"][0]["inputs"][0]["group"] == key["truth"][0]


def test_clean_recording_nothing_explained_on_any_channel(monkeypatch):
    from cosim.discrepancy import diagnose
    from cosim.discrepancy.flexible.cases import simulate

    monkeypatch.setattr(flexible, "candidates", lambda pipe, R, left, noise: list(range(pipe.nd)))  # every channel
    rec, _ = simulate(None, 7600)
    d = diagnose(rec, replay=False, figures=False)
    assert len(d.flexible) == rec.q.shape[1]
    assert not [f.channel for f in d.flexible if f.explained]


def test_cli_prints_and_reports_it(cross_case, tmp_path, capsys):
    from cosim.cli import main
    from cosim.recording import write_recording

    rec, key = cross_case
    csv, _ = write_recording(tmp_path / "case.csv", rec)
    assert main(["diagnose", str(csv), "--out", str(tmp_path / "r"), "--no-replay"]) == 0
    out = capsys.readouterr().out
    assert "where no equation was found" in out
    md = (tmp_path / "r" / "report.md").read_text()
    assert "flexible model" in md and (tmp_path / "r" / "flexible.png").exists()


def test_black_box_replay_term_lowers_the_channels_replay_error(cross_case):
    from cosim.discrepancy import diagnose

    rec, key = cross_case
    d = diagnose(rec, figures=False, black_box=True)
    c = key["joint"] - 1
    runs = d.replay["runs"]
    assert [f.black_box for f in d.flexible if f.joint == key["joint"]] == [True]
    assert runs["fitted + black box"]["rms_tau"][c] < 0.5 * runs["fitted"]["rms_tau"][c]


def _rate_and_slow_state(n):
    """A joint's rate reversing about 1.4 times a second and a slow state (a temperature-like
    history) with a 5 s period, over 12 s: ``(random generator, rate, state)``."""
    t = np.linspace(0.0, 12.0, n)
    qd = np.sin(2 * np.pi * 0.7 * t + 0.5 * np.sin(t))
    return np.random.default_rng(5), qd, 0.5 + 0.5 * np.sin(2 * np.pi * t / 5.0)


def test_a_friction_level_set_by_a_slow_state_names_the_rate_and_the_history():
    # sign(qd) (T - mean T): neither the direction nor the state explains any of it alone (no
    # greedy split finds it); the direction-signed state does, and leaving out either input
    # removes it.  Truth share var(f) / (var(f) + sigma^2) in closed form.
    n, sigma = 700, 0.03
    rng, qd, T = _rate_and_slow_state(n)
    f = 0.4 * np.sign(qd) * (T - T.mean())
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([qd, T, np.sign(qd) * T, rng.uniform(-1, 1, (n, 2))])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("T1", "history of slider 1", 1, "history", "W"),
            ("sign(qd1) T1", "history of slider 1", 1, "history x direction", "W"),
            ("q2", "position of slider 2", 2, "position", "m"), ("q3", "position of slider 3", 3, "position", "m")]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    truth = float(np.var(f) / (np.var(f) + sigma ** 2))
    assert fit.explained
    assert sorted(d.group for d in fit.inputs) == ["history of slider 1", "rate of slider 1"]
    assert abs(fit.share - truth) < 0.1


def test_the_claim_is_judged_again_on_the_named_inputs_refit(monkeypatch):
    # the full model explains a known force on input 2; the refit on the inputs named is replaced by
    # one on a target shuffled in time, which the inputs cannot predict: its held-out share is at
    # most about 0 by construction, so the channel may not be called explained on them
    pipe, X, cols, y, truth = _synthetic(lambda X: 0.3 * np.sin(6.0 * X[:, 2]))

    def select(X, y, fold_rows, groups, named, var, *_, **__):
        use = sorted(i for g in named for i in groups[g])
        shuffled = np.random.default_rng(2).permutation(y)
        return named, flexible_cv.cross_validate(X[:, use], shuffled, fold_rows), use

    monkeypatch.setattr(flexible, "_select", select)
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    assert fit.explained  # the full model's claim, on no single input
    assert fit.inputs == ()
    assert fit.share >= flexible.SHARE_MIN and fit.z > flexible.CHI2_MIN
    assert abs(fit.share - truth) < 0.1  # the stated share is the full model's, which holds the force
    assert fit.screened[0] == ("input 2",) and fit.screened[1] < flexible.SHARE_MIN
    s = flexible.statement(fit, "slider")
    assert "no single input" in s and "input 2" in s and "not significant" in s


def test_noise_alone_cannot_be_judged_structure_off_the_inputs_is_not_explainable():
    # white noise at the stated noise level: nothing beyond the noise, so it cannot be judged
    pipe, X, cols, y, _ = _synthetic(lambda X: np.zeros(len(X)))
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    s = flexible.statement(fit, "slider")
    assert "cannot be judged" in s and "not explainable" not in s
    assert not fit.explained and not fit.beyond_noise
    # a force (RMS 6 times the noise) on a variable the inputs do not hold: structure the inputs do not explain
    hidden = np.random.default_rng(1).normal(0.0, 0.3, len(y))
    fit = flexible.fit_channel(pipe, X, cols, y + hidden, 0.05, ("N", "tau1"))
    s = flexible.statement(fit, "slider")
    assert "not explainable from the recorded inputs" in s and "cannot be judged" not in s
    assert not fit.explained and fit.beyond_noise


def test_a_weak_force_under_twice_the_noise_reaches_the_stage_and_noise_does_not():
    # a residual whose RMS is 1.3 times its own noise (a force of variance 0.69 sigma^2): a model
    # of all of it but the noise would explain a chi-square of 900 / 5 x 0.69 = 124 independent
    # samples' worth, above the claim's 25; white noise alone holds none of it
    rng = np.random.default_rng(3)
    n, sigma = 900, 0.05
    t = np.linspace(0.0, 9.0, n)
    force = np.sqrt(2 * 0.69) * sigma * np.sin(2 * np.pi * 0.4 * t)
    R = np.column_stack([force + rng.normal(0.0, sigma, n), rng.normal(0.0, sigma, n)])
    pipe = types.SimpleNamespace(channels=["tau1", "tau2"], nd=2, window=5, step=1)
    assert 1.2 < np.std(R[:, 0]) / sigma < 1.4
    assert flexible.candidates(pipe, R, [], [sigma, sigma]) == [0]


def test_when_the_trees_on_every_input_claim_nothing_the_strongest_input_alone_is_judged(monkeypatch):
    # the cross-validation on every input is given a target shuffled in time (what trees spreading a
    # weak force over many inputs make of it: nothing out of fold); the force, on input 2 only, is
    # then found on that input alone, judged out of fold by the same bars, share var(f) / (var(f) + sigma^2)
    pipe, X, cols, y, truth = _synthetic(lambda X: 0.3 * np.sin(6.0 * X[:, 2]))
    real = flexible.cross_validate

    def cross_validate(Xs, ys, fold_rows, **kw):
        if Xs.shape[1] == X.shape[1]:
            ys = np.random.default_rng(2).permutation(ys)
        return real(Xs, ys, fold_rows, **kw)

    monkeypatch.setattr(flexible, "cross_validate", cross_validate)
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    assert fit.explained
    assert [d.group for d in fit.inputs] == ["input 2"]
    assert abs(fit.share - truth) < 0.1
    assert "and on nothing else" in flexible.statement(fit, "slider")


def test_the_report_leaves_out_a_weak_channel_where_nothing_was_found():
    """A channel fitted only because its residual holds more than its noise (``weak``) and
    where no force was found is not in the report's section: on a clean recording that
    section would otherwise speak of structure nobody flagged."""
    common = dict(channel="tau2", joint=2, unit="N", share=-0.03, z=-5.0, rms_left=0.0032, noise=0.0029)
    quiet = flexible.FlexibleFit(explained=False, weak=True, statement="tau2: not explainable", **common)
    assert flexible.markdown([quiet], {}) == []
    flagged = flexible.FlexibleFit(explained=False, weak=False, statement="tau2: not explainable", **common)
    assert "- tau2: not explainable" in flexible.markdown([flagged], {})
    found = flexible.FlexibleFit(explained=True, weak=True, statement="a force on slider 2", **common)
    assert "- a force on slider 2" in flexible.markdown([found], {})


def _closed_loop_copy(n=900, sigma=0.05, seed=7):
    # a bump keyed on another joint's position q2; the channel's own model effort carries a
    # copy of the force lagged by 10 ms (what a drive's controller answers in closed loop)
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    q2 = np.sin(2 * np.pi * 0.23 * t) + 0.3 * np.sin(2 * np.pi * 0.71 * t + 1.0)
    f = 0.4 * np.exp(-((q2 - 0.3) / 0.25) ** 2)
    a = np.exp(-(t[1] - t[0]) / 0.01)
    copy = np.empty(n)
    copy[0] = f[0]
    for i in range(1, n):
        copy[i] = a * copy[i - 1] + (1 - a) * f[i]
    effort1 = copy
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([q2, effort1, rng.uniform(-1, 1, (n, 3))])
    cols = [("q2", "position of slider 2", 2, "position", "m"), ("effort1", "effort of slider 1", 1, "effort", "N"),
            ("q3", "position of slider 3", 3, "position", "m"), ("q4", "position of slider 4", 4, "position", "m"),
            ("q5", "position of slider 5", 5, "position", "m")]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    return pipe, X, cols, y, sigma, float(np.var(f) / (np.var(f) + sigma ** 2))


def test_the_cause_is_named_not_the_effort_that_follows_the_force_in_closed_loop():
    # the trees on every input prefer the effort (a clean copy of the force); the causal rule
    # screens the inputs without the consequences first and names the effort only where it adds
    pipe, X, cols, y, sigma, truth = _closed_loop_copy()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained
    assert [d.group for d in fit.inputs] == ["position of slider 2"]
    assert abs(fit.share - truth) < 0.15
    assert flexible.consequences(cols, flexible.input_groups(cols), 1) == {"effort of slider 1"}


def test_a_force_keyed_on_the_effort_itself_keeps_the_effort():
    # a friction growing with the load: sign(qd1) (0.1 + 0.2 |effort1|): no exogenous input holds it
    rng = np.random.default_rng(4)
    n, sigma = 900, 0.03
    t = np.linspace(0.0, 9.0, n)
    qd = np.sin(2 * np.pi * 0.5 * t)
    effort = np.sin(2 * np.pi * 0.13 * t + 0.4) + 0.5 * rng.uniform(-1, 1, n).cumsum() / np.sqrt(n)
    f = np.tanh(qd / 0.05) * (0.1 + 0.2 * np.abs(effort))
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([qd, effort, rng.uniform(-1, 1, (n, 2))])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("effort1", "effort of slider 1", 1, "effort", "N"),
            ("q2", "position of slider 2", 2, "position", "m"), ("q3", "position of slider 3", 3, "position", "m")]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained
    assert sorted(d.group for d in fit.inputs) == ["effort of slider 1", "rate of slider 1"]


def test_a_rate_named_alone_names_the_history_its_signed_columns_carry():
    # the screen passed the rate only; its group holds the direction-signed history it shares with
    # the history group, and the force is sign(qd) (1 + b (T - mean T)): those shared columns add
    # a significant share, so the history is named beside the rate (without the rule: the rate alone)
    n, sigma = 700, 0.03
    rng, qd, T = _rate_and_slow_state(n)
    f = 0.4 * np.sign(qd) * (1.0 + 0.5 * (T - T.mean()) / T.std())
    y = f + rng.normal(0.0, sigma, n)
    X = np.column_stack([qd, T, np.sign(qd) * T, rng.uniform(-1, 1, n)])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("T1", "history of slider 1", 1, "history", "W"),
            ("sign(qd1) T1", "history of slider 1", 1, "history x direction", "W"),
            ("q2", "position of slider 2", 2, "position", "m")]
    groups = flexible.input_groups(cols)
    rows = flexible_cv.folds(n, 1)
    import sklearn.ensemble  # noqa: F401  (loaded before the limit, as fit_channel does)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        kept, cv, use = flexible._select(X, y, rows, groups, ["rate of slider 1"], float(np.var(y)))
    assert kept == ["rate of slider 1", "history of slider 1"]
    assert use == [0, 2]  # the model keeps the rate's columns: the history is named for its shared one
    assert 1.0 - cv.mse / np.var(y) > 0.9


def test_the_trees_on_every_input_stop_once_they_claim_and_claim_as_their_whole_growth(monkeypatch):
    # a force far above the claim's bars: the trees on every input stop after their first step, and
    # their claim is that of the trees grown as far as the held-out loss asks (to the bound here);
    # on noise alone nothing is claimed and the trees are those of the whole growth
    real, seen = flexible.cross_validate, []

    def cross_validate(Xs, ys, fold_rows, enough=None, under=None):
        cv = real(Xs, ys, fold_rows, enough=enough, under=under)
        if enough is not None:
            seen.append((cv, real(Xs, ys, fold_rows), enough))
        return cv

    monkeypatch.setattr(flexible, "cross_validate", cross_validate)
    pipe, X, cols, y, _ = _synthetic(lambda X: 0.3 * np.sin(6.0 * X[:, 2]) + 0.2 * X[:, 0] * X[:, 1])
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    (early, whole, claimed), = seen
    assert all(m.n_iter_ == flexible_cv.STEPS[0] for m in early.models)  # stopped after the first step
    assert all(m.n_iter_ > flexible_cv.STEPS[0] for m in whole.models)  # where the whole growth takes the second
    assert claimed(early.mse) and claimed(whole.mse) and fit.explained
    assert early.mse >= whole.mse
    seen.clear()
    pipe, X, cols, y, _ = _synthetic(lambda X: np.zeros(len(X)))
    fit = flexible.fit_channel(pipe, X, cols, y, 0.05, ("N", "tau1"))
    (early, whole, claimed), = seen
    assert not claimed(early.mse) and not fit.explained
    assert early.iterations == whole.iterations and np.array_equal(early.pred, whole.pred)
