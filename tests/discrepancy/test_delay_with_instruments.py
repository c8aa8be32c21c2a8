"""A delay selected together with an effect estimated by instrumental variables (viscous
friction): the intervals' instrument matrix must have one column per parameter of the
Jacobian, the delay's own instrument included.  The true values come from the generator's
answer key, never from the engine."""
import copy
import json
from pathlib import Path

from cosim.discrepancy import blind, diagnose


def test_an_actuator_delay_with_viscous_friction_gets_intervals_that_hold_the_truth(tmp_path):
    cfg = copy.deepcopy(blind.load_config())
    cfg["general"]["duration"] = 1.0  # short: the delay and two viscous frictions are already selected
    cfg["general"]["two_effects"] = 0.0
    spec = blind.CaseSpec("quattro_visc_delay", "quattro", ["viscous", "actuator_delay"], seed=2024)
    rec, key = blind.make_case(spec, tmp_path / "cases", tmp_path / "keys", cfg)
    d = diagnose(rec, figures=False, replay=False, discovery=False)
    truth = {p: v for e in json.loads(Path(key).read_text())["effects"] for p, v in e["params"].items()}
    found = {p: est for e in d.effects for p, est in e.params.items()}
    assert "actuator.delay" in found and any(p.endswith(".viscous") for p in found), sorted(found)
    for p, est in found.items():
        assert 0 < est.ci95 < abs(truth[p]), (p, est)
        assert abs(est.value - truth[p]) <= est.ci95, (p, est.value, est.ci95, truth[p])
