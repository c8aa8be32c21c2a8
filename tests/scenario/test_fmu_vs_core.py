"""The same scenario stepped at 1 ms against the Co-Simulation FMU (fmpy) and against the core."""
from pathlib import Path

import numpy as np
import pytest

from cosim.master import MasterError
from cosim.scenario import load_scenario, run_scenario

SCEN = Path(__file__).resolve().parents[2] / "scenarios"


def _both(path, duration, **over):
    sc = load_scenario(path).with_overrides(duration=duration, **over)
    core = run_scenario(sc, plant="core", export=False, figures=False)
    fmu = run_scenario(sc, plant="fmu", export=False, figures=False)
    assert core.result.plant["kind"] == "core" and fmu.result.plant["kind"] == "fmu"
    return core.result, fmu.result


@pytest.mark.parametrize("name,duration", [("6pus_step_pd.toml", 0.3), ("6pus_letter_m_ct.toml", 0.6)])
def test_fmu_and_core_give_the_same_run(name, duration):
    core, fmu = _both(SCEN / name, duration)
    assert len(core) == len(fmu) == int(round(duration / 1e-3)) + 1
    assert np.ptp(core["x"], axis=0).max() > 1e-3          # the robot moved
    for field, tol in (("q", 1e-10), ("qd", 1e-8), ("x", 1e-10), ("tau_applied", 1e-6)):
        np.testing.assert_allclose(fmu[field], core[field], rtol=0, atol=tol, err_msg=field)


def test_a_stroke_limit_stops_both_plants_with_leg_and_time(tmp_path):
    # leg 2 shortens from 92 mm to 29 mm during the step: a 50 mm lower limit stops it
    sc = load_scenario(SCEN / "6pus_step_pd.toml").with_overrides(duration=0.3)
    sc.spec["plant_parameters"] = {"rail[2].qmin": 0.05}
    for plant in ("core", "fmu"):
        with pytest.raises(MasterError, match=r"(?s)run stopped in the step from t = 0\.\d+ s to 0\.\d+ s.*leg 2.*stroke") as e:
            run_scenario(sc, plant=plant, export=False, figures=False)
        part = e.value.partial
        assert 10 < len(part) < 300 and np.all(part["q_true"][:, 1] >= 0.05 - 1e-9)
