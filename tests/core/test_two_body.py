"""Backlash and elasticity as two bodies (drive.two_body = 1): the drive body (rotor inertia,
friction, command) and the carriage joined by a dead-band spring, integrated by pkm_sim.

Checked here: the static deflection is the reading model's (gap/2 on the loaded side plus
compliance x load), energy is conserved without damping, a saved state replays bit for
bit, the explicit and the BDF integrators agree, the compiled and the Python loops read
the drive bodies alike, and a bad set-up is refused naming the parameter.  The comparison
with MuJoCo's two bodies is tests/core/test_two_body_mujoco.py.
"""
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim.core import Model, Simulator
from cosim.master import CoreDrive, CorePlant, make_reference, run
from cosim import trajectories as tr
from cosim.errors import ParameterError

GAP, C1, C2, JD = 1e-4, 1e-5, 1e-6, 0.05  # gap [m], compliances [m/N], drive body [kg]


def two_body_model(damping=(20.0, 50.0), gravity=True, gap=GAP):
    m = Model("6pus")
    p = {"drive.two_body": 1.0, "rail[1].compliance": C1, "rail[1].rotor_inertia": JD,
         "rail[1].transmission_damping": damping[0], "rail[2].backlash": gap, "rail[2].compliance": C2,
         "rail[2].rotor_inertia": JD, "rail[2].transmission_damping": damping[1]}
    if not gravity:
        p["gravity.z"] = 0.0
    m.set_params(p)
    return m


def test_static_deflection_is_the_reading_models():
    """Held at home by a PD + gravity on the drive readings, the drive bodies sit gap/2 on the
    loaded side plus compliance x load from their carriages (rail 1: spring only)."""
    m = two_body_model()
    x0 = m.home()
    ref = make_reference(m, tr.step(x0, x0), duration=2.0)
    res = run(CorePlant(m), ctl.pd_gravity(m, kp=3e3, kd=60), ref, drive=CoreDrive(m))
    assert res.loop == "compiled"
    q, q_true, tau = np.asarray(res["q"]), np.asarray(res["q_true"]), np.asarray(res["tau_applied"])
    defl = q[-1] - q_true[-1]                      # the drive body less the carriage
    load = tau[-1]                                 # what the transmission carries at rest
    expect = np.zeros(6)
    expect[0] = C1 * load[0]
    expect[1] = np.sign(load[1]) * GAP / 2 + C2 * load[1]
    assert abs(load[0]) > 0.1 and abs(load[1]) > 0.1
    np.testing.assert_allclose(defl, expect, rtol=0, atol=1e-9)
    # the one-body reading model at the same state says the same
    m1 = two_body_model()
    m1.set_params({"drive.two_body": 0.0})
    read = m1.measure_joints(np.asarray(res["x"])[-1], np.asarray(res["xd"])[-1], load)
    np.testing.assert_allclose(read[:2], q[-1][:2], rtol=0, atol=1e-9)


def _total_energy(m, sim, gap=GAP):
    """Carriage-side mechanics + drive bodies' kinetic energy + springs' potential energy."""
    t, x, xd = sim.state
    mech = Model("6pus")
    mech.set_params({k: v for k, v in m.params().items() if k.startswith("gravity")})
    kin, pot = mech.energy(x, xd)
    th, thd = sim.drive_state
    q, qd = m.ik(x), m.joint_velocity(x, xd)
    e = kin + pot
    for i, (c, g) in enumerate([(C1, 0.0), (C2, gap)]):
        d = th[i] - q[i]
        dz = np.sign(d) * max(abs(d) - g / 2, 0.0)
        e += 0.5 * JD * thd[i] ** 2 + 0.5 * dz ** 2 / c
    return float(e)


def test_energy_is_conserved_without_damping():
    gap = 2e-5
    m = two_body_model(damping=(0.0, 0.0), gravity=False, gap=gap)
    sim = Simulator(m, rtol=1e-11, atol=1e-13)
    x0 = m.home()
    v0 = np.array([0.02, -0.04, 0.01, 0.2, 0.0, -0.1])
    sim.reset(0.0, x0, v0)
    sim.set_input(np.zeros(6))
    e0 = _total_energy(m, sim, gap)
    moved = 0.0
    for k in range(1, 301):
        sim.advance(k * 1e-3)
        th, _ = sim.drive_state
        moved = max(moved, abs(th[1] - m.ik(sim.state[1])[1]))
    e1 = _total_energy(m, sim, gap)
    assert moved > gap / 2     # rail 2 crossed into contact
    assert abs(e1 - e0) < 1e-9 * abs(e0), (e0, e1)
    # with damping the energy falls
    md = two_body_model(damping=(20.0, 50.0), gravity=False)
    sd = Simulator(md, rtol=1e-11, atol=1e-13)
    sd.reset(0.0, x0, v0)
    sd.set_input(np.zeros(6))
    f0 = _total_energy(md, sd)
    sd.advance(0.2)
    assert _total_energy(md, sd) < f0 - 1e-6 * abs(f0)


