"""6-PUS calibration, whole robot (Tiberi 2020 ch. 4): derivatives, recovery of the
identifiable combinations within 3 standard errors, accuracy gain on held-out poses,
bad data.  A "real" robot is a core model with random geometric errors (fixed seeds)."""
import warnings

import numpy as np
import pytest

from cosim.calibration import calibrate, measurements, problem_from_recording
from cosim.calibration.data import (candidate_poses, joint_campaign, read_truth, real_params,
                                    write_campaign)
from cosim.calibration.joint_problem import JointProblem
from cosim.calibration.problems import CalibrationDataError, CalibrationWarning
from cosim.core import Model
from cosim.recording import Recording, RecordingError, read_recording, write_recording

#: Tiberi 2020's workspace without rotations (pure translations)
NO_ROTATION = {"rx_deg": [0.0, 0.0], "ry_deg": [0.0, 0.0], "rz_deg": [0.0, 0.0]}


@pytest.fixture(scope="module")
def nominal():
    return Model("6pus")


@pytest.fixture(scope="module")
def campaign(nominal, tmp_path_factory):
    """120 held poses of a real robot with errors up to 0.5 mm / 0.5 deg, 10 um tracker."""
    real = real_params(nominal, max_length=0.5e-3, max_angle_deg=0.5, rng=20240501)
    poses = candidate_poses(nominal, 120, rng=7)
    rec = joint_campaign(Model("6pus"), real, poses, tracker_noise=10e-6, rng=11)
    path, _, _ = write_campaign(tmp_path_factory.mktemp("cal") / "campaign.csv", rec, real)
    return path, real


def _quiet(f, *a, **k):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        return f(*a, **k)


def test_generator_makes_the_specified_real_robot(nominal, campaign):
    path, real = campaign
    assert read_truth(path)["real_parameters"] == pytest.approx(real)
    rec = read_recording(path)
    assert rec.parameters == {}  # the sidecar names the nominal model, not the truth
    assert len(rec) == 120 and rec.pose is not None
    for i in range(1, 7):
        for n in ("px", "py", "pz", "L"):
            d = real[f"leg[{i}].{n}"] - nominal.param(f"leg[{i}].{n}")
            assert abs(d) <= 0.5e-3
        for n in ("S0x", "S0y", "S0z"):
            assert abs(real[f"rail[{i}].{n}"] - nominal.param(f"rail[{i}].{n}")) <= 0.5e-3
        s = np.array([real[f"rail[{i}].s{c}"] for c in "xyz"])
        s0 = np.array([nominal.param(f"rail[{i}].s{c}") for c in "xyz"])
        assert np.linalg.norm(s) == pytest.approx(1.0, abs=1e-12)
        assert np.degrees(np.arccos(np.clip(s @ s0, -1, 1))) <= 0.5 + 1e-9


def test_jacobian_matches_central_differences_of_the_core(nominal):
    x = candidate_poses(nominal, 15, rng=3)
    P = _quiet(JointProblem, x, nominal.ik(x), nominal)
    p = P.p0 + np.random.default_rng(0).uniform(-3e-4, 3e-4, P.p0.size)
    J = P.jacobian(p)
    h = 1e-7
    Jfd = np.empty_like(J)
    for j in range(p.size):
        e = np.zeros(p.size)
        e[j] = h
        Jfd[:, j] = (P.predict(p + e) - P.predict(p - e)) / (2 * h)
    np.testing.assert_allclose(J, Jfd, atol=2e-7 * np.abs(J).max())


def test_error_model_columns_are_the_seeds_unconstrained_derivatives(nominal):
    # the 60 columns, |s| not kept: the core takes s as given within 1e-6 of unit length
    x = candidate_poses(nominal, 6, rng=4)
    P = _quiet(JointProblem, x, nominal.ik(x), nominal, min_poses=1)
    J60 = P.error_model_jacobian()
    work = P.working_model()
    names = P.error_model.parameters  # robots/calibration/6pus.toml: Tiberi 2020 eq. 4.1, leg by leg
    assert len(names) == 60 and P.error_model.source.startswith("Tiberi 2020")
    base = {n: work.param(n) for n in names}
    h = 1e-7
    for j, n in enumerate(names):
        qs = []
        for sgn in (1, -1):
            m = work.copy()
            m.set_params({n: base[n] + sgn * h})
            qs.append(m.ik(x).reshape(-1))
        np.testing.assert_allclose(J60[:, j], (qs[0] - qs[1]) / (2 * h), atol=1e-6, err_msg=n)
    # the radial rail-direction combination is the stroke scale: column . s = -q
    for i in range(6):
        s = np.array([base[f"rail[{i + 1}].s{c}"] for c in "xyz"])
        np.testing.assert_allclose(J60[i::6, 10 * i + 7:10 * i + 10] @ s, -P.q[:, i], rtol=1e-12)


