"""cosim import: values carried from the source exactly (units, scales, derivations checked
against hand computations), the sidecar's fields, and every malformed input refused in one
line naming the file and the variable or field."""
import json
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest
import scipy.io

from cosim.cli.main import main
from cosim.importing import ImportFailure, derive, import_recording, to_recording
from cosim.recording import read_recording

from import_helpers import MAP


def test_mat_v5_values_units_scale_and_sidecar(rig, tmp_path):
    src, mp, v = rig
    res = import_recording(src, mp, tmp_path / "out", progress=False)
    back = read_recording(res.table)
    t = v["zeit"].ravel() * 1e-3   # ms -> s
    np.testing.assert_array_equal(back.time, t)
    np.testing.assert_allclose(back.q[:, 0], v["ang"].ravel() * np.pi / 180, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back.qref[:, 0], (v["ang"].ravel() + 1.0) * np.pi / 180, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(back.tau[:, 0], v["cmd"].ravel() * 2.5)
    # central differences of the converted position, by hand
    q = v["ang"].ravel() * np.pi / 180
    k = 57
    assert back.qd[k, 0] == pytest.approx((q[k + 1] - q[k - 1]) / (t[k + 1] - t[k - 1]), rel=1e-12)
    assert back.qd[0, 0] == pytest.approx((q[1] - q[0]) / (t[1] - t[0]), rel=1e-12)
    # and close to the true derivative of the sine (central-difference error ~ w^3 A h^2 / 6)
    w, A, h = 2 * np.pi * 1.5, 30.0 * np.pi / 180, 0.002
    exact = A * w * np.cos(w * t)
    assert np.max(np.abs(back.qd[1:-1, 0] - exact[1:-1])) < A * w ** 3 * h ** 2 / 6 * 1.01
    assert back.f_ext is None
    side = json.loads(res.sidecar.read_text())
    assert side["controller"] == {"kind": "discrete", "period": 0.002, "kp": 160.18,
                                  "filter": {"b": [0.5, 0.5], "a": [1.0]}}
    assert side["derived"]["qd1"]["from"] == "q1" and side["derived"]["qd1"]["method"] == "central_difference"
    assert side["sensors"]["q1"]["resolution"] == pytest.approx(0.01 * np.pi / 180)
    assert side["sensors"]["q1"]["unit"] == "rad"
    assert side["source"]["columns"]["tau1"].startswith("cmd * gain (2.5)")
    assert side["source"]["absent_optional"] == ["f_ext1"]
    assert side["units"] == {"time": "s", "q": "rad", "qd": "rad/s", "tau": "N m", "qref": "rad"}
    assert back.notes == "a test rig"


def test_derivations_by_hand():
    t = np.array([0.0, 0.1, 0.3, 0.4])
    x = np.array([1.0, 2.0, 5.0, 4.0])
    np.testing.assert_allclose(derive(x, t, "central_difference"), [10.0, 4.0 / 0.3, 2.0 / 0.3, -10.0])
    np.testing.assert_allclose(derive(x, t, "backward_difference"), [10.0, 10.0, 15.0, -10.0])


def test_optional_external_force_used_when_present(rig, tmp_path):
    src, mp, v = rig
    push = np.where(np.arange(200) % 50 < 25, 5.0, 0.0)
    scipy.io.savemat(src, {**v, "push": push[:, None]})
    res = import_recording(src, mp, tmp_path / "out", progress=False)
    back = read_recording(res.table)
    np.testing.assert_array_equal(back.f_ext[:, 0], push)
    assert json.loads(res.sidecar.read_text())["units"]["f_ext"] == "N m"


def _write_v73(path, arrays, char=None):
    """A MATLAB v7.3 file as MATLAB writes one: HDF5 after a 512-byte header, each array
    stored transposed (column-major) with its MATLAB_class."""
    with h5py.File(path, "w", userblock_size=512) as f:
        for k, a in arrays.items():
            d = f.create_dataset(k, data=np.atleast_2d(np.asarray(a, float)).T if np.ndim(a) == 2 else
                                 np.asarray(a, float).reshape(1, -1) if np.ndim(a) == 1 else np.full((1, 1), a))
            d.attrs["MATLAB_class"] = np.bytes_("double")
        for k, s in (char or {}).items():
            d = f.create_dataset(k, data=np.frombuffer(s.encode("utf-16-le"), np.uint16).reshape(-1, 1))
            d.attrs["MATLAB_class"] = np.bytes_("char")
    with open(path, "r+b") as f:
        f.write(b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Thu Nov 26 12:00:00 2026 HDF5 schema 1.00 .")


def test_mat_v73_read_through_h5py(rig, tmp_path):
    _, mp, v = rig
    src = tmp_path / "rig73.mat"
    _write_v73(src, {"zeit": v["zeit"].ravel(), "ang": v["ang"].ravel(), "cmd": v["cmd"].ravel(),
                     "ref": v["ref"].ravel(), "gain": 2.5, "k_p": 160.18})
    rec = to_recording(src, mp, progress=False)
    np.testing.assert_array_equal(rec.tau[:, 0], v["cmd"].ravel() * 2.5)
    np.testing.assert_array_equal(rec.time, v["zeit"].ravel() * 1e-3)
    assert rec.sidecar["source"]["format"] == "matlab-v7.3" and rec.controller["kp"] == 160.18


def test_csv_with_odd_names_and_tsv(tmp_path):
    t = np.arange(50) * 0.01
    q = 0.3 * np.sin(t)
    rows = "\n".join(f"{a!r},{b!r},{c!r}" for a, b, c in zip(t.tolist(), (q * 1000).tolist(), np.cos(t).tolist()))
    (tmp_path / "odd.csv").write_text('"Zeit [s]",Motor Pos (mrad),"Torque, N m"\n' + rows + "\n")
    (tmp_path / "odd.tsv").write_text("Zeit [s]\tMotor Pos (mrad)\tTorque, N m\n" + rows.replace(",", "\t") + "\n")
    mp = tmp_path / "odd.toml"
    mp.write_text('robot = "fourbar"\n[columns]\ntime = "Zeit [s]"\nq1 = { variable = "Motor Pos (mrad)", '
                  'unit = "mrad" }\nqd1 = { derive = "backward_difference" }\ntau1 = "Torque, N m"\n')
    for name in ("odd.csv", "odd.tsv"):
        rec = to_recording(tmp_path / name, mp, progress=False)
        np.testing.assert_allclose(rec.q[:, 0], q, rtol=1e-15)
        np.testing.assert_array_equal(rec.tau[:, 0], np.cos(t))
        assert rec.qd[5, 0] == pytest.approx((rec.q[5, 0] - rec.q[4, 0]) / (t[5] - t[4]), rel=1e-12)


def test_time_from_a_period_and_a_matrix_column(rig, tmp_path):
    src, mp, v = rig
    mp.write_text(MAP.replace('time = { variable = "zeit", unit = "ms" }', 'time = { period = 2, unit = "ms" }')
                  .replace('q1 = { variable = "ang", unit = "deg" }',
                           'q1 = { variable = "Q", column = 2, unit = "deg" }'))
    rec = to_recording(src, mp, progress=False)
    np.testing.assert_allclose(rec.time, np.arange(200) * 0.002, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rec.q[:, 0], 2 * v["ang"].ravel() * np.pi / 180, rtol=0, atol=1e-15)


# ---------------------------------------------------------------- malformed inputs
def _set(path, old, new):
    s = path.read_text()
    assert old in s, old
    path.write_text(s.replace(old, new))


def _resave(src, v, **changes):
    scipy.io.savemat(src, {**v, **changes})


#: cases that are one edit of the rig's map: (text replaced, replacement, words the message must hold)
MAP_EDITS = {
    "missing variable": ('"ang"', '"angle"',
        ["rig.mat", "'angle'", "q1", "not in the file", "did you mean 'ang'"]),
    "unknown unit": ('unit = "deg" }\nqd1', 'unit = "furlong" }\nqd1',
        ["rig_map.toml", "columns.q1.unit", "unknown unit 'furlong'"]),
    "unit of the wrong kind": ('unit = "deg" }\nqd1', 'unit = "mm" }\nqd1',
        ["rig_map.toml", "columns.q1.unit", "'mm' is a length", "angle"]),
    "scale variable not scalar": ('scale = { variable = "gain" }', 'scale = { variable = "ang" }',
        ["rig.mat", "'ang'", "not a scalar", "columns.tau1.scale"]),
    "unknown column field": ('q1 = { variable = "ang", unit = "deg" }', 'q1 = { variable = "ang", gain = 2 }',
        ["rig_map.toml", "columns.q1.gain", "unknown field"]),
    "not a column of the robot": ("qref1 =", "qref2 =",
        ["rig_map.toml", "columns.qref2", "not a recording column of robot fourbar"]),
    "required column missing": ('tau1 = { variable = "cmd", scale = { variable = "gain" }, unit = "N m" }\n', "",
        ["rig_map.toml", "tau1 is missing"]),
    "matrix without a column": ('q1 = { variable = "ang"', 'q1 = { variable = "Q"',
        ["rig.mat", "'Q'", "matrix of shape 200 x 2", "column = 1..2"]),
    "controller variable missing": ('kp = { variable = "k_p" }', 'kp = { variable = "kq" }',
        ["rig.mat", "'kq'", "controller.kp", "not in the file"]),
    "unknown derivation": ('"central_difference"', '"spline"',
        ["rig_map.toml", "columns.qd1.derive", "unknown derivation 'spline'"]),
    "unknown robot": ('robot = "fourbar"', 'robot = "sixbar"',
        ["rig_map.toml", "field robot", "'sixbar'"]),
    "derived column with a unit": ('qd1 = { derive = "central_difference" }',
                                   'qd1 = { derive = "central_difference", unit = "deg/s" }',
        ["rig_map.toml", "columns.qd1.unit", "derived column"]),
    "sensor unit of the wrong kind": ("q1 = { resolution = 0.01, noise_std = 0.02 }",
                                      'q1 = { resolution = 0.01, unit = "um" }',
        ["rig_map.toml", "sensors.q1.unit", "'um' is a length"]),
}


def _text_source(tmp_path, mp, file, text, time, q, tau):
    """A text source and a minimal map of it: time (a TOML value), q1 and tau1 (column names)."""
    s = tmp_path / file
    s.write_text(text)
    mp.write_text(f'robot = "fourbar"\n[columns]\ntime = {time}\nq1 = "{q}"\n'
                  f'qd1 = {{ derive = "central_difference" }}\ntau1 = "{tau}"\n')
    return s


def _case(name, rig, tmp_path):
    """Make the files of one malformed case; returns (source, map, words the message must hold)."""
    src, mp, v = rig
    n = len(v["zeit"])
    if name in MAP_EDITS:
        old, new, words = MAP_EDITS[name]
        _set(mp, old, new)
        return src, mp, words
    if name == "wrong length":
        _resave(src, v, ref=v["ref"][:-1])
        return src, mp, ["rig.mat", "'ref'", "qref1", f"{n - 1} values", f"has {n}"]
    if name == "non-monotonic time":
        z = v["zeit"].copy()
        z[50] = z[49]
        _resave(src, v, zeit=z)
        return src, mp, ["rig.mat", "'zeit'", "not strictly increasing", "index 51 (1-based)"]
    if name == "NaN rows":
        a = v["ang"].copy()
        a[10], a[12] = np.nan, np.inf
        _resave(src, v, ang=a)
        return src, mp, ["rig.mat", "'ang'", "q1", "2 non-finite", "indices 11, 13"]
    if name == "bad map TOML":
        mp.write_text('robot = "fourbar"\n[columns\ntime = "zeit"\n')
        return src, mp, ["rig_map.toml", "not valid TOML", "line 2"]
    if name == "v7.3 char variable":
        s73 = tmp_path / "text73.mat"
        _write_v73(s73, {"zeit": v["zeit"].ravel(), "cmd": v["cmd"].ravel(), "ref": v["ref"].ravel(),
                         "gain": 2.5, "k_p": 1.0}, char={"ang": "hello"})
        return s73, mp, ["text73.mat", "'ang'", "is a char"]
    if name == "TSV with a word in a number column":
        s = _text_source(tmp_path, mp, "bad.tsv", "zeit\tang\tcmd\tref\n" + "".join(
            f"{k}\t{k}\t1\t0\n" for k in range(3)) + "3\tabc\t1\t0\n", '{ variable = "zeit", unit = "ms" }',
                         "ang", "cmd")
        return s, mp, ["bad.tsv", "'ang'", "line 5", "'abc' is not a number"]
    if name == "CSV with an empty cell":
        s = _text_source(tmp_path, mp, "gap.csv", "Time (s),Pos [rad],Effort\n0,0,1\n0.001,,1\n0.002,0,1\n",
                         '"Time (s)"', "Pos [rad]", "Effort")
        return s, mp, ["gap.csv", "'Pos [rad]'", "non-finite", "line 3"]
    if name == "CSV column misspelt":
        s = _text_source(tmp_path, mp, "names.csv", "Time (s),Pos [rad],Effort\n0,0,1\n0.001,0,1\n", '"Time (s)"',
                         "Pos (rad)", "Effort")
        return s, mp, ["names.csv", "'Pos (rad)'", "did you mean 'Pos [rad]'"]
    if name == "not a MATLAB file":
        s = tmp_path / "notes.mat"
        s.write_text("these are my notes, not data\n" * 20)
        return s, mp, ["notes.mat", "not a MATLAB file"]
    if name == "empty file":
        s = tmp_path / "empty.mat"
        s.write_bytes(b"")
        return s, mp, ["empty.mat", "file is empty"]
    if name == "binary file as CSV":
        s = tmp_path / "blob.csv"
        s.write_bytes(bytes(range(256)) * 4)
        return s, mp, ["blob.csv", "not a text file"]
    if name == "unknown map field":
        mp.write_text(MAP.replace("[sensors]", "[sensor]"))
        return src, mp, ["rig_map.toml", "field sensor", "unknown field"]
    if name == "source not found":
        return tmp_path / "nope.mat", mp, ["nope.mat", "file not found"]
    raise KeyError(name)


CASES = list(MAP_EDITS) + [
    "wrong length", "non-monotonic time", "NaN rows", "bad map TOML", "v7.3 char variable",
    "TSV with a word in a number column", "CSV with an empty cell", "CSV column misspelt", "not a MATLAB file",
    "empty file", "binary file as CSV", "unknown map field", "source not found"]


@pytest.mark.parametrize("name", CASES)
def test_malformed_input_is_one_line_exit_2(name, rig, tmp_path, capsys):
    src, mp, words = _case(name, rig, tmp_path)
    with pytest.raises(ImportFailure) as e:
        to_recording(src, mp, progress=False)
    for w in words:
        assert w in str(e.value), (w, str(e.value))
    code = main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("cosim import: error: ") and "Traceback" not in err
    assert not list((tmp_path / "out").glob("*"))   # nothing written (the command may have made the folder)


@pytest.mark.parametrize("name", ["NaN rows", "bad map TOML"])
def test_malformed_input_through_the_command(name, rig, tmp_path):
    src, mp, words = _case(name, rig, tmp_path)
    p = subprocess.run([sys.executable, "-m", "cosim", "import", str(src), "--map", str(mp), "--out",
                        str(tmp_path / "out")], capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and p.stdout == ""
    assert p.stderr.count("\n") == 1 and "Traceback" not in p.stderr
    for w in words:
        assert w in p.stderr


def test_out_naming_a_file(rig, tmp_path, capsys):
    src, mp, _ = rig
    (tmp_path / "taken").write_text("x")
    assert main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "taken")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "taken is an existing file" in err
    with pytest.raises(ImportFailure, match="taken: exists and is not a directory"):
        import_recording(src, mp, tmp_path / "taken", progress=False)
    assert (tmp_path / "taken").read_text() == "x"


def test_command_writes_and_says_what(rig, tmp_path, capsys):
    src, mp, _ = rig
    assert main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "o"), "--name", "run1"]) == 0
    out = capsys.readouterr().out
    assert "run1.csv (200 rows" in out and "derived: qd1" in out and "optional columns not in the file: f_ext1" in out
    assert len(read_recording(tmp_path / "o" / "run1.csv")) == 200


