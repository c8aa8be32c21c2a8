"""The Quattro FMU driven with motor torques: input.gain = gear.ratio makes a motor torque
input u move the robot exactly as the arm-side torque gear.ratio x u does."""
import numpy as np

from cosim import fmu
from cosim.core import Model


def test_motor_torque_inputs_equal_arm_torques_times_the_gear_ratio():
    m = Model("quattro")
    ratio = m.param("gear.ratio")
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
