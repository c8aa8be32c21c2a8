"""Helpers of the import tests: source files written by scipy, h5py or by hand, and maps."""
import numpy as np
import pytest
import scipy.io
from import_helpers import MAP


@pytest.fixture
def rig(tmp_path):
    """A small rig file (MATLAB v5) and a map for the four-bar (one joint in rad, effort in N m):
    position in degrees, time in ms, effort = command * gain (a scalar of the file)."""
    n = 200
    t_ms = np.arange(n) * 2.0                      # 2 ms sampling, in ms
    ang_deg = 30.0 * np.sin(2 * np.pi * 1.5 * t_ms / 1e3)
    u = np.cos(t_ms / 100.0)
    vars_ = {"zeit": t_ms[:, None], "ang": ang_deg[:, None], "cmd": u[:, None], "ref": (ang_deg + 1.0)[:, None],
             "gain": 2.5, "k_p": 160.18, "Q": np.column_stack([ang_deg, 2 * ang_deg])}
    src = tmp_path / "rig.mat"
    scipy.io.savemat(src, vars_)
    mp = tmp_path / "rig_map.toml"
    mp.write_text(MAP)
    return src, mp, vars_
