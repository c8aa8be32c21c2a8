"""A recording in another joint convention than the model's (a rail coordinate
running the other way on three legs loaded without a word and was diagnosed wrong).

Undeclared, the diagnosis names the legs whose effort runs against the model's and names
no effect (a fit would call the convention some physics); declared in the sidecar (``joint_convention``), the
reader converts the file back and the diagnosis is the one of the original recording."""
import json

import numpy as np
import pytest

from cosim.discrepancy import blind, diagnose
from cosim.recording import RecordingError, read_recording, sidecar_path, write_recording

FLIPPED = [1, 3, 5]  # 0-based legs recorded with the rail coordinate reversed


def _other_convention(src, dst, *, declare):
    """Copy of a recording with legs FLIPPED in the convention recorded = -model + 2 q0."""
    rec = read_recording(src)
    sign = np.ones(rec.ndof)
    sign[FLIPPED] = -1
    offset = np.where(sign < 0, 2 * rec.q[0], 0.0)
    rec.q = sign * rec.q + offset
    rec.qd, rec.tau = sign * rec.qd, sign * rec.tau
    if rec.qref is not None:
        rec.qref = sign * rec.qref + offset
    csv, side = write_recording(dst, rec)
    if declare:
        meta = json.loads(side.read_text())
        meta["joint_convention"] = {"sign": sign.tolist(), "offset": offset.tolist()}
        side.write_text(json.dumps(meta))
    return csv, sign, offset


@pytest.fixture(scope="module")
def case(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("conv")
    rec, _key = blind.make_case(blind.CaseSpec("conv", "6pus", [], seed=3), tmp / "cases", tmp / "keys")
    return rec, tmp


def test_an_undeclared_convention_is_named_per_leg_not_diagnosed(case):
    rec, tmp = case
    csv, _, _ = _other_convention(rec, tmp / "flipped.csv", declare=False)
    d = diagnose(csv, figures=False, replay=False)
    named = sorted(int(w.split()[1].rstrip(":")) - 1 for w in d.warnings)
    assert named == FLIPPED, d.warnings
    assert d.conclusion.startswith("cannot diagnose: the recording contradicts the model"), d.conclusion
    assert d.effects == [] and "joint_convention" in d.warnings[0]


def test_a_declared_convention_reads_back_the_model_coordinates(case):
    rec, tmp = case
    csv, sign, offset = _other_convention(rec, tmp / "declared.csv", declare=True)
    a, b = read_recording(rec), read_recording(csv)
    assert b.joint_convention == {"sign": sign.tolist(), "offset": offset.tolist()}
    for name in ("q", "qd", "tau", "qref"):
        assert np.allclose(getattr(a, name), getattr(b, name), rtol=0, atol=1e-12), name
    d0, d1 = diagnose(rec, figures=False, replay=False), diagnose(csv, figures=False, replay=False)
    assert d1.warnings == [] and d0.warnings == []
    assert d1.conclusion == d0.conclusion


@pytest.mark.parametrize("conv, field", [
    ({"sign": [1, -1, 1]}, "joint_convention.sign must be a list of 6"),
    ({"sign": [1, 2, 1, 1, 1, 1]}, r"joint_convention.sign\[1\] = 2 must be \+1 or -1 \(joint 2\)"),
    ({"offset": [0, 0, 0, 0, 0, "a"]}, r"joint_convention.offset\[5\]"),
    ({"gain": [1] * 6}, "joint_convention must be"),
])
def test_a_bad_convention_names_the_field(case, conv, field):
    rec, tmp = case
    csv, side = write_recording(tmp / "bad.csv", read_recording(rec))
    meta = json.loads(side.read_text())
    meta["joint_convention"] = conv
    side.write_text(json.dumps(meta))
    with pytest.raises(RecordingError, match=field) as e:
        read_recording(csv)
    assert str(sidecar_path(csv)) in str(e.value)
