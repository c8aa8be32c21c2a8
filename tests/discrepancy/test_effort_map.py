"""Two effort channels: the core's command-to-effort map (pkm_effort_map) and its fit.

Oracles: the first-order lag's step response in closed form (1 - exp(-t / T)) for the
core's map; the known parameters of a synthetic drive for the fit (the measured channel
made by the core's map from the commanded effort of a core closed loop, plus white noise
of known size); for the diagnosis, the nominal model the plant was simulated with.
"""
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim.closed_loop import ClosedLoop
from cosim.core import Model, effort_map
from cosim.discrepancy.effort_map import fit_effort_map
from cosim.errors import ArgumentError
from cosim.master import ReferenceTable
from cosim.plants import CorePlant
from cosim.recording import Recording

H = 1e-3


def test_the_core_map_is_the_first_order_step_response_in_closed_form():
    g, o, T = 0.55, 0.02, 7e-3
    k = np.arange(200)
    y = effort_map(np.ones(200), H, gain=g, offset=o, lag=T)
    np.testing.assert_allclose(y, (g + o) * (1 - np.exp(-(k + 1) * H / T)), rtol=1e-12, atol=1e-15)
    y = effort_map(np.full(5, 10.0), H, gain=1.0, offset=0.5, limit=3.0)  # no lag: clip, then the offset
    np.testing.assert_array_equal(y, 3.5)
    y = effort_map([0.0, 2.0], H, lag=T, y0=1.0)
    assert y[0] == pytest.approx(np.exp(-H / T))


def test_a_non_finite_command_or_a_negative_lag_is_refused_naming_it():
    with pytest.raises(ArgumentError, match=r"u\[2\] is not finite"):
        effort_map([0.0, 1.0, np.nan], H)
    with pytest.raises(ArgumentError, match="lag = -1 s must be finite and >= 0"):
        effort_map([0.0], H, lag=-1.0)


def _reference(n, amplitude=0.03):
    """Steps of the carriage up and down (a campaign's torque steps, in closed loop)."""
    t = np.arange(n) * H
    q = 0.1 + amplitude * np.sign(np.sin(2 * np.pi * 1.5 * t))[:, None]
    z = np.zeros_like(q)
    return ReferenceTable(t, q, z, z, q.copy())


def _commanded(m, n):
    rec = ClosedLoop(CorePlant(m), ctl.pd(ndof=1, kp=2e4, kd=1.5e3, saturation=400.0)).run(_reference(n))
    return rec.time, rec.tau_cmd[:, 0]


def _read(u, **drive):
    y = effort_map(u, H, **drive)
    return np.concatenate([[drive.get("y0", 0.0)], y[:-1]])  # read at t_k: the end of the last hold


@pytest.mark.parametrize("limit", [np.inf, 150.0])
def test_the_map_of_a_synthetic_drive_is_recovered_within_its_intervals(limit):
    m = Model("emps")
    t, u = _commanded(m, 4000)
    truth = {"gain": 0.55, "offset": 2.0, "lag": 0.004}
    sigma = 0.5
    meas = _read(u, limit=limit, **truth) + np.random.default_rng(3).normal(0, sigma, u.size)
    fit = fit_effort_map(t, u[:, None], meas[:, None])[0]
    for name, want in truth.items():
        value, ci = fit[name]
        assert abs(value - want) <= ci, f"{name}: {value} +- {ci}, true {want}"
    assert fit["gain"][1] < 0.01 * 0.55 and fit["lag"][1] < 0.2 * 0.004
    assert fit["rms"] == pytest.approx(sigma, rel=0.1)
    if np.isfinite(limit):
        assert abs(fit["limit"][0] - limit) <= fit["limit"][1] and fit["limit"][1] < 0.02 * limit
    else:
        assert fit["limit"] is None and "not reached" in fit["limit_note"]


def test_a_drive_delivering_55_percent_is_a_gain_and_the_physics_is_fitted_on_the_measured_effort():
    """The plant gets what the drive delivers (0.55 of the command, a 3 ms lag), the
    recording has both channels: the diagnosis fits the physics on the measured one, finds
    the nominal model right there, and reports the drive's gain, not a saturation."""
    from cosim.discrepancy import diagnose

    m = Model("emps")
    n = 6000
    law = ctl.pd(ndof=1, kp=2e4, kd=1.5e3, model=m)
    state = {"y": 0.0, "u": []}

    def drive(t, q, qd, row):  # the drive between the controller and the carriage
        u = float(np.asarray(law(t, q, qd, row))[0])
        read = state["y"]
        state["y"] = float(effort_map([u], H, gain=0.55, lag=0.003, y0=read)[0])
        state["u"].append(u)
        return np.array([read])

    ref = _reference(n, 0.04)
    run = ClosedLoop(CorePlant(m), drive).run(ref)
    noise = np.random.default_rng(5).normal(0, 0.2, (n, 1))
    rec = Recording(robot="emps", time=run.time, q=run.q, qd=run.qd, tau=np.asarray(state["u"])[:, None],
                    qref=ref.q, extra={"tau_meas1": run.tau_cmd[:, 0] + noise[:, 0]})
    d = diagnose(rec, replay=False, discovery=False)
    fit = d.effort_map["map"][0]
    assert abs(fit["gain"][0] - 0.55) <= fit["gain"][1] < 0.01
    assert abs(fit["lag"][0] - 0.003) <= fit["lag"][1]
    assert d.effort_map["channel"] == "measured (tau_meas)"
    assert "physics fitted on the measured effort" in d.conclusion
    assert not any(k.endswith("effort_max") for k in d.theta)  # no saturation standing in for the gain
    assert "saturation" not in " ".join(e["name"] for e in d.effects)
