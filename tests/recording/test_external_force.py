"""Known external efforts in a pkm-recording: the optional f_ext<i> columns read, validated
and written, exposed as Recording.f_ext."""
import json

import numpy as np
import pytest

from cosim.recording import Recording, RecordingError, read_recording, write_recording


def _rec(n=12, robot="6pus", nd=6):
    rng = np.random.default_rng(3)
    return Recording(robot=robot, time=np.arange(n) * 1e-3, q=rng.normal(size=(n, nd)), qd=rng.normal(size=(n, nd)),
                     tau=rng.normal(size=(n, nd)), f_ext=rng.normal(size=(n, nd)))


def test_round_trip_with_its_unit(tmp_path):
    rec = _rec()
    csv_path, side = write_recording(tmp_path / "f.csv", rec)
    header = csv_path.read_text().splitlines()[0].split(",")
    assert header[:5] == ["time", "q1", "qd1", "tau1", "f_ext1"] and "f_ext6" in header
    assert json.loads(side.read_text())["units"]["f_ext"] == "N"
    back = read_recording(csv_path)
    np.testing.assert_array_equal(back.f_ext, rec.f_ext)
    assert back.f_ext.shape == (12, 6)
    np.testing.assert_array_equal(back.slice(2, 5).f_ext, rec.f_ext[2:5])


def test_absent_is_none(tmp_path):
    rec = _rec()
    rec.f_ext = None
    assert read_recording(write_recording(tmp_path / "n.csv", rec)[0]).f_ext is None


def _raw(tmp_path, text, units={"f_ext": "N m"}, conv=None):
    p = tmp_path / "raw.csv"
    p.write_text(text)
    meta = {"format": "pkm-recording/1", "robot": "fourbar"}
    if units is not None:
        meta["units"] = units
    if conv is not None:
        meta["joint_convention"] = conv
    (tmp_path / "raw.json").write_text(json.dumps(meta))
    return p


GOOD = "time,q1,qd1,tau1,f_ext1\n0,0.1,0,1,5\n0.001,0.1,0,1,-2.5\n"


def test_hand_written_file_and_the_sign_of_a_joint_convention(tmp_path):
    np.testing.assert_array_equal(read_recording(_raw(tmp_path, GOOD)).f_ext[:, 0], [5.0, -2.5])
    flipped = read_recording(_raw(tmp_path, GOOD, conv={"sign": [-1], "offset": [0.0]}))
    np.testing.assert_array_equal(flipped.f_ext[:, 0], [-5.0, 2.5])   # recorded = -model
    np.testing.assert_array_equal(flipped.tau[:, 0], [-1.0, -1.0])


@pytest.mark.parametrize("text, units, words", [
    (GOOD, None, ["raw.json", "f_ext columns", "units", '"N m"']),
    (GOOD, {"f_ext": "N"}, ["raw.json", "units.f_ext = 'N'", "N m"]),
    (GOOD.replace("-2.5", "nan"), {"f_ext": "N m"}, ["raw.csv", "row 3", "f_ext1", "not a finite"]),
    (GOOD.replace("-2.5", "x"), {"f_ext": "N m"}, ["raw.csv", "row 3", "f_ext1", "not a number"]),
])
def test_bad_external_force_columns(tmp_path, text, units, words):
    with pytest.raises(RecordingError) as e:
        read_recording(_raw(tmp_path, text, units=units))
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_all_joints_or_none(tmp_path):
    rec = _rec()
    csv_path, _ = write_recording(tmp_path / "p.csv", rec)
    lines = csv_path.read_text().splitlines()
    cols = lines[0].split(",")
    k = cols.index("f_ext4")
    csv_path.write_text("\n".join(",".join(c for j, c in enumerate(line.split(",")) if j != k) for line in lines))
    with pytest.raises(RecordingError, match=r"column 'f_ext4'.*all joints or none"):
        read_recording(csv_path)


def test_writing_a_non_finite_force_is_refused(tmp_path):
    rec = _rec()
    rec.f_ext[4, 2] = np.inf
    with pytest.raises(RecordingError, match=r"row 6, column 'f_ext3'"):
        write_recording(tmp_path / "w.csv", rec)
