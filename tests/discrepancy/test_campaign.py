"""Campaigns (cosim.discrepancy.campaign): several runs of one rig diagnosed together.

The runs are simulated by the core (closed-loop EMPS runs, PD control designed on the nominal
model) with a hidden friction shared by all runs, an effort offset of each run's own, and one run
whose viscous friction was changed.  The expected values are the simulated plant's parameters."""
import json

import numpy as np
import pytest

from cosim.discrepancy.campaign import (Campaign, CampaignError, agreement, diagnose_campaign, joined, pieces_of,
                                        read_campaign)
from cosim.discrepancy.residuals import Pipeline
from cosim.core import Model
from cosim.recording import write_recording

from disc_helpers import run

NOISE = {"q": 1e-6, "qd": 1e-4, "tau": 0.5}
SHARED = {"rail[1].coulomb": 20.0, "rail[1].viscous": 150.0}
OFFSETS = [-3.0, 1.0, 4.0, -1.0]
ODD = 2  # the run whose viscous friction differs (wear, temperature)


def _runs(duration=2.5):
    out = []
    for k, off in enumerate(OFFSETS):
        hidden = dict(SHARED, **{"rail[1].offset": off})
        if k == ODD:
            hidden["rail[1].viscous"] = 200.0
        out.append(run("emps", hidden=hidden, duration=duration, seed=11 + k, noise=NOISE))
    return out


@pytest.fixture(scope="module")
def campaign():
    c = read_campaign(_runs(), per_run=["rail[1].offset"])
    c.names = [f"r{k + 1}" for k in range(len(c.runs))]
    return c, diagnose_campaign(c, effects=["coulomb", "viscous", "offset"], discovery=False,
                                replay=False, figures=False)


def test_the_joint_fit_recovers_the_shared_parameters_and_flags_the_odd_run(campaign):
    c, res = campaign
    # the odd run is named, on the parameter that changed, and no other run is
    assert {x["run"] for x in res.disagree} == {"r3"}, res.disagree
    assert {x["param"] for x in res.disagree} == {"rail[1].viscous"}, res.disagree
    odd = res.disagree[0]
    assert abs(odd["value"] - 200.0) < 3 * odd["ci95"], odd
    assert "r3" in res.conclusion and "disagree" in res.conclusion, res.conclusion
    # the joint fit (of the runs that agree) holds the simulated shared values within its intervals
    fitted = {p: v for e in res.joint.effects for p, v in e["params"].items()}
    for p, truth in SHARED.items():
        assert p in fitted, res.joint.conclusion
        assert abs(fitted[p]["value"] - truth) <= fitted[p]["ci95"], (p, fitted[p], truth)
    assert res.first_joint is not None  # the fit of all four runs, before r3 was set aside
    assert res.drifts == []  # one odd run is no drift between the runs
    # each run's own offset, taken out of its data, is the simulated one
    for r, off in zip(res.per_run, OFFSETS):
        assert abs(r["declared"]["rail[1].offset"] - off) < 0.3, (r["name"], r["declared"], off)


def test_the_split_is_by_run_and_no_window_spans_a_seam(campaign):
    c, _ = campaign
    pieces = pieces_of(c, "run")
    ws, tf = joined(c, pieces)
    pipe = Pipeline(ws.recording, Model("emps"), segments=ws.segments)
    train, test = pipe.split(tf)
    held = ws.segments[-1]  # the last run, held out
    rows = pipe.idx
    assert np.all((rows[test] >= held[0]) & (rows[test] < held[1]))
    assert np.all(rows[train] < held[0])
    # every evaluated sample is a smoothing half-window plus the delays away from a seam
    margin = pipe.window // 2 + pipe.max_shift
    for a, b in ws.segments:
        inside = rows[(rows >= a) & (rows < b)]
        assert inside.min() >= a + margin and inside.max() < b - margin
    # within runs: the end of every run is held out, the fitted pieces first
    pw = pieces_of(c, "within", 0.7)
    assert [p[3] for p in pw] == [False] * 4 + [True] * 4
    assert all(b - a > 0 for _, a, b, _ in pw)


