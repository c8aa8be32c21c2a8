"""The engine's closed loop (blind generator, replay) through the core's compiled loop
equals its Python loop: same noise draws, same samples to the rounding of the time grid."""
import numpy as np

from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.core import Model
from cosim.discrepancy import plant as dp
from cosim.master import make_reference


def test_compiled_engine_loop_equals_the_python_loop(monkeypatch):
    m = Model("6pus", params={"rail[2].encoder_offset": 1e-4, "rail[1].coulomb": 0.5, "drive.v_eps": 1e-3,
                              "rail[3].compliance": 2e-5})
    h = m.home()
    d = np.zeros(6)
    d[0] = 0.005
    ref = make_reference(m, tr.waypoints([h, h + d, h], move_time=0.3), duration=0.8)
    c = ctl.pd_gravity(m, kp=300, kd=30)
    noise = {"q": 1e-6, "qd": 1e-5, "tau": 0.01, "pose": 1e-6}
    fast = dp.closed_loop(m, c, ref, noise=noise, seed=4)
    monkeypatch.setattr(dp, "_compiled", lambda *a, **k: None)
    slow = dp.closed_loop(m, c, ref, noise=noise, seed=4)
    for f in ("q", "qd", "tau", "pose", "x", "q_true"):
        np.testing.assert_allclose(getattr(fast, f), getattr(slow, f), rtol=0, atol=1e-12, err_msg=f)
    assert np.ptp(fast.x[:, 0]) > 0.004  # it moved
