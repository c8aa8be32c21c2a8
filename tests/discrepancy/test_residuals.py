"""The residual pipeline against closed-loop runs of the core plant.

The plant is integrated by the core's simulator with its drive and sensor
models; the pipeline runs the core's kinematics and inverse dynamics on the recorded
signals.  Two independent paths through the core: they agree when the pipeline
models an effect the way the plant holds it.
"""
import copy

import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy import DiagnosisError, diagnose
from cosim.discrepancy.effects import groups_for
from cosim.discrepancy.residuals import Pipeline
from cosim.discrepancy.engine import prepare
from cosim.discrepancy.regressors import LINEAR, LOCAL
from cosim.recording import Recording, RecordingError, write_recording

from disc_helpers import COMBINED, rms


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_clean_noiseless_run_leaves_round_off(clean_runs, robot):
    rec = clean_runs[robot]
    p = Pipeline(rec, Model(robot))
    r = p.evaluate({})
    effort = rms(p.tau_s[p.idx])
    # The central-difference acceleration and the zero-order-hold effort are exact
    # counterparts: what is left is integration error (rtol 1e-9) and smoothing
    # round-off, far below any effect of the library.
    assert np.all(rms(r.eff) < 2e-5 * effort.max()), rms(r.eff) / effort
    assert np.all(rms(r.kin) < 1e-9)


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_every_effect_is_modelled_as_the_plant_holds_it(combined_runs, robot):
    """A plant holding many effects at once: with the true parameters the residual
    falls by orders of magnitude, and leaving out any one effect brings it back."""
    rec = combined_runs[robot]
    hidden = COMBINED[robot]
    p = Pipeline(rec, Model(robot))
    R0 = p.evaluate({}).stack()
    Rt = p.evaluate(hidden).stack()
    floor = np.concatenate([1e-4 * rms(p.tau_s[p.idx]), np.full(p.nd, 1e-8)])
    true = np.maximum(rms(Rt), floor)
    assert np.all(rms(R0)[: p.nd] > 50 * true[: p.nd]), (rms(R0), rms(Rt))
    for name in hidden:
        if name.endswith("stribeck_v"):
            continue
        h = {k: v for k, v in hidden.items() if k != name and not (name.endswith(".stribeck") and k == name + "_v")}
        change = rms(p.evaluate(h).stack() - Rt) / true
        assert change.max() > 5, f"leaving out {name} changes the residual by only {change.max():.2f} x its floor"


@pytest.fixture(scope="module")
def engine_6pus(clean_runs):
    rec = clean_runs["6pus"]
    m = Model("6pus")
    p = Pipeline(rec, m)
    groups, _ = groups_for(m, True)
    return prepare(p, groups)


def test_linear_regressors_match_central_differences(engine_6pus):
    """The columns of the effects the residual is linear in are one-sided differences at
    the nominal model; central differences of the pipeline about another point (the
    core refuses a negative friction, so not about zero) give the same slope."""
    e = engine_6pus
    for lab, opts in e.options.items():
        g = opts[0].group
        if g.key not in LINEAR:
            continue
        for j, name in enumerate(g.params):
            h = 0.5 * e.step(g, name)
            nom = e.nominal[name]
            sgn = 1.0 if g.effect.sign == ">=0" else -1.0  # Izz + 3h would break Ixx + Iyy >= Izz
            central = (e.R({name: nom + 3 * sgn * h}) - e.R({name: nom + sgn * h})) / (2 * sgn * h)
            if g.key in LOCAL:
                keep = np.zeros(e.C, bool)
                keep[e.channels(g)] = True
                if g.effect.family == "kinematic":
                    keep[: e.nd] = True  # the pose the dynamics is evaluated at moves too
                central[:, ~keep] = 0.0
            col = opts[0].cols[:, :, j]
            scale = np.abs(central).max()
            assert scale > 0, lab
            # 1e-3: the pose a sensor error moves enters the dynamics at second order
            np.testing.assert_allclose(col, central, atol=1e-3 * scale, err_msg=f"{lab} {name}")


def test_drive_parameters_act_on_their_own_joint(engine_6pus):
    e = engine_6pus
    for key in ("coulomb", "rotor_inertia", "viscous"):
        d = e.R({f"rail[2].{key}": 0.05}) - e.R0
        moved = rms(d)
        assert moved[1] > 0
        assert np.all(moved[[0, 2, 3, 4, 5]] == 0), (key, moved)


def _rec(n=3000, dt=1e-3, robot="6pus"):
    m = Model(robot)
    x = np.tile(m.home(), (n, 1))
    t = np.arange(n) * dt
    x[:, 0] += 0.005 * np.sin(2 * np.pi * t)
    q = m.ik(x)
    qd = np.gradient(q, dt, axis=0)
    return Recording(robot, t, q, qd, m.gravity_load(x))


def test_too_short_recording_says_how_many_samples_are_needed():
    with pytest.raises(DiagnosisError, match=r"too few.*at least \d+ samples"):
        diagnose(_rec(n=80))


def test_non_uniform_sampling_is_refused():
    rec = _rec()
    rec.time = rec.time.copy()
    rec.time[1000:] += 0.0004
    with pytest.raises(DiagnosisError, match="not uniform.*rows 1001-1002"):
        diagnose(rec)


def test_standstill_recording_cannot_excite_anything():
    rec = _rec()
    m = Model("6pus")
    rec.q = np.tile(m.ik(m.home()), (len(rec.time), 1))
    rec.qd = np.zeros_like(rec.q)
    rec.tau = np.tile(m.gravity_load(m.home()), (len(rec.time), 1))
    with pytest.raises(DiagnosisError, match="do not move"):
        diagnose(rec)


def test_robot_without_dynamics_is_refused():
    n = 3000
    rec = Recording("fourbar", np.arange(n) * 1e-3, np.full((n, 1), 0.6), np.zeros((n, 1)), np.zeros((n, 1)))
    with pytest.raises(DiagnosisError, match="no inverse dynamics"):
        diagnose(rec)


def test_model_of_another_robot_is_refused():
    with pytest.raises(DiagnosisError, match="model of 'quattro'"):
        diagnose(_rec(), Model("quattro"))


def test_malformed_file_names_file_row_and_column(tmp_path):
    csv, _ = write_recording(tmp_path / "r.csv", _rec(n=400))
    lines = csv.read_text().splitlines()
    lines[0] = lines[0].replace("tau3", "tauX")
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=r"r.csv, row 1, column 'tau3'.*missing"):
        diagnose(csv)
    lines = csv.read_text().splitlines()
    lines[0] = lines[0].replace("tauX", "tau3")
    lines[7] = lines[7].replace(lines[7].split(",")[2], "nan", 1)
    csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match="row 8"):
        diagnose(csv)


def test_kinematic_effects_need_tracker_columns(clean_runs):
    rec = copy.copy(clean_runs["6pus"])
    rec.pose = None
    d = diagnose(rec, replay=False)
    text = " ".join(d.unavailable)
    for name in ("encoder offset", "backlash", "joint elasticity", "geometric"):
        assert name in text
    assert "tracker pose columns" in text
    assert d.conclusion == "no missing physics found"
