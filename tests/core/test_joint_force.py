"""The drive layer's generic joint force (``<j>[i].force_*``, joint_force.hpp; its constant is
the drive's ``<j>[i].offset``): the term the discovery step of the discrepancy engine fits.
Checked against the formula written here from the joint positions and rates (inverse kinematics of the pose, and of a pose a small
step along the velocity), in the inverse dynamics, the forward dynamics and on a described
robot with rotary joints."""
import math

import numpy as np
import pytest

from cosim.core import Model

COEF = {"offset": 0.3, "force_qc": 0.25, "force_k1": -230.0, "force_k2": 40.0, "force_k3": -900.0,
        "force_v2": 2.5, "force_vpos": 0.7, "force_vneg": 0.2, "force_cpos": 0.05, "force_cneg": 0.11,
        "force_sin": 0.32, "force_cos": -0.1, "force_period": 0.01, "force_step": 0.04, "force_step_q": 0.26,
        "force_step_w": 0.002}


def _expected(q, qd, v_eps):
    c = COEF
    z = q - c["force_qc"]
    s = math.tanh(qd / v_eps)
    a = 2 * math.pi * q / c["force_period"]
    return (c["offset"] + c["force_k1"] * z + c["force_k2"] * z**2 + c["force_k3"] * z**3
            + c["force_v2"] * qd * abs(qd) + c["force_vpos"] * max(qd, 0) + c["force_vneg"] * min(qd, 0)
            + c["force_cpos"] * max(s, 0) + c["force_cneg"] * min(s, 0)
            + c["force_sin"] * math.sin(a) + c["force_cos"] * math.cos(a)
            + c["force_step"] * math.tanh((q - c["force_step_q"]) / c["force_step_w"]))


def _state(m):
    x = m.home() + np.array([0.002, -0.001, 0.004, 0.01, -0.02, 0.015])
    xd = np.array([0.05, -0.02, 0.03, 0.2, -0.1, 0.3])
    return x, xd


def _joint_rates(m, x, xd, h=1e-7):
    return (m.ik(x + h * xd) - m.ik(x - h * xd)) / (2 * h)


@pytest.mark.parametrize("joint", [1, 4])
def test_inverse_dynamics_adds_the_force_on_its_joint_only(joint):
    nominal = Model("6pus")
    m = Model("6pus", params={f"rail[{joint}].{k}": v for k, v in COEF.items()})
    x, xd = _state(m)
    xdd = np.array([0.3, -0.2, 0.1, 1.0, 0.5, -0.7])
    dtau = m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd)
    q, qd = m.ik(x), _joint_rates(m, x, xd)
    want = _expected(q[joint - 1], qd[joint - 1], m.params()["drive.v_eps"])
    assert abs(want) > 0.05
    np.testing.assert_allclose(dtau[joint - 1], want, rtol=1e-6)
    np.testing.assert_allclose(np.delete(dtau, joint - 1), 0.0, atol=1e-12)


def test_forward_dynamics_is_driven_by_the_effort_less_the_force():
    nominal = Model("6pus")
    m = Model("6pus", params={f"rail[3].{k}": v for k, v in COEF.items()})
    x, xd = _state(m)
    tau = nominal.gravity_load(x) + np.array([0.1, -0.2, 0.3, 0.0, 0.1, -0.1])
    q, qd = m.ik(x), _joint_rates(m, x, xd)
    f = np.zeros(6)
    f[2] = _expected(q[2], qd[2], m.params()["drive.v_eps"])
    np.testing.assert_allclose(m.forward_dynamics(x, xd, tau), nominal.forward_dynamics(x, xd, tau - f),
                               rtol=1e-9, atol=1e-9)


def test_shape_parameters_alone_are_no_force():
    nominal = Model("6pus")
    m = Model("6pus", params={"rail[2].force_qc": 0.3, "rail[2].force_period": 0.01, "rail[2].force_step_w": 0.01,
                              "rail[2].force_cv": 0.02})
    x, xd = _state(m)
    xdd = np.zeros(6)
    np.testing.assert_array_equal(m.inverse_dynamics(x, xd, xdd), nominal.inverse_dynamics(x, xd, xdd))


def test_parameters_are_in_the_table_with_units_and_bounds():
    info = {p.name: p for p in Model("quattro").param_info()}
    assert info["arm[2].force_k1"].unit == "N m/rad"
    assert info["arm[2].force_v2"].unit == "N m s2/rad2"
    with pytest.raises(Exception, match="force_period"):
        Model("quattro", params={"arm[1].force_period": -0.1})
    assert info["arm[2].force_cv"].unit == "rad/s"
    with pytest.raises(Exception, match="force_cv"):
        Model("quattro", params={"arm[1].force_cv": -0.1})


