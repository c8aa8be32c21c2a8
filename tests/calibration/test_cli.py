"""``cosim calibrate``: report, figures, errors, seed examples."""
import json

import numpy as np
import pytest

from cosim.calibration.data import candidate_poses, joint_campaign, real_params, write_campaign
from cosim.cli import main
from cosim.core import Model


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    nom = Model("6pus")
    real = real_params(nom, rng=31)
    rec = joint_campaign(Model("6pus"), real, candidate_poses(nom, 60, rng=32), rng=33)
    return write_campaign(tmp_path_factory.mktemp("cli") / "camp.csv", rec, real)[0]


def test_calibrate_prints_report_and_writes_figures(recording, tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["calibrate", str(recording), "--holdout", "0.25", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    for want in ("Identifiability: 54 parameters in 6 independent block(s)", "structural model",
                 "Solver gauss-newton", "SE", "Accuracy on held-out poses (15)", "gain"):
        assert want in text, want
    for f in ("calibration_accuracy.png", "calibration_singular_values.png", "calibration_estimates.png",
              "calibration_report.txt"):
        assert (out / f).stat().st_size > 1000, f
    cal = json.loads((out / "calibrated_parameters.json").read_text())
    assert len(cal["parameters"]) == 60 and cal["method"] == "gauss-newton"
    s = np.array([cal["parameters"][f"rail[1].s{c}"] for c in "xyz"])
    assert np.linalg.norm(s) == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("solver", ["pinv", "lm"])
def test_solver_option(recording, capsys, solver):
    assert main(["calibrate", str(recording), "--solver", solver, "--model", "prediction"]) == 0
    assert f"Solver {solver} (prediction model)" in capsys.readouterr().out


def test_bad_recording_is_an_error_not_a_traceback(tmp_path, capsys):
    nom = Model("6pus")
    rec = joint_campaign(Model("6pus"), real_params(nom, rng=1), candidate_poses(nom, 4, rng=2), rng=3)
    path = write_campaign(tmp_path / "few.csv", rec, {})[0]
    assert main(["calibrate", str(path)]) == 2
    assert "too few poses" in capsys.readouterr().err
    assert main(["calibrate", str(tmp_path / "missing.csv")]) == 2
    assert "file not found" in capsys.readouterr().err


def test_seed_examples(capsys):
    assert main(["calibrate", "--seed-examples"]) == 0
    text = capsys.readouterr().out
    assert "0.2990   0.5021   0.5544   0.6876" in text
    assert "S0x: not identifiable; X absorbs -1 x dS0x" in text
