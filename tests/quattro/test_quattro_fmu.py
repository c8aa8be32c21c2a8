"""The Quattro FMU built by the shared FMU machinery (fmu/quattro/variables.txt)."""
import numpy as np
import pytest

from cosim import fmu
from cosim.core import Model


@pytest.fixture(scope="module")
def fmu_file():
    return fmu.fmu_path("PKM_QUATTRO")  # a missing FMU is a failure, not a skip


def test_fmu_validates(fmu_file):
    assert fmu.validate(fmu_file) == []


def test_inputs_are_the_four_arm_torques_and_outputs_the_pose(fmu_file):
    names = fmu.variable_names(fmu_file)
    assert names["tau"] == ["tau[1]", "tau[2]", "tau[3]", "tau[4]"]
    assert names["x"] == ["x", "y", "z", "rz"]


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_holding_torques_keep_the_robot_still_and_a_push_moves_it_like_the_core(fmu_file, kind):
    m = Model("quattro")
    x0 = m.home()
    hold = m.gravity_load(x0)
    r = fmu.simulate(fmu_file, kind, stop_time=0.1, step=1e-3, tau=hold)
    pose = np.column_stack([r[n] for n in ("x", "y", "z", "rz")])
    assert np.abs(pose - x0).max() < 1e-7
    # 1 N m more on arm 1: the initial acceleration is the core's forward dynamics.
    push = hold + np.array([1.0, 0, 0, 0])
    r = fmu.simulate(fmu_file, kind, stop_time=0.01, step=1e-3, tau=push, rtol=1e-10)
    xdd = m.forward_dynamics(x0, np.zeros(4), push)
    t = r["time"]
    pose = np.column_stack([r[n] for n in ("x", "y", "z", "rz")])
    expect = x0 + 0.5 * np.outer(t ** 2, xdd)  # constant-acceleration approximation, 10 ms
    assert np.abs(pose - expect).max() < 0.05 * 0.5 * np.abs(xdd).max() * t[-1] ** 2
