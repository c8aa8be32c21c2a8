"""`cosim diagnose` with a link-side encoder (q_link<i> columns of an import map): the gear's
stiffness and backlash reported as the two-body drive's core parameters with intervals.

Oracle: a two-mass drive simulated by scipy's solve_ivp, not by the core (tests/oracles/two_mass.py):
a motor inertia JM with viscous friction BM driven by a torque u(t), a link inertia JL with viscous
friction BL, and between them a spring of stiffness K with a dead band of total width GAP (transmitted torque
K (d - GAP/2) for d > GAP/2, K (d + GAP/2) for d < -GAP/2, 0 between; d = motor - link angle).
The recording holds the motor angle (q1), its rate (qd1), the motor torque (tau1) and the link
angle (q_link1), each encoder with white noise of 2e-7 rad; the map gives the nominal drive (JM,
BM) and the link's inertia (JL) as the recording's parameters, its friction BL left out: the
diagnosis proper runs on a model that differs from the drive by that friction and the spring."""
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from cosim.discrepancy import diagnose
from cosim.importing import to_recording
from cosim.importing.errors import ImportFailure
from cosim.jsonable import jsonable

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "oracles"))
from two_mass import two_mass_drive  # noqa: E402

JM, BM, JL, BL = 0.5, 1.5, 2.0, 4.0  # kg m2, N m s/rad
K, GAP = 3.0e4, 6e-4  # N m/rad, rad
NOISE = 2e-7  # rad


def _u(t):
    return 50 * np.sin(2 * np.pi * 0.9 * t) + 20 * np.sin(2 * np.pi * 3.1 * t + 0.5) + 8 * np.sin(2 * np.pi * 7 * t)


def _two_mass():
    d = two_mass_drive(_u, jm=JM, bm=BM, jl=JL, bl=BL, k=K, gap=GAP)
    rng = np.random.default_rng(7)
    return (d.t, d.motor + NOISE * rng.standard_normal(d.t.size), d.link + NOISE * rng.standard_normal(d.t.size),
            d.motor_rate, d.u)


@pytest.fixture(scope="module")
def drive_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("two_mass")
    t, th, q, thd, u = _two_mass()
    assert np.mean(np.abs(th - q) < GAP / 2) > 0.005  # the motion crosses the dead band
    col = lambda a: a[:, None]  # noqa: E731
    scipy.io.savemat(d / "drive.mat", {"t": col(t), "motor": col(th), "link": col(q), "rate": col(thd), "u": col(u)})
    # the pendulum's link made the drive's (no gravity, its inertia JL: m 0.5**2 + Iyy = JL); its
    # friction BL left out of the nominal model
    head = ('robot = "pendulum"\n[parameters]\n"axis[1].rotor_inertia" = %r\n"axis[1].viscous" = %r\n'
            '"gravity.z" = 0.0\n"platform.m" = %r\n"platform.Iyy" = 1e-4\n'
            '[columns]\ntime = "t"\nq1 = "motor"\nqd1 = "rate"\ntau1 = "u"\n' % (JM, BM, (JL - 1e-4) / 0.25))
    (d / "both.toml").write_text(head + 'q_link1 = "link"\n')
    (d / "motor_only.toml").write_text(head)
    return d


def _diagnose(d, name):
    rec = to_recording(d / "drive.mat", d / name)
    return rec, diagnose(rec, replay=False, discovery=False, platform=False, drift=False, figures=False,
                         out=d / name.replace(".toml", ""))


def test_stiffness_and_backlash_within_their_intervals(drive_files):
    rec, d = _diagnose(drive_files, "both.toml")
    assert "q_link1" in rec.extra
    assert not d.warnings and "axis[1].viscous" in d.theta  # the diagnosis proper ran (the friction BL found)
    (f,) = d.encoders
    c, b = f["params"]["axis[1].compliance"], f["params"]["axis[1].backlash"]
    assert abs(c.value - 1 / K) <= c.ci95, c
    assert abs(b.value - GAP) <= b.ci95, b
    assert c.ci95 < 0.05 / K and b.ci95 < 0.2 * GAP  # intervals that say something
    lo, hi = f["stiffness_ci95"]
    assert lo <= K <= hi
    enc = json.dumps(d.to_dict()["encoders"], default=jsonable, allow_nan=False)  # strict JSON
    assert '"axis[1].backlash"' in enc
    assert "link side" in f["effort_side"]
    assert "axis[1].compliance" in d.conclusion and "effort referred to the link side" in d.conclusion
    report = (drive_files / "both" / "report.md").read_text()
    assert "## Gear elasticity and backlash (motor and link encoders)" in report
    assert "`axis[1].backlash`" in report


def test_without_a_link_encoder_the_diagnosis_is_unchanged(drive_files):
    _, both = _diagnose(drive_files, "both.toml")
    _, motor = _diagnose(drive_files, "motor_only.toml")
    assert motor.encoders == []
    assert "encoder" not in motor.conclusion
    assert both.conclusion.startswith(motor.conclusion.rstrip("."))
    assert [e["key"] for e in both.effects] == [e["key"] for e in motor.effects]
    assert both.theta == motor.theta


def test_a_link_encoder_of_a_joint_the_robot_lacks_is_named(drive_files):
    m = drive_files / "bad.toml"
    m.write_text((drive_files / "both.toml").read_text() + 'q_link2 = "link"\n')
    with pytest.raises(ImportFailure, match="q_link2"):
        to_recording(drive_files / "drive.mat", m)
