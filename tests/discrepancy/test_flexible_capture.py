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
    target: object = None
    left_out: str = ""


def _fakes(monkeypatch, seen, offers=None):
    """stage.inputs and fit_channel as cheap stand-ins: the matrix is the residual itself; the
    lines offered to each fit are appended to ``offers``."""
    offers = [] if offers is None else offers
    monkeypatch.setattr(stage, "inputs", lambda pipe, R, **kw: (np.array(R, float), [("a", "a", 1, "position", "m"),
                                                                          ("b", "b", 2, "position", "m")]))

    def fit(pipe, X, columns, y, noise, unit, weak=False, fitted=None, offered=(), without=()):
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


def _fake_rivalled(pipe, r_rival, outfit):
    """A discovered term's rival on both channels (the residual before the terms, ``r_rival``):
    its own inputs, one fit per channel, ``outfit`` {channel (0-based): whether the trees outfit
    the term}, as :func:`cosim.discrepancy.flexible.rival.rivalled` returns it."""
    from cosim.discrepancy.flexible import rival

    def rivalled(eng, theta, R, found):
        X, cols = rival.inputs(pipe, r_rival, direction=True)
        for c in (0, 1):
            stage.fit_channel(pipe, X, cols, r_rival[:, c], 0.1, ("N", pipe.channels[c]))
        return found, {c: SimpleNamespace(outfit=o) for c, o in outfit.items()}
    return rivalled


def _rival_diagnosis(pipe, r_after):
    """The rival (the module's, at call time, as the diagnosis imports it), then the stage."""
    from cosim.discrepancy.flexible.rival import rivalled

    rivalled(None, {}, r_after, [])
    return _diagnosis(pipe, r_after, r_after.copy())


def test_capture_keeps_a_channel_the_rival_outfits_and_the_replay_fits_it_on_the_rivals_inputs(monkeypatch,
                                                                                                 tmp_path):
    from cosim.discrepancy.flexible import rival

    seen = []
    _fakes(monkeypatch, seen)
    r_after = np.random.default_rng(4).normal(size=(30, 2))
    r_rival = r_after.copy()
    r_rival[:, 0] += 2.0  # channel 1 before its term
    monkeypatch.setattr(rival, "inputs", lambda pipe, R, **kw: (np.array(R, float), ["a", "b"]))
    monkeypatch.setattr(rival, "rivalled", _fake_rivalled(_pipe(), r_rival, {0: True, 1: False}))
    out, kept = bench._captured(lambda: _rival_diagnosis(_pipe(), r_after))
    assert out == "diagnosis"
    # the stage's channel 2 and the rival's channel 1 (outfit); the rival's channel 2 (not outfit) is not kept
    assert sorted(ch["unit"] for ch in kept["channels"]) == [("N", "tau1"), ("N", "tau2")]
    ch1 = next(ch for ch in kept["channels"] if ch["unit"] == ("N", "tau1"))
    np.testing.assert_array_equal(ch1["R"], r_rival)
    np.testing.assert_array_equal(ch1["y"], r_rival[:, 0])
    kept["pipe"] = bench._light(SimpleNamespace(**vars(_pipe()), x_s=None))
    with open(tmp_path / "0.pkl", "wb") as fh:
        pickle.dump({"row": {"kind": "clean", "seed": 0, "cpu": 0.0}, "kept": kept}, fh)
    seen.clear()
    bench.replay(tmp_path / "0.pkl")
    # the rival's channel fitted on the rival's inputs, the stage's on the stage's
    assert len(seen) == 2
    assert any(np.array_equal(X, r_rival) for X in seen) and any(np.array_equal(X, r_after) for X in seen)
