"""A real recording end to end: the EMPS drive (data/emps/, docs/emps.md), imported as it comes and
diagnosed from a nominal description (robots/emps.toml: a round 90 kg moving mass, no friction, no
offset), fitted on the first 60 % of the file and judged on the rest.

The expected values are the benchmark's published model (Janot, Gautier, Brunot 2019, identified
by its authors with another method, IDIM-LS on the whole file; docs/references.md), not anything
this code computed: M = 95.1089 kg, Fv = 203.5034 N s/m, Fc = 20.3935 N, OF = -3.1648 N, written
M qdd = tau - Fv qd - Fc sgn(qd) - OF, so the core's offset (the drive supplies ID + friction +
offset) is OF itself."""
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy import diagnose
from cosim.importing import import_recording

DATA = Path(__file__).resolve().parents[2] / "data" / "emps"
PUBLISHED = {"M": 95.1089, "rail[1].viscous": 203.5034, "rail[1].coulomb": 20.3935, "rail[1].offset": -3.1648}


@pytest.fixture(scope="module")
def emps(tmp_path_factory):
    out = tmp_path_factory.mktemp("emps")
    res = import_recording(DATA / "DATA_EMPS.mat", DATA / "emps_map.toml", out, progress=False)
    # the default diagnosis, the discovery step included
    return diagnose(res.table, train_fraction=0.6, compare=["reference"], figures=False)


def _param(d, name):
    for e in d.effects:
        if name in e["params"]:
            return e["params"][name]
    raise AssertionError(f"{name} not fitted: {d.conclusion}")


def test_the_nominal_model_is_corrected_to_the_published_one(emps):
    d = emps
    assert not d.warnings, d.warnings
    named = d.named()
    for key in ("viscous", "offset"):
        assert key in named, d.conclusion
    assert "platform_mass" in named or "rotor_inertia" in named, d.conclusion
    # the moving mass: the platform's plus the axis's rotor inertia (the same physics on one axis)
    th = d.plant_parameters()
    mass = th.get("platform.m", 90.0) + th.get("rail[1].rotor_inertia", 0.0)
    assert abs(mass - PUBLISHED["M"]) < 0.03 * PUBLISHED["M"], mass
    p = _param(d, "rail[1].viscous")
    assert abs(p["value"] - PUBLISHED["rail[1].viscous"]) < 0.03 * PUBLISHED["rail[1].viscous"], p
    # the interval carries the friction's spread over the recording's windows (the rig's viscous
    # friction is 194 N s/m on the first 60 % of the file and 209 on the rest, docs/emps.md) and
    # over its speed bands (a friction law of another shape than the model's: 28 N s/m from the
    # windows, 32 with the bands): it holds the published value and stays below 20 %
    assert 0 < p["ci95"] < 0.20 * p["value"], p
    assert abs(p["value"] - PUBLISHED["rail[1].viscous"]) <= p["ci95"], p
    off = _param(d, "rail[1].offset")
    assert abs(off["value"] - PUBLISHED["rail[1].offset"]) < 0.5, off
    assert 0 < off["ci95"] < 1.0, off
    # The friction the fitted plant puts against the motion (the core's inverse dynamics at zero
    # acceleration: the library's friction and the discovered terms), its part odd in the speed,
    # against the published Fv v + Fc at the speeds the carriage moves at (the 10th-99th
    # percentiles of |qd|: 0.035-0.125 m/s)
    m = Model("emps", params=th)
    x = np.array([0.12])

    def force(v):
        return float(m.inverse_dynamics(x, np.array([v]), np.array([0.0]))[0])

    for v in (0.02, 0.035, 0.05, 0.08, 0.1, 0.125):
        want = PUBLISHED["rail[1].viscous"] * v + PUBLISHED["rail[1].coulomb"]
        odd = 0.5 * (force(v) - force(-v))
        assert abs(odd - want) < 0.03 * want, (v, odd, want)


def test_the_mass_is_a_tie_of_the_platform_and_the_rotor(emps):
    d = emps
    first = next(e for e in d.effects if e["key"] in ("platform_mass", "rotor_inertia"))
    other = "rotor_inertia" if first["key"] == "platform_mass" else "platform_mass"
    assert other in d.ties(first["key"]), first["lookalikes"]


