"""Adept Cycle times predicted by the torque-limited time-optimal model through the core,
against the measured Tables 6.1-6.5 (the only real robot data of the project)."""
import numpy as np
import pytest

from cosim.quattro import cycle_fit as cf
from cosim.quattro import cycle_time as ct
from cosim.core import Model


@pytest.fixture(scope="module")
def cmp61():
    return ct.compare(param_set="appendix_a", tables=["6.1"], n=200).table("6.1")


def test_measured_tables_are_loaded():
    meas = ct.load_measured()
    assert sorted(meas) == ["6.1", "6.2", "6.3", "6.4", "6.5"]
    t = meas["6.1"]
    assert t.cycle == "standard" and t.layout == "centred_x0" and len(t.z) == 15
    assert t.z[np.argmin(t.t10)] == pytest.approx(-1.000)


def test_table_6_1_minimum_height_within_50_mm(cmp61):
    # Acceptance: the predicted minimum within 50 mm of the measured one.
    assert abs(cmp61.z_min_pred - cmp61.z_min_meas) <= 0.050, cmp61.summary()


def test_table_6_1_rank_correlation_at_least_0_7(cmp61):
    assert cmp61.spearman >= 0.7, cmp61.summary()


def test_table_6_1_absolute_level_gap_is_reported_not_hidden(cmp61):
    # the controller's profile and settling set the level; the model is a
    # torque-limited optimum, so it must be well below the measurement.
    assert 2.0 < cmp61.level_ratio < 3.5, cmp61.summary()
    assert 0.3 < cmp61.predicted_t10.mean() / 10 < 0.5


def test_text_values_miss_the_measured_minimum():
    # The default set (platform 0.262 kg) predicts the fastest cycle near -1100 mm: it does
    # not reproduce Table 6.1.  Documented, and checked so it cannot change silently.
    c = ct.compare(param_set="default", tables=["6.1"], n=100).table("6.1")
    assert abs(c.z_min_pred - c.z_min_meas) > 0.050 or c.spearman < 0.7, c.summary()


def test_profile_respects_the_torque_limit_through_the_core():
    m = Model("quattro", "appendix_a")
    lim = 50 * 2.39  # N m: the s650H's gear ratio times its nominal motor torque (Virzi 2010 ch. 5.6)
    assert m.quattro_constants()["tau_arm_max"] == lim
    _, profs = ct.cycle_time(m, z=-1.0, detail=True, n=200)
    for p in profs:
        x = p.x0[None, :] + p.s[:, None] * p.u[None, :]
        xd = p.sd[:, None] * p.u[None, :]
        sdd = np.gradient(p.sd ** 2, p.s) / 2
        tau = m.inverse_dynamics(x, xd, sdd[:, None] * p.u[None, :])
        inner = slice(2, -2)  # the one-sided gradient at the ends is not the planned value
        assert np.abs(tau[inner]).max() <= lim * 1.02
        # Time-optimal: some arm is at its limit almost everywhere along the segment.
        sat = (np.abs(p.tau).max(axis=1) >= lim * (1 - 1e-6)).mean()
        assert sat > 0.9
        assert p.sd[0] == 0 and p.sd[-1] == 0


def test_planned_segment_replays_through_forward_dynamics():
    m = Model("quattro", "appendix_a")
    _, profs = ct.cycle_time(m, z=-1.0, detail=True, n=200)
    p = profs[0]  # the 25 mm lift
    t, x, tau = ct.simulate_segment(m, p, dt=2e-4)
    end = p.x0 + p.s[-1] * p.u
    assert np.allclose(x[-1, :3], end[:3], atol=2e-5)
    assert t[-1] == pytest.approx(p.duration)


def test_waypoints_follow_the_layout():
    m = Model("quattro", "appendix_a")
    w = ct.cycle_waypoints(m, -1.0, "standard", "start_x75")
    assert w.shape == (7, 4)
    path = np.sum(np.linalg.norm(np.diff(w[:, :3], axis=0), axis=1))
    assert path == pytest.approx(0.710)
    assert np.allclose(w[0], w[-1])
    with pytest.raises(ValueError, match="unknown layout"):
        ct.cycle_waypoints(m, -1.0, "standard", "diagonal")


# ------------------------------------------------ fitted cycle model 

@pytest.fixture(scope="module")
def fit_61_65():
    return cf.fit_cycle_model(fit_tables=("6.1", "6.5"), terms=("time_scale", "settle"), n=150)


