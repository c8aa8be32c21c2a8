"""The two-body replay of a fitted gap or compliance (cosim.discrepancy.drive_bodies)."""
import numpy as np
from disc_helpers import run

from cosim.core import Model
from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.drive_bodies import drive_joints, two_body_params


def test_the_drive_joints_and_their_two_body_parameters():
    m = Model("6pus", params={"rail[2].rotor_inertia": 0.05})
    joints = drive_joints({"rail[2].backlash": 4e-5, "rail[5].compliance": 2e-5, "rail[1].coulomb": 0.1,
                           "rail[3].backlash": 0.0}, m)
    assert joints == [("rail[2]", 1, 4e-5, 0.0), ("rail[5]", 4, 0.0, 2e-5)]
    p = two_body_params(m, joints[:1], np.full(6, 0.5), zeta=0.5, face=0.01)
    # faces deflecting 1 % of the 40 um gap under 0.5 N: 8e-7 m/N; damping 2 zeta sqrt(m k)
    assert p["drive.two_body"] == 1.0
    assert abs(p["rail[2].compliance"] - 8e-7) < 1e-18
    assert abs(p["rail[2].transmission_damping"] - 2 * 0.5 * np.sqrt(0.05 / 8e-7)) < 1e-9


def test_a_gap_without_a_drive_inertia_is_not_replayed_as_two_bodies(tmp_path):
    from cosim.recording import write_recording

    rec = run("6pus", {"rail[6].backlash": 6e-5}, duration=6.0, seed=7, noise=blind.load_config()["noise"]["6pus"])
    csv, _ = write_recording(tmp_path / "gap.csv", rec)
    d = diagnose(csv, figures=False, replay=True)
    assert "backlash" in d.named(), d.conclusion
    assert "fitted, two bodies" not in d.replay["runs"]
    assert "needs the drive's inertia" in d.replay["two_body"]["skipped"]
    assert "rail[6]" in d.replay["two_body"]["skipped"]


def test_the_fitting_window_is_where_the_gap_is_crossed():
    from types import SimpleNamespace

    from cosim.discrepancy.drive_bodies import WINDOW, fitting_window

    dt, n = 1e-3, 6000
    t = np.arange(n) * dt
    tau = np.full((n, 6), 0.5)
    tau[:, 5] = np.where((t > 2.0) & (t < 3.2), np.sin(2 * np.pi * 5 * t), 0.4)  # crossings in 2.0-3.2 s only
    pipe = SimpleNamespace(dt=dt, tau_s=tau)
    k, m = fitting_window(pipe, [("rail[6]", 5, 4e-5, 0.0)], 100, 5000)
    assert m == int(round(WINDOW / dt))
    assert 1.9 <= k * dt and (k + m) * dt <= 3.35
    # no sign change anywhere: where the effort varies most
    tau[:, 5] = 0.5 + np.where((t > 4.0) & (t < 4.8), 0.2 * np.sin(2 * np.pi * 3 * t), 0.0)
    k, m = fitting_window(pipe, [("rail[6]", 5, 0.0, 2e-5)], 100, 5000)
    assert 3.7 <= k * dt <= 4.1
