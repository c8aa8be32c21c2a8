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


def test_sensor_delay_is_the_same_in_the_core_loop_the_python_replay_and_the_master(monkeypatch):
    # sensor.delay = 3.5 ms: the readings are those of t - 3.5 ms, interpolated between samples;
    # applied inside the core's closed loop, by the replay's Python loop and by the master's.
    from cosim.master import CoreDrive, CorePlant, run

    m = Model("6pus", params={"sensor.delay": 3.5e-3, "rail[2].encoder_offset": 1e-4})
    h = m.home()
    d = np.zeros(6)
    d[2] = 0.006
    ref = make_reference(m, tr.waypoints([h, h + d, h], move_time=0.3), duration=0.8)
    c = ctl.pd_gravity(m, kp=300, kd=30)
    fast = dp.closed_loop(m, c, ref, seed=4)
    m0 = Model("6pus", params={"rail[2].encoder_offset": 1e-4})
    undelayed = dp.closed_loop(m0, ctl.pd_gravity(m, kp=300, kd=30), ref, seed=4)
    assert np.max(np.abs(fast.x - undelayed.x)) > 1e-6               # the lag changes the motion
    with_ms = ref.time >= ref.time[0] + 0.1
    lag = fast.q[with_ms] - fast.q_true[with_ms]
    assert np.max(np.abs(lag[:, 2])) > 1e-5                          # readings trail the joints
    with monkeypatch.context() as mp:
        mp.setattr(dp, "_compiled", lambda *a, **k: None)
        slow = dp.closed_loop(m, c, ref, seed=4)
    for f in ("q", "qd", "x"):
        np.testing.assert_allclose(getattr(fast, f), getattr(slow, f), rtol=0, atol=1e-12, err_msg=f)
    # the master: compiled loop and Python loop with the same delay line
    a = run(CorePlant(m), c, ref, drive=CoreDrive(m), compiled=True)
    b = run(CorePlant(m), c, ref, drive=CoreDrive(m), compiled=False)
    for f in ("q", "qd", "x"):
        np.testing.assert_allclose(a[f], b[f], rtol=0, atol=1e-12, err_msg=f)
    np.testing.assert_allclose(a["x"], fast.x, rtol=0, atol=1e-12)
