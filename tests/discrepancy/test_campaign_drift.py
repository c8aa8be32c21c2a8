"""Drifts between the runs of a campaign (cosim.discrepancy.campaign_drift).

Oracles: per-run values put exactly on a line (its slope and change are the line's, written
here); per-run values drawn from known normal laws, without drift, for the share of campaigns
called drifting (at most the stated 5 %, also when the runs scatter three times beyond their
intervals); and campaigns simulated by the core (cosim.discrepancy.blind.campaigns: EMPS runs
whose Coulomb friction the plant was given, run by run), whose drift is the generator's."""
import numpy as np
import pytest

from cosim.discrepancy.blind.campaigns import drift_campaign
from cosim.discrepancy.campaign import CampaignError, diagnose_campaign, read_campaign
from cosim.discrepancy.campaign_drift import between_runs, detrended, predict


def _per(values, ci):
    return [{"c": {"value": float(v), "ci95": float(c), "unit": "N"}} for v, c in zip(values, ci)]


def test_a_line_through_the_runs_is_measured_in_run_order_and_in_time():
    names = [f"r{k}" for k in range(8)]
    d = between_runs(_per(20.0 - 0.2 * np.arange(8), [0.05] * 8), names)[0]
    assert d.axis == "run" and d.param == "c"
    assert d.slope == pytest.approx(-0.2) and d.change == pytest.approx(-1.4)
    assert d.relative == pytest.approx(-1.4 / 20.0) and d.per_step == pytest.approx(-0.2)
    # irregular start times: the line is in time, not in the run order
    t = np.array([0.0, 300.0, 1500.0, 1800.0, 4000.0, 4100.0, 6000.0, 7200.0])
    d = between_runs(_per(20.0 - 1e-4 * t, [0.05] * 8), names, times=t)[0]
    assert d.axis == "time" and d.slope == pytest.approx(-1e-4) and d.change == pytest.approx(-0.72)
    # the held-out run's value from the other runs' line
    assert predict("c", _per(20.0 - 1e-4 * t, [0.05] * 8), t, 7) == pytest.approx(20.0 - 0.72)
    # compared about the line, the runs agree exactly
    flat = detrended(_per(20.0 - 1e-4 * t, [0.05] * 8), [d])
    assert np.ptp([p["c"]["value"] for p in flat]) == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("widen", [1.0, 3.0])
def test_campaigns_without_drift_are_called_drifting_at_most_five_percent_of_the_time(widen):
    """Three parameters per run, eight runs; ``widen``: the runs scatter that many times
    beyond their stated intervals (intervals too narrow, as fits' often are; judged against
    the intervals alone, 3x too narrow, about 80 % of these campaigns would be called
    drifting)."""
    rng = np.random.default_rng(3)
    names = [f"r{k}" for k in range(8)]
    called = 0
    trials = 1000
    for _ in range(trials):
        ci = rng.uniform(0.05, 0.2, (3, 8))
        per = [{p: {"value": 10.0 + widen * ci[i, k] / 1.96 * rng.standard_normal(), "ci95": ci[i, k], "unit": "N"}
                for i, p in enumerate("abc")} for k in range(8)]
        called += bool(between_runs(per, names))
    # at most 5 %, within the Monte Carlo's own error (its standard deviation 0.7 % at 5 %)
    assert called / trials <= 0.05 + 0.02, called / trials


def test_a_drift_of_four_intervals_is_found_with_its_size():
    rng = np.random.default_rng(4)
    names = [f"r{k}" for k in range(8)]
    found, changes = 0, []
    for _ in range(300):
        truth = 10.0 - 0.4 * np.arange(8) / 7  # 0.4 over the campaign: four 95 % half widths
        per = _per(truth + 0.1 / 1.96 * rng.standard_normal(8), [0.1] * 8)
        ds = between_runs(per, names)
        found += bool(ds)
        changes += [ds[0].change] if ds else []
    assert found / 300 >= 0.9, found / 300
    assert np.mean(changes) == pytest.approx(-0.4, abs=0.03)


@pytest.fixture(scope="module")
def drifting():
    recs, times, truth = drift_campaign(seed=7, robot="emps", runs=6)
    return truth, diagnose_campaign(read_campaign(recs, times=times), effects=["coulomb", "viscous"],
                                    discovery=False, figures=False)


def test_a_friction_that_drifts_between_runs_is_named_with_its_size_and_modelled(drifting):
    truth, res = drifting
    assert [d.param for d in res.drifts] == [truth["param"]], (truth, res.drifts)
    d = res.drifts[0]
    assert d.axis == "time"
    assert abs(d.change - truth["change"]) <= 0.15 * abs(truth["change"]), (d.change, truth["change"])
    assert ("falls" if truth["change"] < 0 else "rises") in res.conclusion and truth["param"] in res.conclusion
    assert res.disagree == []  # compared about the line, no run is odd
    # the held-out (last) run predicted from the others' line beats the shared constant
    h = res.drift_heldout[0]
    assert abs(h["values"][truth["param"]][1] - truth["values"][-1]) < abs(h["values"][truth["param"]][0]
                                                                          - truth["values"][-1])
    assert h["ratio"] > 1.2, h
    runs = res.replays[0]["runs"]
    assert runs["fitted, drift"]["rel_tau"][0] < runs["fitted"]["rel_tau"][0], runs


def test_a_campaign_without_drift_is_not_called_drifting():
    recs, times, _ = drift_campaign(seed=7, robot="emps", runs=6, drift=False)
    res = diagnose_campaign(read_campaign(recs, times=times), effects=["coulomb", "viscous"], discovery=False,
                            replay=False, figures=False)
    assert res.drifts == [] and res.drift_heldout == [] and "Between the runs" not in res.conclusion
    with pytest.raises(CampaignError, match="not one finite time in seconds per run"):
        read_campaign(recs, times=times[:3])


def test_a_line_extrapolated_out_of_its_range_is_said_not_raised():
    """Runs whose Coulomb friction falls 8 N a run, the fourth predicted at -4 N: the held-out
    comparison says the core's reason and the replay gets no drifting plant."""
    from types import SimpleNamespace

    from cosim.discrepancy.campaign_drift import heldout, predicted, sentence

    recs, times, _ = drift_campaign(seed=7, robot="emps", runs=4, duration=1.2, drift=False)
    c = read_campaign(recs, times=times)
    per = [{"rail[1].coulomb": {"value": 20.0 - 8.0 * k, "ci95": 0.1, "unit": "N"}} for k in range(4)]
    ds = between_runs(per, c.names)
    h = heldout(c, [(3, 0, len(c.runs[3]), True)], SimpleNamespace(theta={"rail[1].coulomb": 10.0}), None, ds, per,
                np.arange(4.0))
    assert h[0]["values"]["rail[1].coulomb"] == pytest.approx([10.0, -4.0])
    assert "outside its valid range" in h[0]["skipped"] and predicted(h) == {}
    assert "not predicted with the drift" in sentence(ds, h, 4)