@pytest.mark.parametrize("fmt, suffix", [("parquet", ".parquet"), ("hdf5", ".h5")])
def test_command_writes_a_parquet_or_hdf5_table(rig, tmp_path, fmt, suffix):
    src, mp, v = rig
    assert main(["import", str(src), "--map", str(mp), "--out", str(tmp_path / "o"), "--format", fmt]) == 0
    back = read_recording(tmp_path / "o" / f"rig{suffix}")
    np.testing.assert_array_equal(back.tau[:, 0], v["cmd"].ravel() * 2.5)


def test_robot_as_a_description_path_relative_to_the_map(tmp_path):
    repo = Path(__file__).resolve().parents[2]
    (tmp_path / "desc").mkdir()
    (tmp_path / "maps").mkdir()
    (tmp_path / "desc" / "my_rails.toml").write_text(
        (repo / "robots" / "linear_delta.toml").read_text().replace('name = "linear_delta"', 'name = "my_rails"'))
    t = np.arange(20) * 1e-3
    rows = "".join(f"{a!r},{0.1 + a},{0.1 + 2 * a},{0.1 + 3 * a},1,2,3\n" for a in t.tolist())
    (tmp_path / "rails.csv").write_text("t,a,b,c,fa,fb,fc\n" + rows)
    mp = tmp_path / "maps" / "rails.toml"
    mp.write_text('robot = "../desc/my_rails.toml"\n[columns]\ntime = "t"\n' + "".join(
        f'q{i} = {{ variable = "{v}", unit = "mm" }}\nqd{i} = {{ derive = "central_difference" }}\ntau{i} = "f{v}"\n'
        for i, v in ((1, "a"), (2, "b"), (3, "c"))))
    res = import_recording(tmp_path / "rails.csv", mp, tmp_path / "out", progress=False)
    back = read_recording(res.table)
    assert back.robot == "my_rails"
    np.testing.assert_allclose(back.q[:, 2], (0.1 + 3 * t) * 1e-3, rtol=1e-15)
    np.testing.assert_allclose(back.qd[:, 1], 2e-3, rtol=1e-9)
    side = json.loads(res.sidecar.read_text())
    assert (res.sidecar.parent / side["robot_file"]).resolve() == (tmp_path / "desc" / "my_rails.toml").resolve()


