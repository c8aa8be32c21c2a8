"""A fast periodic force is structure left, not noise (cosim.discrepancy.lines).

A clean 4 s recording of the engine's generator (6-PUS, PD + gravity, 5 mN effort noise), and
the same recording with a force of 0.1 N at 5.4 Hz added to rail 2's recorded effort (an
unbalance the drive balances: the nominal model has no term for it).  The smoothed residual
keeps the force (the smoother passes 5.4 Hz), and a yardstick of differences of samples 70 ms
apart reads it as noise of the force's size.  Checked against what was added, not against
anything the code computed: the structure is on rail 2, keyed on time, at 5.4 Hz with its
amplitude, and no library effect is named with confidence; the recording without it stays
clean."""
import copy
import json
import shutil

import numpy as np
import pytest

from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.diagnosis import tied

F_HZ, AMP, RAIL = 5.4, 0.1, 2


@pytest.fixture(scope="module")
def clean_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("periodic")
    cfg = copy.deepcopy(blind.load_config())
    cfg["general"]["duration"] = 4.0
    rec, _ = blind.make_case(blind.CaseSpec("clean", "6pus", [], seed=300), out / "c", out / "k", cfg=cfg)
    return rec


def _with_force(src, dst):
    """Copy the recording ``src`` (and its sidecar) to ``dst`` with AMP sin(2 pi F_HZ t) added
    to rail RAIL's effort column."""
    with open(src) as f:
        head = f.readline()
    names = head.strip().split(",")
    data = np.loadtxt(src, delimiter=",", skiprows=1)
    t = data[:, names.index("time")]
    data[:, names.index(f"tau{RAIL}")] += AMP * np.sin(2 * np.pi * F_HZ * t + 0.3)
    np.savetxt(dst, data, delimiter=",", header=head.strip(), comments="", fmt="%.10g")
    shutil.copy(src.with_suffix(".json"), dst.with_suffix(".json"))
    return dst


def test_a_force_turning_at_5_hz_is_structure_keyed_on_time_not_noise(clean_csv, tmp_path):
    d = diagnose(_with_force(clean_csv, tmp_path / "fan.csv"), figures=False, replay=False)
    periodic = [e for e in d.unexplained if e["signature"] == "periodic"]
    assert [e["channel"] for e in periodic] == [f"tau{RAIL}"], d.unexplained
    keyed = periodic[0]["keyed_on"]
    f = float(keyed.split("repeating at ")[1].split(" Hz")[0])
    amp = float(keyed.split("amplitude ")[1].split(")")[0])
    assert abs(f - F_HZ) < 0.02 * F_HZ and abs(amp - AMP) < 0.15 * AMP, keyed
    # the entry carries its lines (frequency, amplitude) for the flexible stage, which offers them
    # to every channel
    (f_line, a_line), *_ = periodic[0]["lines"]
    assert abs(f_line - F_HZ) < 0.02 * F_HZ and abs(a_line - AMP) < 0.15 * AMP, periodic[0]["lines"]
    # the yardstick is the noise without the line: the smoothed 5 mN sensor noise, not the force
    assert periodic[0]["noise"] < 0.1 * AMP, periodic
    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    assert confident == [], d.conclusion
    assert "no missing physics" not in d.conclusion and "repeating at" in d.conclusion + d.details


def test_the_same_recording_without_the_force_stays_clean(clean_csv, tmp_path):
    d = diagnose(clean_csv, figures=False, replay=False)
    assert d.unexplained == [] and d.effects == [] and not d.discovered, d.conclusion
    assert d.conclusion.startswith("no missing physics found"), d.conclusion
    assert json.loads(clean_csv.with_suffix(".json").read_text())  # the sidecar the copy carries
