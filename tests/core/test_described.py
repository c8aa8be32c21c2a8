"""Robots compiled from description files (robots/*.toml, docs/robots.md).

The 6-PUS and the Quattro the core serves from their descriptions against the hand-written
oracles (1000 random poses and rates, 1e-10, oracle_6pus.py and oracle_quattro.py),
the closed-form derivatives of every leg kind against forward-mode differentiation and
finite differences, energy conservation, and one clear error per kind of bad description.
"""
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model, robots
from cosim.errors import ArgumentError, PkmError

from described_checks import assert_one_clear_error, rel, run_oracle, samples

REPO = Path(__file__).resolve().parents[2]
LISTED = [n.split("#")[0].strip() for n in (REPO / "robots" / "robots.list").read_text().splitlines()]
LISTED = [n for n in LISTED if n]
NEW = [n for n in LISTED if n != "6pus"]  # quattro too: its platform kind is new


def test_every_listed_description_is_listed_by_the_core():
    names = robots()
    assert {"6pus", "quattro", "fourbar"} <= set(names)
    assert set(LISTED) <= set(names)
    assert {"hexapod_ups", "delta_clavel", "planar_3rrr", "linear_delta"} <= set(LISTED)


def test_6pus_is_served_from_its_description_and_equals_the_hand_written_oracle():
    """"6pus" is robots/6pus.toml ("6pus_described" its former name); oracle_6pus.py compares it
    with the hand-written 6-PUS kept as a test oracle (libpkm_oracle.so): the parameter table,
    and IK, both dynamics, Jacobians, their rate, the mass matrix, joint accelerations, energy and
    singularity measures at 1000 random states to 1e-10."""
    import os
    import subprocess
    import sys

    assert Path(Model("6pus").facts.file).resolve() == REPO / "robots" / "6pus.toml"
    assert Model("6pus_described").robot == "6pus"
    from cosim.cli.common import robot_arg  # the CLI's --robot takes the former name too

    assert robot_arg("6pus_described") == "6pus_described" and "6pus_described" not in robots()
    lib = Path(os.environ.get("PKM_BUILD_DIR", REPO / "build")) / "lib" / "libpkm_oracle.so"
    assert lib.exists(), f"{lib} is missing: cmake builds it with the core (target pkm_oracle)"
    r = subprocess.run([sys.executable, str(Path(__file__).with_name("oracle_6pus.py"))], cwd=REPO,
                       env=dict(os.environ, PKM_LIB=str(lib)), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stdout + r.stderr


def test_quattro_is_served_from_its_description():
    """"quattro" is robots/quattro.toml ("quattro_described" its former name)."""
    assert Path(Model("quattro").facts.file).resolve() == REPO / "robots" / "quattro.toml"
    assert Model("quattro_described").robot == "quattro" and "quattro_described" not in robots()
    assert "quattro_hand" not in robots()  # the oracle is in libpkm_oracle.so only


@pytest.mark.parametrize("case", ["default", "appendix_a", "payload"])
def test_quattro_equals_the_hand_written_oracle(case):
    """oracle_quattro.py: IK, Jacobians, both dynamics, the mass matrix, joint accelerations,
    energy, singularity measures and chain points at 1000 random states near home to 1e-10,
    the two models' parameters given by each one's names."""
    run_oracle("oracle_quattro.py", "motion", case)


def test_quattro_differs_where_the_hand_written_oracle_differs():
    """The comparison can fail: one parameter of the description moved by 1 % shows."""
    run_oracle("oracle_quattro.py", "differs")


@pytest.mark.parametrize("name", NEW)
def test_closed_form_derivatives_agree_with_forward_mode_and_finite_differences(name):
    m = Model(name)
    X, XD, XDD = samples(m, 40, seed=3)
    h = 1e-6
    for x, xd, xdd in zip(X, XD, XDD):
        J = m.jacobian(x)
        # J (closed form) against central differences of the inverse kinematics
        Jfd = np.column_stack([(m.ik(x + h * e) - m.ik(x - h * e)) / (2 * h) for e in np.eye(m.ndof)])
        assert np.abs(J - Jfd).max() < 1e-6 * max(1.0, np.abs(J).max())
        # qdd (the closure differentiated twice) = J xdd + Jdot xd (J and Jdot in closed form),
        # and the second difference of the inverse kinematics along x(t) = x + t xd + t^2/2 xdd
        qdd = m.joint_acceleration(x, xd, xdd)
        assert rel(qdd, J @ xdd + m.jacobian_dot(x, xd) @ xd) < 1e-10
        t = 1e-4
        q2 = (m.ik(x + t * xd + t * t / 2 * xdd) - 2 * m.ik(x) + m.ik(x - t * xd + t * t / 2 * xdd)) / (t * t)
        assert np.abs(qdd - q2).max() < 1e-5 * max(1.0, np.abs(qdd).max())
        # Jx xd = Jq qd
        Jx, Jq, _ = m.jacobians(x)
        assert rel(Jx @ xd, Jq @ (J @ xd)) < 1e-10
        # inverse and forward dynamics invert each other; M is symmetric positive definite
        tau = m.inverse_dynamics(x, xd, xdd)
        assert rel(xdd, m.forward_dynamics(x, xd, tau)) < 1e-9
        M = m.mass_matrix(x)
        assert np.allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
        assert np.linalg.eigvalsh(M).min() > 0


@pytest.mark.parametrize("name", NEW)
def test_power_balance(name):
    """d/dt (kinetic + potential) = tau . qd along any motion (closed forms consistent with the energy)."""
    m = Model(name)
    X, XD, XDD = samples(m, 10, seed=5)
    h = 1e-5
    for x, xd, xdd in zip(X, XD, XDD):
        def e(s):
            k, p = m.energy(x + s * xd + 0.5 * s * s * xdd, xd + s * xdd)
            return k + p
        dE = (e(h) - e(-h)) / (2 * h)
        power = m.inverse_dynamics(x, xd, xdd) @ (m.jacobian(x) @ xd)
        assert abs(dE - power) < 1e-6 * max(1.0, abs(power))


@pytest.mark.parametrize("name", NEW)
def test_energy_drift_over_ten_seconds(name):
    """No gravity, friction or input: the energy stays put (< 1e-12 relative over 10 s)."""
    from cosim.core import Simulator

    m = Model(name)
    m.set_params({"gravity.x": 0.0, "gravity.y": 0.0, "gravity.z": 0.0})
    rng = np.random.default_rng(2)
    ang = np.array([u == "rad" for u in m.facts.pose_units])
    scale = np.where(ang, 2e-3, 4e-4)  # slow enough to stay inside the strokes
    xd = rng.normal(size=m.ndof) * scale
    xd *= max(1.0, 1.0 / np.abs(xd / scale).max())  # one coordinate at least at its scale (a 1-DOF draw may be tiny)
    # 1 ms steps at most: 10,000 steps, as many as a 1 kHz co-simulation takes
    sim = Simulator(m, method="erk", rtol=1e-12, atol=1e-15, max_step=1e-3)
    sim.reset(0.0, m.home(), xd)
    k0 = sum(m.energy(m.home(), xd))
    sim.advance(10.0)
    _, x1, xd1 = sim.state
    k1 = sum(m.energy(x1, xd1))
    assert np.abs(x1 - m.home()).max() > 1e-3 and sim.stats["steps"] >= 10000  # it did move
    assert abs(k1 - k0) / k0 < 1e-12, abs(k1 - k0) / k0


# ------------------------------------------------------------------ bad descriptions

# The good description the bad ones are edited from (shared with c_core/tests/described_test.cpp);
# its header comment is dropped so that the lines the errors must name count from [robot].
GOOD = "".join(l for l in (REPO / "c_core" / "tests" / "robots" / "tiny_delta.toml").read_text().splitlines(True)
               if not l.startswith("#"))


def write(tmp_path, text, name="robot.toml"):
    f = tmp_path / name
    f.write_text(text)
    return str(f)


def test_a_good_description_loads_by_path(tmp_path):
    f = write(tmp_path, GOOD)
    m = Model(f)
    assert m.robot == "tiny_delta" and m.ndof == 3
    assert m.facts.pose_names == ("x", "y", "z")
    assert m.joint_unit == "m"
    q = m.ik(m.home())
    assert np.allclose(q, q[0])  # three identical legs at 120 deg
    # a changed file is a new robot; models made from the old text keep theirs
    m2 = Model(write(tmp_path, GOOD.replace("rod_length = 0.2", "rod_length = 0.21")))
    assert m2.param("leg[1].L") == 0.21 and m.param("leg[1].L") == 0.2


def test_defaults_and_parameter_sets(tmp_path):
    f = write(tmp_path, GOOD + '\n[defaults]\n"rail[2].coulomb" = 1.5\n\n[sets.heavy]\n"payload.m" = 0.4\n')
    m = Model(f)
    assert m.param("rail[2].coulomb") == 1.5 and m.param("payload.m") == 0.0
    h = Model(f, param_set="heavy")
    assert h.param("payload.m") == 0.4 and h.param("rail[2].coulomb") == 1.5
    assert m.facts.param_sets == ("default", "heavy")


BAD = [
    # (what, edit of GOOD, the line the error must name, words it must contain)
    ("unknown joint type", lambda s: s.replace('type = "P(SS)2"', 'type = "PXS"'), 11, ["PXS", "known", "UPS"]),
    ("negative length", lambda s: s.replace("rod_length = 0.2", "rod_length = -0.2"), 16, ["rod_length", "> 0"]),
    ("missing inertia", lambda s: s.replace("inertia = [1e-4, 1e-4, 2e-4]\n", ""), 6, ["inertia", "missing"]),
    ("mobility mismatch", lambda s: s.replace('"P(SS)2"', '"PSS"'), 3, ["Grubler-Kutzbach", "is 6", "3 coordinates"]),
    ("unreachable home", lambda s: s.replace("home = [0.0, 0.0, 0.2]", "home = [0.5, 0.0, 0.2]"), 4,
     ["home pose", "cannot reach", "leg 1", "line 10"]),
    ("architecture singularity at home", lambda s: s.replace("home = [0.0, 0.0, 0.2]", "home = [0.0, 0.0, 0.0]")
     .replace("rod_length = 0.2", "rod_length = 0.12"), 4, ["singularity", "home"]),
    ("typo in a field", lambda s: s.replace("slider_mass", "slidr_mass"), 15, ["slidr_mass", "known"]),
    ("syntax", lambda s: s.replace("mass = 0.1", "mass = 0.1 0.2"), 7, ["unexpected"]),
    ("inline table", lambda s: s.replace("mass = 0.1", "mass = {value = 0.1}"), 7, ["inline tables"]),
    ("not a number", lambda s: s.replace("mass = 0.1", 'mass = "heavy"'), 7, ["platform.mass", "number"]),
    ("unknown parameter in a set", lambda s: s + '\n[defaults]\n"rail[7].coulomb" = 1\n', 23, ["rail[7].coulomb",
                                                                                              "not a parameter"]),
    ("legs and coordinates", lambda s: s.replace("copies = 3", "copies = 2"), 10, ["2 legs", "3 coordinates"]),
    ("articulated platform in x y z", lambda s: s.replace("inertia = [1e-4, 1e-4, 2e-4]",
                                                            'inertia = [1e-4, 1e-4, 2e-4]\nkind = "articulated"'),
     3, ["articulated", "rz"]),
    ("unknown platform kind", lambda s: s.replace("inertia = [1e-4, 1e-4, 2e-4]",
                                                  'inertia = [1e-4, 1e-4, 2e-4]\nkind = "floppy"'),
     9, ["floppy", "rigid, articulated"]),
    ("unknown rod model", lambda s: s.replace("rod_length = 0.2", 'rod_length = 0.2\nrod_model = "bendy"'), 17,
     ["rod_model", "bendy", "uniform, lumped"]),
    ("redundant constraints beyond the count", lambda s: s.replace('home = [0.0, 0.0, 0.2]',
                                                                   'home = [0.0, 0.0, 0.2]\nredundant_constraints = 1'),
     3, ["Grubler-Kutzbach", "is 4", "+ 1 redundant", "3 coordinates"]),
    ("non-unit rail", lambda s: s.replace("rail_direction = [0.0, 0.0, 1.0]", "rail_direction = [0.0, 0.0, 2.0]"),
     14, ["rail_direction", "unit"]),
    # every non-finite spelling refused at its own line, here inside a multi-line array
    *[(f"{word} in an array", lambda s, w=word: s.replace("rail_origin = [0.15, 0.0, 0.0]",
                                                           f"rail_origin = [0.15,\n  0.0,\n  {w}]"), 15,
       [f"'{word}'", "not a finite number"]) for word in ("NaN", "NAN", "nan", "Inf", "-Infinity", "+inf", "INFINITY")],
    ("a range in [defaults]", lambda s: s + '\n[defaults]\n"platform.m" = 1e300\n', 23,
     ["platform.m = 1e+300 kg", "outside [0, 1000000]"]),
    ("a range in a set", lambda s: s + '\n[sets.heavy]\n"payload.m" = 0.1\n"rail[1].rotor_inertia" = -1\n', 24,
     ["rail[1].rotor_inertia = -1 kg", "outside"]),
    ("an unknown name's hint is a command that exists", lambda s: s + '\n[defaults]\n"rail[9].coulomb" = 1\n', 23,
     ["cosim params ", "lists them"]),
    ("an empty set name", lambda s: s + '\n[sets.]\n"payload.m" = 0.1\n', 22, ["set's name", "not empty"]),
    ("a set named default", lambda s: s + '\n[sets.default]\n"payload.m" = 0.1\n', 22, ["'default'"]),
    ("branch a hair off -1", lambda s: s.replace("branch = -1", "branch = -1.0000000001"), 19,
     ["branch = -1.0000000001"]),
    ("a C++ robot's name", lambda s: s.replace('name = "tiny_delta"', 'name = "fourbar"'), 2,
     ["robot.name 'fourbar'", "written in C++"]),
    ("a served robot's name", lambda s: s.replace('name = "tiny_delta"', 'name = "6pus"'), 2,
     ["robot.name '6pus'", "taken by the bundled", "6pus.toml"]),
    ("a bundled description's name", lambda s: s.replace('name = "tiny_delta"', 'name = "hexapod_ups"'), 2,
     ["robot.name 'hexapod_ups'", "taken by the bundled", "hexapod_ups.toml"]),
]


@pytest.mark.parametrize("what,edit,line,words", BAD, ids=[b[0] for b in BAD])
def test_bad_description_gives_one_clear_error(tmp_path, what, edit, line, words):
    msg = assert_one_clear_error(write(tmp_path, edit(GOOD)), line, words)
    assert "--robot" not in msg  # cosim params takes the file itself


def test_a_copy_of_a_bundled_description_keeps_its_name(tmp_path):
    f = write(tmp_path, (REPO / "robots" / "hexapod_ups.toml").read_text(), name="copy.toml")
    assert Model(f).robot == "hexapod_ups"


def test_unknown_robot_names_the_descriptions_and_paths():
    with pytest.raises(ArgumentError, match=r"unknown robot 'nope'.*linear_delta.*path to a description"):
        Model("nope")
    with pytest.raises(ArgumentError, match=r"cannot read robot description /no/such.toml"):
        Model("/no/such.toml")


def test_mangled_descriptions_never_crash(tmp_path):
    """600 random edits of a good description (bytes dropped, duplicated, swapped, numbers
    replaced by huge, tiny, negative or non-numbers): each loads or gives one PkmError line."""
    from cosim.errors import PkmError

    rng = np.random.default_rng(11)
    base = GOOD + '\n[defaults]\n"rail[2].coulomb" = 1.5\n'
    junk = ["1e308", "-1e308", "1e-320", "nan", "inf", "-0", '"x"', "[", "]", "[1, 2", "{", "=", "\n", "#", '"',
            "[[leg]]", "[robot]", "copies = 7", "type = \"UPS\"", "0x10", "1_000", "+", "\\"]
    loaded = refused = 0
    for k in range(600):
        s = list(base)
        for _ in range(rng.integers(1, 4)):
            i = int(rng.integers(0, len(s)))
            op = rng.integers(0, 4)
            if op == 0:
                del s[i:i + int(rng.integers(1, 8))]
            elif op == 1:
                s[i:i] = list(junk[int(rng.integers(0, len(junk)))])
            elif op == 2:
                j = int(rng.integers(0, len(s)))
                s[i], s[j] = s[j], s[i]
            else:
                s[i:i] = s[i:i + int(rng.integers(1, 20))]
        f = write(tmp_path, "".join(s), name=f"m{k}.toml")
        try:
            m = Model(f)
            m.ik(m.home())
            loaded += 1
        except PkmError as e:
            assert str(e) and "\n" not in str(e), repr(str(e))
            refused += 1
    assert loaded + refused == 600 and refused > 300


# Line by line: every value of a few descriptions (rails, arms, a P and an R axis, [defaults]
# and [sets.*]) replaced by a hostile one.  Each case loads (and then nothing it computes at
# home is NaN) or is refused naming the edited line; a value that is fine alone but breaks
# the robot as a whole (the home pose out of reach, a massless axis) is reported at the home
# line, naming the parameter set.
HOSTILE = ["NaN", "nan", "NAN", "-Infinity", "inf", "+Inf", "1e400", "-1e400", "1e300", "-1e300", "-1", "0", "1e-320",
           "-1.0000000001", '"x"', "[1, 2", "true", "[]", "1e6", "-0.0"]
CORPUS_BASES = {
    "tiny_delta": GOOD + '\n[defaults]\n"rail[2].coulomb" = 1.5\n"payload.m" = 0.01\n\n[sets.heavy]\n'
                         '"payload.m" = 0.4\n"rail[1].viscous" = 2.0\n',
    "emps": (REPO / "robots" / "emps.toml").read_text(),
    "pendulum": (REPO / "robots" / "pendulum.toml").read_text(),
    "planar_3rrr": (REPO / "robots" / "planar_3rrr.toml").read_text(),
}


def corpus_cases():
    import re

    value = re.compile(r'^(\s*"?[A-Za-z_][\w\[\].]*"?\s*=\s*)([^#\n]*?)(\s*(#.*)?)$')
    for base, text in CORPUS_BASES.items():
        # a copy named differently: the bundled descriptions' names are taken by their files
        text = re.sub(r'^name = "[^"]*"', f'name = "mangled_{base}"', text, count=1, flags=re.M)
        lines = text.split("\n")
        for i, line in enumerate(lines):
            m = value.match(line)
            if not m or not re.search(r"\d", m.group(2)):
                continue
            for junk in HOSTILE:
                v = m.group(2)
                # arrays: the first element replaced; numbers: the whole value
                new = ("[" + junk + v[v.index(",") :]) if v.startswith("[") and "," in v and junk[0] != "[" else junk
                out = lines[:i] + [m.group(1) + new + m.group(3)] + lines[i + 1 :]
                yield base, i + 1, "\n".join(out)


def test_mangled_values_are_refused_at_their_line_or_load_finite(tmp_path):
    import re
    import time

    from cosim._native import PkmError

    cases = list(corpus_cases())
    assert len(cases) >= 300
    loaded = refused = 0
    for k, (base, line, text) in enumerate(cases):
        f = write(tmp_path, text, name=f"v{k}.toml")
        home_line = next(i + 1 for i, l in enumerate(text.split("\n")) if l.startswith("home"))
        t0 = time.perf_counter()
        try:
            m = Model(f)
            x = m.home()
            xd = np.full(m.ndof, 0.01)
            out = [m.ik(x), m.inverse_dynamics(x, xd, xd), m.forward_dynamics(x, xd, np.zeros(m.ndof)),
                   np.array(m.energy(x, xd)), m.mass_matrix(x), np.array(list(m.params().values()))]
            assert all(np.all(np.isfinite(o)) for o in out), (base, line, text.split("\n")[line - 1])
            loaded += 1
        except PkmError as e:
            msg = str(e)
            at = int(re.match(re.escape(f) + r":(\d+): ", msg).group(1))
            ok = at == line or (at == home_line and "parameter set" in msg)
            assert ok, (base, line, text.split("\n")[line - 1], msg)
            assert "\n" not in msg
            refused += 1
        assert time.perf_counter() - t0 < 2.0, (base, line)
    assert refused > 0.8 * len(cases) and loaded > 0


def test_a_huge_description_is_refused_fast(tmp_path):
    """The reader is linear in its input: 200,000 keys in [defaults], 200,000 tables."""
    import time

    for extra, words in [("\n[defaults]\n" + "".join(f'"k{i}" = 1\n' for i in range(200000)), "'k0' is not a parameter"),
                         ("".join(f'\n[sets.s{i}]\n"payload.m" = 0.1\n' for i in range(200000)), "more than 1000")]:
        f = write(tmp_path, GOOD + extra)
        t0 = time.perf_counter()
        with pytest.raises(ArgumentError, match=words):
            Model(f)
        assert time.perf_counter() - t0 < 4.0  # 149 s for the keys with a quadratic duplicate check


def test_cosim_robots_lists_every_robot_with_its_file():
    import subprocess
    import sys

    p = subprocess.run([sys.executable, "-m", "cosim", "robots"], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    for name in ["6pus", "quattro", "fourbar", *LISTED]:
        assert any(line.split()[0] == name for line in p.stdout.splitlines() if line.strip()), name
    assert "robots/delta_clavel.toml" in p.stdout and "3 arms [rad]" in p.stdout and "(C++)" in p.stdout


@pytest.mark.parametrize("name", NEW)
def test_chain_points_draw_the_legs_the_kinematics_solve(name):
    """Base joint, moving joint and platform joint of each leg: a rod's length is L, the
    platform joints are the platform points, the base joints the description's."""
    m = Model(name)
    X, _, _ = samples(m, 5, seed=9)
    p = m.params()
    for x in X:
        c = m.chain_points(x)
        assert c.shape == (m.ndof, 3, 3)
        q = m.ik(x)
        for i in range(m.ndof):
            if f"leg[{i + 1}].L" not in p and m.facts.joint_prefix == "rail":  # a single P axis
                S0, s = (np.array([p[f"rail[{i + 1}].{k}{a}"] for a in "xyz"]) for k in ("S0", "s"))
                assert np.allclose(c[i, 1], S0 + q[i] * s, atol=1e-15) and np.allclose(c[i, 0], S0, atol=1e-15)
            elif m.facts.joint_prefix == "strut":
                assert np.linalg.norm(c[i, 2] - c[i, 0]) == pytest.approx(q[i], abs=1e-12)
                assert np.allclose(c[i, 0], [p[f"leg[{i + 1}].b{k}"] for k in "xyz"], atol=1e-15)
            else:
                assert np.linalg.norm(c[i, 2] - c[i, 1]) == pytest.approx(p[f"leg[{i + 1}].L"], abs=1e-12)
    from cosim.report import mechanism_figure

    fig = mechanism_figure(m, np.array([0.0, 1.0]), np.vstack([X[0], X[1]]))
    assert {t.name for t in fig.data} >= {"links", "legs", "platform"}


def test_the_four_bar_has_no_chain_points():
    """(The Quattro's chain points against the hand-written oracle's: oracle_quattro.py.)"""
    from cosim.errors import UnsupportedError

    with pytest.raises(UnsupportedError, match="chain points"):
        Model("fourbar").chain_points(Model("fourbar").home())


def test_robot_specific_functions_are_declared_by_the_core_not_by_the_name():
    """Capabilities come from the core (pkm_model_has): the 6-PUS served from its description
    has the 60-parameter calibration rows (robots/sixpus_facts.cpp: any described robot of six
    PUS legs over the whole pose), another rail robot does not, and asking a model for a
    function it lacks names the function and what the robot has."""
    from cosim.errors import UnsupportedError

    assert Model("6pus").facts.features == ("6pus_calib_rows", "6pus_leg_points")
    assert Model("quattro").has("quattro_indices")
    assert not Model("delta_clavel").has("quattro_indices")  # arms and rods, but a rigid platform
    assert Model("fourbar").has("fourbar_output") and not Model("hexapod_ups").facts.features
    m = Model("tripod_3prs")
    with pytest.raises(UnsupportedError, match="'6pus_calib_rows'.*'tripod_3prs' does not.*none"):
        m.calib_rows(m.home())
    with pytest.raises(UnsupportedError, match="'quattro_indices'.*6pus_calib_rows, 6pus_leg_points"):
        Model("6pus").quattro_indices(np.zeros((1, 4)))


def test_the_state_kept_for_the_last_pose_is_never_stale():
    """A pkm_data of a described robot keeps the legs' state of the last pose: calls that
    come back to a pose, follow a pose that failed or a parameter change give what a fresh
    model gives at that pose, to the bit."""
    a = Model("quattro")
    X, XD, XDD = samples(a, 3, seed=5)
    far = a.home() + np.array([5.0, 0, 0, 0])  # no leg reaches it

    def fresh(k, params=None):
        f = Model("quattro", params=params)
        return f.inverse_dynamics(X[k], XD[k], XDD[k]), f.mass_matrix(X[k]), f.jacobian(X[k])
    for k in [0, 1, 0, 2, 2, 1]:
        if k == 2:
            with pytest.raises(PkmError):
                a.inverse_dynamics(far, XD[k], XDD[k])
        for got, want in zip((a.inverse_dynamics(X[k], XD[k], XDD[k]), a.mass_matrix(X[k]), a.jacobian(X[k])),
                             fresh(k)):
            assert np.array_equal(got, want)
    a.set_params({"platform.m": 2 * a.param("platform.m")})
    for got, want in zip((a.inverse_dynamics(X[1], XD[1], XDD[1]), a.mass_matrix(X[1]), a.jacobian(X[1])),
                         fresh(1, {"platform.m": a.param("platform.m")})):
        assert np.array_equal(got, want)
    assert not np.array_equal(a.mass_matrix(X[1]), fresh(1)[1])


def test_the_hand_written_quattros_parameter_names_give_a_clear_error():
    """The served Quattro takes the description's names (docs/robots.md maps the hand-written
    model's to them): an old name is an unknown parameter, with the closest names and the
    command that lists them all."""
    from cosim.errors import ParameterError

    with pytest.raises(ParameterError, match=r"no parameter named 'joint\[1\]\.coulomb'; did you mean "
                                             r"arm\[1\]\.coulomb.*`cosim params quattro` lists"):
        Model("quattro").set_params({"joint[1].coulomb": 0.1})
    with pytest.raises(ParameterError, match=r"no parameter named 'gear\.ratio' \(`cosim params quattro`"):
        Model("quattro", params={"gear.ratio": 50.0})
