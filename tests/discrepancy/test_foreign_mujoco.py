"""The engine on recordings from MuJoCo, a simulator the project did not write.

A few cases of bench/foreign/mujoco_blind.py (which runs the full set: every effect type,
clean cases, PD + gravity or PID): the robot simulated by MuJoCo with an effect hidden in
MuJoCo's own physics (joint frictionloss; a drive and a carriage as two bodies joined by a
gap with stiff faces, the backlash) or in the drive around it (a dead zone), and a clean
run, diagnosed blind; the truth is compared only afterwards.  Nothing of the engine
is tuned on these cases."""
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.recording import read_recording  # noqa: E402


def _case(folder, effect, value, joint, replay=False):
    """(truth, diagnosis) of a 6 s MuJoCo recording of the 6-PUS hiding ``effect``."""
    m = Model("6pus")
    rec, truth = mb.simulate(m, effect, value, joint, seed=21, duration=6.0,
                             noise=blind.load_config()["noise"]["6pus"])
    csv = mb.write_case(m, rec, folder / "run.csv")  # MuJoCo's joint zero is home: declared in the sidecar
    return truth, diagnose(csv, figures=False, replay=replay)


@pytest.fixture(scope="module")
def gap_case(tmp_path_factory):
    """MuJoCo's gap on rail 6 diagnosed once, with its replays (the blind check reads the
    same selection and values as without them: the replays come after the fit)."""
    return _case(tmp_path_factory.mktemp("gap"), "backlash", 5e-5, 5, replay=True)


@pytest.mark.parametrize("effect, value, joint, key", [
    (None, 0.0, 0, None),
    ("coulomb", 0.03, 2, "rail[3].coulomb"),          # MuJoCo's soft friction (frictionloss)
    ("dead_zone", 0.04, 4, "rail[5].dead_zone"),      # the drive passes nothing within +-0.04 N
    ("backlash", 5e-5, 5, "rail[6].backlash"),        # two bodies; rail 6's effort changes sign (gap_case)
])
def test_a_mujoco_recording_is_diagnosed_blind(tmp_path, request, effect, value, joint, key):
    truth, d = request.getfixturevalue("gap_case") if effect == "backlash" else _case(tmp_path, effect, value, joint)
    if effect is None:
        assert d.named() == [] and d.conclusion == "no missing physics found", d.conclusion
        return
    if effect == "dead_zone" and d.named()[0] == "offset":
        # the rail is commanded one way, never within the band: a dead zone is then a constant,
        # the offset's column; the offset of its size is named, the dead zone its tie
        tau = np.asarray(read_recording(d.recording).tau)[:, joint]
        assert np.all(np.sign(tau) == np.sign(tau[0])) and np.abs(tau).min() > value, d.conclusion
        assert "dead_zone" in d.ties("offset"), d.conclusion
        key = key.replace(".dead_zone", ".offset")
        est = abs(d.plant_parameters()[key])
        assert abs(est - value) < 0.10 * value, (est, value)
        return
    assert d.named()[0] == effect, d.conclusion
    est = d.plant_parameters()[key]
    assert abs(est - truth[key]) < 0.10 * truth[key], (est, truth[key])


def test_a_gap_is_put_on_a_rail_whose_effort_changes_sign():
    # case 1109 of the full set draws rail 1, which carries the platform's weight one way
    # throughout (a gap there is an offset of b/2, not measurable): it moves to rail 6
    m = Model("6pus")
    assert mb.gap_joint(m, 1109, 9.0, 0) == 5
    assert mb.gap_joint(m, 1109, 9.0, 5) == 5  # a rail whose effort changes sign stays