# ----------------------------------------------------------------- the Coulomb levels' velocity scale
# force_cv [m/s | rad/s]: the Coulomb levels act through tanh(qd / force_cv), a friction that
# fades below that speed; 0 keeps the drive's drive.v_eps (a sharp friction).

@pytest.mark.parametrize("qd", [-0.3, -0.02, 0.004, 0.05, 0.8])
def test_coulomb_levels_fade_below_their_velocity_scale(qd):
    cv, cpos, cneg = 0.05, 0.7, 0.4
    nominal = Model("pendulum")
    m = Model("pendulum", params={"axis[1].force_cpos": cpos, "axis[1].force_cneg": cneg, "axis[1].force_cv": cv})
    x, xd, xdd = np.array([0.3]), np.array([qd]), np.array([1.2])
    s = math.tanh(qd / cv)
    want = cpos * max(s, 0.0) + cneg * min(s, 0.0)
    np.testing.assert_allclose(m.inverse_dynamics(x, xd, xdd) - nominal.inverse_dynamics(x, xd, xdd), [want],
                               rtol=1e-12, atol=1e-15)
    # the drive's own friction that fades (coulomb with its velocity scale coulomb_v) is the same
    # physics when the two levels are equal: one plant by either parameter set
    smooth = Model("pendulum", params={"axis[1].coulomb": cpos, "axis[1].coulomb_v": cv})
    split = Model("pendulum", params={"axis[1].force_cpos": cpos, "axis[1].force_cneg": cpos, "axis[1].force_cv": cv})
    np.testing.assert_allclose(split.inverse_dynamics(x, xd, xdd), smooth.inverse_dynamics(x, xd, xdd), rtol=1e-13)


def test_without_a_velocity_scale_the_levels_are_sharp():
    m = Model("pendulum", params={"axis[1].force_cpos": 0.7})
    eps = m.params()["drive.v_eps"]
    x, xdd = np.array([0.3]), np.array([0.0])
    d = m.inverse_dynamics(x, np.array([3 * eps]), xdd) - Model("pendulum").inverse_dynamics(x, np.array([3 * eps]), xdd)
    np.testing.assert_allclose(d, [0.7 * math.tanh(3.0)], rtol=1e-12)


# ----------------------------------------------------------------- the added inertia
# force_inertia [kg | kg m2]: F = force_inertia qdd, an inertia the drive carries on the joint.
# References: the pendulum's closed form (robots/pendulum.toml: a 1 kg bob 0.5 m below the
# shaft, its own inertia 1e-4 kg m2), tau = (m l^2 + I + J) qdd + m g l sin q, and the rotor
# inertia (an existing parameter of the same physics) on the 6-PUS.
M_L2, MGL = 1.0 * 0.5**2 + 1e-4, 1.0 * 9.81 * 0.5


def test_added_inertia_in_the_pendulum_dynamics_by_hand():
    J = 0.25
    m = Model("pendulum", params={"axis[1].force_inertia": J})
    x, xd, xdd = np.array([0.3]), np.array([0.5]), np.array([1.2])
    np.testing.assert_allclose(m.inverse_dynamics(x, xd, xdd), (M_L2 + J) * 1.2 + MGL * math.sin(0.3), rtol=1e-12)
    np.testing.assert_allclose(m.mass_matrix(x), [[M_L2 + J]], rtol=1e-12)
    ke, _ = m.energy(x, xd)
    assert float(ke) == pytest.approx(0.5 * (M_L2 + J) * 0.25, rel=1e-12)
    np.testing.assert_allclose(m.forward_dynamics(x, xd, np.array([2.0])),
                               (2.0 - MGL * math.sin(0.3)) / (M_L2 + J), rtol=1e-12)


def test_added_inertia_slows_the_pendulum_as_its_closed_form_says():
    # small swings: period 2 pi sqrt((m l^2 + I + J) / (m g l)); with J = m l^2 it grows by sqrt(2)
    from cosim.core import Simulator

    J = 0.25
    period = 2 * math.pi * math.sqrt((M_L2 + J) / MGL)
    sim = Simulator(Model("pendulum", params={"axis[1].force_inertia": J}), rtol=1e-10, atol=1e-12)
    sim.reset(0.0, [0.01])
    crossings, prev, t = [], 0.01, 0.0
    h = 1e-3
    while len(crossings) < 2:
        t += h
        sim.advance(t)
        q = float(sim.state[1][0])
        if prev > 0 >= q:  # a downward crossing of the vertical, interpolated
            crossings.append(t - h * q / (q - prev))
        prev = q
    assert crossings[1] - crossings[0] == pytest.approx(period, rel=1e-4)
    assert period > 1.4 * 2 * math.pi * math.sqrt(M_L2 / MGL)