@pytest.fixture(scope="module")
def structural(campaign):
    return _quiet(calibrate, campaign[0], holdout=0.25, model="structural", seed=1)


@pytest.fixture(scope="module")
def full(campaign):
    return _quiet(calibrate, campaign[0], holdout=0.25, model="full", seed=1)


def _true_delta(res, real):
    P = res.problem
    return dict(zip(P.names, np.array([real[n] for n in P.names]) - P.p0))


def test_every_identifiable_combination_within_3_standard_errors(structural, campaign):
    res, real = structural, campaign[1]
    s = res.solution
    want = res.identifiability.combination_values(_true_delta(res, real))
    z = np.array([(s.dp[j] - want[n]) / s.se[j] for j, n in enumerate(s.names) if s.free[j]])
    assert s.free.sum() >= 40 and s.converged
    assert np.all(np.abs(z) < 3), f"worst |z| = {np.abs(z).max():.2f}"
    # the standard errors are honest: the spread of z is about 1 (not 0.1, not 10)
    assert 0.5 < np.sqrt(np.mean(z ** 2)) < 1.6


def test_all_parameters_within_3_standard_errors_with_the_full_model(full, campaign):
    res, real = full, campaign[1]
    s = res.solution
    d = _true_delta(res, real)
    z = np.array([(s.dp[j] - d[n]) / s.se[j] for j, n in enumerate(s.names)])
    assert s.free.all() and s.converged
    assert np.all(np.abs(z) < 3), f"worst |z| = {np.abs(z).max():.2f}"


@pytest.mark.parametrize("kind", ["structural", "full"])
def test_held_out_accuracy_improves_at_least_10x(kind, structural, full):
    res = structural if kind == "structural" else full
    a = res.holdout_accuracy
    assert a.n == 30 and not a.excluded
    assert a.position[0] > 10 * a.position[1], f"{a.position}"
    assert a.joint[0] > 10 * a.joint[1]
    assert "held-out poses (30)" in res.text()


def test_accuracy_against_the_truth_without_tracker_noise(nominal, full, campaign):
    # independent of the recording: true poses, the real robot's joints, FK of each model
    real = Model("6pus", params=campaign[1])
    x = candidate_poses(nominal, 40, rng=99)
    q = real.ik(x)
    err = []
    for m in (nominal, full.calibrated_model()):
        xf = m.fk(q, x_guess=x)
        err.append(np.sqrt(np.mean(np.sum((xf[:, :3] - x[:, :3]) ** 2, axis=1))))
    assert err[0] > 10 * err[1], err


def test_solvers_agree_on_the_same_problem(campaign):
    P = _quiet(problem_from_recording, campaign[0])
    from cosim.calibration.solvers import solve

    ref = solve(P, "gauss-newton")
    for method in ("pinv-iter", "lm"):
        s = solve(P, method)
        assert np.max(np.abs(s.p - ref.p) / ref.se) < 1e-3, method
    one = solve(P, "pinv")
    assert one.cost[-1] < 0.05 * one.cost[0]  # one step already removes most of the error


def test_too_few_poses_is_an_error(nominal):
    x = candidate_poses(nominal, 5, rng=1)
    rec = joint_campaign(Model("6pus"), real_params(nominal, rng=2), x, rng=3)
    with pytest.raises(CalibrationDataError, match="too few poses: 5 usable pose"):
        calibrate(rec)


@pytest.mark.filterwarnings("ignore:no pose held out")
def test_rank_deficient_pose_set_warns_or_refuses(nominal):
    # pure translations: with R = I the platform point and the rail origin move together
    x = candidate_poses(nominal, 30, rng=5, workspace=NO_ROTATION)
    rec = joint_campaign(Model("6pus"), real_params(nominal, rng=6), x, tracker_noise=0.0, angle_noise=0.0, rng=7)
    with pytest.warns(CalibrationWarning, match="rank-deficient: the measurements determine only 6 of 9"):
        res = calibrate(rec)
    for b in res.identifiability.blocks:
        assert len(b.null_space) == 3
        assert all(len(v) == 2 and {n.split(".")[-1] for n in v} in ({"px", "S0x"}, {"py", "S0y"}, {"pz", "S0z"})
                   for v in b.null_space)
    with pytest.raises(CalibrationDataError, match="rank-deficient pose set"):
        _quiet(calibrate, rec, model="full")


