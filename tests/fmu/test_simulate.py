"""fmpy runs the FMU as Co-Simulation and as Model Exchange; both agree with the core's own
integration (pkm_sim driven directly, its default explicit Runge-Kutta 5(4)) to 1e-6."""
import numpy as np
import pytest

from cosim import fmu

H = 1e-3  # communication step [s]

T = 0.3
N = int(round(T / H))
POSE = ["x", "y", "z", "rx", "ry", "rz"]
RATE = ["xd", "yd", "zd", "rxd", "ryd", "rzd"]
# All three integrations (the core's RK 5(4), the FMU's, fmpy's CVode) run converged: the
# plant is open-loop unstable and magnifies the integration error of looser tolerances.
RTOL = 1e-12


@pytest.fixture(scope="module")
def reference(model, hold, core_run):
    t, x, xd = core_run(model, np.tile(hold, (N, 1)), rtol=RTOL, atol=RTOL)
    # The drift must be large enough for the comparison to mean something.
    assert np.max(np.abs(x[-1] - model.home())) > 1e-3
    return t, x, xd


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_fmpy_simulation_agrees_with_the_core(fmu_file, hold, reference, kind):
    t, x, xd = reference
    # CS: the FMU's integrator gets the tolerance as a parameter; ME: fmpy's CVode gets it.
    params = {"solver.rtol": RTOL, "solver.atol": RTOL} if kind == "CoSimulation" else None
    rtol = RTOL if kind == "ModelExchange" else None
    r = fmu.simulate(fmu_file, fmi_type=kind, stop_time=T, step=H, tau=hold, rtol=rtol, params=params,
                     outputs=POSE + RATE)
    assert len(r) == N + 1
    np.testing.assert_allclose(r["time"][1:], t, rtol=0, atol=1e-12)
    pose = np.column_stack([r[n] for n in POSE])[1:]
    rate = np.column_stack([r[n] for n in RATE])[1:]
    assert np.max(np.abs(pose - x)) < 1e-6
    assert np.max(np.abs(rate - xd)) < 1e-6


def test_outputs_are_the_core_functions_of_the_state(fmu_file, model, hold):
    with fmu.FMUInstance(fmu_file) as f:
        for _ in range(50):
            f.step(H, tau=hold)
        x, xd = f.vector("x"), f.vector("xd")
        np.testing.assert_allclose(f.vector("q"), model.ik(x), rtol=0, atol=1e-15)
        np.testing.assert_allclose(f.vector("qd"), model.joint_velocity(x, xd), rtol=0, atol=1e-15)
        np.testing.assert_allclose(f.vector("xdd"), model.forward_dynamics(x, xd, hold), rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose([f.get("singularity.ik"), f.get("singularity.direct")],
                                   model.singularity(x), rtol=0, atol=1e-15)
        ke, pe = model.energy(x, xd)
        assert f.get("energy.kinetic") == pytest.approx(float(ke), abs=1e-15)
        assert f.get("energy.potential") == pytest.approx(float(pe), abs=1e-15)


def test_start_elsewhere_and_stay_there(fmu_file, model):
    # A pose away from home held by its own gravity load: the plant must start there
    # (x0 parameters) and not move.
    x0 = np.array([0.01, -0.005, 0.075, 0.02, -0.01, 0.03])
    g = model.gravity_load(x0)
    names = fmu.variable_names(fmu_file)
    with fmu.FMUInstance(fmu_file, params=dict(zip(names["x0"], x0))) as f:
        np.testing.assert_array_equal(f.vector("x"), x0)
        for _ in range(100):
            f.step(H, tau=g)
        assert np.max(np.abs(f.vector("x") - x0)) < 1e-9
        assert np.max(np.abs(f.vector("xd"))) < 1e-7


def test_parameters_reach_the_plant(fmu_file, model, hold, core_run):
    # A heavier platform under the same efforts sinks: the FMU parameter is used...
    heavy = model.copy()
    heavy.set_params({"platform.m": 0.5})
    t, x, _ = core_run(heavy, np.tile(hold, (100, 1)))
    with fmu.FMUInstance(fmu_file, params={"platform.m": 0.5}) as f:
        for _ in range(100):
            f.step(H, tau=hold)
        # ... and it is the same plant as the core with that parameter.
        assert np.max(np.abs(f.vector("x") - x[-1])) < 1e-12
        assert x[-1][2] < model.home()[2] - 1e-3


def test_an_effort_offset_reaches_the_fmu_as_a_force_the_drive_works_against(fmu_file, model, hold, core_run):
    # rail[2].offset = 0.2 N (a parameter of the core's table, so of the FMU): the same plant as
    # the nominal one driven by the effort less 0.2 N on rail 2
    off = np.array([0.0, 0.2, 0.0, 0.0, 0.0, 0.0])
    t, x, _ = core_run(model, np.tile(hold - off, (100, 1)))
    with fmu.FMUInstance(fmu_file, params={"rail[2].offset": 0.2}) as f:
        for _ in range(100):
            f.step(H, tau=hold)
        assert np.max(np.abs(f.vector("x") - x[-1])) < 1e-10
    t0, x0, _ = core_run(model, np.tile(hold, (100, 1)))
    assert np.max(np.abs(x0[-1] - x[-1])) > 1e-4


def test_importer_tolerance_replaces_solver_rtol(fmu_file, model, hold, core_run):
    _, x_loose, _ = core_run(model, np.tile(hold, (100, 1)), rtol=1e-4)
    with fmu.FMUInstance(fmu_file, tolerance=1e-4) as f:
        for _ in range(100):
            f.step(H, tau=hold)
        assert np.max(np.abs(f.vector("x") - x_loose[-1])) < 1e-12


def test_an_added_inertia_is_an_fmu_parameter_with_the_rotor_inertia_physics(fmu_file, model, hold, core_run):
    # rail[3].force_inertia = 0.08 kg (declared once, in the core's table): read back as set, and the
    # plant is the core's with rail[3].rotor_inertia = 0.08 kg (the same joint inertia, another parameter)
    rotor = model.copy()
    rotor.set_params({"rail[3].rotor_inertia": 0.08})
    _, x, _ = core_run(rotor, np.tile(hold, (100, 1)))
    with fmu.FMUInstance(fmu_file, params={"rail[3].force_inertia": 0.08}) as f:
        assert [v.name for v in f.md.modelVariables].count("rail[3].force_inertia") == 1
        assert f.vars["rail[3].force_inertia"].unit == "kg"
        assert f.vars["rail[3].force_inertia"].causality == "parameter"
        assert f.get("rail[3].force_inertia") == 0.08
        for _ in range(100):
            f.step(H, tau=hold)
        assert np.max(np.abs(f.vector("x") - x[-1])) < 1e-10
    _, x0, _ = core_run(model, np.tile(hold, (100, 1)))
    assert np.max(np.abs(x0[-1] - x[-1])) > 1e-6
