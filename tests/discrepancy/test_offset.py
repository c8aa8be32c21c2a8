"""A constant effort offset (a force on the joint, a cable carrier, an unbalanced mass, a bias of the
effort reading) as a named effect, and the pre-check that must not call it a unit.

The core's convention: the drive supplies inverse dynamics + friction + ``<j>[i].offset``, so a
constant force F pushing a rail the positive way is an offset of -F.  The truth of each case is
read only after the diagnosis."""
import json
import sys
from pathlib import Path

import numpy as np

from cosim.core import Model
from cosim.discrepancy import blind, diagnose
from cosim.recording import read_recording, write_recording

BENCH = Path(__file__).resolve().parents[2] / "bench"


def test_a_constant_force_on_a_mujoco_rail_is_an_offset_not_a_unit(tmp_path):
    # MuJoCo pushes rail 4 with 0.5 N (qfrc_applied) under the nominal PD + gravity; its effort
    # keeps one sign, so the recorded effort is the model's times 0.39 with a cosine of 0.94: before
    # the effect existed the pre-check stopped there ("a gear ratio or a unit?")
    sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]
    import mujoco_blind as mb

    m = Model("6pus")
    rec, truth = mb.simulate(m, "offset", 0.5, 3, seed=21, duration=6.0,
                             noise=blind.load_config()["noise"]["6pus"])
    d = diagnose(mb.write_case(m, rec, tmp_path / "force.csv"), figures=False, replay=False)
    assert not d.warnings, d.warnings
    assert d.named()[0] == "offset", d.conclusion
    first = d.effects[0]
    assert first["joint"] == 4, d.conclusion
    est = first["params"]["rail[4].offset"]
    assert truth["rail[4].offset"] == -0.5
    assert abs(est["value"] - -0.5) < 0.05, est
    # an interval that holds the truth and is far narrower than the value
    assert 0 < est["ci95"] < 0.1 and abs(est["value"] - -0.5) < 3 * est["ci95"], est


def test_a_hidden_offset_of_the_own_generator_is_named_first_with_its_size(tmp_path):
    spec = blind.CaseSpec("off1", "6pus", ["offset"], seed=3)
    csv, key = blind.make_case(spec, tmp_path / "cases", tmp_path / "keys")
    d = diagnose(csv, figures=False, replay=False)
    hidden = json.loads(Path(key).read_text())["effects"][0]
    assert hidden["type"] == "offset"
    assert d.named()[0] == "offset", d.conclusion
    values = d.plant_parameters()
    for name, true in hidden["params"].items():
        assert abs(values.get(name, 0.0) - true) < 0.1 * abs(true), (name, values.get(name), true)


def test_an_effort_in_millinewtons_is_still_refused_and_the_check_says_how_sure(tmp_path):
    # a clean recording whose rail-4 effort column was written in mN: a unit, not physics; the
    # sentence gives the residual of the scale and of the offset explanation
    spec = blind.CaseSpec("mn", "6pus", [], seed=5)
    csv, _ = blind.make_case(spec, tmp_path / "cases", tmp_path / "keys")
    rec = read_recording(csv)
    tau = np.array(rec.tau, float)
    tau[:, 3] *= 1000.0
    rec.tau = tau
    bad, _ = write_recording(tmp_path / "mn.csv", rec)
    d = diagnose(bad, figures=False, replay=False)
    assert d.named() == [] and len(d.warnings) == 1, d.conclusion
    w = d.warnings[0]
    assert w.startswith("slider 4: the recorded effort is the model's times 1e+03"), w
    assert "times more" in w and "plus a constant offset" in w, w
    # the same recording as written: clean, no warning
    d0 = diagnose(csv, figures=False, replay=False)
    assert not d0.warnings and d0.conclusion == "no missing physics found", d0.conclusion
