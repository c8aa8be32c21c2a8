"""The engine on gaps that are two bodies in the core's own plant (drive.two_body = 1): the
project's blind generator with each hidden backlash made a 0.05 kg drive body riding on its
carriage through stiff, damped faces (1e6 N/m) instead of the quasi-static reading model.
Measured (seeds 1-5): backlash named first 5/5, the gap within 0.6-3.6 %, the drive body's
inertia (undeclared here) named next at 0.049-0.051 kg; structure left on the gap's reading,
keyed on the velocity (the crossing time the reading model lacks), on 3 of 5, as on MuJoCo's
two bodies (docs/discrepancy.md).  The answer key is read only after the diagnosis."""
import pytest

import cosim.discrepancy.runs as runs_mod
from cosim.discrepancy import blind, diagnose


@pytest.fixture
def two_body_generator(monkeypatch):
    loop = runs_mod.closed_loop

    def closed_loop(plant, controller, ref, **kw):
        pre = plant.facts.joint_prefix
        for i in range(plant.ndof):
            if plant.param(f"{pre}[{i + 1}].backlash") > 0:
                plant.set_params({"drive.two_body": 1.0, f"{pre}[{i + 1}].compliance": 1e-6,
                                  f"{pre}[{i + 1}].rotor_inertia": 0.05,
                                  f"{pre}[{i + 1}].transmission_damping": 130.0})
        return loop(plant, controller, ref, **kw)

    monkeypatch.setattr(runs_mod, "closed_loop", closed_loop)


@pytest.mark.parametrize("seed", [1, 3])
def test_a_two_body_gap_is_named_first_with_its_width(two_body_generator, seed):
    rec, hidden, _ = blind.simulate_case(blind.CaseSpec(f"tb{seed}", "6pus", ["backlash"], seed))
    d = diagnose(rec, figures=False, replay=False)
    (name, true), = hidden[0].params.items()
    assert d.named()[0] == "backlash", d.conclusion
    values = d.plant_parameters()
    assert abs(values[name] - true) < 0.05 * true, (values[name], true)
    joint = name.split("]")[0] + "]"
    assert abs(values.get(f"{joint}.rotor_inertia", 0.0) - 0.05) < 0.005, values
