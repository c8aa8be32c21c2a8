"""Drifts judged against the place: a force keyed on where the robot is, on a trajectory whose
second half goes elsewhere, is no drift; a true step on a trajectory that revisits its places
is one; parameters that step together are one statement.  A linear fit state stands in for
the diagnosis's (the residual is the parameters' columns times their change from the nominal
plus what the test puts in it), so that the residual holds exactly the force under test."""
import math
from types import SimpleNamespace

import numpy as np

from cosim.discrepancy.drift import find_drifts, markdown, sentence

M, THRESHOLD = 2000, 10.0


class _LinearFit:
    """What :func:`find_drifts` reads of a fit state: ``R(theta) = base - sum_k (theta_k -
    nominal_k) col_k`` on rows at times ``t`` and joint positions ``q``, unit weights."""

    def __init__(self, t, q, base, cols):
        self.pipe = SimpleNamespace(t=t, idx=np.arange(len(t)), q_s=q)
        self.base, self.cols = base, cols
        self.nominal = {k: 0.0 for k in cols}
        self.C = base.shape[1]
        self.W = np.ones_like(base)
        self.n_eff = float(len(t))

    def R(self, theta):
        return self.base - sum(v * self.cols[k] for k, v in theta.items())

    try_R = R

    def vec(self, Rm, mask=None, w=None):
        mask = np.ones(len(Rm), bool) if mask is None else mask
        return Rm[mask].T.reshape(-1)


def _trajectory(elsewhere: bool):
    """Two joints over 10 s; with ``elsewhere`` the second half circles about another place."""
    t = np.linspace(0.0, 10.0, M)
    a = 2 * math.pi * 0.7 * t
    centre = np.where(t < 5.0, 0.0, 3.0 if elsewhere else 0.0)
    q = np.stack([centre + np.cos(a), np.sin(1.3 * a)], 1)
    return t, q


def _noise(seed):
    return np.random.default_rng(seed).normal(0.0, 1.0, (M, 2))


def test_a_force_keyed_on_the_place_on_a_trajectory_that_goes_elsewhere_is_no_drift():
    t, q = _trajectory(elsewhere=True)
    # an offset-like column and a force of 2 (the noise's 1) wherever joint 1 passes 2.0: the
    # second half alone goes there, so a step of the offset mimics it
    col = np.stack([np.ones(M), np.zeros(M)], 1)
    force = np.where(q[:, 0] > 2.0, 2.0, 0.0)
    base = _noise(1) + np.stack([force, np.zeros(M)], 1)
    eng = _LinearFit(t, q, base, {"rail[1].offset": col})
    theta = {"rail[1].offset": -float(np.mean(force))}  # the constant fitted: the mean
    assert not find_drifts(eng, theta, THRESHOLD)


def test_a_true_step_on_a_trajectory_that_revisits_its_places_is_a_drift():
    t, q = _trajectory(elsewhere=False)
    col = np.stack([np.ones(M), 0.5 * np.ones(M)], 1)
    step = np.where(t >= 6.0, 1.0, 0.0)
    base = _noise(2) + col * step[:, None]
    eng = _LinearFit(t, q, base, {"rail[1].offset": col})
    found = find_drifts(eng, {"rail[1].offset": -float(np.mean(step))}, THRESHOLD)
    assert [d.param for d in found] == ["rail[1].offset"] and found[0].kind == "step"
    assert abs(found[0].time - 6.0) < 0.3 and abs(found[0].size - 1.0) < 0.1, found[0].equation


def test_parameters_that_step_together_are_one_statement():
    t, q = _trajectory(elsewhere=False)
    col = np.stack([np.ones(M), 0.5 * np.ones(M)], 1)
    step = np.where(t >= 6.0, 1.0, 0.0)
    base = _noise(3) + col * step[:, None]
    # a second parameter whose column is the first's, slightly changed: each alone fits the step
    twin = col * (1.0 + 0.05 * np.cos(t))[:, None]
    eng = _LinearFit(t, q, base, {"rail[1].offset": col, "rail[1].twin": twin})
    theta = {"rail[1].offset": -float(np.mean(step)), "rail[1].twin": 0.01}  # off zero: its column is a difference
    found = find_drifts(eng, theta, THRESHOLD)
    assert len(found) == 1 and found[0].kind == "step", [d.equation for d in found]
    assert set(found[0].also) | {found[0].param} == {"rail[1].offset", "rail[1].twin"}
    other = ({"rail[1].offset", "rail[1].twin"} - {found[0].param}).pop()
    assert f"the same course also fits {other}" in sentence(found)
    assert any(line.endswith(other) and "also fits" in line for line in markdown(found, {}))