@pytest.mark.parametrize("table", ["6.2", "6.3", "6.4"])
def test_fit_on_6_1_and_6_5_predicts_held_out_tables_within_1_5_percent(fit_61_65, table):
    # Measured tables the fit never saw; the baseline is the torque-limited model times one
    # time scale fitted on the same tables.
    assert fit_61_65.rms_pct[table] < 1.5, fit_61_65.summary()
    assert fit_61_65.rms_pct[table] < 0.5 * fit_61_65.scale_only_rms_pct[table], fit_61_65.summary()


@pytest.mark.parametrize("table", ["6.1", "6.2", "6.3", "6.4", "6.5"])
def test_fitted_model_keeps_the_trend_and_the_fastest_height(fit_61_65, table):
    meas, model = fit_61_65.measured[table], fit_61_65.model_t10[table]
    assert ct.spearman(model, meas.t10) >= 0.85, fit_61_65.summary()
    assert abs(meas.z[np.argmin(model)] - meas.z[np.argmin(meas.t10)]) <= 0.025 + 1e-9, fit_61_65.summary()


def test_fitted_cycle_parameters_are_the_linear_least_squares_and_carry_intervals(fit_61_65):
    # Oracle: the model of a row is linear in its two terms, 10 (scale S + 6 settle) with S
    # the torque-limited cycle, and the fit minimises the relative errors: numpy's linear
    # least squares on the same rows gives the same two numbers (scipy's iterative fit).
    f = fit_61_65
    rows = [np.column_stack([f.torque_limited_t10[t], np.full(len(f.measured[t].t10), 60.0)])
            / f.measured[t].t10[:, None] for t in ("6.1", "6.5")]
    scale, settle = np.linalg.lstsq(np.vstack(rows), np.ones(sum(len(r) for r in rows)), rcond=None)[0]
    assert f.params["time_scale"] == pytest.approx(scale, rel=1e-6), f.summary()
    assert f.params["settle"] == pytest.approx(settle, rel=1e-4), f.summary()
    assert settle > 0.0  # a settling at each stop, not a negative one
    assert f.peak_speed < 10.0 and f.peak_acceleration < 150.0, f.summary()  # datasheet
    for k, v in fit_61_65.params.items():
        lo, hi = fit_61_65.intervals[k]
        assert lo < v < hi and (hi - lo) < 0.4 * v, (k, v, lo, hi)


def test_aic_keeps_settling_and_leaves_the_torque_fraction_out_on_6_1_and_6_5():
    fit = cf.select_cycle_model(fit_tables=("6.1", "6.5"), n=100)
    assert fit.terms == ("time_scale", "settle"), fit.summary()
    assert fit.candidates[("time_scale",)] > fit.aic + 10, fit.summary()     # settling pays for itself
    assert "left out (the data do not support it): torque_fraction" in fit.summary()


def test_fit_on_6_1_alone_rules_out_the_settling_the_extended_cycle_needs_and_says_so():
    # Table 6.1's height dependence is steeper than the torque-limited model's, which argues for a pure
    # stretch: the profile-likelihood interval of the per-stop settling ends below 47 ms (what 6.1 + 6.5
    # find), so the extended cycle is missed by ~11 % (the shortfall the docs report).  The fit must say
    # that table 6.5 is an extrapolation and that its band of predictions excludes the measurement.
    fit = cf.select_cycle_model(fit_tables=("6.1",), n=100, terms=("time_scale", "settle"))
    assert fit.terms == ("time_scale",), fit.summary()
    assert fit.rms_pct["6.5"] > 5.0, fit.summary()
    both = cf.fit_cycle_model(fit_tables=("6.1",), terms=("time_scale", "settle"), n=100)
    assert both.interval_method == "profile likelihood"
    lo, hi = both.intervals["settle"]
    assert lo == 0.0 and 0.005 < hi < 0.03, both.summary()
    assert both.held_out_band["6.5"][0] > 5.0, both.summary()          # the measurement is outside
    assert "6.5" in both.extrapolated and "40/700/40 mm" in both.extrapolated["6.5"]
    assert "extrapolated" in both.summary() and "EXCLUDES the measurement" in both.summary()


def test_held_out_bands_of_the_6_1_and_6_5_fit_cover_table_6_2(fit_61_65):
    assert fit_61_65.interval_method == "profile likelihood"
    assert not fit_61_65.extrapolated, fit_61_65.extrapolated        # both cycles are in the fit
    lo, hi = fit_61_65.held_out_band["6.2"]
    assert lo < 0.0 < hi and hi - lo < 2.0, fit_61_65.summary()


def test_fit_cycle_model_rejects_unknown_terms_and_tables():
    with pytest.raises(ValueError, match="unknown cycle-model term 'jerk'"):
        cf.fit_cycle_model(terms=("jerk",))
    with pytest.raises(ValueError, match="'7.1' is not among the measured tables"):
        cf.fit_cycle_model(fit_tables=("7.1",))
