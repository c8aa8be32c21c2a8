"""Computed torque on the laser-cut "M" (Zavala-Yoe et al. 2015 sec. 8.1, 8.9): nominal plant vs 20 % heavier platform."""
from pathlib import Path

import numpy as np
import pytest

from cosim import trajectories as tr
from cosim.scenario import run_scenario

SCEN = Path(__file__).resolve().parents[2] / "scenarios"


def test_computed_torque_traces_the_m_and_feels_a_heavier_platform():
    nominal = run_scenario(SCEN / "6pus_letter_m_ct.toml", export=False, figures=False)
    heavy = run_scenario(SCEN / "6pus_letter_m_ct_heavy.toml", export=False, figures=False)
    rms_n = nominal.metrics["tracking"]["pen_error_rms"]
    rms_h = heavy.metrics["tracking"]["pen_error_rms"]
    assert rms_n < 1e-5, rms_n
    assert rms_h > 10 * rms_n and rms_h > 1e-5, (rms_n, rms_h)
    # the RMS is of the pen point: recompute it from the poses (independent of the metric code)
    res = nominal.result
    pen = tr.tool_point(res["x"], [0, 0, -0.02]) - tr.tool_point(res["xref"], [0, 0, -0.02])
    assert np.sqrt(np.mean(np.sum(pen**2, axis=1))) == pytest.approx(rms_n, rel=1e-12)
    # the letter was traced: the platform covered the 30 x 30 mm box at constant height
    assert np.ptp(res["x"][:, 0]) > 0.0299 and np.ptp(res["x"][:, 1]) > 0.0299
    assert np.max(np.abs(res["x"][:, 2] - 0.075)) < 1e-5
    # the plant was heavier, the controller's model was not
    assert heavy.metrics["plant_parameters"]["platform.m"] == 0.35 * 1.2
    assert "platform.m" not in nominal.metrics["plant_parameters"]


def test_pen_point_uses_the_core_pose_convention():
    """tool_point must rotate like the core: compare with the core's platform points."""
    from cosim._native import lib, ptr
    from cosim.core import Model

    m = Model("6pus")
    x = np.array([0.004, -0.003, 0.08, 0.05, -0.04, 0.07])
    P, S = np.empty((6, 3)), np.empty((6, 3))
    assert lib.pkm_6pus_leg_points(m._m, m._d, ptr(x), ptr(P), ptr(S)) == 0
    for i in range(6):
        local = [m.param(f"leg[{i + 1}].{c}") for c in ("px", "py", "pz")]
        np.testing.assert_allclose(tr.tool_point(x, local)[0], P[i], atol=1e-15)
