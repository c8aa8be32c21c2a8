"""The flexible stage's fit folded by the direction of motion (cosim.discrepancy.flexible.folded).

Synthetic, truth in closed form: an eddy-current brake over a band of slider 1's stroke,
c qd1 band(q1), whose mean level a fitted viscous friction took, c qd1 (band(q1) - mean band),
beside inputs that carry nothing; and, for the screen that decides when to fold, a force on
position alone that does not switch with the direction.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import folded
from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.columns import SINCE, _since_reversal


def _recording(force, n=900, sigma=0.05, seed=3, others=12):
    """Slider 1 moving back and forth, the stage's columns of it (position, rate, the time since
    its direction last changed and that time signed), ``others`` smooth inputs that carry nothing
    and the residual ``force(q1, qd1)`` plus noise."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    q1 = sum(np.sin(2 * np.pi * f * t + i) / (1 + i) for i, f in enumerate((0.31, 0.73, 1.37)))
    qd1 = np.gradient(q1, t)
    since, held = _since_reversal(qd1, t, {0}, 0.05)
    carry_nothing = [sum(np.sin(2 * np.pi * f * t + p) for f, p in zip(rng.uniform(0.05, 1.0, 3),
                                                                        rng.uniform(0.0, 6.3, 3)))
                     for _ in range(others)]
    X = np.column_stack([q1, qd1, since, held * since] + carry_nothing)
    cols = [("q1", "position of slider 1", 1, "position", "m"), ("qd1", "rate of slider 1", 1, "rate", "m/s"),
            (f"{SINCE} qd1 reversed", "history of slider 1", 1, "history", "s"),
            (f"{SINCE} qd1 reversed x sign(qd1)", "history of slider 1", 1, "history x direction", "s")]
    cols += [(f"q{i + 2}", f"position of slider {i + 2}", i + 2, "position", "m") for i in range(others)]
    truth = force(q1, qd1)
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5,
                                 model=types.SimpleNamespace(facts=types.SimpleNamespace(joint_noun="slider")))
    return pipe, X, cols, truth + rng.normal(0.0, sigma, n), sigma, truth, held


def _eddy(q1, qd1):
    band = 0.5 * (np.tanh((q1 + 0.2) / 0.05) - np.tanh((q1 - 0.6) / 0.05))
    return 0.3 * qd1 * (band - np.mean(band))


def test_an_eddy_brake_over_a_band_of_the_stroke_is_fitted_folded_and_named_by_position_and_rate():
    # folded, the trees learn the level 0.3 |qd1| (band - mean) of a function of q1 and qd1 and
    # name both; on the residual itself they need the splits of the product's two factors at once
    # (without the rule: nothing explained, or one factor named)
    pipe, X, cols, y, sigma, truth, held = _recording(_eddy)
    assert folded.prefer(X, y, folded.direction(X, cols, 1), flexible.folds(len(y), flexible.gap_for(1.0))) != ""
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.folded and fit.explained and fit.share > 0.6
    assert {d.group for d in fit.inputs} == {"position of slider 1", "rate of slider 1"}
    assert fit.inputs[0].feature == "direction of motion"
    # the model predicts the residual itself from the stage's columns (the black box's call):
    # sigma times the level, close to the force
    predicted = fit.model.predict(X[:, list(fit.use)])
    assert np.corrcoef(predicted, truth)[0, 1] > 0.85


def test_a_force_on_position_alone_is_not_folded():
    # a spring-like force 0.4 tanh(q1 / 0.3) does not switch with the direction: folded it becomes a
    # product; the screen does not pass it (where it would, the plain fit explains more and is kept)
    pipe, X, cols, y, sigma, truth, held = _recording(lambda q1, qd1: 0.4 * np.tanh(q1 / 0.3))
    rows = flexible.folds(len(y), flexible.gap_for(1.0))
    assert folded.prefer(X, y, folded.direction(X, cols, 1), rows) == ""
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert not fit.folded and fit.explained
    assert [d.group for d in fit.inputs] == ["position of slider 1"]


def test_the_direction_is_read_from_the_stage_columns():
    # the held sign of the rate through its dead band, at a reversal (time 0) the rate's own sign
    pipe, X, cols, y, sigma, truth, held = _recording(_eddy)
    s = folded.direction(X, cols, 1)
    assert set(np.unique(s)) <= {-1.0, 1.0}
    moving = held != 0
    assert np.mean(s[moving] == held[moving]) > 0.99
    assert folded.direction(X[:, :2], cols[:2], 1) is None  # no such columns: no fold


def test_the_folded_fit_is_kept_only_where_it_explains_more():
    # both fits judged on the residual itself: the larger claimed share is kept, a claim before none
    def fit(share, explained=True):
        return flexible.FlexibleFit("tau1", 1, "N", share, 100.0, explained, 1.0, 0.1)
    assert folded.kept(fit(0.40), fit(0.32)).share == 0.40
    assert folded.kept(fit(0.40), fit(0.52)).share == 0.52
    assert folded.kept(fit(0.0, False), fit(0.30)).share == 0.30
    assert folded.kept(fit(0.20), fit(0.9, False)).share == 0.20
