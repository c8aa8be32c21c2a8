"""``cosim sweep``: list, run, refuse to mix, resume, strict exit status."""
from pathlib import Path

import pytest

from cosim.cli import main

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

REPO = Path(__file__).resolve().parents[2]


@pytest.fixture
def spec_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('name = "cli"\nkind = "calibration"\n[base]\nn_poses = 20\nvalidation_poses = 20\n'
                 '[grid]\nseed = [1, 2]\n[[cases]]\nn_poses = 4\n')
    return p


def test_list_prints_every_case_with_its_id(spec_file, capsys):
    from cosim.sweep import case_id

    assert main(["sweep", str(spec_file), "--list"]) == 0
    out = capsys.readouterr().out
    assert "cli (calibration): 3 cases" in out
    assert case_id({"seed": 2}) in out and case_id({"n_poses": 4}) in out


def test_run_refuse_resume_strict(spec_file, tmp_path, capsys):
    out_dir = tmp_path / "out"
    args = ["sweep", str(spec_file), "--workers", "0", "--out", str(out_dir), "--no-progress"]
    assert main(args + ["--max-cases", "1"]) == 0
    assert "this call ran 1 (0 already done, 2 left)" in capsys.readouterr().out
    assert main(args) == 2
    assert "--resume" in capsys.readouterr().err
    assert main(args + ["--resume", "--strict"]) == 3       # the 4-pose case fails
    out = capsys.readouterr().out
    assert "this call ran 2 (1 already done, 0 left)" in out and "FAILED case 2" in out and "n_poses = 4" in out
    assert (out_dir / "results.csv").read_text().count("\n") == 4
    assert main(args + ["--resume"]) == 0
    assert "this call ran 0 (3 already done" in capsys.readouterr().out


def test_bad_spec_is_an_error_not_a_traceback(tmp_path, capsys):
    p = tmp_path / "bad.toml"
    p.write_text('kind = "calibration"\n[grid]\nn_pose = [1]\n')
    assert main(["sweep", str(p)]) == 2
    assert f"{p}: n_pose: not a parameter" in capsys.readouterr().err
