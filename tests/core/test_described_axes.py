"""Single-axis robots from a description: leg types P (prismatic axis, the carriage is the
platform) and R (revolute axis, the platform turns on it), docs/robots.md.

Expected values are written here by hand: the carriage's m qdd + m g.s + friction, the
pendulum's I qdd + m g l sin q, a tilted turntable's inertia and gravity from scipy's
rotations; energy over a free swing; the EMPS sets against the published figures."""
from pathlib import Path

import numpy as np
import pytest

from cosim._native import PkmError
from cosim.core import Model, Simulator

from described_checks import assert_one_clear_error

REPO = Path(__file__).resolve().parents[2]
G = 9.81

INCLINED = """
[robot]
name = "inclined_axis"
coordinates = ["z"]
home = [0.1]
[platform]
mass = 2.0
inertia = [0.01, 0.02, 0.03]
[payload]
mass = 0.5
position = [0.1, -0.2, 0.05]
[[leg]]
type = "P"
platform_point = [0.0, 0.0, 0.0]
rail_origin = [0.2, 0.0, 0.3]
rail_direction = [0.8660254037844387, 0.0, 0.5]
stroke = [-0.2, 0.6]
[defaults]
"rail[1].rotor_inertia" = 0.3
"rail[1].viscous" = 1.5
"rail[1].coulomb" = 0.8
"""

TILTED = """
[robot]
name = "tilted_table"
coordinates = ["rz"]
home = [0.3]
[gravity]
vector = [0.5, -0.3, -9.7]
[platform]
mass = 3.0
inertia = [0.02, 0.03, 0.04]
[payload]
mass = 0.7
position = [0.15, 0.05, 0.02]
[[leg]]
type = "R"
platform_point = [0.01, -0.02, 0.0]
axis_point = [0.1, 0.2, 0.5]
axis = [0.0, 0.6, 0.8]
stroke = [-4.0, 4.0]
"""


def write(tmp_path, text, name="axis.toml"):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


def test_emps_default_is_the_nominal_data_sheet_axis():
    m = Model("emps")
    assert m.ndof == 1 and m.facts.pose_names == ("x",) and m.joint_unit == "m"
    assert m.facts.effort_unit == "N" and m.facts.joint_prefix == "rail"
    assert m.param("platform.m") == 90.0 and m.param("rail[1].rotor_inertia") == 0.0
    assert m.param("rail[1].coulomb") == 0.0 and m.param("rail[1].viscous") == 0.0
    lo, hi = m.joint_limits()
    assert lo[0] < -2.2e-5 and hi[0] > 0.2464  # the recorded range
    for x, xd, xdd in [(0.0, 0.0, 1.0), (0.1, 0.3, -2.0), (0.24, -0.5, 0.7)]:
        assert m.inverse_dynamics([x], [xd], [xdd])[0] == pytest.approx(90.0 * xdd, rel=1e-14)
    assert m.gravity_load([0.1])[0] == 0.0  # horizontal: gravity does not act along the screw


def test_emps_reference_set_is_the_published_model():
    m = Model("emps", param_set="reference")
    assert m.param("platform.m") == 95.1089
    assert m.param("rail[1].viscous") == 203.5034 and m.param("rail[1].coulomb") == 20.3935
    # M qdd + Fv qd + Fc sign(qd) + OF (at 0.2 m/s the smooth sign is 1 to rounding)
    OF = -3.1648
    tau = m.inverse_dynamics([0.1], [0.2], [1.5])[0]
    assert tau == pytest.approx(95.1089 * 1.5 + 203.5034 * 0.2 + 20.3935 + OF, rel=1e-13)
    tau = m.inverse_dynamics([0.1], [-0.2], [0.0])[0]
    assert tau == pytest.approx(-203.5034 * 0.2 - 20.3935 + OF, rel=1e-13)