def test_agreement_compares_each_run_with_the_others():
    def p(v, c):
        return {"x": {"value": v, "ci95": c, "unit": "N"}}

    names = ["a", "b", "c"]
    assert agreement([p(1.0, 0.1), p(1.05, 0.1), p(0.98, 0.1)], names) == []
    dis = agreement([p(1.0, 0.1), p(1.05, 0.1), p(2.0, 0.1)], names)
    assert dis[0]["run"] == "c" and dis[0]["sigmas"] > 5


def test_runs_of_two_robots_and_a_run_column(tmp_path):
    r = run("emps", hidden=SHARED, duration=1.5, seed=1)
    other = run("pendulum", duration=1.5, seed=1)
    with pytest.raises(CampaignError, match="runs of two robots"):
        read_campaign([r, other])
    # one file with a run column: a run per value, in order
    two = run("emps", hidden=SHARED, duration=1.5, seed=2)
    t = np.concatenate([r.time, two.time - two.time[0] + r.time[-1] + 1.0])  # a file's time keeps increasing
    both = Campaign([r, two], ["a", "b"]).runs
    from cosim.recording import Recording

    rec = Recording("emps", t, np.vstack([x.q for x in both]), np.vstack([x.qd for x in both]),
                    np.vstack([x.tau for x in both]), qref=np.vstack([x.qref for x in both]),
                    extra={"run": np.repeat([1.0, 2.0], [len(r), len(two)])}, controller=r.controller)
    csv, _ = write_recording(tmp_path / "both.csv", rec)
    c = read_campaign(csv)
    assert c.names == ["run 1", "run 2"] and [len(x) for x in c.runs] == [len(r), len(two)]
    # a campaign file lists its runs
    for k, x in enumerate((r, two)):
        write_recording(tmp_path / f"r{k}.csv", x)
    (tmp_path / "c.toml").write_text('runs = ["r0.csv", "r1.csv"]\nper_run = ["rail[1].offset"]\n')
    c = read_campaign(tmp_path / "c.toml")
    assert c.names == ["r0", "r1"] and c.per_run == ("rail[1].offset",)
    with pytest.raises(CampaignError, match="only an effort offset"):
        read_campaign([r, two], per_run=["platform.m"])


def test_the_cli_diagnoses_runs_together(tmp_path, capsys):
    from cosim.cli.main import main

    files = []
    for k, x in enumerate(_runs(duration=2.0)[:3]):
        files.append(str(write_recording(tmp_path / f"run{k + 1}.csv", x)[0]))
    code = main(["diagnose", *files, "--effects", "coulomb,viscous,offset", "--no-discovery", "--no-figures",
                 "--per-run", "rail[1].offset", "--leave-one-out", "--out", str(tmp_path / "out")])
    text = capsys.readouterr().out
    assert code == 0, text
    assert text.startswith("campaign of 3 runs (run1, run2, run3)"), text[:300]
    assert "each run fitted alone" in text and "replay of the held-out runs:" in text
    # run3 is the odd one (viscous friction 200 N s/m): set aside, so the last run that agrees is held out
    assert "runs that disagree beyond their intervals:\n  run3: rail[1].viscous" in text, text
    assert "replay of the held-out runs:\n  run2: closed loop" in text, text
    # each run that agrees held out in turn: the fit of the other one beats the nominal model on it
    assert "leave one run out (fitted on the others, judged on it):\n  run1: held-out residual RMS" in text, text
    saved = json.loads((tmp_path / "out" / "campaign.json").read_text())
    assert saved["runs"] == ["run1", "run2", "run3"]
    assert [x["name"] for x in saved["leave_one_out"]] == ["run1", "run2"]
    assert all(x["gain"] > 5 for x in saved["leave_one_out"]), saved["leave_one_out"]
