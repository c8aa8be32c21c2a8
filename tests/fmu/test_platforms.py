"""The FMU binaries of the other platforms, run for real: x86_64-windows under Wine and
aarch64-linux under QEMU, Co-Simulation and Model Exchange, through the tests' own FMI 2.0
host cross-compiled for each
(tests/fmu/host/fmi_host.c built as fmi2_host), against the linux64 binary through the same host; and the
linux64 host against fmpy's importer, so the host itself is checked by another one.

Two robots here (the 6-PUS, whose FMUs have tables of their own, and the described Gough-Stewart hexapod, plant and
controller FMUs); bench/fmu_platforms.py runs every FMU the build makes.
"""
import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave

from platform_host import (H, PLATFORMS, fmu_pair, largest_difference, loop_script, loop_setup, me_script, run,
                           solver_script)

ROBOTS = ["6pus", "hexapod_ups"]
CROSS = [p for p in PLATFORMS if p != "linux64"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Every (robot, platform) run of the PD-step script, computed once."""
    out = {}
    for robot in ROBOTS:
        folder = tmp_path_factory.mktemp(robot)
        plant, ctrl = fmu_pair(robot, folder)
        for p in PLATFORMS:
            out[robot, p] = run(p, loop_script(plant, ctrl, robot, p), folder)
            out[robot, p, "me"] = run(p, me_script(plant, robot, p), folder)
        out[robot, "fmus"] = (plant, ctrl)
    return out


def _fmpy_loop(plant, ctrl, robot, steps=60):
    """The host's loop (connections, then controller and plant steps) with fmpy's FMU2Slave:
    the printed values at the three print points of loop_script, without the restore."""
    m, cparams, pparams, (pose, joints, rates, efforts) = loop_setup(robot)
    slaves = {}
    for name, u, params in (("ctrl", ctrl, cparams), ("plant", plant, pparams)):
        s = FMU2Slave(guid=u.guid, unzipDirectory=str(u.folder), modelIdentifier=u.ident, instanceName=name)
        s.instantiate()
        for k, v in params.items():
            (s.setInteger if k in u.integer else s.setReal)([u.vr[k]], [int(v) if k in u.integer else float(v)])
        s.setupExperiment(startTime=0.0)
        s.enterInitializationMode()
        s.exitInitializationMode()
        slaves[name] = s
    p, c = slaves["plant"], slaves["ctrl"]
    t, printed = 0.0, []
    for _ in range(2):
        for _ in range(steps):
            c.setReal([ctrl.vr[n] for n in joints + rates], p.getReal([plant.vr[n] for n in joints + rates]))
            p.setReal([plant.vr[n] for n in efforts], c.getReal([ctrl.vr[n] for n in efforts]))
            c.doStep(t, H)
            p.doStep(t, H)
            t += H
        printed.append(np.array([t] + p.getReal([plant.vr[n] for n in pose + joints + rates])))
        printed.append(np.array([t] + c.getReal([ctrl.vr[n] for n in efforts])))
    for s in slaves.values():
        s.terminate()
        s.freeInstance()
    return printed


@pytest.mark.parametrize("robot", ROBOTS)
def test_linux_host_agrees_with_fmpy(runs, robot):
    """The tests' host against an importer written elsewhere, on the linux64 binary: the
    same loop gives the same numbers (the host is no source of the agreement below)."""
    plant, ctrl = runs[robot, "fmus"]
    ref = _fmpy_loop(plant, ctrl, robot)
    got = runs[robot, "linux64"]["values"][:4]
    for u, v in zip(got, ref):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-14)
    # the step moved the robot: the comparison is not of a platform at rest
    assert np.max(np.abs(got[2][1:] - got[0][1:])) > 1e-4


@pytest.mark.parametrize("platform", CROSS)
@pytest.mark.parametrize("robot", ROBOTS)
def test_platform_binary_reproduces_linux(runs, robot, platform):
    """PD step, state save / serialise / restore, a refused NaN effort: the Windows binary
    under Wine and the ARM binary under QEMU print the linux64 binary's trajectory to 1e-12
    (relative above 1) and the same statuses and messages."""
    ref, got = runs[robot, "linux64"], runs[robot, platform]
    assert len(got["values"]) == 6
    assert largest_difference(ref, got) <= 1e-12
    assert got["lines"] == ref["lines"]
    # the restore went back: the third print equals the second, bit for bit, on every platform
    np.testing.assert_array_equal(got["values"][4], got["values"][2])
    np.testing.assert_array_equal(got["values"][5], got["values"][3])
    # the NaN effort is an Error with the FMU's message
    assert "status setReal Error" in got["lines"]
    assert any(ln.startswith("log plant Error logStatusError: fmi2SetReal") and "tau[1] = nan" in ln
               for ln in got["lines"]), got["lines"]


@pytest.mark.parametrize("platform", CROSS)
@pytest.mark.parametrize("robot", ROBOTS)
def test_platform_model_exchange_reproduces_linux(runs, robot, platform):
    """The plant as Model Exchange (derivatives, states, events, FMU state) stepped by the
    host's explicit Euler: the same pose and rates as linux64 to 1e-12, the same messages."""
    ref, got = runs[robot, "linux64", "me"], runs[robot, platform, "me"]
    assert len(got["values"]) == 3
    assert largest_difference(ref, got) <= 1e-12
    assert got["lines"] == ref["lines"]
    np.testing.assert_array_equal(got["values"][2], got["values"][1])
    assert np.max(np.abs(got["values"][1][1:] - got["values"][0][1:])) > 1e-6  # it moved
    assert "status setReal Error" in got["lines"]


@pytest.mark.parametrize("platform", CROSS)
def test_platform_binary_refuses_bdf_and_says_why(runs, platform, tmp_path):
    """No SUNDIALS on these platforms: solver.method = 0 (BDF) is an Error naming the
    platform and the methods there are, where the linux64 binary runs it."""
    plant, _ = runs["6pus", "fmus"]
    linux = run("linux64", solver_script(plant, "linux64", 0), tmp_path)
    assert linux["lines"] == [], linux["lines"]
    out = run(platform, solver_script(plant, platform, 0), tmp_path)
    assert "status exitInitializationMode Error" in out["lines"], out["lines"]
    msg = [ln for ln in out["lines"] if ln.startswith("log plant Error")]
    assert msg and "needs SUNDIALS CVODE" in msg[0] and f"({platform})" in msg[0] and "PKM_ERK" in msg[0], msg
