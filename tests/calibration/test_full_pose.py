"""Calibration with a 6-DOF tracker: a robot that declares some pose components (3-RPS, 3-PRS:
z rx ry) measured in all six, so that the parasitic x, y, rz its legs force enter the fit.

The truth is the synthetic campaign's real robot (known perturbations of the joint centres,
rail origins and rods); the measured parasitic motion comes from the real robot's core model.
What is checked against it: the parameters recovered (noise-free to 1e-9 m; with tracker noise
each within 4.5 standard errors), the parasitic residual measured minus predicted before and
after, and that the full pose identifies what the declared coordinates alone cannot.
"""
import warnings

import numpy as np
import pytest

from cosim.calibration import calibrate, data
from cosim.core import Model
from cosim.recording import FULL_POSE, RecordingError, read_recording, write_recording

# the 3-PRS's rod length and rail height are nearly one combination (cond 6e4): the full model
CASES = {"tripod_3rps": "structural", "tripod_3prs": "full"}


def campaign(name, noise, full_pose=True, n=32, seed=3):
    m = Model(name)
    X = data.candidate_poses(m, n, rng=seed)
    real = data.real_params(m, max_length=0.3e-3, rng=seed + 1, poses=X)
    rec = data.joint_campaign(m, real, X, tracker_noise=noise, rng=seed + 2, full_pose=full_pose)
    return m, real, rec


def run(rec, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return calibrate(rec, holdout=0.25, **kw)


@pytest.mark.parametrize("name", sorted(CASES))
def test_noise_free_campaign_recovers_every_perturbed_length(name):
    _, real, rec = campaign(name, 0.0)
    assert rec.pose_full.shape[1] == 6 and np.array_equal(rec.pose, rec.pose_full[:, 2:5])
    r = run(rec, model=CASES[name])
    est = r.calibrated_params
    assert set(real) <= set(est) and r.solution.free.all()
    err = max(abs(est[k] - v) for k, v in real.items())
    assert err < 1e-9, err  # metres
    h = r.holdout_accuracy
    for c in ("x", "y", "rz"):
        before, after = h.parasitic[c]
        assert before > 5e-6 and after < 1e-9, (c, before, after)
    assert h.position[0] > 50e-6 and h.position[1] < 1e-9


def test_the_full_pose_identifies_what_the_declared_coordinates_cannot():
    """3-RPS: with z rx ry alone a third of the joint-centre coordinates are not identified
    (each leg's base and platform points along the strut); with x y rz too, all of them."""
    _, real, rec3 = campaign("tripod_3rps", 0.0, full_pose=False)
    _, _, rec6 = campaign("tripod_3rps", 0.0, full_pose=True)
    r3, r6 = run(rec3), run(rec6)
    assert rec3.pose_full is None and r3.solution.free.sum() <= 12
    assert r6.solution.free.sum() == len(real) == 18
    assert r3.holdout_accuracy.position[1] > 100 * r6.holdout_accuracy.position[1]


@pytest.mark.parametrize("name", sorted(CASES))
def test_noisy_campaign_within_its_standard_errors_and_to_the_tracker_noise(name):
    """1 um and 10 urad of tracker noise: each estimate within 4.5 SE of the truth, the
    held-out pose and parasitic motion predicted to the tracker's noise."""
    _, real, rec = campaign(name, 1e-6, n=40, seed=11)
    r = run(rec, model=CASES[name])
    s = r.solution
    z = np.array([(s.p[j] - real[n]) / s.se[j] for j, n in enumerate(s.names) if s.free[j] and n in real])
    assert len(z) == len(real) and np.max(np.abs(z)) < 4.5, z
    h = r.holdout_accuracy
    assert h.position[0] > 50e-6 and h.position[1] < 3e-6, h.position
    for c, bound in (("x", 2.5e-6), ("y", 2.5e-6), ("rz", 30e-6)):
        assert h.parasitic[c][0] > 5 * bound and h.parasitic[c][1] < bound, (c, h.parasitic[c])


def test_full_pose_recording_round_trip_and_a_partial_full_pose_is_refused(tmp_path):
    _, _, rec = campaign("tripod_3rps", 1e-6, n=12)
    csv_path, side = write_recording(tmp_path / "c.csv", rec)
    back = read_recording(csv_path)
    assert np.array_equal(back.pose_full, rec.pose_full) and back.pose_columns == ["z", "rx", "ry"]
    assert np.array_equal(back.pose, rec.pose_full[:, 2:5])  # what the rest of the toolkit reads: z rx ry
    header = csv_path.read_text().splitlines()[0].split(",")
    assert [c for c in header if c in FULL_POSE] == list(FULL_POSE)
    # drop the rz column: the full pose without one of its undeclared components is an error
    lines = [ln.split(",") for ln in csv_path.read_text().splitlines()]
    k = header.index("rz")
    (tmp_path / "d.csv").write_text("\n".join(",".join(c[:k] + c[k + 1:]) for c in lines) + "\n")
    (tmp_path / "d.json").write_text(side.read_text())
    with pytest.raises(RecordingError, match=r"d\.csv, row 1, column 'rz': the full pose"):
        read_recording(tmp_path / "d.csv")


def test_3prs_scenario_campaign_through_the_cli(tmp_path, capsys):
    """The shipped 6-DOF campaign: `cosim run` (PD + gravity holds, a plant with six geometry
    errors, tracker noise 1 um / 10 urad) then `cosim calibrate --model full`."""
    from pathlib import Path

    from cosim.cli import main

    scen = Path(__file__).resolve().parents[2] / "scenarios" / "described" / "tripod_3prs_calibration_6dof.toml"
    assert main(["run", str(scen), "--out", str(tmp_path)]) == 0
    csv_path = tmp_path / "tripod_3prs_calibration_6dof.csv"
    assert read_recording(csv_path).pose_full.shape[1] == 6
    capsys.readouterr()
    assert main(["calibrate", str(csv_path), "--holdout", "0.25", "--model", "full"]) == 0
    text = capsys.readouterr().out
    assert "parasitic motion, measured - predicted at the measured pose" in text
    delta = {ln.split()[0]: float(ln.split()[3]) for ln in text.splitlines()
             if ln.strip().startswith(("leg[", "rail[")) and ln.strip().endswith(" mm")}
    # the well-conditioned errors of the plant (its [plant_offset]), to 5 um
    for k, v in {"leg[1].pz": -0.2, "leg[2].px": 0.15, "leg[3].py": 0.1}.items():
        assert abs(delta[k] - v) < 5e-3, (k, delta[k])  # mm
    held = text[text.index("Accuracy on held-out poses"):]
    before, after = (float(s) for s in held.split("position RMS")[1].split("um (gain")[0].split(")")[1]
                     .replace("um", "").split("->"))
    assert before > 100 and after < 1.0, (before, after)  # um
