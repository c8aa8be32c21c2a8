"""Pose selection (D-optimal, greedy + exchange) against the seed's hand-picked poses."""
import warnings

import numpy as np
import pytest

from cosim.calibration.data import candidate_poses
from cosim.calibration.design import common_scale, observability, pose_rows, select_poses, sixpus_seed_comparison
from cosim.calibration.joint_problem import JointProblem
from cosim.calibration.problems import CalibrationWarning
from cosim.core import Model


def test_beats_the_seeds_ten_poses_on_the_seeds_own_problem():
    cmp = sixpus_seed_comparison(n=10, ncand=600, seed=5)
    seed, dopt = cmp["seed"], cmp["dopt"]
    assert dopt["O1"] > 1.3 * seed["O1"]
    assert dopt["cond"] < seed["cond"] / 2
    assert dopt["logdet"] > seed["logdet"]
    assert len(set(cmp["idx"].tolist())) == 10


@pytest.fixture(scope="module")
def rows():
    m = Model("6pus")
    cand = candidate_poses(m, 400, rng=3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        P = JointProblem(cand, m.ik(cand), m)
    return pose_rows(P)[0]


def test_whole_robot_beats_random_poses(rows):
    idx, hist = select_poses(rows, 12)
    h = common_scale(rows)
    best = observability(rows, idx, scale=h)
    rng = np.random.default_rng(0)
    for _ in range(20):
        rnd = observability(rows, rng.choice(len(rows), 12, replace=False), scale=h)
        assert best["logdet"] > rnd["logdet"] and best["O1"] > rnd["O1"]
    assert all(b >= a - 1e-9 for a, b in zip(hist[12:], hist[13:])), "exchanges only increase det"


def test_exchange_finds_no_better_single_swap(rows):
    idx, _ = select_poses(rows, 10)
    h = common_scale(rows)
    base = observability(rows, idx, scale=h)["logdet"]
    rng = np.random.default_rng(1)
    for _ in range(30):
        j, k = rng.integers(10), rng.integers(len(rows))
        if k in idx:
            continue
        trial = idx.copy()
        trial[j] = k
        assert observability(rows, trial, scale=h)["logdet"] <= base + 1e-6


def _numpy_logdet(rows, idx, h):
    """Oracle: numpy's LU log-determinant (slogdet) of each block's column-scaled information
    matrix H J^T J H over the poses idx, summed over the blocks."""
    total = 0.0
    for b in range(rows.shape[1]):
        Jb = rows[np.asarray(idx), b].reshape(-1, rows.shape[-1]) * h[b]
        sign, ld = np.linalg.slogdet(Jb.T @ Jb)
        assert sign > 0
        total += ld
    return total


def test_rank_one_update_matches_direct_determinant(rows):
    idx, hist = select_poses(rows, 15, exchange=False)
    # history holds log det of the growing set, accumulated by rank-one updates on top of
    # a relative 1e-9 ridge (which moves it by ~1e-3); compare with numpy's determinant
    assert hist[-1] == pytest.approx(_numpy_logdet(rows, idx, common_scale(rows)), abs=1e-2)


def test_scores_are_numpys_determinant_and_condition_number(rows):
    # Oracle: numpy's slogdet (LU) and cond of the column-normalised rows, computed here, and
    # Borm and Menq's O1 = (product of the singular values)^(1/n) / sqrt(m) = det(J^T J)^(1/2n) /
    # sqrt(m), against the scores observability computes from the SVD
    idx = np.arange(0, 60, 4)
    h = common_scale(rows)
    got = observability(rows, idx, scale=h)
    n = rows.shape[-1]
    assert got["logdet"] == pytest.approx(_numpy_logdet(rows, idx, h), rel=1e-9)
    for b, blk in enumerate(got["blocks"]):
        Jb = rows[idx, b].reshape(-1, n)
        _, ld = np.linalg.slogdet((Jb * h[b]).T @ (Jb * h[b]))
        assert blk["O1"] == pytest.approx(np.exp(ld / (2 * n)) / np.sqrt(Jb.shape[0]), rel=1e-9)
        assert blk["cond"] == pytest.approx(np.linalg.cond(Jb / np.linalg.norm(Jb, axis=0)), rel=1e-9)


def test_asking_for_more_poses_than_candidates_is_an_error(rows):
    with pytest.raises(ValueError, match="cannot choose"):
        select_poses(rows[:5], 6)
