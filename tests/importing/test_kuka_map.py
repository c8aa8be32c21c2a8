"""The KUKA KR300 recordings' import map (data/kuka_kr300/kr300_map.toml) on the first 0.4 s of
trajectory A (data/kuka_kr300/kr300_A_head.mat, from JonasWeigand/Robot_Identification).

Oracles: the file's values read by scipy (the columns are those values in SI units, shifted by
the model's qs, the efforts times the gear ratios of the file's own ``para``), and the
repository's gravity torques at the start pose (``tau_g_init``, from its symbolic model): the
description's gravity load there agrees on the axes no payload or counterbalance reaches."""
from pathlib import Path

import numpy as np
import scipy.io

from cosim.core import Model
from cosim.importing import to_recording

REPO = Path(__file__).resolve().parents[2]
DATA = REPO / "data" / "kuka_kr300"


def test_the_map_reads_the_struct_fields_row_by_row():
    rec = to_recording(str(DATA / "kr300_A_head.mat"), str(DATA / "kr300_map.toml"))
    raw = scipy.io.loadmat(str(DATA / "kr300_A_head.mat"), squeeze_me=True, struct_as_record=False)
    r, u = raw["rec"], raw["para"].u
    qs = np.radians([0, -90, 90, 0, 0, 0])
    assert rec.q.shape == (100, 6)
    np.testing.assert_array_equal(rec.time, r.time_cont)
    np.testing.assert_allclose(rec.q, np.radians(r.act_pos_mot_deg.T) + qs, rtol=0, atol=1e-15)
    np.testing.assert_allclose(rec.qd, np.radians(r.act_vel_mot_deg_per_s.T), rtol=1e-15)
    np.testing.assert_allclose(rec.tau, r.act_torque_abs_nm.T * u, rtol=1e-12)
    np.testing.assert_allclose(rec.qref, np.radians(r.ref_pos_deg.T) + qs, rtol=0, atol=1e-15)
    # the secondary encoders of axes 1-3, the link side, as q_link1..3 (none on axes 4-6)
    assert sorted(k for k in rec.extra if k.startswith("q_link")) == ["q_link1", "q_link2", "q_link3"]
    for j in range(3):
        np.testing.assert_allclose(rec.extra[f"q_link{j + 1}"], np.radians(r.act_pos_se_deg[j]) + qs[j], rtol=0,
                                   atol=1e-15)


def test_the_description_is_the_repositorys_model_at_the_start_pose():
    """At q = qs the kinematics put axes 1 and 6 under no gravity torque and axis 4 under
    -25.04 N m (the repository's gravload, tau_g_init), whatever the payload: the joint
    frames, the start pose convention and link 4's centre of mass agree with the repository's
    symbolic model.  (Axes 2, 3, 5 carry the payload, 2 also the hydraulic counterbalance.)"""
    m = Model(str(REPO / "robots" / "kr300.toml"))
    tau_g = scipy.io.loadmat(str(DATA / "kr300_A_head.mat"), squeeze_me=True)["tau_g_init"]
    g = m.gravity_load(m.home())
    np.testing.assert_allclose(g[[0, 3, 5]], tau_g[[0, 3, 5]], atol=0.01)
    assert abs(tau_g[3]) > 20  # a real torque, not a zero matched


def test_row_mistakes_name_the_field(tmp_path):
    import pytest

    from cosim.importing.errors import ImportFailure

    text = (DATA / "kr300_map.toml").read_text().replace('robot = "../../robots/kr300.toml"',
                                                         f'robot = "{REPO / "robots" / "kr300.toml"}"')
    for bad, words in [('row = 1, unit = "deg" }', "row 7"), ('row = 1, unit = "deg" }', "column or row")]:
        change = 'row = 7, unit = "deg" }' if "7" in words else 'row = 1, column = 1, unit = "deg" }'
        p = tmp_path / "m.toml"
        p.write_text(text.replace(bad, change, 1))
        with pytest.raises(ImportFailure, match=words):
            to_recording(str(DATA / "kr300_A_head.mat"), str(p))