def test_the_delay_in_the_answer_key_is_the_one_the_delay_line_makes():
    # the delay line applies each 1 kHz command from the first 0.1 ms MuJoCo step at or after its
    # time plus the drawn delay: a drawn 2.74 ms is a shift of the held command by 2.8 ms, the
    # same recording as 2.8 ms drawn (where the line is exact) and not that of 2.7 ms
    m, noise = Model("6pus"), blind.load_config()["noise"]["6pus"]

    def run(delay):
        return mb.simulate(m, "actuator_delay", delay, 0, seed=5, duration=1.5, noise=noise)

    rec, truth = run(2.74e-3)
    key = truth["actuator.delay"]
    same, _ = run(2.8e-3)
    shorter, _ = run(2.7e-3)
    assert np.array_equal(np.asarray(rec.q), np.asarray(same.q))
    assert not np.array_equal(np.asarray(rec.q), np.asarray(shorter.q))
    assert abs(key - 2.8e-3) < 1e-12, key


def test_a_fitted_gap_is_replayed_as_two_bodies_closer_to_the_recorded_readings(gap_case):
    # MuJoCo's gap: a 0.05 kg drive (declared as the rail's rotor inertia) on faces of 1e6 N/m
    # with damping ratio 0.3; the engine fits the gap by its reading model, then the damping and
    # the faces of two bodies on the last second of the fitted part (cosim.discrepancy.drive_bodies)
    _, d = gap_case
    assert d.named()[0] == "backlash", d.conclusion
    tb = d.replay["two_body"]
    assert tb["params"]["drive.two_body"] == 1.0 and tb["params"]["rail[6].transmission_damping"] > 0
    runs = d.replay["runs"]
    gap = {name: runs[name]["rms_q"][5] for name in ("nominal", "fitted", "fitted, two bodies")}
    # the reading model in closed loop has no drive to cross the gap: its readings of rail 6 are
    # further from the recording than the nominal plant's (3.2 um against 1.6 um); the two
    # bodies' are 1.7 um
    assert gap["fitted, two bodies"] < 0.75 * gap["fitted"], gap
    assert "replayed as two bodies (drive and carriage) the held-out readings come closer" in d.details


def test_a_payload_at_the_platforms_centre_of_mass_is_tied_with_a_heavier_platform(tmp_path, monkeypatch):
    """MuJoCo's payload body put at the platform's centre of mass (its offsets drawn as zero):
    the same physics as a heavier platform on any recording.  Whichever is named first, the
    other is declared its tie ("fits the data as well"), never ruled out."""
    class Centred:  # the generator's draws of the payload's offset, all zero
        def __init__(self, rng):
            self.rng = rng

        def uniform(self, lo, hi):
            return 0.0

        def __getattr__(self, name):
            return getattr(self.rng, name)

    xml = mb.case_xml
    monkeypatch.setattr(mb, "case_xml", lambda m, hidden, rng, gap_model="applied": xml(m, hidden, Centred(rng),
                                                                                         gap_model))
    truth, d = _case(tmp_path, "payload", 0.05, 0)
    assert (truth["payload.x"], truth["payload.y"], truth["payload.z"]) == (0.0, 0.0, 0.0)
    first = d.named()[0]
    assert first in ("platform_mass", "payload"), d.conclusion
    other = "payload" if first == "platform_mass" else "platform_mass"
    assert other in d.ties(first), d.effects[0]["lookalikes"]


def test_the_interval_of_mujocos_friction_loss_counts_its_fade(tmp_path):
    # MuJoCo's friction loss (a soft constraint) is 0.31 of its level below 0.1 mm/s: plan 59's
    # first case (29.7 mN on rail 5) is fitted 3.1 % low, 1.27 half widths of the windows' interval;
    # the spread across the rail's speed bands counts it
    m = Model("6pus")
    effect, value, joint, seed = mb.plan(59, 0)[0]
    rec, truth = mb.simulate(m, effect, value, joint, seed, 9.0, blind.load_config()["noise"]["6pus"])
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    key = f"rail[{joint + 1}].coulomb"
    stated = {p: v for e in d.effects for p, v in e["params"].items()}[key]
    assert abs(stated["value"] - truth[key]) <= stated["ci95"], (stated, truth[key])
