"""The closed loop as an SSP archive run by OSP libcosim, an engine not written here
(ssp_driver.py in its own process), against cosim.master.run.

libcosim's fixed-step algorithm exchanges values after every step, so the effort the
controller computes from the readings at t acts over [t + h, t + 2h]: the same loop as
cosim.master.run on a core plant with actuator.delay = h (docs/fmu.md)."""
import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from cosim import controllers as ctl
from cosim import ssp
from cosim import trajectories as tr
from cosim.core import Model
from cosim.master import CorePlant, make_reference, run

H = 1e-3
DRIVER = Path(__file__).with_name("ssp_driver.py")


def _libcosim(path, n, tmp_path):
    out = tmp_path / "ssp_run.json"
    p = subprocess.run([sys.executable, str(DRIVER), str(path), str(out), str(n), str(H)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, f"libcosim run failed (exit {p.returncode}): {p.stderr[-2000:]}{p.stdout[-500:]}"
    d = json.loads(out.read_text())
    return d["columns"], np.array(d["values"])


@pytest.mark.parametrize("robot,kind", [("6pus", "pd_gravity"), ("quattro", "computed_torque")])
def test_the_ssp_runs_in_libcosim_and_equals_the_master(robot, kind, tmp_path):
    m = Model(robot)
    h = m.home()
    step = np.zeros(m.ndof)
    step[2] = 0.008 if robot == "6pus" else -0.02
    target = h + step
    c = ctl.pd_gravity(m, kp=300, kd=30) if kind == "pd_gravity" else ctl.computed_torque(m, kp=400, kd=40)
    n = 300
    path = ssp.export_ssp(tmp_path / "loop.ssp", model=m, controller=c, qref=m.ik(target), dt=H,
                          stop_time=n * H, plant_parameters={"solver.rtol": 1e-10, "solver.atol": 1e-12})
    with zipfile.ZipFile(path) as z:
        names = z.namelist()
    assert "SystemStructure.ssd" in names and f"resources/PKM_{robot.upper()}_CTRL.fmu" in names
    cols, got = _libcosim(path, n, tmp_path)
    pose = list(m.facts.pose_names)
    x_lib = got[:, [cols.index(p) for p in pose]]
    # the master's loop with the one-step exchange delay of a Jacobi engine
    delayed = Model(robot, params={"actuator.delay": H})
    ref = make_reference(m, tr.step(target, target), step=H, duration=n * H)
    want = run(CorePlant(delayed), c, ref, x0=h)
    # libcosim records after each step: sample k + 1 of the master
    np.testing.assert_allclose(x_lib, want["x"][1:n + 1], rtol=0, atol=1e-9)
    assert abs(x_lib[-1, 2] - h[2]) > 0.5 * abs(step[2])   # the loop moved the robot


def test_bad_controller_parameters_are_refused_naming_the_field(tmp_path):
    m = Model("6pus")
    with pytest.raises(ValueError, match="kind"):
        ssp.controller_parameters(lambda t, q, qd, r: q, ndof=6, dt=H, lti_states=12)
    with pytest.raises(ValueError, match="qref"):
        ssp.export_ssp(tmp_path / "x.ssp", model=m, controller=ctl.pd(ndof=6, kp=1, kd=1), qref=[np.nan] * 6)


def test_a_step_scenario_exports_to_an_ssp_that_libcosim_runs(tmp_path):
    from cosim.scenario import load_scenario

    scen = Path(__file__).resolve().parents[2] / "scenarios" / "6pus_step_pdg.toml"
    path = ssp.export_scenario_ssp(scen, tmp_path / "scenario.ssp")
    cols, got = _libcosim(path, 400, tmp_path)
    target = np.asarray(load_scenario(scen).spec["reference"]["to"], float)
    z = got[:, cols.index("z")]
    assert abs(z[-1] - target[2]) < abs(z[0] - target[2]) / 2   # on its way to the set-point