@pytest.mark.filterwarnings("ignore:no pose held out")
def test_nearly_rank_deficient_pose_set_warns(nominal):
    # the same with tracker noise: the measured rotations are not exactly zero, so the
    # matrix has full rank, with singular values at the noise level
    x = candidate_poses(nominal, 30, rng=5, workspace=NO_ROTATION)
    rec = joint_campaign(Model("6pus"), real_params(nominal, rng=6), x, rng=7)
    with pytest.warns(CalibrationWarning, match=r"nearly rank-deficient: 3 direction\(s\)") as rec_w:
        calibrate(rec)
    msg = next(str(w.message) for w in rec_w if "nearly" in str(w.message))
    assert "S0" in msg and "p" in msg


def test_nan_in_a_recording_is_named_by_row_and_column(campaign, tmp_path):
    text = open(campaign[0]).read().splitlines()
    cells = text[5].split(",")
    cells[3] = "nan"
    text[5] = ",".join(cells)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(text) + "\n")
    (tmp_path / "bad.json").write_text(open(str(campaign[0]).replace(".csv", ".json")).read())
    with pytest.raises(RecordingError, match=r"row 6, column 'tau1'"):
        calibrate(bad)


def test_nan_in_arrays_is_named_by_row_and_column(nominal):
    x = candidate_poses(nominal, 12, rng=8)
    q = nominal.ik(x)
    x[4, 2] = np.nan
    with pytest.raises(CalibrationDataError, match="row 4, column 'z'"):
        JointProblem(x, q, nominal)


@pytest.mark.filterwarnings("ignore:no pose held out")
def test_unreachable_pose_is_dropped_with_a_warning_naming_it(nominal):
    x = candidate_poses(nominal, 20, rng=9)
    rec = joint_campaign(Model("6pus"), real_params(nominal, rng=10), x, rng=11)
    rec.pose[3] = [0.0, 0.0, 0.5, 0.0, 0.0, 0.0]  # 0.5 m up: no leg reaches
    with pytest.warns(CalibrationWarning, match=r"row 5 \(t = 3 s\).*cannot reach"):
        res = calibrate(rec, holdout=0.0)
    assert res.calibration_accuracy.n == 19


def test_recording_without_pose_columns_is_an_error(nominal, tmp_path):
    rec = Recording("6pus", np.arange(3.0), np.zeros((3, 6)), np.zeros((3, 6)), np.zeros((3, 6)))
    path, _ = write_recording(tmp_path / "nopose.csv", rec)
    with pytest.raises(CalibrationDataError, match="no pose columns"):
        calibrate(path)


def test_labelled_recording_uses_one_measurement_per_hold(nominal):
    x = candidate_poses(nominal, 12, rng=12)
    real = real_params(nominal, rng=13)
    # each pose held for 20 samples; 5 samples of motion (label 0) in between
    rows_x, rows_lab = [], []
    for k in range(12):
        rows_x += [x[k]] * 20
        rows_lab += [k + 1] * 20
        if k < 11:
            for t in np.linspace(0, 1, 7)[1:-1]:
                rows_x.append((1 - t) * x[k] + t * x[k + 1])
                rows_lab.append(0)
    rec = joint_campaign(Model("6pus"), real, np.array(rows_x), tracker_noise=10e-6, rng=14, dwell=1e-3)
    rec.extra["label"] = np.array(rows_lab, float)
    meas = measurements(rec)
    assert meas.averaged and len(meas) == 12
    # averaging the settled half (10 samples) of each hold divides the tracker noise
    err = meas.pose[:, :3] - x[:, :3]
    assert np.sqrt(np.mean(err ** 2)) < 10e-6 / np.sqrt(10) * 2
    assert len(measurements(rec, use="rows")) == len(rows_x)
    res = _quiet(calibrate, rec)
    assert "12 held poses" in res.text()


def test_standard_errors_are_calibrated_over_campaigns(nominal):
    # Over independent campaigns (fixed seeds) the errors in units of their standard
    # error spread like a standard normal: the SEs are neither optimistic nor padded.
    z = []
    for k in range(5):
        real = real_params(nominal, rng=500 + k)
        rec = joint_campaign(Model("6pus"), real, candidate_poses(nominal, 80, rng=600 + k), rng=700 + k)
        res = _quiet(calibrate, rec, model="full")
        d = _true_delta(res, real)
        z += [(res.solution.dp[j] - d[n]) / res.solution.se[j] for j, n in enumerate(res.solution.names)]
    z = np.abs(np.array(z))
    assert len(z) == 270
    assert 0.8 < np.sqrt(np.mean(z ** 2)) < 1.25
    assert np.mean(z > 2) < 0.10 and np.mean(z > 3) < 0.02