def _replay_errors(d):
    runs = d.replay["runs"]
    return {name: runs[name]["rel_tau"][0] for name in ("nominal", "fitted", "reference")}


def _held_out(d):
    """The recorded effort of the held-out part and each replay's difference to it."""
    from cosim.recording import read_recording

    rec = read_recording(d.recording)
    k0 = int(np.argmin(np.abs(rec.time - d.replay["start"])))
    y = rec.tau[k0:, 0]
    return y, {name: d.replay["runs"][name]["tau"][:, 0] - y for name in ("nominal", "fitted", "reference")}


def test_the_replay_starts_where_the_rig_was(emps):
    """The held-out replay starts from the recorded state with the rig's controller primed by
    the recorded readings: no start transient (a controller at rest outputs nothing for its
    delay sample and sees no velocity: a kick of 350 N on this rig).  Its first 20 ms are no
    further from the recorded force than the replay on average."""
    y, err = _held_out(emps)
    for name in ("fitted", "reference"):
        e = err[name]
        assert np.sqrt(np.mean(e[:20] ** 2)) < np.sqrt(np.mean(e ** 2)), (name, e[:20])


def test_the_fitted_model_replays_the_held_out_force_far_better_than_the_nominal_one(emps):
    err = _replay_errors(emps)
    assert err["nominal"] > 10 * err["fitted"], err


def test_the_fitted_model_replays_the_held_out_force_no_worse_than_the_published_one(emps):
    """The fitted model (first 60 %: the library's effects and the friction the discovery step
    finds) against the published model (whole file) in the same loop on
    the held-out 40 %, the nominal one far behind."""
    err = _replay_errors(emps)
    assert err["fitted"] <= err["reference"] < err["nominal"] / 10, err


def test_the_discovered_term_is_a_friction_that_builds_up_over_a_velocity_scale(emps):
    """On this rig the discovery step finds the friction building up over a speed range (levels
    through tanh(qd / v), v fitted) and withdraws the library's sharp Coulomb friction, which fits
    the held-out part significantly worse; the direction-split viscous increments on the named
    viscous friction keep every total positive."""
    (w,) = emps.withdrawn
    assert w["effect"] == "Coulomb friction", w
    assert w["gain"] > w["bar"] and w["gain"] > 1.645 * w["se"], w
    (term,) = emps.discovered
    assert "fading" in term.terms, term.equation
    th = emps.plant_parameters()
    v = th["rail[1].force_cv"]
    assert 0 < v - term.shape_ci95["rail[1].force_cv"] and v < 0.01, term.equation  # below 10 mm/s, resolved
    assert th["rail[1].force_cpos"] > 0 and th["rail[1].force_cneg"] > 0, term.equation
    pos, neg = th.get("rail[1].force_vpos", 0.0), th.get("rail[1].force_vneg", 0.0)
    assert th["rail[1].viscous"] + min(pos, neg) > 0, term.equation


def test_the_conclusion_is_a_short_paragraph_that_says_first_how_sure_it_is(emps):
    # the conclusion is one short paragraph whose first words say how sure it is, consistent with
    # the body; the full statement follows it in the details
    c = emps.conclusion
    assert c.split(":")[0] in ("found with confidence", "most likely, tied with another explanation",
                               "structure left, not named"), c
    assert "\n" not in c and len(c) < 600, (len(c), c)
    assert emps.details and len(emps.details) > len(c)
    # the paragraph and the details agree: structure left in one is structure left in the other, and
    # then nothing is named with confidence in either
    left = "structure left unexplained" in emps.details
    assert left == c.startswith("structure left, not named"), (c, emps.details)
    if left:
        said = ("not named as the physics" in emps.details or "none named with confidence" in emps.details
                or "no effect of the library explains" in emps.details)
        assert "found with confidence" not in c and said, emps.details
    else:
        assert ("tie:" in emps.details) == c.startswith("most likely"), (c, emps.details)
