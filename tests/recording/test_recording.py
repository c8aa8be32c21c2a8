"""pkm-recording/1: round trip and one clear error per kind of malformed file."""
import json

import numpy as np
import pytest

from cosim.recording import Recording, RecordingError, read_recording, write_recording


def _rec(n=20, robot="6pus", nd=6, pose=True, qref=True):
    rng = np.random.default_rng(1)
    t = np.arange(n) * 1e-3
    return Recording(
        robot=robot, time=t, q=rng.normal(size=(n, nd)), qd=rng.normal(size=(n, nd)),
        tau=rng.normal(size=(n, nd)), qref=rng.normal(size=(n, nd)) if qref else None,
        pose=0.01 * rng.normal(size=(n, 6)) if pose else None, extra={"x_meas": rng.normal(size=n)},  # a robot's range
        parameters={"platform.m": 0.42}, controller={"type": "pd", "Kp": [1, 2]}, notes="unit test",
    )


def test_round_trip_is_exact(tmp_path):
    rec = _rec()
    csv_path, side = write_recording(tmp_path / "run.csv", rec)
    back = read_recording(csv_path)
    assert back.robot == "6pus" and side.exists()
    for name in ("time", "q", "qd", "tau", "qref", "pose"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name))
    np.testing.assert_array_equal(back.extra["x_meas"], rec.extra["x_meas"])
    assert back.parameters == {"platform.m": 0.42}
    assert back.controller["Kp"] == [1, 2]
    assert json.loads(side.read_text())["format"] == "pkm-recording/1"


def test_optional_columns_absent(tmp_path):
    rec = _rec(robot="quattro", nd=4, pose=False, qref=False)
    back = read_recording(write_recording(tmp_path / "q.csv", rec)[0])
    assert back.qref is None and back.pose is None and back.q.shape == (20, 4)


def _write_raw(tmp_path, text, meta=None, name="bad.csv"):
    p = tmp_path / name
    p.write_text(text)
    if meta is not False:
        (tmp_path / name.replace(".csv", ".json")).write_text(
            json.dumps(meta or {"format": "pkm-recording/1", "robot": "fourbar"}))
    return p


GOOD = "time,q1,qd1,tau1\n0,0,0,0\n0.001,0,0,0\n0.002,0,0,0\n"


def test_good_fourbar_file(tmp_path):
    assert len(read_recording(_write_raw(tmp_path, GOOD))) == 3


@pytest.mark.parametrize(
    "text, row, column, words",
    [
        ("time,q1,tau1\n0,0,0\n1,0,0\n", 1, "qd1", "missing"),
        ("time,q1,qd1,tau1\n0,0,0,0\n0.001,nan,0,0\n", 3, "q1", "not a finite"),
        ("time,q1,qd1,tau1\n0,0,0,0\n0.001,abc,0,0\n", 3, "q1", "not a number"),
        ("time,q1,qd1,tau1\n0,0,0,0\n0.002,0,0,0\n0.001,0,0,0\n", 4, "time", "strictly increasing"),
        ("time,q1,qd1,tau1\n0,0,0,0\n0.001,0,0\n", 3, None, "fields"),
        ("q1,time,qd1,tau1\n0,0,0,0\n0.001,0,0,0\n", 1, "q1", "first column"),
        ("time,q1,qd1,tau1\n0,0,0,0\n", 3, None, "at least 2"),
    ],
)
def test_malformed_file_names_file_row_column(tmp_path, text, row, column, words):
    p = _write_raw(tmp_path, text)
    with pytest.raises(RecordingError) as e:
        read_recording(p)
    msg = str(e.value)
    assert "bad.csv" in msg and f"row {row}" in msg and words in msg
    if column:
        assert repr(column) in msg
    assert e.value.row == row


def test_unknown_robot_and_missing_sidecar(tmp_path):
    p = _write_raw(tmp_path, GOOD, meta={"format": "pkm-recording/1", "robot": "delta"})
    with pytest.raises(RecordingError, match="unknown robot 'delta'"):
        read_recording(p)
    p2 = _write_raw(tmp_path, GOOD, meta=False, name="nosidecar.csv")
    with pytest.raises(RecordingError, match="sidecar .* is missing"):
        read_recording(p2)
    assert len(read_recording(p2, robot="fourbar")) == 3


def test_wrong_format_and_wrong_robot(tmp_path):
    p = _write_raw(tmp_path, GOOD, meta={"format": "other/2", "robot": "fourbar"})
    with pytest.raises(RecordingError, match="format"):
        read_recording(p)
    p = _write_raw(tmp_path, GOOD, name="ok.csv")
    with pytest.raises(RecordingError, match="expected '6pus'"):
        read_recording(p, robot="6pus")


def test_writer_refuses_nan_and_bad_shapes(tmp_path):
    rec = _rec()
    rec.tau[5, 2] = np.nan
    with pytest.raises(RecordingError, match=r"row 7, column 'tau3'"):
        write_recording(tmp_path / "w.csv", rec)
    rec = _rec()
    rec.q = rec.q[:, :5]
    with pytest.raises(RecordingError, match="q has shape"):
        write_recording(tmp_path / "w.csv", rec)


def test_a_recording_of_a_described_robot_carries_its_description(tmp_path):
    # a robot no process knows by name: its description file next to the recording, then gone
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    from cosim.core import Model

    src = (Path(__file__).resolve().parents[2] / "robots" / "linear_delta.toml").read_text()
    desc = tmp_path / "robots" / "my_delta.toml"
    desc.parent.mkdir()
    desc.write_text(src.replace('name = "linear_delta"', 'name = "my_delta"'))
    m = Model(str(desc))
    assert m.robot == "my_delta"
    csv_path, side = write_recording(tmp_path / "runs" / "a.csv", _rec(robot="my_delta", nd=3, pose=False))
    meta = json.loads(side.read_text())
    assert meta["robot_file"] == "../robots/my_delta.toml"  # relative: the folder can move
    moved = tmp_path / "elsewhere"
    shutil.copytree(tmp_path / "runs", moved)
    desc.unlink()  # and the description is gone: the sidecar's copy serves
    code = ("import sys; from cosim.recording import read_recording; r = read_recording(sys.argv[1]); "
            "from cosim.core import Model; print(r.robot, r.q.shape[1], Model(r.robot).ndof)")
    out = subprocess.run([sys.executable, "-c", code, str(moved / "a.csv")], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["my_delta", "3", "3"]
    # a sidecar without either: one line saying what is missing
    meta.pop("robot_description")
    (moved / "a.json").write_text(json.dumps(meta))
    out = subprocess.run([sys.executable, "-c", code, str(moved / "a.csv")], capture_output=True, text=True)
    assert out.returncode != 0 and "description file ../robots/my_delta.toml is gone" in out.stderr


def test_a_recording_without_rates_is_refused_saying_how_to_derive_them(tmp_path):
    # another simulator may log positions only: the refusal names the column and the importer's derivation
    csv_path, _ = write_recording(tmp_path / "run.csv", _rec(pose=False, qref=False))
    lines = csv_path.read_text().splitlines()
    keep = [i for i, c in enumerate(lines[0].split(",")) if not c.startswith("qd")]
    csv_path.write_text("\n".join(",".join(line.split(",")[i] for i in keep) for line in lines) + "\n")
    with pytest.raises(RecordingError, match=r"row 1, column 'qd1': required column is missing .* derive = "
                                             r"\"central_difference\" \(docs/importing.md\)"):
        read_recording(csv_path)