def test_saved_state_replays_bit_for_bit_and_integrators_agree():
    m = two_body_model()
    g = m.gravity_load(m.home())
    sims = {meth: Simulator(m, method=meth, rtol=1e-10, atol=1e-12) for meth in ("erk", "bdf")}
    out = {}
    for meth, s in sims.items():
        s.reset(0.0, m.home())
        s.set_input(g * 1.5)
        s.advance(0.05)
        saved = s.save_state()
        assert saved[0] == 2.0 and saved.size == 5 + 4 * 6 + 6  # layout 2: with the drive bodies' states
        s.advance(0.1)
        a = (s.state[1].copy(), s.drive_state[0].copy())
        s.load_state(saved)
        s.advance(0.1)
        b = (s.state[1], s.drive_state[0])
        assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
        out[meth] = a
    np.testing.assert_allclose(out["erk"][0], out["bdf"][0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(out["erk"][1], out["bdf"][1], rtol=0, atol=1e-8)


def test_compiled_and_python_loops_read_the_drive_bodies_alike():
    m = two_body_model()
    x0 = m.home()
    ref = make_reference(m, tr.step(x0, x0 + np.array([0.0, 0.0, 0.003, 0.0, 0.0, 0.0])), duration=0.3)
    a = run(CorePlant(m), ctl.pd_gravity(m, kp=3e3, kd=60), ref, drive=CoreDrive(m))
    b = run(CorePlant(m), ctl.pd_gravity(m, kp=3e3, kd=60), ref, drive=CoreDrive(m), compiled=False)
    assert a.loop == "compiled" and b.loop == "python"
    np.testing.assert_allclose(np.asarray(a["q"]), np.asarray(b["q"]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.asarray(a["qd"]), np.asarray(b["qd"]), rtol=0, atol=1e-9)
    # the readings of rails 1 and 2 are their drive bodies, not their carriages
    assert np.abs(np.asarray(a["q"])[:, 1] - np.asarray(a["q_true"])[:, 1]).max() > GAP / 4


@pytest.mark.parametrize("params,words", [
    ({"drive.two_body": 1.0, "rail[3].backlash": 1e-4, "rail[3].rotor_inertia": 0.05}, ["rail[3].compliance", "> 0"]),
    ({"drive.two_body": 1.0, "rail[4].compliance": 1e-5}, ["rail[4].rotor_inertia", "> 0"]),
    ({"drive.two_body": 0.5}, ["drive.two_body", "0 or 1"]),
])
def test_a_two_body_joint_without_its_physics_is_refused(params, words):
    m = Model("6pus")
    with pytest.raises(ParameterError) as e:
        m.set_params(params)
    for w in words:
        assert w in str(e.value), (w, str(e.value))


def test_the_fmu_plant_has_the_drive_bodies_too():
    """The Co-Simulation FMU integrates the same two bodies (its q_drive outputs are what the
    encoders read); Model Exchange, whose states are the pose's only, refuses them."""
    from cosim.fmu import fmu_path, simulate
    from cosim.master import FMUPlant

    m = two_body_model()
    x0 = m.home()
    params = {k: v for k, v in m.params().items() if v != Model("6pus").param(k)}
    ref = make_reference(m, tr.step(x0, x0 + np.array([0.0, 0.0, 0.003, 0.0, 0.0, 0.0])), duration=0.3)
    core = run(CorePlant(m), ctl.pd_gravity(m, kp=3e3, kd=60), ref, drive=CoreDrive(m))
    with FMUPlant(fmu_path("6pus"), parameters=params) as plant:
        fmu = run(plant, ctl.pd_gravity(m, kp=3e3, kd=60), ref, drive=CoreDrive(m))
    np.testing.assert_allclose(np.asarray(fmu["q_true"]), np.asarray(core["q_true"]), rtol=0, atol=1e-10)
    np.testing.assert_allclose(np.asarray(fmu["q"]), np.asarray(core["q"]), rtol=0, atol=1e-10)
    assert np.abs(np.asarray(fmu["q"])[:, 1] - np.asarray(fmu["q_true"])[:, 1]).max() > GAP / 4
    log = []
    with pytest.raises(Exception):
        simulate(fmu_path("6pus"), fmi_type="ModelExchange", stop_time=0.01, params=params,
                 logger=lambda *a: log.append(a))
    lines = [a[4].decode() for a in log]
    assert any("Model Exchange has the pose states only" in s for s in lines), lines


def test_the_discrepancy_replay_reads_the_drive_bodies_on_both_of_its_paths():
    """cosim.discrepancy.runs.closed_loop: the compiled loop and its Python loop (a
    controller the core does not implement) give the same readings of a two-body plant."""
    from cosim.discrepancy.runs import closed_loop

    m = two_body_model()
    x0 = m.home()
    ref = make_reference(m, tr.step(x0, x0 + np.array([0.0, 0.0, 0.003, 0.0, 0.0, 0.0])), duration=0.2)
    pdg = ctl.pd_gravity(m, kp=3e3, kd=60)
    a = closed_loop(m, pdg, ref)
    b = closed_loop(m, lambda t, q, qd, r: pdg(t, q, qd, r), ref)
    np.testing.assert_allclose(b.q, a.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.qd, a.qd, rtol=0, atol=1e-9)
    assert np.abs(a.q[:, 1] - a.q_true[:, 1]).max() > GAP / 4
