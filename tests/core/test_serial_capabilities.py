"""A serial arm read from URDF goes where any robot goes: the closed loop of a scenario (PD whose
steady-state error is the core's gravity load through Kp^-1, PD + gravity compensation that
removes it) with the drive layer's rotor inertias.  Expectations are the core's gravity load and the control law,
never the simulation itself.  The arm: the UR5 of robots/urdf/ur5.urdf, through ``cosim urdf``."""
from pathlib import Path

import numpy as np
import pytest

from cosim.cli.main import main
from cosim.core import Model
from cosim.scenario import run_scenario, scenario_from_dict

REPO = Path(__file__).resolve().parents[2]
KP, KD = 3000.0, 150.0


@pytest.fixture(scope="module")
def ur5(tmp_path_factory):
    out = tmp_path_factory.mktemp("ur5") / "ur5.toml"
    assert main(["urdf", str(REPO / "robots" / "urdf" / "ur5.urdf"), "--tip", "tool0", "--name", "ur5_loop", "--out", str(out)]) == 0
    # the drive layer as for any robot: gearbox-reflected rotor inertias, 0.4 kg m2 a joint
    with open(out, "a") as f:
        f.write("[defaults]\n" + "".join(f'"joint[{i}].rotor_inertia" = 0.4\n' for i in range(1, 7)))
    return str(out)


def _step(robot, controller):
    home = Model(robot).home()
    spec = {"robot": robot, "duration": 3.0, "step": 0.001, "integrator": {"rtol": 1e-10, "atol": 1e-12},
            "controller": {"type": controller, "kp": KP, "kd": KD},
            "reference": {"type": "step", "from": list(home), "to": list(home + [0.1, -0.3, 0.4, 0.2, -0.1, 0.3]),
                          "t_step": 0.0}, "output": {"settle_window": 0.2}}
    return scenario_from_dict(spec), run_scenario(scenario_from_dict(spec), export=False, figures=False)


def test_pd_sags_by_kp_inverse_of_the_gravity_load_and_gravity_compensation_removes_it(ur5):
    m = Model(ur5)
    sc, pd = _step(ur5, "pd")
    ss = pd.metrics["steady_state"]
    e = np.array(ss["joint_error"])
    assert np.abs(e).max() > 1e-3  # a real sag (the shoulder and the elbow carry the arm)
    np.testing.assert_allclose(e, m.gravity_load(pd.result["x"][-1]) / KP, rtol=1e-4, atol=1e-9)
    _, pdg = _step(ur5, "pd_gravity")
    assert pdg.metrics["steady_state"]["joint_error_max"] < 1e-6 * np.abs(e).max()
