"""Errors in variables: masses, inertias and viscous friction by instrumental variables.

Their regressor columns are built from the measured rates and accelerations, whose noise
least squares reads as a smaller coefficient (attenuation).  The engine estimates them with
the same columns along the reference motion as instruments (docs/discrepancy.md).  Checked
on a synthetic regression with a known answer and on a MuJoCo recording (a simulator the
project did not write) with rate readings 15 times noisier than the generator's, where least
squares is measured to fail."""
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.discrepancy.regressors import fit

BENCH = Path(__file__).resolve().parents[2] / "bench"


def test_instrumental_variables_remove_the_attenuation_of_least_squares():
    rng = np.random.default_rng(3)
    n = 20000
    truth = np.array([2.0, -0.5])
    x = np.column_stack([np.sin(np.linspace(0, 40, n)), np.cos(np.linspace(0, 23, n))])
    X = x + rng.normal(0, 0.5, x.shape)          # regressors measured with noise
    t = -(x @ truth) + rng.normal(0, 0.1, n)     # residual t + X c = 0 at c = truth
    ls, iv = fit(X, t), fit(X, t, x + rng.normal(0, 0.01, x.shape))
    assert np.all(np.abs(ls / truth) < 0.85)      # least squares: attenuated by 1 / (1 + var(noise) / var(x))
    assert np.all(np.abs(iv - truth) < 0.03)     # consistent: within its sampling error (about 0.01)
    assert np.allclose(fit(x, t), fit(x, t, x))   # regressors as their own instruments: least squares


@pytest.fixture(scope="module")
def noisy_rate_recording(tmp_path_factory):
    sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]
    import mujoco_blind as mb

    from cosim.core import Model
    from cosim.discrepancy import blind

    m = Model("6pus")
    base = blind.load_config()["noise"]["6pus"]
    rec, truth = mb.simulate(m, "rotor_inertia", 0.03, 2, seed=201, duration=9.0, noise=dict(base, qd=15 * base["qd"]))
    return mb.write_case(m, rec, tmp_path_factory.mktemp("eiv") / "rotor.csv"), truth


def test_a_rotor_inertia_under_rate_noise_is_estimated_without_the_bias(noisy_rate_recording):
    from cosim.discrepancy import diagnose

    csv, truth = noisy_rate_recording
    key = "rail[3].rotor_inertia"
    iv = diagnose(csv, figures=False, replay=False)
    ls = diagnose(csv, figures=False, replay=False, instruments=False)
    # least squares (the engine before instruments): 17 % low, and a spurious platform inertia
    assert ls.plant_parameters()[key] < 0.9 * truth[key]
    assert "platform_inertia" in ls.named()
    # instrumental variables: the right effect alone, within 10 %
    assert iv.named() == ["rotor_inertia"], iv.conclusion
    assert abs(iv.plant_parameters()[key] - truth[key]) < 0.10 * truth[key]


def test_a_clean_recording_under_heavy_rate_noise_names_no_delay(tmp_path):
    # 3 mm/s of rate noise: the delay's instrumental root drifts to 0.21 ms at 1.7 of its
    # standard errors, which was named an actuator delay before the root had to clear three
    sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]
    import mujoco_blind as mb

    from cosim.core import Model
    from cosim.discrepancy import blind, diagnose

    m = Model("6pus")
    base = blind.load_config()["noise"]["6pus"]
    rec, _ = mb.simulate(m, None, 0.0, 0, seed=31004, duration=9.0, noise=dict(base, qd=15 * base["qd"]))
    d = diagnose(mb.write_case(m, rec, tmp_path / "clean.csv"), figures=False, replay=False)
    assert d.named() == [], d.conclusion
