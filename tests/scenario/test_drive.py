"""The plant's drive and sensor model in the runs: saturation and encoder offset, both plants.

The plants clip the effort at ``rail[i].effort_max`` inside; the master records the
applied effort and passes the joints through the encoder model of the plant's
parameters, the same for the FMU and the core plant."""
from pathlib import Path

import numpy as np
import pytest

from cosim.recording import read_recording
from cosim.scenario import load_scenario, run_scenario

SCEN = Path(__file__).resolve().parents[2] / "scenarios"


def _run(tmp_path, plant):
    sc = load_scenario(SCEN / "6pus_step_pdg.toml").with_overrides(duration=0.4)
    sc.spec["plant_parameters"] = {"rail[2].encoder_offset": 1e-4, "rail[1].effort_max": 5.0}
    out = run_scenario(sc, plant=plant, out_dir=tmp_path, figures=False)
    res = out.result
    # encoder: joint 2 reads 0.1 mm more than the slider's true stroke, the others exactly
    np.testing.assert_allclose(res["q"][:, 1] - res["q_true"][:, 1], 1e-4, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(res["q"][:, [0, 2, 3, 4, 5]], res["q_true"][:, [0, 2, 3, 4, 5]])
    # saturation: the 70 mm step asks for ~18 N at first; slider 1 gets at most 5 N
    assert np.max(np.abs(res["tau_cmd"][:, 0])) > 10.0
    assert np.max(np.abs(res["tau_applied"][:, 0])) == pytest.approx(5.0)
    np.testing.assert_array_equal(res["tau_applied"][:, 1:], res["tau_cmd"][:, 1:])
    rec = read_recording(out.files["recording"])
    np.testing.assert_array_equal(rec.tau, res["tau_applied"])
    np.testing.assert_array_equal(rec.extra["tau_cmd1"], res["tau_cmd"][:, 0])
    # the two plants integrate the same clipped efforts
    return res


def test_saturation_and_encoder_offset_in_both_plants(tmp_path):
    core = _run(tmp_path / "core", "core")
    fmu = _run(tmp_path / "fmu", "fmu")
    np.testing.assert_allclose(fmu["x"], core["x"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(fmu["q"], core["q"], rtol=0, atol=1e-10)


def test_a_sensor_lag_is_applied_the_same_with_the_fmu_and_the_core_plant(tmp_path):
    # sensor.delay: the FMU outputs the joints of its own time; the master delays the readings
    # for it as the core's compiled loop does for the core plant.
    runs = {}
    for plant in ("core", "fmu"):
        sc = load_scenario(SCEN / "6pus_step_pdg.toml").with_overrides(duration=0.3)
        sc.spec["plant_parameters"] = {"sensor.delay": 0.003}
        runs[plant] = run_scenario(sc, plant=plant, out_dir=tmp_path / plant, figures=False).result
    core, fmu = runs["core"], runs["fmu"]
    assert core.loop == "compiled" and fmu.loop == "python"
    np.testing.assert_allclose(fmu["q"], core["q"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(fmu["x"], core["x"], rtol=0, atol=1e-10)
    k = np.searchsorted(core["time"], 0.1)
    # the readings at 0.1 s are the joints of 0.097 s
    np.testing.assert_allclose(core["q"][k], core["q_true"][k - 3], rtol=0, atol=1e-12)
    assert np.max(np.abs(core["q"][k] - core["q_true"][k])) > 1e-5


@pytest.mark.parametrize("plant", ["core", "fmu"])
def test_a_constant_effort_offset_is_held_by_the_pd_as_a_steady_error(tmp_path, plant):
    # rail[3].offset = 0.3 N: the drive must supply 0.3 N more than the mechanism needs. The PD +
    # gravity controller compensates the nominal gravity only, so at rest its proportional term
    # carries the offset: kp (qref - q) = 0.3 N on rail 3, a 1 mm error, nothing on the others.
    sc = load_scenario(SCEN / "6pus_step_pdg.toml").with_overrides(duration=1.5)
    sc.spec["plant_parameters"] = {"rail[3].offset": 0.3}
    res = run_scenario(sc, plant=plant, out_dir=tmp_path, figures=False).result
    err = np.mean(res["qref"][-100:] - res["q"][-100:], axis=0)
    assert err[2] == pytest.approx(0.3 / 300.0, rel=0.02), err
    assert np.max(np.abs(np.delete(err, 2))) < 0.02 * 0.3 / 300.0, err