def test_text_with_comment_lines_before_the_header_and_latin1(tmp_path):
    """Lines before the header are skipped exactly (no data row lost), a latin-1 header read."""
    body = "".join(f"{k * 0.001!r};{k * 1.5!r};{k * 2.0!r}\n" for k in range(10))
    (tmp_path / "rig.csv").write_bytes(("# logged by the rig\n\n# v2\nZeit;Winkel [°];Moment\n" + body)
                                      .encode("latin-1"))
    mp = tmp_path / "m.toml"
    mp.write_text('robot = "fourbar"\n[source]\nencoding = "latin-1"\n[columns]\ntime = "Zeit"\n'
                  'q1 = { variable = "Winkel [°]", unit = "deg" }\nqd1 = { derive = "central_difference" }\n'
                  'tau1 = "Moment"\n')
    rec = to_recording(tmp_path / "rig.csv", mp, progress=False)
    assert len(rec) == 10
    np.testing.assert_array_equal(rec.tau[:, 0], np.arange(10) * 2.0)
    np.testing.assert_allclose(rec.q[:, 0], np.arange(10) * 1.5 * np.pi / 180, rtol=1e-15)
    mp.write_text(mp.read_text().replace('encoding = "latin-1"\n', ""))
    with pytest.raises(ImportFailure, match=r"rig.csv: is not a text file in utf-8 \(byte 0xb0 at byte 39\)"):
        to_recording(tmp_path / "rig.csv", mp, progress=False)
