"""The exciting trajectories of the blind cases: continuous, inside the workspace, with
every motion phase in the fitted and in the held-out part."""
import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy.excitation import LABELS, check_trajectory, excitation


@pytest.mark.parametrize("robot", ["6pus", "quattro", "hexapod_ups", "delta_clavel", "planar_3rrr", "linear_delta"])
def test_excitation_is_smooth_reachable_and_varied(robot):
    m = Model(robot)
    tr = excitation(m, 9.0, seed=3)
    assert check_trajectory(m, tr) is None
    t = np.arange(0.0, tr.duration, 1e-3)
    x, xd, xdd = tr.evaluate(t)
    # derivatives agree with differences of the pose (the closed form has no jumps)
    np.testing.assert_allclose(np.gradient(x, t, axis=0)[1:-1], xd[1:-1], atol=2e-3 * np.abs(xd).max())
    np.testing.assert_allclose(np.gradient(xd, t, axis=0)[2:-2], xdd[2:-2], atol=2e-2 * np.abs(xdd).max())
    assert np.abs(np.diff(x, axis=0)).max() <= 1.01e-3 * np.abs(xd).max()  # no step larger than the rate allows
    lab = tr.label(t)
    held = t >= tr.duration - 0.3 * 9.0
    for part in (~held, held):
        kinds = set(lab[part])
        assert {LABELS["multisine"], LABELS["sweep"]} <= kinds or {LABELS["sweep"], LABELS["slow"]} <= kinds
    q = m.ik(x)
    qd = np.gradient(q, t, axis=0)
    # every joint reverses its motion many times
    rev = (np.diff(np.sign(qd[np.abs(qd).max(axis=1) > 0]), axis=0) != 0).sum(axis=0)
    assert np.all(rev >= 10), rev


def test_excitation_is_reproducible_and_seeded():
    m = Model("6pus")
    a, b, c = (excitation(m, 4.0, seed=s).pose(np.linspace(0, 4, 50)) for s in (1, 1, 2))
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).max() > 1e-3


def test_a_tuned_profile_of_the_wrong_length_is_refused_naming_the_file(monkeypatch):
    from cosim.discrepancy import excitation as ex

    bad = {"6pus": {"centre": [0.01] * 5, "centre_offset": [0.0] * 6, "amp": [0.01] * 6, "slow": [0.001] * 6}}
    monkeypatch.setattr(ex, "tuned_profiles", lambda: bad)
    with pytest.raises(ValueError, match=r"excitation.toml: \[6pus\] centre needs 6 values .* got 5"):
        ex.profile(Model("6pus"))


def test_the_tuned_profiles_are_data_and_other_robots_get_theirs_from_the_core():
    from cosim.discrepancy import excitation as ex

    assert set(ex.tuned_profiles()) == {"6pus", "quattro"}
    four = Model("fourbar")
    assert ex.profile(four)["amp"].shape == (1,)
