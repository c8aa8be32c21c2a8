"""The Quattro FMU driven with motor torques: input.gain = the gear ratio (50) makes a motor
torque input u move the robot exactly as the arm-side torque 50 u does."""
import numpy as np

from cosim import fmu
from cosim.core import Model


def test_motor_torque_inputs_equal_arm_torques_times_the_gear_ratio():
    m = Model("quattro")
    ratio = m.quattro_constants()["gear_ratio"]
    assert ratio == 50
    g = m.gravity_load(m.home())
    arm = [g + np.array([2.0, -1.0, 0.5, 1.5]) * np.sin(0.01 * k) for k in range(50)]
    runs = []
    for gain, scale in ((1.0, 1.0), (ratio, 1.0 / ratio)):
        with fmu.FMUInstance(fmu.fmu_path("quattro"), params={"input.gain": gain}) as f:
            xs = []
            for tau in arm:
                f.step(1e-3, tau=tau * scale)
                xs.append(f.vector("x"))
            runs.append(np.array(xs))
    assert np.max(np.abs(runs[0][-1] - runs[0][0])) > 1e-5  # it moved
    np.testing.assert_allclose(runs[1], runs[0], rtol=0, atol=1e-12)


def test_the_fmu_moves_as_scipy_integrates_the_cores_dynamics():
    # Oracle for the FMU's time integration: scipy's DOP853 (rtol 1e-12) on
    # d/dt (x, xd) = (xd, forward_dynamics(x, xd, tau)), tau held over each 1 ms step
    from scipy.integrate import solve_ivp

    m = Model("quattro")
    g = m.gravity_load(m.home())
    arm = [g + np.array([2.0, -1.0, 0.5, 1.5]) * np.sin(0.01 * k) for k in range(50)]
    with fmu.FMUInstance(fmu.fmu_path("quattro")) as f:
        x0 = f.vector("x")
        xs = []
        for tau in arm:
            f.step(1e-3, tau=tau)
            xs.append(f.vector("x"))
    y, ref = np.concatenate([x0, np.zeros(4)]), []
    for tau in arm:
        sol = solve_ivp(lambda t, s, tau=tau: np.concatenate([s[4:], m.forward_dynamics(s[:4], s[4:], tau)]),
                        (0.0, 1e-3), y, method="DOP853", rtol=1e-12, atol=1e-14)
        y = sol.y[:, -1]
        ref.append(y[:4])
    assert np.max(np.abs(np.array(xs)[-1] - x0)) > 1e-3  # it moved by millimetres
    np.testing.assert_allclose(np.array(xs), np.array(ref), rtol=0, atol=1e-10)