def test_inclined_rail_carries_the_weight_along_it(tmp_path):
    m = Model(write(tmp_path, INCLINED))
    mass, sin_a = 2.5, 0.5  # platform + payload; the rail rises 30 deg
    J, Fv, Fc = 0.3, 1.5, 0.8
    for x, xd, xdd in [(0.1, 0.0, 0.0), (0.3, 0.4, 2.0), (-0.1, -0.25, -1.0)]:
        want = (mass + J) * xdd + mass * G * sin_a + Fv * xd + Fc * np.sign(xd)
        assert m.inverse_dynamics([x], [xd], [xdd])[0] == pytest.approx(want, rel=1e-12)
    assert m.gravity_load([0.2])[0] == pytest.approx(mass * G * sin_a, rel=1e-14)
    assert m.mass_matrix([0.2])[0, 0] == pytest.approx(mass + J, rel=1e-15)  # with the drive's rotor inertia
    # forward dynamics inverts it: at rest, the effort that holds it plus 2.8 N gives 1 m/s2
    # (2.5 kg of bodies, 0.3 kg of reflected rotor inertia)
    assert m.forward_dynamics([0.2], [0.0], [mass * G * sin_a + 2.8])[0] == pytest.approx(1.0, rel=1e-12)
    # the drawing: rail origin, the carriage's point on the rail, the platform origin
    c = m.chain_points([0.2])[0]
    s = np.array([0.8660254037844387, 0.0, 0.5])
    assert np.allclose(c[0], [0.2, 0.0, 0.3]) and np.allclose(c[1], [0.2, 0.0, 0.3] + 0.2 * s, atol=1e-15)
    # potential energy: the bodies' heights (platform origin on the rail, payload 0.05 above it)
    _, V = m.energy([0.2], [0.0])
    z = 0.3 + 0.2 * 0.5
    assert V == pytest.approx(2.0 * G * z + 0.5 * G * (z + 0.05), rel=1e-14)


def test_pendulum_is_i_qdd_plus_m_g_l_sin_q():
    m = Model("pendulum")
    assert m.facts.pose_names == ("ry",) and m.joint_unit == "rad" and m.facts.effort_unit == "N m"
    mass, l, I = 1.0, 0.5, 1e-4
    rng = np.random.default_rng(3)
    for _ in range(20):
        q, qd, qdd = rng.uniform(-3, 3), rng.uniform(-5, 5), rng.uniform(-20, 20)
        want = (mass * l * l + I) * qdd + mass * G * l * np.sin(q)
        assert m.inverse_dynamics([q], [qd], [qdd])[0] == pytest.approx(want, rel=1e-12, abs=1e-13)
    # bob position: 0.5 m below the shaft at 1 m, swung towards -x by a positive angle
    c = m.chain_points([0.4])[0]
    assert np.allclose(c[2], [-0.5 * np.sin(0.4), 0.0, 1.0 - 0.5 * np.cos(0.4)], atol=1e-15)


def test_tilted_turntable_against_scipy_rotations(tmp_path):
    """Inertia about the axis and the gravity load from the bodies placed by scipy's rotations
    (and the potential differentiated numerically), not from the core."""
    from scipy.spatial.transform import Rotation

    m = Model(write(tmp_path, TILTED))
    g = np.array([0.5, -0.3, -9.7])
    k = np.array([0.0, 0.6, 0.8])
    A, p = np.array([0.1, 0.2, 0.5]), np.array([0.01, -0.02, 0.0])
    bodies = [(3.0, np.zeros(3)), (0.7, np.array([0.15, 0.05, 0.02]))]  # mass, point in the platform frame
    I_axis = k @ np.diag([0.02, 0.03, 0.04]) @ k + sum(mb * np.linalg.norm(np.cross(k, c - p)) ** 2 for mb, c in bodies)

    def V(q):
        R = Rotation.from_rotvec(q * k).as_matrix()
        return -sum(mb * g @ (A + R @ (c - p)) for mb, c in bodies)

    for q in (-2.0, 0.3, 1.7):
        h = 1e-5
        G_q = -(V(q + h) - V(q - h)) / (2 * h)
        for qd, qdd in [(0.0, 0.0), (1.2, -3.0)]:
            assert m.inverse_dynamics([q], [qd], [qdd])[0] == pytest.approx(I_axis * qdd - G_q, rel=1e-8, abs=1e-9)
        assert m.energy([q], [0.0])[1] == pytest.approx(V(q), rel=1e-13)
    assert m.mass_matrix([0.3])[0, 0] == pytest.approx(I_axis, rel=1e-14)


