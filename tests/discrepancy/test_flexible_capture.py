"""bench/flexible_bench.py's capture and replay of the flexible stage: the residual kept is the one
the stage built its inputs from, though ``flexible.stage.inputs`` is called again after the stage
(keyed.elsewhere, on the residual before a partial discovered term is set aside)."""
import pickle
import sys
from pathlib import Path
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import flexible_bench as bench  # noqa: E402

from cosim.discrepancy.flexible import stage  # noqa: E402


def _pipe(n=30):
    facts = SimpleNamespace(joint_noun="slider", joint_unit="m", effort_unit="N")
    return SimpleNamespace(idx=np.arange(n), nd=2, t=np.arange(n) * 1e-2, segments=[(0, n)], dt=1e-2,
                           tau_s=np.zeros((n, 2)), q_s=np.zeros((n, 2)), qd_s=np.zeros((n, 2)),
                           qdd_s=np.zeros((n, 2)), has_pose=False, channels=["tau1", "tau2"], window=5, step=1,
                           model=SimpleNamespace(facts=facts), rec=SimpleNamespace(qref=None), polyorder=3)


@dataclass(frozen=True)
class _Fit:
    explained: bool = False
    joint: int = 0
    weak: bool = False


def _fakes(monkeypatch, seen, offers=None):
    """stage.inputs and fit_channel as cheap stand-ins: the matrix is the residual itself; the
    lines offered to each fit are appended to ``offers``."""
    offers = [] if offers is None else offers
    monkeypatch.setattr(stage, "inputs", lambda pipe, R, **kw: (np.array(R, float), ["a", "b"]))

    def fit(pipe, X, columns, y, noise, unit, weak=False, fitted=None, offered=()):
        seen.append(np.array(X))
        offers.append(tuple(offered))
        return _Fit()
    monkeypatch.setattr(stage, "fit_channel", fit)


#: a line offered to every channel, as the stage passes it (:func:`~cosim.discrepancy.flexible.periodic.offered`)
OFFERED = ((4.57, 0.1),)


def _diagnosis(pipe, r_after, r_fit):
    """The order of a diagnosis: the stage's inputs on its residual (a partial term's channel set
    aside), its channel fitted, then keyed.elsewhere's inputs on the residual before that."""
    X, cols = stage.inputs(pipe, r_fit, direction=True)
    stage.fit_channel(pipe, X, cols, r_fit[:, 1], 0.1, ("N", "tau2"), offered=OFFERED)
    from cosim.discrepancy.flexible.stage import inputs  # as keyed.elsewhere imports it: at call time
    inputs(pipe, r_after)
    return "diagnosis"


def test_capture_keeps_the_residual_the_stage_was_given(monkeypatch):
    _fakes(monkeypatch, [])
    r_after = np.random.default_rng(0).normal(size=(30, 2))
    r_fit = r_after.copy()
    r_fit[:, 1] += 1.0  # the partial term's channel, without the term
    out, kept = bench._captured(lambda: _diagnosis(_pipe(), r_after, r_fit))
    assert out == "diagnosis"
    np.testing.assert_array_equal(kept["R"], r_fit)
    assert len(kept["channels"]) == 1


def test_capture_keeps_the_lines_offered_and_the_replay_offers_them_again(monkeypatch, tmp_path):
    offers = []
    _fakes(monkeypatch, [], offers)
    r_after = np.random.default_rng(2).normal(size=(30, 2))
    out, kept = bench._captured(lambda: _diagnosis(_pipe(), r_after, r_after.copy()))
    assert offers == [OFFERED] and kept["channels"][0]["offered"] == OFFERED
    kept["pipe"] = bench._light(SimpleNamespace(**vars(_pipe()), x_s=None))
    with open(tmp_path / "0.pkl", "wb") as fh:
        pickle.dump({"row": {"kind": "clean", "seed": 0, "cpu": 0.0}, "kept": kept}, fh)
    bench.replay(tmp_path / "0.pkl")
    assert offers == [OFFERED, OFFERED]


def test_replay_gives_the_stage_its_own_residual_from_a_capture_of_the_last_call(monkeypatch, tmp_path):
    seen = []
    _fakes(monkeypatch, seen)
    r_after = np.random.default_rng(1).normal(size=(30, 2))
    y = r_after[:, 1] + 1.0
    kept = {"pipe": bench._light(SimpleNamespace(**vars(_pipe()), x_s=None)), "R": r_after,
            "channels": [dict(y=y, noise=0.1, unit=("N", "tau2"), weak=False, fitted=None)]}
    row = {"kind": "clean", "seed": 0, "cpu": 0.0}
    with open(tmp_path / "0.pkl", "wb") as fh:
        pickle.dump({"row": row, "kept": kept}, fh)
    bench.replay(tmp_path / "0.pkl")
    np.testing.assert_array_equal(seen[0][:, 1], y)
    np.testing.assert_array_equal(seen[0][:, 0], r_after[:, 0])


def test_a_fit_on_inputs_the_stage_did_not_make_passes_through_and_is_not_kept(monkeypatch):
    offers = []
    _fakes(monkeypatch, [], offers)
    r = np.random.default_rng(3).normal(size=(30, 2))

    def rival_then_stage():
        # a discovered term's rival: its own matrix, then the stage's
        stage.fit_channel(_pipe(), r.copy(), ["a", "b"], r[:, 0], 0.1, ("N", "tau1"))
        return _diagnosis(_pipe(), r, r.copy())
    out, kept = bench._captured(rival_then_stage)
    assert out == "diagnosis" and len(offers) == 2
    assert [ch["unit"] for ch in kept["channels"]] == [("N", "tau2")]
