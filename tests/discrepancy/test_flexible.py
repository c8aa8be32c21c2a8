"""The flexible stage (cosim.discrepancy.flexible): what is left, how much of it is explainable
and on which inputs it depends.

The synthetic checks know their truth in closed form (a force of known variance on one input,
white noise of known variance); the recordings hide a force of flexible_cases (keyed on another
joint's acceleration, which no family of the discovery step covers) or none.
"""
import types

import numpy as np
import pytest

from cosim.discrepancy import flexible


def _synthetic(force, n=1200, sigma=0.05, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 1.0, (n, 6))
    f = force(X)
    y = f + rng.normal(0.0, sigma, n)
    cols = [(f"x{i}", f"input {i}", None, "position", "m") for i in range(6)]
    test = np.arange(n) >= int(0.7 * n)
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    truth = float(np.var(f[test]) / (np.var(f[test]) + sigma ** 2))
    return pipe, X, cols, y, test, truth


def test_names_the_one_input_and_its_share_on_a_known_force():
    # a force on input 2 only above 0.6 (smooth, not a polynomial); share var(f) / (var(f) + sigma^2)
    pipe, X, cols, y, test, truth = _synthetic(lambda X: np.where(X[:, 2] > 0.6, np.tanh((X[:, 2] - 0.6) / 0.15) ** 2,
                                                                  0.0) * 0.3)
    fit = flexible.fit_channel(pipe, X, cols, y, ~test, test, 0.05, ("N", "tau1"))
    assert fit.explained
    assert [d.group for d in fit.inputs] == ["input 2"]
    assert abs(fit.share - truth) < 0.1
    assert fit.inputs[0].where.startswith("above")
    assert 0.55 <= float(fit.inputs[0].where.split()[1]) <= 0.7


def test_noise_alone_is_not_claimed():
    pipe, X, cols, y, test, _ = _synthetic(lambda X: np.zeros(len(X)))
    fit = flexible.fit_channel(pipe, X, cols, y, ~test, test, 0.05, ("N", "tau1"))
    assert not fit.explained and fit.inputs == ()


@pytest.mark.parametrize("curve, expect", [((0, 0, 0, 0, 0, 0, 1, 2, 3, 4), "above"),
                                           ((4, 3, 2, 1, 0, 0, 0, 0, 0, 0), "below"),
                                           ((0, 1, 2, 3, 4, 5, 6, 7, 8, 9), "over")])
def test_where_a_curve_acts(curve, expect):
    grid = np.linspace(0.0, 0.9, 10)
    assert flexible._where(grid, np.asarray(curve, float), "m").startswith(expect)


@pytest.fixture(scope="module")
def cross_case():
    from cosim.discrepancy.flexible_cases import simulate

    return simulate("cross_acceleration", 7112)


def test_a_force_keyed_on_another_joints_acceleration(cross_case):
    from cosim.discrepancy import diagnose
    from cosim.discrepancy.flexible_cases import truth_share

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
    from cosim.discrepancy.flexible_cases import simulate

    monkeypatch.setattr(flexible, "RMS_OVER_NOISE", 0.0)  # every effort channel fitted, structure or not
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
