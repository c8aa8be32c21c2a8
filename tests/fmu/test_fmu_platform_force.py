"""The force on the platform reaches the FMU as named parameters of the core's table: an FMU with a
cable to an anchor and a drag is the core's plant with them (the core's integrator driven
directly, conftest.core_run), and moves away from the nominal plant."""
import numpy as np

from cosim import fmu

H = 1e-3  # communication step [s], as conftest.H

CABLE = {"cable.anchor_x": 0.1, "cable.anchor_y": -0.05, "cable.anchor_z": 0.4, "cable.tension": 0.5,
         "cable.stiffness": 5.0, "cable.rest_length": 0.3, "platform_drag.linear": 2.0}


def test_a_cable_on_the_platform_is_an_fmu_parameter_with_the_core_physics(fmu_file, model, hold, core_run):
    plant = model.copy()
    plant.set_params(CABLE)
    _, x, _ = core_run(plant, np.tile(hold, (100, 1)))
    with fmu.FMUInstance(fmu_file, params=CABLE) as f:
        assert f.vars["cable.tension"].unit == "N" and f.vars["cable.tension"].causality == "parameter"
        assert f.vars["platform_drag.linear"].unit == "N s/m"
        assert f.get("cable.anchor_z") == 0.4
        for _ in range(100):
            f.step(H, tau=hold)
        assert np.max(np.abs(f.vector("x") - x[-1])) < 1e-10
    _, x0, _ = core_run(model, np.tile(hold, (100, 1)))
    # the cable pulls the platform towards its anchor (up and along +x)
    assert x[-1][2] - x0[-1][2] > 1e-4 and x[-1][0] - x0[-1][0] > 1e-5