def test_kinematics_is_the_identity_and_limits_hold():
    for name in ("emps", "pendulum"):
        m = Model(name)
        lo, hi = m.joint_limits()
        x = np.array([0.5 * (lo[0] + hi[0])])
        assert m.ik(x)[0] == x[0] and m.fk(x)[0] == x[0]
        assert m.jacobian(x)[0, 0] == 1.0 and m.jacobian_dot(x, [0.7])[0, 0] == 0.0
        assert m.joint_acceleration(x, [0.3], [2.0])[0] == 2.0
        assert np.all(m.singularity(x) == 1.0)
        with pytest.raises(PkmError, match=r"leg 1 joint q = .* outside"):
            m.ik([hi[0] + 0.01])


def test_free_pendulum_keeps_its_energy_and_swings_at_its_frequency():
    m = Model("pendulum")
    # a large swing: the energy (swing energy m g l (1 - cos 1) = 2.25 J) stays
    sim = Simulator(m, rtol=1e-11, atol=1e-13)
    sim.reset(0.0, [1.0], [0.0])
    sim.set_input([0.0])
    E0 = sum(m.energy([1.0], [0.0]))
    for t in np.linspace(0.1, 3.0, 30):
        sim.advance(t)
        _, x, xd = sim.state
        assert abs(sum(m.energy(x, xd)) - E0) < 1e-8 * 2.25
    # a small one: the Lindstedt-Poincare solution of q'' + w0^2 sin q = 0 to third order,
    # w0^2 = m g l / (m l^2 + I): q = q0 cos(w t) + q0^3 / 192 (cos(w t) - cos(3 w t)),
    # w = w0 (1 - q0^2 / 16); the terms left are of order q0^5 = 1e-10 rad
    q0 = 0.01
    w = np.sqrt(1.0 * G * 0.5 / (1.0 * 0.25 + 1e-4)) * (1 - q0 ** 2 / 16)
    sim.reset(0.0, [q0], [0.0])
    worst = 0.0
    for t in np.linspace(0.1, 3.0, 30):
        sim.advance(t)
        _, x, _ = sim.state
        want = q0 * np.cos(w * t) + q0 ** 3 / 192 * (np.cos(w * t) - np.cos(3 * w * t))
        worst = max(worst, abs(x[0] - want))
    assert worst < 2e-9, worst  # the first-order solution q0 cos(w0 t) is off by 8e-8 here


def test_carriage_without_gravity_friction_or_input_coasts():
    """No gravity along the rail, no friction, no input: the velocity stays, the energy too."""
    m = Model("emps")
    sim = Simulator(m)
    sim.reset(0.0, [0.0], [0.05])
    sim.set_input([0.0])
    sim.advance(2.0)
    _, x, xd = sim.state
    assert x[0] == pytest.approx(0.1, abs=1e-12) and xd[0] == pytest.approx(0.05, abs=1e-14)
    assert m.energy(x, xd)[0] == pytest.approx(0.5 * 90.0 * 0.05 ** 2, rel=1e-12)


BAD = [
    # (what, description text edit, the line the error must name, words it must contain)
    ("P with a rod field", lambda s: s.replace('type = "P"', 'type = "P"\nrod_length = 0.2'), 14,
     ["rod_length", "unknown field", "rail_origin"]),
    ("P copied", lambda s: s.replace('type = "P"', 'type = "P"\ncopies = 2'), 14, ["single-axis", "only"]),
    ("P on an angle coordinate", lambda s: s.replace('coordinates = ["z"]', 'coordinates = ["rx"]'), 4,
     ["type P", "x, y, z", "'rx'"]),
    ("P rail not unit", lambda s: s.replace("rail_direction = [0.8660254037844387, 0.0, 0.5]",
                                            "rail_direction = [1.0, 0.0, 0.5]"), 16, ["rail_direction", "unit"]),
    ("P missing rail origin", lambda s: s.replace("rail_origin = [0.2, 0.0, 0.3]\n", ""), 12,
     ["rail_origin", "missing"]),
    ("P home beyond the stroke", lambda s: s.replace("home = [0.1]", "home = [0.7]"), 5,
     ["home pose", "outside"]),
    ("P stroke reversed", lambda s: s.replace("stroke = [-0.2, 0.6]", "stroke = [0.6, -0.2]"), 17, ["stroke", "min < max"]),
    ("P with a second leg", lambda s: s.replace('coordinates = ["z"]', 'coordinates = ["z", "x"]')
     .replace("home = [0.1]", "home = [0.1, 0.0]") + s[s.index("[[leg]]"):s.index("[defaults]")], 12,
     ["single-axis", "only leg"]),
    ("P massless", lambda s: s.replace("mass = 2.0", "mass = 0.0").replace("mass = 0.5", "mass = 0.0"), 5,
     ["carries no inertia"]),
    ("P friction out of range", lambda s: s.replace('"rail[1].coulomb" = 0.8', '"rail[1].coulomb" = -0.8'), 21,
     ["rail[1].coulomb"]),
]

