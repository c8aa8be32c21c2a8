"""A new robot touches the core and nothing in Python.

``libpkm_toy.so`` is the core plus one robot written only in the core's test tree
(``c_core/tests/robots/slider_crank.cpp``: a vertical slider-crank, one joint).  With
``PKM_LIB`` pointing at it, the CLI must list its parameters, run a step scenario (PD, whose
steady-state error must match Kp^-1 g), run a calibration campaign and calibrate the robot's
lengths from the recording, and diagnose a recording in which the plant hides a friction the
model lacks: all from the core's facts, with no Python edit (checked: the package never names
the robot)."""
import json
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
TOY = Path(os.environ.get("PKM_BUILD_DIR", REPO / "build")) / "lib" / "libpkm_toy.so"
COSIM = [sys.executable, "-m", "cosim"]

def cosim(*args, cwd):
    assert TOY.exists(), f"{TOY} is missing: cmake builds it with the core (target pkm_toy)"
    env = dict(os.environ, PKM_LIB=str(TOY))
    r = subprocess.run([*COSIM, *map(str, args)], cwd=cwd, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_the_package_never_names_the_toy_robot():
    hits = [p for p in (REPO / "cosim").rglob("*.py") if "slider_crank" in p.read_text()]
    assert hits == [], hits



def test_geometry_parameters_come_from_the_core_or_its_inverse_kinematics(tmp_path):
    # The toy names no geometry parameters (pkm_model_geometry_param gives ""): the
    # package takes the lengths that move its joint, which are the crank and the rod
    # (not the slider mass, not gravity); the geometry effect is one group of both.
    code = ("from cosim.core import Model\n"
            "from cosim.discrepancy.effects import geometry_layout, groups_for\n"
            "m = Model('slider_crank')\n"
            "g = [x.params for x in groups_for(m, True)[0] if x.effect.key == 'geometry']\n"
            "print(list(m.facts.geometry_params), geometry_layout(m), g)\n")
    env = dict(os.environ, PKM_LIB=str(TOY))
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[] (['crank.r', 'rod.l'], False) [('crank.r', 'rod.l')]", r.stdout

def test_params(tmp_path):
    out = cosim("params", "slider_crank", cwd=tmp_path)
    for name in ("crank.r", "rod.l", "slider.m", "crank.I", "joint[1].coulomb"):
        assert name in out, out


STEP = """
name = "toy_step_pd"
robot = "slider_crank"
plant = "core"
duration = 1.5
step = 0.001
[controller]
type = "pd"
kp = 5.0
kd = 0.2
[reference]
type = "step"
from = [0.1414]
to = [0.150]
t_step = 0.1
[output]
settle_window = 0.2
figures = false
"""


def test_step_scenario_settles_at_kp_inverse_g(tmp_path):
    (tmp_path / "step.toml").write_text(STEP)
    out = cosim("run", "step.toml", "--out", "o", cwd=tmp_path)
    assert "step of z by +" in out and "predicted Kp^-1 g" in out, out
    ss = json.loads((tmp_path / "o" / "toy_step_pd_metrics.json").read_text())["steady_state"]
    assert abs(ss["joint_error"][0]) > 1e-3                       # rad: gravity pulls the slider down
    assert ss["prediction_relative_error"] < 1e-3, ss



EXCITATION = """
name = "toy_excitation"
robot = "slider_crank"
plant = "core"
duration = 2.0
step = 0.001
[controller]
type = "pd_gravity"
kp = 5.0
kd = 0.2
[reference]
type = "excitation"
seed = 2
"""


def test_excitation_scenario_draws_its_figure(tmp_path):
    # An excitation reference on a robot the package never heard of: the trajectory comes
    # from the core's reach, and the figure shows every pose coordinate (no KeyError on
    # the reference type).
    (tmp_path / "exc.toml").write_text(EXCITATION)
    out = cosim("run", "exc.toml", "--out", "o", cwd=tmp_path)
    png = tmp_path / "o" / "toy_excitation.png"
    assert png.exists() and png.stat().st_size > 10_000, out


def _recording(path):
    import numpy as np

    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    return lines[0].split(","), np.genfromtxt(lines[1:], delimiter=",")


def test_the_toy_fmu_validates_and_runs_the_step_like_the_core_plant(tmp_path):
    # The FMU side of a new robot is one folder (c_core/tests/robots/slider_crank_fmu:
    # variables.txt + model.c); the scenario finds its FMU by the robot's name.
    import numpy as np

    fmu_file = TOY.parent.parent / "fmu" / "PKM_SLIDER_CRANK.fmu"
    assert fmu_file.exists(), f"{fmu_file} is missing: cmake builds it with the FMUs (target PKM_SLIDER_CRANK_fmu)"
    from fmpy.validation import validate_fmu

    assert validate_fmu(str(fmu_file)) == []
    (tmp_path / "core.toml").write_text(STEP)
    (tmp_path / "fmu.toml").write_text(STEP.replace('plant = "core"', 'plant = "fmu"')
                                       .replace('name = "toy_step_pd"', 'name = "toy_step_fmu"'))
    cosim("run", "core.toml", "--out", "o", cwd=tmp_path)
    out = cosim("run", "fmu.toml", "--out", "o", cwd=tmp_path)
    assert "predicted Kp^-1 g" in out, out
    hc, c = _recording(tmp_path / "o" / "toy_step_pd.csv")
    hf, f = _recording(tmp_path / "o" / "toy_step_fmu.csv")
    assert hc == hf and c.shape == f.shape == (1501, len(hc))
    np.testing.assert_allclose(f, c, rtol=0, atol=1e-10)

CAMPAIGN = """
name = "toy_campaign"
robot = "slider_crank"
plant = "core"
duration = 4.4
step = 0.001
seed = 3
[plant_offset]
"rod.l" = 0.0004
"crank.r" = -0.0002
[controller]
type = "pd_gravity"
kp = 5.0
kd = 0.2
[reference]
type = "poses"
move_time = 0.25
hold_time = 0.3
poses = [[0.110], [0.125], [0.140], [0.150], [0.160], [0.170], [0.180], [0.190]]
[noise]
q = 1e-6
pose = [1e-6]
[output]
figures = false
"""


def test_calibration_finds_the_robots_length_errors(tmp_path):
    (tmp_path / "cal.toml").write_text(CAMPAIGN)
    cosim("run", "cal.toml", "--out", "o", cwd=tmp_path)
    report = cosim("calibrate", "o/toy_campaign.csv", "--out", "c", cwd=tmp_path)
    est = json.loads((tmp_path / "c" / "calibrated_parameters.json").read_text())["parameters"]
    assert abs(est["rod.l"] - (0.15 + 0.0004)) < 2e-6, report      # within 0.5 % of the error
    assert abs(est["crank.r"] - (0.05 - 0.0002)) < 2e-6, report
    assert "held-out poses" in report and "urad" in report, report


BLIND = """
name = "toy_blind"
robot = "slider_crank"
plant = "core"
duration = 9.5
step = 0.001
seed = 5
[plant_offset]
"joint[1].coulomb" = 0.004
[controller]
type = "pd_gravity"
bandwidth_hz = 8.0
[reference]
type = "excitation"
[noise]
q = 2e-6
pose = [5e-6]
[output]
figures = false
"""


def test_diagnose_names_the_hidden_friction(tmp_path):
    (tmp_path / "blind.toml").write_text(BLIND)
    cosim("run", "blind.toml", "--out", "o", cwd=tmp_path)
    side = json.loads((tmp_path / "o" / "toy_blind.json").read_text())
    assert "joint[1].coulomb" not in json.dumps(side)                # the sidecar does not give it away
    d = json.loads(cosim("diagnose", "o/toy_blind.csv", "--out", "d", "--json", cwd=tmp_path))
    assert d["effects"] and d["effects"][0]["key"] == "coulomb", d["conclusion"]
    assert abs(d["theta"]["joint[1].coulomb"] - 0.004) < 0.1 * 0.004, d["theta"]


def test_blind_case_generator_and_diagnosis(tmp_path):
    # the generator sizes effects and noise from the core for a robot its configuration does
    # not list; the key stays in its own directory until the diagnosis is done
    cosim("blind-case", "--robot", "slider_crank", "--effect", "viscous", "--seed", "3", "--name", "toy",
          "--out", "cases", "--keys", "keys", cwd=tmp_path)
    d = json.loads(cosim("diagnose", "cases/toy.csv", "--no-figures", "--out", "d", "--json", cwd=tmp_path))
    key = json.loads((tmp_path / "keys" / "toy.json").read_text())["effects"][0]
    assert key["type"] == "viscous" and d["effects"][0]["key"] == "viscous", d["conclusion"]
    true = key["params"]["joint[1].viscous"]
    assert abs(d["theta"]["joint[1].viscous"] - true) < 0.1 * true, (d["theta"], true)
