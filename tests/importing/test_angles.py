"""Angle columns of an import (``angle = "wrap" | "unwrap"``) and the joint limits checked at
import (docs/importing.md, Angles and joint limits).

Oracles: numpy.unwrap and complex exponentials for the angles; the true angle and rate of a
spinning axis written by hand; the row of the file where the value was put out of range."""
from pathlib import Path

import numpy as np
import pytest
from continuous_axis import continuous_pendulum

from cosim.importing import to_recording
from cosim.importing.angles import unwrap, wrap
from cosim.importing.errors import ImportFailure

REPO = Path(__file__).resolve().parents[2]

MAP = """robot = "{robot}"
[columns]
time = {{ variable = "t", unit = "s" }}
q1 = {{ variable = "angle", unit = "deg"{extra} }}
qd1 = {{ derive = "central_difference" }}
tau1 = {{ variable = "u", unit = "N m" }}
"""


def test_wrap_and_unwrap_against_numpy():
    rng = np.random.default_rng(3)
    a = np.cumsum(rng.uniform(-3.0, 3.0, 5000)) + 40.0  # steps below pi: unwrapping is unique
    w = wrap(a)
    assert np.all(w > -np.pi) and np.all(w <= np.pi)
    np.testing.assert_allclose(np.exp(1j * w), np.exp(1j * a), atol=1e-12)
    np.testing.assert_allclose(unwrap(w), np.unwrap(w), atol=1e-9)
    np.testing.assert_allclose(unwrap(w) - w[0] + a[0], a, atol=1e-9)  # the continuous angle, less its turns
    assert wrap(np.pi) == np.pi and wrap(-np.pi) == np.pi


def _csv(tmp_path, angle_deg, t, name="spin.csv"):
    p = tmp_path / name
    rows = "\n".join(f"{a:.12g},{ti:.12g},0.0" for a, ti in zip(angle_deg, t))
    p.write_text("angle,t,u\n" + rows + "\n")
    return p


def _map(tmp_path, robot, extra=""):
    p = tmp_path / "map.toml"
    p.write_text(MAP.format(robot=robot, extra=extra))
    return p


def test_a_spinning_axis_recorded_wrapped_is_unwrapped_for_a_continuous_joint(tmp_path):
    continuous_pendulum(tmp_path, "spinner")
    t = np.arange(2000) * 1e-3
    true = 0.3 + 50.0 * t + 5.0 * t**2  # rad: 110 rad after 2 s
    src = _csv(tmp_path, np.degrees(wrap(true)), t)
    rec = to_recording(src, _map(tmp_path, "spinner.toml", ', angle = "unwrap"'))
    np.testing.assert_allclose(rec.q[:, 0], true, atol=1e-9)
    np.testing.assert_allclose(rec.qd[1:-1, 0], (50.0 + 10.0 * t)[1:-1], atol=1e-6)
    assert rec.sidecar["source"]["columns"]["q1"].endswith(", unwrapped")
    # wrapped into (-pi, pi] instead: the position jumps, its derived rate does not
    rec = to_recording(src, _map(tmp_path, "spinner.toml", ', angle = "wrap"'))
    assert np.all(np.abs(rec.q[:, 0]) <= np.pi) and np.ptp(rec.q[:, 0]) > 6
    np.testing.assert_allclose(rec.qd[1:-1, 0], (50.0 + 10.0 * t)[1:-1], atol=1e-6)


def test_a_position_outside_the_joint_limits_is_refused_at_import_naming_row_and_time(tmp_path):
    """The pendulum's stroke is [-3.1, 3.1] rad: an angle that turns past it is refused, at the
    line of the file where it first leaves the range (the header is line 1)."""
    t = np.arange(100) * 0.01
    ang = np.degrees(np.linspace(0.0, 1.0, 100))
    ang[40:] = np.degrees(3.2)  # rows 40.. (0-based) are out: file line 42
    src = _csv(tmp_path, ang, t)
    with pytest.raises(ImportFailure) as e:
        to_recording(src, _map(tmp_path, "pendulum"))
    msg = str(e.value)
    assert msg.startswith(f"{src}, variable 'angle' (column q1): line 42 (t = 0.4 s): q1 = 3.2 rad is outside the "
                          "joint limits [-3.1, 3.1] rad of robot pendulum (60 rows outside in all)"), msg
    assert "declare the joint continuous" in msg and "\n" not in msg
    # the same angle wrapped by the map is inside the limits
    ang[40:] = np.degrees(3.2 - 2 * np.pi)
    assert to_recording(_csv(tmp_path, ang, t, "ok.csv"), _map(tmp_path, "pendulum")).q[41, 0] == pytest.approx(
        3.2 - 2 * np.pi)


def test_a_matlab_source_counts_its_rows_from_one(tmp_path):
    import scipy.io

    t = np.arange(50) * 0.01
    ang = np.zeros(50)
    ang[7] = 200.0  # deg: 3.49 rad, index 8 as MATLAB counts
    scipy.io.savemat(tmp_path / "r.mat", {"t": t[:, None], "angle": ang[:, None], "u": t[:, None]})
    with pytest.raises(ImportFailure, match=r"index 8 \(1-based\) \(t = 0.07 s\): q1 = 3.49066 rad"):
        to_recording(tmp_path / "r.mat", _map(tmp_path, "pendulum"))
