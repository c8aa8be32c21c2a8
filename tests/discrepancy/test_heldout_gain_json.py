"""A held-out gain that cannot be measured: NaN in the diagnosis, null in ``diagnosis.json`` with
its reason beside it (JSON has no NaN; a strict reader refuses ``NaN``).

Oracle: a fit whose effects change no held-out residual (the residual with the fitted parameters
is the nominal one, sample for sample) has no gain to measure, whatever the numbers; the JSON is
read back by a parser that raises on ``NaN``, ``Infinity`` and ``-Infinity``."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from cosim.discrepancy.campaign import CampaignDiagnosis
from cosim.discrepancy.diagnosis import Diagnosis
from cosim.discrepancy.diagnosis.checks import heldout_fit
from cosim.discrepancy.report import _strip_arrays
from cosim.jsonable import finite


def _strict(text):
    def refuse(name):
        raise ValueError(f"{name} in JSON")

    return json.loads(text, parse_constant=refuse)


def _engine(effect_changes_residual: bool):
    """A one-joint engine (effort and joint channels) whose fitted residual is the nominal one,
    or the nominal one shrunk where the fit acts."""
    rng = np.random.default_rng(3)
    n = 400
    t = np.arange(n) * 1e-2
    R0 = np.column_stack([np.sin(t) + 0.01 * rng.standard_normal(n), 1e-4 * rng.standard_normal(n)])
    R1 = R0 * np.array([0.2, 1.0]) if effect_changes_residual else R0
    pipe = SimpleNamespace(channels=["tau1", "q1"], nd=1, idx=np.arange(n), t=t,
                           tau_s=np.sin(t)[:, None] + 2.0, q=np.cos(t)[:, None], qd_s=-np.sin(t)[:, None],
                           model=SimpleNamespace(facts=SimpleNamespace(effort_unit="N", joint_unit="m")))
    eng = SimpleNamespace(test=t >= 2.0, use=np.ones((n, 2), int), pipe=pipe,
                          R=lambda theta: R1 if theta else R0)
    sel = SimpleNamespace(theta={"rail[1].coulomb": 1.0}, sigma=np.array([0.01, 1e-4]))
    return eng, sel


def _diagnosis(heldout):
    return Diagnosis(recording="r.csv", robot="emps", conclusion="c", effects=[], theta={"rail[1].coulomb": 1.0},
                     heldout=heldout, localisation={}, not_excited=[], unavailable=[], channels=["tau1", "q1"],
                     noise={})


def test_an_unmeasurable_gain_is_null_with_its_reason_in_the_json():
    eng, sel = _engine(effect_changes_residual=False)
    held = heldout_fit(eng, sel)
    assert held["affected"] == []
    assert np.isnan(held["gain"]) and np.isnan(held["gain_windows"])
    assert "no gain can be measured" in held["gain_note"]
    d = _diagnosis(held)
    for text in (d.to_json(), _strip_arrays(d)):  # Diagnosis.to_json and the report's diagnosis.json
        back = _strict(text)["heldout"]
        assert back["gain"] is None and back["gain_windows"] is None, back
        assert back["gain_note"] == held["gain_note"]


def test_a_campaign_writes_an_unmeasurable_gain_as_null_too():
    eng, sel = _engine(effect_changes_residual=False)
    held = heldout_fit(eng, sel)
    loro = [{"name": "run 1", "gain": held["gain"], "gain_note": held["gain_note"], "named": [], "conclusion": "c"}]
    back = _strict(CampaignDiagnosis("c", _diagnosis(held), ["run 1", "run 2"], "run", leave_one_out=loro).to_json())
    assert back["joint"]["heldout"]["gain"] is None and back["leave_one_out"][0]["gain"] is None
    assert back["leave_one_out"][0]["gain_note"] == held["gain_note"]


def test_a_measured_gain_is_written_as_it_is():
    eng, sel = _engine(effect_changes_residual=True)
    held = heldout_fit(eng, sel)
    assert held["affected"] == ["tau1"]
    # the effort residual shrunk 5x where the fit acts, the joint one unchanged and unaffected
    assert held["gain"] == pytest.approx(5.0, rel=1e-12)
    assert held["gain_note"] is None
    back = _strict(_diagnosis(held).to_json())["heldout"]
    assert back["gain"] == held["gain"] and back["gain_note"] is None


def test_finite_replaces_every_non_finite_number():
    o = {"a": float("nan"), "b": [1.0, float("inf"), np.float64(-np.inf)], "c": np.array([[0.5, np.nan]]),
         "d": (np.int64(3), True, "x", None), "e": np.float32(2.5)}
    assert finite(o) == {"a": None, "b": [1.0, None, None], "c": [[0.5, None]], "d": [3, True, "x", None],
                         "e": 2.5}
