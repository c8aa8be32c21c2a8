"""The shipped EMPS recording imported with its shipped map: every column has the values of
the .mat (read here independently with scipy), the controller holds the file's gains, and
cosim diagnose takes the result."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from cosim.importing import import_recording, read_map
from cosim.recording import read_recording

REPO = Path(__file__).resolve().parents[2]
MAT = REPO / "data" / "emps" / "DATA_EMPS.mat"
MAP = REPO / "data" / "emps" / "emps_map.toml"


def test_emps_columns_are_the_mat_values(tmp_path):
    mat = scipy.io.loadmat(MAT)
    res = import_recording(MAT, MAP, tmp_path / "out", progress=False)
    rec = read_recording(res.table)
    t, qm, qg = mat["t"].ravel(), mat["qm"].ravel(), mat["qg"].ravel()
    assert len(rec) == 24841 and rec.robot == "emps"
    np.testing.assert_array_equal(rec.time, t)
    np.testing.assert_array_equal(rec.q[:, 0], qm)
    np.testing.assert_array_equal(rec.qref[:, 0], qg)
    np.testing.assert_array_equal(rec.tau[:, 0], mat["vir"].ravel() * mat["gtau"].item())
    for k in (1, 5000, 24839):
        assert rec.qd[k, 0] == pytest.approx((qm[k + 1] - qm[k - 1]) / (t[k + 1] - t[k - 1]), rel=1e-12)
        assert rec.extra["qdref1"][k] == pytest.approx((qg[k + 1] - qg[k - 1]) / (t[k + 1] - t[k - 1]), rel=1e-12)
    assert rec.f_ext is None and "inject1" not in rec.extra  # this file has no test signal (pulses_N)
    assert "pulses_N" not in mat
    c = rec.controller
    assert c["kp"] == mat["kp"].item() == 160.18 and c["kv"] == mat["kv"].item() == 243.45
    assert c["output_gain"] == mat["gtau"].item()
    assert (c["kind"], c["period"], c["law"], c["velocity"], c["delay_samples"]) == \
        ("discrete", 0.001, "cascade_pp", "backward_difference", 1)
    assert "position_filter" not in c and c["velocity_filter"] == {"b": [0.5, 0.5], "a": [1.0]}
    assert c["saturation"] == [-10.0, 10.0]
    side = json.loads(res.sidecar.read_text())
    assert side["derived"]["qd1"] == {"from": "q1", "method": "central_difference",
                                      "formula": side["derived"]["qd1"]["formula"]}
    assert side["units"] == {"time": "s", "q": "m", "qd": "m/s", "tau": "N", "qref": "m"}
    assert side["sensors"] == {"q1": {"resolution": 5e-8, "unit": "m"}}


def test_emps_map_is_the_documented_one():
    m = read_map(MAP)
    assert m.robot == "emps"
    assert m.columns["tau1"].variable == "vir" and m.columns["tau1"].scale == "gtau"
    assert m.columns["qd1"].derive == "central_difference" and m.columns["qdref1"].derive == "central_difference"
    # the test signal pulses_N is a 0/5 V signal added to the command before the drive gain,
    # included in vir: an injection at the command, not an external force
    assert "f_ext1" not in m.columns
    c = m.columns["inject1"]
    assert (c.variable, c.scale, c.unit, c.optional) == ("pulses_N", "gtau", "N", True)
    assert m.injection == {"point": "command", "in_effort": True}


def test_cosim_diagnose_takes_the_imported_recording(tmp_path):
    out = tmp_path / "emps"
    p = subprocess.run([sys.executable, "-m", "cosim", "import", str(MAT), "--map", str(MAP), "--out", str(out)],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "24841 rows" in p.stdout and "robot emps" in p.stdout
    p = subprocess.run([sys.executable, "-m", "cosim", "diagnose", str(out / "DATA_EMPS.csv"), "--no-figures",
                        "--out", str(tmp_path / "diagnosis")], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "DATA_EMPS.csv (emps)" in p.stdout and "tau1" in p.stdout
    assert (tmp_path / "diagnosis" / "report.md").exists()


def test_a_file_with_the_test_signal_gets_it_as_a_command_injection_in_the_effort(tmp_path):
    """A file like the rig's second recording (DATA_EMPS.mat's variables plus a 0/5 square
    wave named pulses_N, made here): the map makes it the signal added to the command,
    pulses_N * gtau [N], included in the recorded effort."""
    from cosim.injection import from_recording

    mat = {k: v for k, v in scipy.io.loadmat(MAT).items() if not k.startswith("__")}
    n = 3000
    for k in ("t", "qm", "qg", "vir"):
        mat[k] = mat[k][:n]
    pulses = 5.0 * ((np.arange(n) // 250) % 2 == 1)
    mat["pulses_N"] = pulses[:, None]
    scipy.io.savemat(tmp_path / "second.mat", mat)
    res = import_recording(tmp_path / "second.mat", MAP, tmp_path / "out")
    rec = read_recording(res.table)
    inj = from_recording(rec)
    gtau = mat["gtau"].item()
    np.testing.assert_allclose(inj.signal[:, 0], pulses * gtau, rtol=1e-15)
    assert (inj.point, inj.in_effort) == ("command", True)
    side = json.loads(res.sidecar.read_text())
    assert side["injection"] == {"point": "command", "in_effort": True} and side["units"]["inject"] == "N"
    assert rec.f_ext is None  # not a force on the carriage
    np.testing.assert_array_equal(inj.applied_from_recorded(rec.tau), rec.tau)  # vir includes it
