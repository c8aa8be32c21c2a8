"""Scenario files: every shipped one loads; a bad one is refused naming the file and the key;
the ``cosim run`` and ``cosim demo`` commands write their outputs."""
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.scenario import ScenarioError, load_scenario

SCEN = Path(__file__).resolve().parents[2] / "scenarios"
SHIPPED = sorted(SCEN.glob("*.toml"))


def test_the_required_scenarios_are_shipped():
    kinds = {(load_scenario(p).spec["controller"]["type"], load_scenario(p).spec["reference"]["type"]) for p in SHIPPED}
    assert {("pd", "step"), ("pd_gravity", "step"), ("computed_torque", "letter_m"),
            ("pd_gravity", "poses")} <= kinds


@pytest.mark.parametrize("path", SHIPPED, ids=[p.stem for p in SHIPPED])
def test_shipped_scenarios_load(path):
    sc = load_scenario(path)
    assert sc.name == path.stem and sc.spec["robot"] == "6pus" and sc.spec["step"] == 1e-3


@pytest.mark.parametrize("text,key", [
    ("duration = 1.0\nspeed = 2\n[controller]\ntype='pd'\nkp=1\nkd=1\n[reference]\ntype='step'\nfrom=[0]\nto=[0]",
     "speed: unknown key"),
    ("[controller]\ntype='pd'\nkp=1\nkd=1\n[reference]\ntype='step'\nfrom=[0]\nto=[0]", "duration: missing"),
    ("duration=1\n[controller]\ntype='pi'\n[reference]\ntype='step'", "controller.type: must be"),
    ("duration=1\n[controller]\ntype='pid'\nkp=1\nkd=1\n[reference]\ntype='step'", "controller.ki: missing"),
    ("duration=1\n[controller]\ntype='pd'\nkp=1\nkd=1\nki=1\n[reference]\ntype='step'",
     "controller.ki: only a 'pid' controller takes it"),
    ("duration=1\n[controller]\ntype='pd'\nkp=1\nkd=1\nbandwidth_hz=3\n[reference]\ntype='step'\nfrom=[0]\nto=[0]",
     "controller: give either kp and kd, or bandwidth_hz"),
    ("duration=1\nplant='gazebo'\n[controller]\ntype='pd'\nkp=1\nkd=1\n[reference]\ntype='step'", "plant: must be"),
    ("duration=1\n[controller]\ntype='pd'\nkp=1\nkd=1\n[reference]\ntype='step'\nto=[0]", "reference.from: missing"),
    ("duration = = 1", "not valid TOML"),
])
def test_bad_scenario_names_file_and_key(tmp_path, text, key):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(ScenarioError, match="bad.toml: " + key.replace(".", r"\.").replace("(", r"\(")):
        load_scenario(p)


def test_cosim_run_writes_recording_metrics_and_figure(tmp_path, capsys):
    rc = main(["run", str(SCEN / "6pus_step_pd.toml"), "--duration", "0.3", "--out", str(tmp_path)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "steady-state joint error" in text and "step of z by +" in text
    for f in ("6pus_step_pd.csv", "6pus_step_pd.json", "6pus_step_pd_metrics.json", "6pus_step_pd.png"):
        assert (tmp_path / f).stat().st_size > 0, f


def test_cosim_run_reports_a_bad_file(tmp_path, capsys):
    p = tmp_path / "broken.toml"
    p.write_text("duration = 1\n")
    assert main(["run", str(p)]) == 2
    assert "broken.toml: controller: missing section" in capsys.readouterr().err


def test_cosim_demo(tmp_path, capsys):
    assert main(["demo", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "pd_gravity" in text and "predicted Kp^-1 g" in text
    assert (tmp_path / "6pus_step_pdg.png").exists() and (tmp_path / "6pus_step_pdg.csv").exists()
