"""A recording whose joint leaves the robot's limits is refused by `cosim diagnose` in one
line naming the row as the file counts it, the time and what to do; the same recording of a
continuous joint (docs/robots.md) has no limits to leave."""
import numpy as np
from continuous_axis import continuous_pendulum

from cosim.core import Model
from cosim.discrepancy.residuals import Pipeline
from cosim.recording import Recording, write_recording


def _spin(robot, n=3000):
    t = np.arange(n) * 1e-3
    q = 2.0 * t + 1.5 * t**2  # rad: passes 3.1 rad (the pendulum's stroke) at row 1010
    qd = 2.0 + 3.0 * t
    return Recording(robot, t, q[:, None], qd[:, None], np.zeros((n, 1)))


def test_diagnose_names_the_row_the_time_and_a_hint(tmp_path, capsys):
    from cosim.cli.main import main

    rec = _spin("pendulum")
    k = int(np.flatnonzero(rec.q[:, 0] > 3.1)[0])
    path, _ = write_recording(tmp_path / "spin.csv", rec)
    assert main(["diagnose", str(path), "--out", str(tmp_path / "d"), "--no-figures"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    line = path.read_text().splitlines()[k + 1]  # the file's row k + 2 (1-based, the header row 1)
    assert float(line.split(",")[0]) == rec.time[k]
    assert f"row {k + 2} (t = {rec.time[k]:.6g} s): joint 1 q1 = {rec.q[k, 0]:.6g} rad is outside its limits " \
           "[-3.1, 3.1] rad" in err, err
    assert "declare the joint continuous" in err


def test_a_continuous_joint_takes_the_same_recording(tmp_path):
    continuous_pendulum(tmp_path, "spin_axis")
    m = Model(str(tmp_path / "spin_axis.toml"))
    p = Pipeline(_spin("spin_axis"), m)
    assert p.q[-1, 0] > 10


def test_a_continuous_joint_recorded_wrapped_is_refused_with_the_way_out(tmp_path):
    import pytest

    from cosim.discrepancy.residuals import DiagnosisError

    continuous_pendulum(tmp_path, "spin_axis")
    m = Model(str(tmp_path / "spin_axis.toml"))
    rec = _spin("spin_axis")
    rec.q[:, 0] = np.angle(np.exp(1j * rec.q[:, 0]))  # into (-pi, pi]: jumps by -2 pi
    k = int(np.flatnonzero(np.abs(np.diff(rec.q[:, 0])) > np.pi)[0]) + 1
    with pytest.raises(DiagnosisError, match=f"row {k + 2} \\(t = {rec.time[k]:.6g} s\\): q1 of the continuous "
                                             "joint 1 jumps by -6.2"):
        Pipeline(rec, m)