def test_added_inertia_keeps_the_energy_of_a_free_swing():
    # no friction, no effort: kinetic (with 0.5 J qd^2) + potential energy stays constant;
    # an energy without the added inertia would not (the swing trades 0.5 J qd^2 too)
    from cosim.core import Simulator

    m = Model("pendulum", params={"axis[1].force_inertia": 0.4})
    sim = Simulator(m, rtol=1e-11, atol=1e-12)
    sim.reset(0.0, [1.0])
    energies, speeds = [], []
    for k in range(1, 300):
        sim.advance(k * 5e-3)
        _, x, xd = sim.state
        ke, pe = m.energy(x, xd)
        energies.append(float(ke + pe))
        speeds.append(abs(float(xd[0])))
    assert max(speeds) > 1.0  # it swings through the bottom
    assert np.ptp(energies) < 1e-7 * energies[0]
    # the share the added inertia carries at the fastest point is far above that tolerance
    assert 0.5 * 0.4 * max(speeds) ** 2 > 1e-2 * energies[0]


def _sixpus_motion():
    m = Model("6pus")
    x, xd = _state(m)
    return x, xd, np.array([0.3, -0.2, 0.1, 1.0, 0.5, -0.7])


def test_added_inertia_is_the_rotor_inertia_physics_on_the_6pus():
    # the same joint inertia split between the rotor and the added term gives the same plant
    x, xd, xdd = _sixpus_motion()
    rotor = {f"rail[{i}].rotor_inertia": 0.02 * i for i in range(1, 7)}
    split = dict(rotor, **{"rail[2].force_inertia": 0.05, "rail[5].force_inertia": 0.11})
    lumped = dict(rotor, **{"rail[2].rotor_inertia": 0.04 + 0.05, "rail[5].rotor_inertia": 0.10 + 0.11})
    a, b = Model("6pus", params=split), Model("6pus", params=lumped)
    tau = a.inverse_dynamics(x, xd, xdd)
    np.testing.assert_allclose(tau, b.inverse_dynamics(x, xd, xdd), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(a.mass_matrix(x), b.mass_matrix(x), rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(a.energy(x, xd), b.energy(x, xd), rtol=1e-13)
    np.testing.assert_allclose(a.forward_dynamics(x, xd, tau), b.forward_dynamics(x, xd, tau), rtol=1e-9, atol=1e-9)
    # and it is a force on its joint: force_inertia times the joint acceleration
    nominal = Model("6pus", params=rotor)
    qdd = nominal.joint_acceleration(x, xd, xdd)
    want = np.zeros(6)
    want[1], want[4] = 0.05 * qdd[1], 0.11 * qdd[4]
    assert np.min(np.abs(want[[1, 4]])) > 5e-4  # well above the comparison's 1e-12
    np.testing.assert_allclose(tau - nominal.inverse_dynamics(x, xd, xdd), want, rtol=1e-10, atol=1e-12)


def test_added_inertia_round_trip_with_the_other_terms():
    # forward dynamics of the inverse dynamics' efforts gives the acceleration back, the
    # generic force's position and rate terms and friction on the same joints
    x, xd, xdd = _sixpus_motion()
    p = {f"rail[3].{k}": v for k, v in COEF.items()}
    p.update({"rail[3].force_inertia": 0.07, "rail[6].force_inertia": 0.2, "rail[6].viscous": 3.0,
              "rail[1].rotor_inertia": 0.05})
    m = Model("6pus", params=p)
    tau = m.inverse_dynamics(x, xd, xdd)
    np.testing.assert_allclose(m.forward_dynamics(x, xd, tau), xdd, rtol=1e-9, atol=1e-9)
    # the layered calls agree with the whole (the discrepancy engine's path)
    mech = m.mechanism_inverse_dynamics(x[None], xd[None], xdd[None])
    joints = (m.ik(x)[None], m.joint_velocity(x, xd)[None], m.joint_acceleration(x, xd, xdd)[None])
    np.testing.assert_array_equal(m.add_drive_efforts(*joints, mech)[0], tau)


def test_a_negative_joint_inertia_is_refused_naming_both_parameters():
    Model("pendulum", params={"axis[1].rotor_inertia": 0.1, "axis[1].force_inertia": -0.05})  # a correction
    with pytest.raises(Exception, match=r"axis\[1\]\.rotor_inertia \+ axis\[1\]\.force_inertia = -0\.05"):
        Model("pendulum", params={"axis[1].force_inertia": -0.05})
