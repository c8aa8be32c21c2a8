"""The Quattro's own functions (the 22 indices of Virzi 2010, the GIMRE, the joint points, the
constants) and its motion on the Quattro the core serves (c_core/src/robots/quattro_facts.cpp
over robots/quattro.toml) against the hand-written model kept as a test oracle
(c_core/tests/oracles/quattro.cpp, "quattro_hand"): two implementations written apart.  The
comparisons run in tests/core/oracle_quattro.py under libpkm_oracle.so."""
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "core"))
from described_checks import run_oracle  # noqa: E402


def poses(n=400, seed=4):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.6, 0.6, n), rng.uniform(-0.6, 0.6, n), rng.uniform(-1.3, -0.7, n),
                            rng.uniform(-0.8, 0.8, n)])


@pytest.mark.parametrize("case", ["appendix_a", "default", "payload"])
def test_described_quattro_facts_equal_the_hand_written_ones(case):
    """Indices over the workspace grid of the thesis' maps (unreachable and out-of-range poses
    included: the same status expected) within 1e-12, GIMRE 1e-12, joint points 1e-14."""
    run_oracle("oracle_quattro.py", "facts", case)


def test_described_quattro_facts_follow_the_description():
    """The comparison can fail: a forearm 1 % longer, an arm 1 % heavier on one side only move
    the indices that read them (the kinematic ones, the dynamic ones)."""
    X = poses(60, seed=9)
    a = Model("quattro")
    Ia, sa = a.quattro_indices(X)
    ok = sa == 0
    rods = {f"leg[{i}].L": 0.825 * 1.01 for i in range(1, 5)}
    Ib, _ = Model("quattro", params=rods).quattro_indices(X[ok])
    assert np.abs(Ib[:, 0] - Ia[ok, 0]).max() > 1e-4 * np.abs(Ia[ok, 0]).max()   # mu_T
    Ic, _ = Model("quattro", params={"arm[1].mass": 1.45 * 1.01}).quattro_indices(X[ok])
    assert np.array_equal(Ic[:, :7], Ia[ok, :7])                                     # kinematic: unchanged
    assert np.abs(Ic[:, 12] - Ia[ok, 12]).max() > 1e-6 * np.abs(Ia[ok, 12]).max()   # kat


@pytest.mark.parametrize("st", ["default", "appendix_a"])
def test_described_quattro_constants_and_cycle_time_equal_the_hand_written_ones(st):
    """The constants cosim.quattro reads (torque limit, Adept origin, link length) equal the
    hand-written model's parameters, and a time-optimal cycle of Virzi 2010 ch. 6 is the same."""
    run_oracle("oracle_quattro.py", "constants", st)


@pytest.mark.parametrize("st", ["default", "appendix_a"])
def test_described_quattro_motion_equals_the_hand_written_one_over_the_workspace(st):
    """Inverse kinematics, Jacobian and inverse dynamics within 1e-12, forward dynamics within
    1e-10, at the reachable poses of the workspace."""
    run_oracle("oracle_quattro.py", "workspace_motion", st)
