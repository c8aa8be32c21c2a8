"""Every capability of the toolkit on robots compiled from description files (docs/robots.md).

Two described robots the Python package never names: the Gough-Stewart 6-UPS hexapod
(struts, six pose coordinates) and the rotary Delta 3-R(SS)2 (arms, x y z).  On each, as a
user would: the shipped scenarios of ``scenarios/described/`` (PD whose steady-state error
must be the core's gravity load through Kp^-1, PD + gravity compensation that removes it,
computed torque that tracks a trajectory on the nominal plant and not on a heavier one), a
calibration campaign with known geometric errors calibrated from its recording, and blind
cases (viscous and Coulomb friction hidden in the plant) diagnosed from the recording alone.
Every expectation is the core's physics or an injected error, never the simulation itself.
"""
import json
import os
import subprocess
import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model
from cosim.scenario import load_scenario, run_scenario, scenario_from_dict

REPO = Path(__file__).resolve().parents[2]
SCEN = REPO / "scenarios" / "described"
ROBOTS = ["delta_clavel", "hexapod_ups"]  # an arm robot, a strut robot
COSIM = [sys.executable, "-m", "cosim"]


def cosim(*args, cwd):
    r = subprocess.run([*COSIM, *map(str, args)], cwd=cwd, env=dict(os.environ), capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return r.stdout


def test_the_package_never_names_a_described_robot():
    listed = [n.split("#")[0].strip() for n in (REPO / "robots" / "robots.list").read_text().splitlines()]
    # "6pus", served from its description since its hand-written model became a test oracle,
    # is the toolkit's default robot: the package names it in defaults and examples; "quattro",
    # served from its description likewise, is the default of its own family (cosim.quattro).
    listed = [n for n in listed if n and n not in ("6pus", "quattro")]
    assert set(ROBOTS) <= set(listed)
    # a name as a string of its own ("delta_clavel", 'emps'): what a dispatch on the robot would
    # write (a data path such as "data/emps/..." in an example is not one)
    import re

    hits = [(str(p.relative_to(REPO)), n) for p in (REPO / "cosim").rglob("*.py") for n in listed
            if re.search(rf"""["']{re.escape(n)}["']""", p.read_text())]
    assert hits == [], hits


# ---------------------------------------------------------------- scenarios

def test_the_described_scenarios_load_and_name_described_robots():
    files = sorted(SCEN.glob("*.toml"))
    robots = {load_scenario(p).spec["robot"] for p in files}
    assert set(ROBOTS) <= robots
    kinds = {(load_scenario(p).spec["controller"]["type"], load_scenario(p).spec["reference"]["type"]) for p in files}
    assert {("pd", "step"), ("pd_gravity", "step"), ("computed_torque", "poses"), ("pd_gravity", "poses")} <= kinds


@pytest.fixture(scope="module", params=ROBOTS)
def step_runs(request):
    robot = request.param
    pd = load_scenario(SCEN / f"{robot}_step_pd.toml")
    pdg = load_scenario(SCEN / f"{robot}_step_pdg.toml")
    assert pd.spec["robot"] == pdg.spec["robot"] == robot
    return robot, pd, run_scenario(pd, export=False, figures=False), pdg, run_scenario(pdg, export=False,
                                                                                      figures=False)


def test_pd_steady_state_error_is_kp_inverse_of_the_cores_gravity_load(step_runs):
    robot, sc, out, _, _ = step_runs
    m = Model(robot)
    kp = float(sc.spec["controller"]["kp"])
    x_ref = np.array(sc.spec["reference"]["to"], float)
    ss = out.metrics["steady_state"]
    e_sim = np.array(ss["joint_error"])
    assert ss["joint_speed_max"] < 1e-6 * np.abs(e_sim).max() / 1e-3     # at rest: a steady state
    g_ref = m.gravity_load(x_ref)
    assert np.all(np.abs(g_ref) > 1.0)                                   # gravity loads every joint
    assert np.all(np.abs(e_sim) > 1e-4)                                  # a real sag, not round-off
    # the law at the pose the robot settled at: Kp e = g(x_settled), g from the core
    np.testing.assert_allclose(e_sim, m.gravity_load(out.result["x"][-1]) / kp, rtol=1e-4)
    # the static prediction from the core alone: e = Kp^-1 g(fk(qref - e)), by fixed point
    qref = m.ik(x_ref)
    e, x = g_ref / kp, x_ref.copy()
    for _ in range(30):
        x = m.fk(qref - e, x_guess=x)
        e = m.gravity_load(x) / kp
    np.testing.assert_allclose(e_sim, e, rtol=1e-4)
    # first order (g at the reference pose) within a few per cent
    np.testing.assert_allclose(e_sim, g_ref / kp, rtol=0.05)
    assert ss["prediction_relative_error"] < 1e-4
    # the platform hangs below its reference (z is the third coordinate of both robots)
    assert out.result["x"][-1, 2] < x_ref[2] - 1e-5


def test_gravity_compensation_removes_the_pd_error(step_runs):
    robot, _, pd, sc, pdg = step_runs
    assert sc.spec["controller"]["type"] == "pd_gravity"
    e_pd = pd.metrics["steady_state"]["joint_error_max"]
    e_pdg = pdg.metrics["steady_state"]["joint_error_max"]
    assert e_pdg < 1e-6 * e_pd, (e_pdg, e_pd)
    z = pdg.metrics["step_info"]["pose"]["z"]
    step = np.array(sc.spec["reference"]["to"]) - np.array(sc.spec["reference"]["from"])
    assert z["Amplitude"] == pytest.approx(step[2], rel=1e-6)
    assert z["Overshoot"] < 1.0 and z["SettlingTime"] < 0.5


@pytest.mark.parametrize("robot", ROBOTS)
def test_computed_torque_tracks_on_the_nominal_plant_not_on_a_heavier_one(robot):
    sc = load_scenario(SCEN / f"{robot}_traj_ct.toml")
    assert sc.spec["controller"]["type"] == "computed_torque" and sc.spec["reference"]["type"] == "poses"
    nominal = run_scenario(sc, export=False, figures=False)
    travel = np.ptp(nominal.result["qref"], axis=0).max()
    e_nom = nominal.metrics["motion"]["joint_error_max"]
    assert e_nom < 1e-4 * travel, (e_nom, travel)       # the core's inverse dynamics is the plant's
    spec = dict(sc.spec, plant_scale={"platform.m": 1.5})
    heavy = run_scenario(scenario_from_dict(spec), export=False, figures=False)
    assert heavy.metrics["motion"]["joint_error_max"] > 10 * e_nom
    assert nominal.metrics["held_poses"] == len(sc.spec["reference"]["poses"])


# and the robots with dependent coordinates (PRS, RPS legs) or legs meeting at a point
@pytest.mark.parametrize("robot", ROBOTS + ["tripod_3prs", "tripod_3rps", "fivebar"])
def test_the_fmu_plant_runs_the_step_like_the_core_plant(robot):
    from cosim.fmu import fmu_path

    assert fmu_path(robot).exists()      # built with the FMUs (fmu/CMakeLists.txt, one per listed description)
    sc = load_scenario(SCEN / f"{robot}_step_pd.toml")
    core = run_scenario(sc, export=False, figures=False)
    fmu = run_scenario(sc, plant="fmu", export=False, figures=False)
    assert fmu.result.plant["kind"] == "fmu"
    np.testing.assert_allclose(fmu.result["q"], core.result["q"], rtol=0, atol=1e-10)
    tau = core.result["tau_applied"]
    np.testing.assert_allclose(fmu.result["tau_applied"], tau, rtol=0, atol=1e-8 * np.abs(tau).max())


# -------------------------------------------------------------- calibration

@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    """The shipped calibration campaigns, run once: {robot: (recording path, injected errors)}."""
    d = tmp_path_factory.mktemp("campaigns")
    out = {}
    for robot in ROBOTS:
        path = SCEN / f"{robot}_calibration_campaign.toml"
        errors = tomllib.loads(path.read_text())["plant_offset"]
        res = run_scenario(path, out_dir=d / robot, figures=False)
        side = json.loads(Path(res.files["sidecar"]).read_text())
        assert not set(errors) & set(json.dumps(side).split('"'))     # the sidecar does not give them away
        out[robot] = (Path(res.files["recording"]), errors)
    return out


@pytest.mark.parametrize("robot", ROBOTS)
def test_generic_calibration_recovers_what_the_data_identifies(campaigns, robot):
    """Every length that moves a joint is fitted; the estimates equal the identifiable
    combinations of the injected errors (the report's structural model) within 3 SE plus 2 %
    of the largest error (the hexapod's SE are optimistic: RMS z about 1.5 over its legs)."""
    from cosim.calibration import calibrate

    rec, errors = campaigns[robot]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = calibrate(rec, holdout=0.25)
    m = Model(robot)
    idr = res.identifiability
    assert len(idr.blocks) == m.ndof                                     # one independent block per leg
    assert set(errors) <= set(res.problem.names)
    truth = res.identifiability.combination_values(errors)
    est = res.solution.estimates()
    moved, tol = 0, 0.02 * max(abs(v) for v in errors.values())
    for name, want in truth.items():
        got = res.calibrated_params[name] - m.param(name)
        se = est[name][3]
        assert abs(got - want) < 3 * se + tol, (name, got, want, se)
        moved += abs(want) > 5e-5
    assert moved >= 3
    assert res.holdout_accuracy.gain > 10, res.text()
    assert res.holdout_accuracy.position[1] < 20e-6


def test_cli_calibrates_the_rod_lengths_of_the_delta(campaigns, tmp_path):
    rec, errors = campaigns["delta_clavel"]
    report = cosim("calibrate", rec, "--params", "leg[*].L", "--out", "c", cwd=tmp_path)
    est = json.loads((tmp_path / "c" / "calibrated_parameters.json").read_text())["parameters"]
    m = Model("delta_clavel")
    assert set(est) == set(errors)
    for name, err in errors.items():
        assert abs(est[name] - (m.param(name) + err)) < 0.01 * abs(err), (name, est[name], err)
    assert "Identifiability" in report and "held-out poses" in report and "position RMS" in report, report


# ---------------------------------------------------------------- diagnosis

@pytest.mark.parametrize("robot,effect", [("delta_clavel", "viscous"), ("hexapod_ups", "coulomb")])
def test_blind_case_and_diagnosis_from_the_command_line(tmp_path, robot, effect):
    cosim("blind-case", "--robot", robot, "--effect", effect, "--seed", "3", "--name", "case", "--out", "cases",
          "--keys", "keys", cwd=tmp_path)
    d = json.loads(cosim("diagnose", "cases/case.csv", "--no-figures", "--out", "d", "--json", cwd=tmp_path))
    _check_diagnosis(d["effects"], d["theta"], json.loads((tmp_path / "keys" / "case.json").read_text()), effect)


@pytest.mark.parametrize("robot,effect", [("delta_clavel", "coulomb"), ("hexapod_ups", "viscous")])
def test_blind_case_and_diagnosis_in_python(tmp_path, robot, effect):
    from cosim.discrepancy import blind, diagnose

    csv, key = blind.make_case(blind.CaseSpec("case", robot, [effect], seed=4), tmp_path / "cases",
                               tmp_path / "keys")
    d = diagnose(csv, replay=False, figures=False)
    _check_diagnosis([{"key": k} for k in d.named()], d.theta, json.loads(Path(key).read_text()), effect)


def _check_diagnosis(effects, theta, key, effect):
    hidden = key["effects"][0]
    assert hidden["type"] == effect and effects, effects
    assert {e["key"] for e in effects} == {effect}, effects            # that effect, nothing else
    for name, true in hidden["params"].items():
        assert abs(theta[name] - true) < 0.1 * true, (name, theta[name], true)


# ------------------------------------------------------------------ indices

@pytest.mark.parametrize("robot", ROBOTS)
def test_generic_index_map_from_the_core(robot):
    """The indices every robot has (cosim.indices): reachability from the core's inverse
    kinematics and limits, the speed gains equal to finite differences of its forward
    kinematics, the static effort to its gravity load."""
    from cosim.indices import index_map

    m = Model(robot)
    home = m.home()
    span = np.where(np.array(m.facts.pose_units) == "m", 0.02 if robot == "hexapod_ups" else 0.6, 0.1)
    mp = index_map(m, x=home[0] + np.linspace(-1, 1, 9) * span[0], y=home[1] + np.linspace(-1, 1, 7) * span[1])
    assert mp["reachable"].shape == (9, 7)
    assert 0 < np.sum(mp["reachable"]) < mp["reachable"].size            # the grid crosses the workspace's edge
    assert np.all(np.isnan(mp["direct"][mp["reachable"] == 0]))
    best = mp.argbest("direct")
    x = np.array([best.get(n, mp.fixed.get(n)) for n in m.facts.pose_names])
    assert np.isclose(np.nanmax(mp["direct"]), m.singularity(x)[1])
    # speed gains: singular values of d(translation)/dq by central differences of the forward kinematics
    q, h = m.ik(x), 1e-7
    lin = [i for i, u in enumerate(m.facts.pose_units) if u == "m"]
    D = np.column_stack([(m.fk(q + h * e, x_guess=x) - m.fk(q - h * e, x_guess=x))[lin] / (2 * h)
                         for e in np.eye(m.ndof)])
    sv = np.linalg.svd(D, compute_uv=False)
    i, j = (np.flatnonzero(np.isclose(v, best[k]))[0] for k, v in mp.axes.items())
    np.testing.assert_allclose([mp["speed_min"][i, j], mp["speed_max"][i, j]], [sv.min(), sv.max()], rtol=1e-5)
    assert mp["gravity_max"][i, j] == pytest.approx(np.abs(m.gravity_load(x)).max())


# ------------------------------------------------------------------- sweeps

def test_a_gain_sweep_on_a_described_robot(tmp_path):
    """scenarios/sweeps/delta_clavel_pd_gains.toml in a plain loop: the steady-state error
    follows Kp^-1 g in every case (it halves as kp doubles)."""
    from cosim.sweep import load_spec, run_sweep

    res = run_sweep(load_spec(REPO / "scenarios" / "sweeps" / "delta_clavel_pd_gains.toml"), out=tmp_path / "sw",
                    workers=0, progress=False)
    assert not res.failed
    kp = res.column("controller.kp")
    e = res.column("steady_state.joint_error_max")
    assert np.all(res.column("steady_state.prediction_relative_error") < 1e-3)
    order = np.argsort(kp)
    np.testing.assert_allclose(e[order] * kp[order], e[order][0] * kp[order][0], rtol=0.02)


def test_the_quattro_runs_a_step_in_the_core_and_its_fmu_alike():
    """A PD step of all four coordinates: the Quattro's FMU plant follows its core plant and
    the steady-state error is the predicted Kp^-1 g (its motion against the hand-written
    oracle: tests/core/oracle_quattro.py)."""
    runs = {}
    for robot, plant in [("quattro", "core"), ("quattro", "fmu")]:
        spec = dict(name="quattro_step", robot=robot, plant=plant, duration=0.6, step=0.001, seed=1,
                    integrator=dict(rtol=1e-10, atol=1e-12), controller=dict(type="pd", kp=2000.0, kd=60.0),
                    reference={"type": "step", "from": [0.0, 0.0, -0.95, 0.0], "to": [0.05, 0.0, -0.9, 0.1],
                               "t_step": 0.0},
                    output=dict(settle_window=0.2, figures=False))
        runs[robot, plant] = run_scenario(scenario_from_dict(spec), export=False, figures=False)
    desc, fmu = runs["quattro", "core"], runs["quattro", "fmu"]
    assert np.ptp(desc.result["q"], axis=0).min() > 2e-3  # every arm moved
    np.testing.assert_allclose(fmu.result["q"], desc.result["q"], rtol=0, atol=1e-10)
    ss = desc.metrics["steady_state"]
    assert ss["prediction_relative_error"] < 1e-5 and ss["joint_error_max"] > 1e-3
