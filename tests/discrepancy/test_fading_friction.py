"""Friction that fades at low speed (MuJoCo's soft friction is 35 % of nominal at
0.1-1 mm/s): the drive's Coulomb friction with a velocity scale, F tanh(qd / v_c), as a named
effect.  A blind case hiding one is named so with its amplitude and its velocity scale; a step
Coulomb friction on the same trajectory stays a Coulomb friction (the extra parameter is not
paid for); the answer keys are read only after the diagnosis."""
import json
from pathlib import Path

import pytest

from cosim.discrepancy import blind, diagnose


@pytest.mark.parametrize("robot, seed", [("6pus", 1), ("quattro", 2)])
def test_a_fading_friction_is_named_with_its_amplitude_and_velocity_scale(tmp_path, robot, seed):
    spec = blind.CaseSpec(f"fade_{robot}", robot, ["smooth_coulomb"], seed=seed)
    rec, key = blind.make_case(spec, tmp_path / "cases", tmp_path / "keys")
    d = diagnose(rec, figures=False, replay=False)
    hidden = json.loads(Path(key).read_text())["effects"][0]
    (amp, true_amp), (vel, true_v) = hidden["params"].items()
    assert amp.endswith(".coulomb") and vel.endswith(".coulomb_v") and true_v > 0
    assert d.named()[0] == "smooth_coulomb", d.conclusion
    values = d.plant_parameters()
    assert abs(values[amp] - true_amp) < 0.10 * true_amp, (values[amp], true_amp)
    assert abs(values[vel] - true_v) < 0.15 * true_v, (values[vel], true_v)


def test_a_step_coulomb_friction_is_not_called_fading(tmp_path):
    spec = blind.CaseSpec("step", "6pus", ["coulomb"], seed=1)
    rec, key = blind.make_case(spec, tmp_path / "cases", tmp_path / "keys")
    d = diagnose(rec, figures=False, replay=False)
    hidden = json.loads(Path(key).read_text())["effects"][0]
    assert hidden["type"] == "coulomb"
    assert d.named() == ["coulomb"] * len(hidden["params"]), d.conclusion
    assert not any(k.endswith(".coulomb_v") for k in d.plant_parameters())
