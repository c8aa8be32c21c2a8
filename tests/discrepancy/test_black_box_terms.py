"""The replay's black-box force beside the fitted plant's terms (diagnosis.replay.black_box_for_plant):
a partial term's channel is fitted on the residual before the term, while the plant carries the
term; the black box must give what the plant with its terms leaves, not the term's force again."""
from types import SimpleNamespace

import numpy as np

from cosim.discrepancy.diagnosis.replay import black_box_for_plant
from cosim.discrepancy.flexible import stage
from cosim.discrepancy.flexible.stage import FlexibleFit

ROWS, STEP = 200, 2  # recording rows, decimation


def _case(monkeypatch):
    """Two channels over 2 s: on channel 1 a term's force g that the plant carries (the residual
    after it ``left``; the stage fitted the residual before it, g + left), channel 2 no term.
    The stage's inputs are the residual itself (the columns the models read), recorded in ``given``."""
    t_all = np.arange(ROWS) * 0.01
    idx = np.arange(0, ROWS, STEP)
    t = t_all[idx]
    g = 3.0 * np.sin(2 * np.pi * 0.5 * t)
    left = 0.2 * np.cos(2 * np.pi * 1.5 * t)
    R = np.column_stack([left, 0.5 * np.sin(2 * np.pi * t)])  # after the fitted model, term included
    given = []

    def inputs(pipe, R_in, direction=False):
        given.append(np.array(R_in, float))
        return np.array(R_in, float), ["r1", "r2"]
    monkeypatch.setattr(stage, "inputs", inputs)
    eng = SimpleNamespace(pipe=SimpleNamespace(t=t_all, idx=idx, nd=2))
    return eng, R, g + left, given


def _fit(joint, target, model, use):
    return FlexibleFit(f"tau{joint}", joint, "N", 0.9, 50.0, True, 0.1, 0.01, model=model, use=use,
                       target=np.array(target, float))


def test_the_plants_term_is_not_given_again_by_the_black_box(monkeypatch):
    eng, R, before, _ = _case(monkeypatch)
    # trees that predict their targets exactly (whatever the inputs)
    fits = [_fit(1, before, SimpleNamespace(predict=lambda X: before), (0,)),
            _fit(2, R[:, 1], SimpleNamespace(predict=lambda X: R[:, 1]), (1,))]
    out = black_box_for_plant(eng, R, fits, ROWS)
    # minus what the plant with the term leaves: the residual after the term, not before it
    np.testing.assert_allclose(out[eng.pipe.idx, 0], -R[:, 0], atol=1e-12)
    np.testing.assert_allclose(out[eng.pipe.idx, 1], -R[:, 1], atol=1e-12)


def test_the_models_read_the_inputs_they_were_fitted_on(monkeypatch):
    eng, R, before, given = _case(monkeypatch)
    # trees that read their channel's residual column: fitted on the residual before the term
    fits = [_fit(1, before, SimpleNamespace(predict=lambda X: X[:, 0]), (0,)),
            _fit(2, R[:, 1], SimpleNamespace(predict=lambda X: X[:, 0]), (1,))]
    out = black_box_for_plant(eng, R, fits, ROWS)
    np.testing.assert_array_equal(given[-1][:, 0], before)
    np.testing.assert_allclose(out[eng.pipe.idx, 0], -R[:, 0], atol=1e-12)
    np.testing.assert_allclose(out[eng.pipe.idx, 1], -R[:, 1], atol=1e-12)
