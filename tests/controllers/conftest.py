"""Test doubles for the master and controllers: a plant whose exact sampled response is known.

``ToyModel`` has identity kinematics (pose = joints), a constant diagonal mass and a
constant gravity load; ``ToyPlant`` integrates ``M qdd = tau - g`` exactly over a
step with the effort held (the closed form of a double integrator), so a run of the
master can be compared with python-control's discretised loop to round-off.
"""
import numpy as np
import pytest


class ToyModel:
    robot = "toy"
    joint_unit = "m"  # sliders (the Model interface: RobotFacts.joint_unit)

    def __init__(self, mass=(0.5, 0.2), gravity=(1.5, -0.4)):
        self.M = np.diag(mass).astype(float)
        self.g = np.asarray(gravity, float)
        self.ndof = len(mass)

    def home(self):
        return np.zeros(self.ndof)

    def ik(self, x):
        return np.array(x, float)

    def fk(self, q, x_guess=None):
        return np.array(q, float)

    def jacobian(self, x):
        return np.eye(self.ndof)

    def mass_matrix(self, x):
        return self.M.copy()

    def gravity_load(self, x):
        return self.g.copy()

    def joint_velocity(self, x, xd):
        return np.array(xd, float)

    def joint_acceleration(self, x, xd, xdd):
        return np.array(xdd, float)

    def pose_velocity(self, x, qd):
        return np.array(qd, float)

    def pose_acceleration(self, x, xd, qdd):
        return np.array(qdd, float)

    def inverse_dynamics(self, x, xd, xdd):
        return self.M @ np.asarray(xdd, float) + self.g


class ToyPlant:
    """Exact zero-order-hold response of M qdd = tau - g (identity kinematics)."""

    kind = "toy"

    def __init__(self, model, fail_at=None):
        self.model = model
        self.robot = "toy"
        self.ndof = model.ndof
        self.fail_at = fail_at

    def initialize(self, t0, x0, xd0=None):
        self.t = t0
        self.q = np.array(x0, float)
        self.qd = np.zeros(self.ndof) if xd0 is None else np.array(xd0, float)
        self.tau = np.zeros(self.ndof)

    def set_input(self, tau):
        self.tau = np.array(tau, float)

    def do_step(self, t, h):
        if self.fail_at is not None and t + h > self.fail_at:
            raise RuntimeError(f"toy plant: leg 2 hit its stroke limit at t = {self.fail_at} s")
        a = np.linalg.solve(self.model.M, self.tau - self.model.g)
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


@pytest.fixture
def toy():
    return ToyModel()


@pytest.fixture
def toy_plant(toy):
    return ToyPlant(toy)


@pytest.fixture
def failing_toy_plant(toy):
    """A toy plant that fails when a step would pass t = 0.0505 s."""
    return ToyPlant(toy, fail_at=0.0505)
