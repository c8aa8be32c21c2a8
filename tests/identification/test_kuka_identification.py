"""The KUKA KR300's rigid model identified on the shipped trajectory A, judged on B and C
(data/kuka_kr300/, JonasWeigand/Robot_Identification, MIT licence; docs/kuka.md).

Reference: the makers' own model values (the description's set ``para``: their friction,
offsets and motor inertias on the repository's link model) on the same held-out trajectories.
The identified model must predict the held-out efforts of axes 1 and 2 (the axes whose friction
and counterbalance ``para`` gets wrong) better than ``para`` does and within the errors measured
(here, 50 bootstrap draws: B 17.1 / 27.8 %, C 17.1 / 20.2 %), with margin; and what it misses on
axis 2 must rise with q2 (the hydraulic counterbalance, a position-dependent torque).  The
consistent fit is solved to its optimum (the solver's status optimal, no warning of reduced
accuracy)."""
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.signal

from cosim.core import Model
from cosim.identification import identify
from cosim.identification.identify import _lowpass, prepare
from cosim.importing import to_recording

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data" / "kuka_kr300"
ROBOT = str(REPO / "robots" / "kr300.toml")
CUT = 2.0


def _held_out(model, rec):
    q, qd, qdd, tau, fs = prepare(rec.time, rec.q, rec.qd, rec.tau, CUT)
    b, a = _lowpass(CUT, fs)
    pred = scipy.signal.filtfilt(b, a, model.inverse_dynamics(q, qd, qdd), axis=0)
    tf = scipy.signal.filtfilt(b, a, tau, axis=0)
    e = int(np.ceil(fs / CUT))
    d, tf = (pred - tf)[e:-e], tf[e:-e]
    return 100 * np.sqrt(np.mean(d ** 2, 0) / np.mean(tf ** 2, 0)), q[e:-e], d


@pytest.fixture(scope="module")
def kuka():
    recs = {t: to_recording(str(DATA / f"kr300_{t}.mat"), str(DATA / "kr300_map.toml")) for t in "ABC"}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ident = identify(recs["A"], ROBOT, cutoff=CUT, bootstrap=50)
    assert not [w for w in caught if "semidefinite program" in str(w.message)], [str(w.message) for w in caught]
    return recs, ident


def test_identified_on_A_beats_the_makers_model_on_B_and_C(kuka):
    recs, ident = kuka
    assert len(ident.names) == 58 and ident.gap < ident.gap_bound
    para, mine = Model(ROBOT, "para"), ident.model(ROBOT)
    # B axis 1: 17.1 % measured (50 draws; 17.1 % with the bench's 200, docs/kuka.md's table).
    # The fit is the convex program's unique optimum: solver settings and a 1e-12 change of the
    # base parameters move every figure by less than 0.01 points; the bound of 20 % leaves 2.9 points
    # for the filters' and the least squares' floating point on other CPUs and libraries, and is
    # half the makers' model's 38.9 %.  C axis 4 is the closest to the 60 % floor (59.0 %).
    bound = {"B": [20.0, 32.0], "C": [25.0, 25.0]}
    for t in "BC":
        ref, err = _held_out(para, recs[t])[0], _held_out(mine, recs[t])[0]
        assert np.all(err[:2] < ref[:2]), (t, err, ref)
        assert np.all(err[:2] < bound[t]), (t, err)
        assert np.all(err < 60.0), (t, err)  # no axis lost


def test_axis_2_misses_a_torque_rising_with_its_angle(kuka):
    recs, ident = kuka
    mine = ident.model(ROBOT)
    for t in "ABC":
        _, q, d = _held_out(mine, recs[t])
        slope = np.polyfit(q[:, 1], -d[:, 1], 1)[0]
        assert slope > 300.0, (t, slope)  # N m/rad; the repository's counterbalance: 475 over A's angles
