"""The open-loop replay (cosim.discrepancy.open_loop, multiple shooting) on the real KUKA KR300
recording B (data/kuka_kr300/, JonasWeigand/Robot_Identification, MIT licence; docs/kuka.md,
"Open-loop replay"): the recorded link efforts applied to the core plant of the model identified
on A and of the makers' ``para``, 20 windows of 0.5 s spread over the 10 s, each restarted from the
recorded state (about 2 s of CPU).

Oracle: physics, not the code's own output.  With the recorded efforts the arm must follow the
recorded motion far better than with no effort at all (the arm then falls under gravity: axes 2
and 3 carry about 10 kN m and 4 kN m of gravity torque); and the position errors must stay within
the figures measured when the test was written (docs/kuka.md), with margin, so that a replay that
stops running or whose error jumps fails."""
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy.open_loop import can_replay_open_loop, open_loop_replay
from cosim.identification import identify
from cosim.importing import to_recording

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data" / "kuka_kr300"
ROBOT = str(REPO / "robots" / "kr300.toml")


@pytest.fixture(scope="module")
def replay():
    recs = {t: to_recording(str(DATA / f"kr300_{t}.mat"), str(DATA / "kr300_map.toml")) for t in "AB"}
    ident = identify(recs["A"], ROBOT, cutoff=2.0, strict=False)
    plants = {"para": Model(ROBOT, "para"), "identified": ident.model(ROBOT)}
    rec = recs["B"]
    assert rec.qref is not None and can_replay_open_loop(rec) == (True, "")  # the map declares it
    out = open_loop_replay(rec, plants, window=0.5)
    limp = dataclasses.replace(rec, tau=np.zeros_like(rec.tau))
    out0 = open_loop_replay(limp, {"identified": plants["identified"]}, window=0.5)
    return out, out0


def test_the_replay_runs_on_every_axis(replay):
    out, _ = replay
    assert out["windows"] == 20 and abs(out["window"] - 0.5) < 1e-6
    for name, r in out["runs"].items():
        assert "error" not in r, (name, r)
        assert np.all(np.isfinite(r["rms_q"])) and np.all(np.isfinite(r["rms_qd"])), name


def test_the_recorded_efforts_hold_the_arm(replay):
    out, out0 = replay
    with_tau = np.asarray(out["runs"]["identified"]["rms_q"])
    without = np.asarray(out0["runs"]["identified"]["rms_q"])
    assert np.all(without[:4] > 2 * with_tau[:4]), (with_tau, without)  # measured 2.8-5.9 x
    assert np.all(without > 1.5 * with_tau), (with_tau, without)  # measured 1.9 x and more


def test_the_position_errors_stay_where_they_were_measured(replay):
    out, _ = replay
    bound = {"identified": [0.025] * 5 + [0.040], "para": [0.060] * 6}  # rad
    for name, b in bound.items():
        q = np.asarray(out["runs"][name]["rms_q"])
        assert np.all(q < b), (name, q)


def test_the_identified_model_replays_closer_than_para_on_axes_1_2_4(replay):
    out, _ = replay
    mine, para = (np.asarray(out["runs"][n]["rms_q"]) for n in ("identified", "para"))
    assert np.all(mine[[0, 1, 3]] < 0.7 * para[[0, 1, 3]]), (mine, para)