BAD_R = [
    ("R on a length coordinate", lambda s: s.replace('coordinates = ["rz"]', 'coordinates = ["z"]'), 4,
     ["type R", "rx, ry, rz", "'z'"]),
    ("R axis not unit", lambda s: s.replace("axis = [0.0, 0.6, 0.8]", "axis = [0.0, 0.6, 0.9]"), 18,
     ["axis", "unit"]),
    ("R arm field", lambda s: s.replace('type = "R"', 'type = "R"\narm_length = 0.1'), 16,
     ["arm_length", "unknown field", "axis_point"]),
    ("R with nothing to turn", lambda s: s.replace("mass = 3.0", "mass = 0.0").replace("mass = 0.7", "mass = 0.0")
     .replace("inertia = [0.02, 0.03, 0.04]", "inertia = [0.0, 0.0, 0.0]"), 5, ["carries no inertia"]),
    ("R stroke beyond 100 rad", lambda s: s.replace("stroke = [-4.0, 4.0]", "stroke = [-4.0, 400.0]"), 19,
     ["axis[1].qmax", "outside"]),
]


@pytest.mark.parametrize("what,edit,line,words,base", [b + (INCLINED,) for b in BAD] + [b + (TILTED,) for b in BAD_R],
                         ids=[b[0] for b in BAD + BAD_R])
def test_bad_axis_descriptions_name_file_line_and_field(tmp_path, what, edit, line, words, base):
    assert_one_clear_error(write(tmp_path, edit(base)), line, words)


def test_mobility_count_of_a_single_axis():
    """Grubler-Kutzbach: base and platform, one joint of one freedom: 6 (2 - 1 - 1) + 1 = 1."""
    for name in ("emps", "pendulum"):
        assert Model(name).ndof == 1


# ------------------------------------------------------- the EMPS through the toolkit

def test_emps_step_scenario_is_the_second_order_system_and_the_fmu_plant_agrees():
    """PD on a frictionless 90 kg carriage: overshoot exp(-zeta pi / sqrt(1 - zeta^2)) of the
    closed-form second-order system (zeta = kd / (2 sqrt(kp m)) = 0.8), no steady-state error
    (no gravity along the axis); the FMU plant runs it like the core plant."""
    from cosim.scenario import load_scenario, run_scenario

    sc = load_scenario(REPO / "scenarios" / "described" / "emps_step_pd.toml")
    kp, kd, mass = sc.spec["controller"]["kp"], sc.spec["controller"]["kd"], 90.0
    zeta = kd / (2 * np.sqrt(kp * mass))
    core = run_scenario(sc, export=False, figures=False)
    x = core.result["x"][:, 0]
    overshoot = 100 * (x.max() - 0.1) / 0.1
    assert overshoot == pytest.approx(100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta ** 2)), abs=0.05)
    assert abs(x[-1] - 0.1) < 1e-6
    fmu = run_scenario(sc, plant="fmu", export=False, figures=False)
    assert fmu.result.plant["kind"] == "fmu"
    np.testing.assert_allclose(fmu.result["q"], core.result["q"], rtol=0, atol=1e-10)


def test_blind_case_and_diagnosis_on_the_emps(tmp_path):
    """The blind generator sizes its effects for a 1-DOF robot from the core; cosim diagnose
    finds the hidden viscous friction and its value."""
    import json
    import subprocess
    import sys

    from cosim.discrepancy import blind

    csv, key = blind.make_case(blind.CaseSpec("case", "emps", ["viscous"], seed=3), tmp_path / "cases",
                               tmp_path / "keys")
    p = subprocess.run([sys.executable, "-m", "cosim", "diagnose", str(csv), "--no-figures", "--no-replay", "--out",
                        str(tmp_path / "d"), "--json"], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
    d = json.loads(p.stdout)
    hidden = json.loads(Path(key).read_text())["effects"][0]
    assert {e["key"] for e in d["effects"]} == {"viscous"}, d["effects"]
    for name, true in hidden["params"].items():
        assert abs(d["theta"][name] - true) < 0.05 * true, (name, d["theta"][name], true)
