"""Test doubles for the master and controllers: a plant whose exact sampled response is known.

``axis_model(mass, load)`` is a core model of a vertical prismatic axis (a description
written here: the carriage of ``mass`` [kg] under a gravity that loads the joint with
``load`` [N], no friction, no rotor inertia), so its pose is its joint and its dynamics
``mass qdd = tau - load``.  ``ToyPlant`` integrates that equation exactly over a step with
the effort held (the closed form of a double integrator) from the numbers written here,
not from the core: a run of the master can be compared with python-control's discretised
loop to round-off while the controller's law is the core's.
"""
import numpy as np
import pytest

from cosim.core import Model

AXIS = """
[robot]
name = "toy_axis_{n}"
coordinates = ["z"]
home = [0.0]
[gravity]
vector = [0.0, 0.0, {gz!r}]
[platform]
mass = {mass!r}
inertia = [0.0, 0.0, 0.0]
[[leg]]
type = "P"
platform_point = [0.0, 0.0, 0.0]
rail_origin = [0.0, 0.0, 0.0]
rail_direction = [0.0, 0.0, 1.0]
stroke = [-1.0, 1.0]
"""

#: the two toy joints: (mass [kg], gravity load [N])
JOINTS = ((0.5, 1.5), (0.2, -0.4))


def axis_model(tmp_path, mass, load, n=0):
    """The core model of a vertical axis of ``mass`` whose gravity load is ``load``."""
    path = tmp_path / f"toy_axis_{n}.toml"
    path.write_text(AXIS.format(n=n, gz=-load / mass, mass=mass))
    return Model(str(path))


class ToyPlant:
    """Exact zero-order-hold response of ``mass qdd = tau - load`` (pose = joint)."""

    kind = "toy"

    def __init__(self, model, mass, load, fail_at=None):
        self.model = model
        self.robot = model.robot
        self.ndof = 1
        self.mass, self.load = float(mass), float(load)
        self.fail_at = fail_at

    def initialize(self, t0, x0, xd0=None):
        self.t = t0
        self.q = np.array(x0, float)
        self.qd = np.zeros(1) if xd0 is None else np.array(xd0, float)
        self.tau = np.zeros(1)

    def set_input(self, tau):
        self.tau = np.array(tau, float)

    def do_step(self, t, h):
        if self.fail_at is not None and t + h > self.fail_at:
            raise RuntimeError(f"toy plant: leg 1 hit its stroke limit at t = {self.fail_at} s")
        a = (self.tau - self.load) / self.mass
        self.q = self.q + h * self.qd + 0.5 * h * h * a
        self.qd = self.qd + h * a
        self.t = t + h

    def outputs(self):
        from cosim.master import PlantOutputs

        return PlantOutputs(self.q.copy(), self.qd.copy(), self.q.copy(), self.qd.copy())

    def close(self):
        pass

    def describe(self):
        return {"kind": "toy"}


@pytest.fixture(params=[0, 1], ids=["joint1", "joint2"])
def toy(request, tmp_path):
    """(index, mass, load, core model, exact plant) of one toy joint."""
    j = request.param
    mass, load = JOINTS[j]
    m = axis_model(tmp_path, mass, load, j)
    return j, mass, load, m, ToyPlant(m, mass, load)


@pytest.fixture
def make_axis(tmp_path):
    """``make_axis(mass, load)``: :func:`axis_model` in the test's directory."""
    return lambda mass, load: axis_model(tmp_path, mass, load, 9)


@pytest.fixture
def failing_toy_plant(tmp_path):
    """A toy plant (joint 1) that fails when a step would pass t = 0.0505 s."""
    mass, load = JOINTS[0]
    return ToyPlant(axis_model(tmp_path, mass, load), mass, load, fail_at=0.0505)
