"""The controller FMUs (the core's pkm_ctrl behind the project's FMI layer): they validate,
and an fmpy master stepping controller then plant (Gauss-Seidel, the order of
cosim.master.run) reproduces cosim.master.run with the same controller."""
import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

import control
from cosim import controllers as ctl
from cosim import fmu, ssp
from cosim import trajectories as tr
from cosim.core import Model
from cosim.master import CorePlant, make_reference, run

H = 1e-3


def _slave(path, name, start):
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    ints = {v.name for v in md.modelVariables if v.type == "Integer"}
    f = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(path)), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName=name)
    f.instantiate()
    f.setupExperiment(startTime=0.0)
    for k, v in start.items():
        (f.setInteger if k in ints else f.setReal)([vr[k]], [int(v) if k in ints else float(v)])
    f.enterInitializationMode()
    f.exitInitializationMode()
    return f, vr


def _fmu_loop(m, controller, qref, n):
    nd = m.ndof
    plant, pv = _slave(fmu.fmu_path(m.robot), "plant", {"solver.rtol": 1e-10, "solver.atol": 1e-12})
    params = ssp.controller_parameters(controller, ndof=nd, dt=H, lti_states=ssp._lti_room(
        fmu.fmu_path(f"PKM_{m.robot.upper()}_CTRL")))
    params.update({f"qref[{i + 1}]": qref[i] for i in range(nd)})
    ctrl, cv = _slave(fmu.fmu_path(f"PKM_{m.robot.upper()}_CTRL"), "controller", params)
    J = range(1, nd + 1)
    xs = []
    for k in range(n):
        y = plant.getReal([pv[f"q[{i}]"] for i in J] + [pv[f"qd[{i}]"] for i in J])
        xs.append(plant.getReal([pv[c] for c in m.facts.pose_names]))
        ctrl.setReal([cv[f"q[{i}]"] for i in J] + [cv[f"qd[{i}]"] for i in J], y)
        ctrl.doStep(k * H, H)                       # samples the readings at t_k
        tau = ctrl.getReal([cv[f"tau[{i}]"] for i in J])
        plant.setReal([pv[f"tau[{i}]"] for i in J], tau)
        plant.doStep(k * H, H)                      # tau_k over [t_k, t_k + h]
    for f in (plant, ctrl):
        f.terminate()
        f.freeInstance()
    return np.array(xs)


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_controller_fmus_validate(robot):
    assert fmu.validate(fmu.fmu_path(f"PKM_{robot.upper()}_CTRL")) == []


@pytest.mark.parametrize("kind", ["pd_gravity", "computed_torque", "lti"])
def test_fmpy_loop_of_plant_and_controller_fmus_equals_the_master(kind):
    m = Model("6pus")
    h = m.home()
    target = h + [0, 0, 0.008, 0, 0, 0.02]
    qref = m.ik(target)
    if kind == "pd_gravity":
        c = ctl.pd_gravity(m, kp=300, kd=30)
    elif kind == "computed_torque":
        c = ctl.computed_torque(m, kp=400, kd=40)
    else:  # a python-control design: kp + kd s / (Tf s + 1) per joint, Tustin at 1 ms
        kp, kd, tf = 300.0, 30.0, 0.01
        pd = control.c2d(control.tf([kp * tf + kd, kp], [tf, 1.0]), H, "tustin")
        c = ssp.lti_controller(control.ss(pd), ndof=6, model=m, gravity_feedforward=True)
    n = 300
    got = _fmu_loop(m, c, qref, n)
    ref = make_reference(m, tr.step(target, target), step=H, duration=(n - 1) * H)
    want = run(CorePlant(m), c, ref, x0=h)
    assert want.loop == "compiled"
    np.testing.assert_allclose(got, want["x"], rtol=0, atol=1e-12)
    assert abs(got[-1, 2] - h[2]) > 0.004  # it moved toward the target


def test_a_bad_gain_is_an_fmi_error_naming_it():
    # the message (from the FMI logger) names the gain and the joint
    path = fmu.fmu_path("PKM_6PUS_CTRL")
    with fmu.FMUInstance(path, params={"kp[2,2]": -5.0}, initialize=False) as f:
        with pytest.raises(fmu.FMUError, match="kp of joint 2 is negative"):
            f.initialize()
