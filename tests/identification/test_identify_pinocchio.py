"""Base-parameter identification of a serial arm against an independent oracle.

The recording is simulated by Pinocchio, not by the core: ``pinocchio.rnea`` of the UR5 built
by Pinocchio's own URDF reader (robots/urdf/ur5.urdf), with rotor inertias as Pinocchio's
armature, plus viscous and Coulomb friction and an effort offset written here (the drive
layer's law as docs/robots.md states it: f_v qd + f_c tanh(qd / v_c) + offset), along a
five-harmonic Fourier motion (positions, rates, accelerations in closed form), the efforts with
1 % white noise.  The true base parameters are the true standard parameters (Pinocchio's
``Inertia.toDynamicParameters`` of each link, the friction values above) regrouped by
Pinocchio's own joint-torque regressor (``computeJointTorqueRegressor``) on the independent
columns the identification chose: ``K = lstsq(Y_B, Y_D)``."""
import numpy as np
import pinocchio as pin
import pytest

from cosim.core import Model
from cosim.identification import IdentificationError, identify, regressor
from cosim.recording import Recording
from cosim.robots.urdf import register_urdf

PATH = "robots/urdf/ur5.urdf"
ORDER = [0, 1, 2, 3, 4, 5, 7, 6, 8, 9]  # ours: m, mx, my, mz, XX, XY, XZ, YY, YZ, ZZ; Pinocchio: ... Iyy, Ixz ...
ARM = np.array([0.3, 0.3, 0.2, 0.05, 0.05, 0.04])  # rotor inertia [kg m2]
FV = np.array([2.0, 2.0, 1.5, 0.5, 0.5, 0.3])  # viscous [N m s/rad]
FC = np.array([3.0, 3.0, 2.0, 1.0, 1.0, 0.5])  # Coulomb [N m]
OFF = np.array([0.5, -1.0, 0.3, 0.0, 0.1, -0.1])  # offset [N m]
VC = 0.01  # Coulomb's velocity scale [rad/s]


def _motion(fs=100.0, T=20.0, seed=1):
    rng = np.random.default_rng(seed)
    t = np.arange(0, T, 1 / fs)
    w, k = 2 * np.pi * 0.1, np.arange(1, 6)
    a, b = (rng.normal(0, 1, (6, 5)) / k * 0.5 for _ in range(2))
    s, c = np.sin(w * np.outer(t, k)), np.cos(w * np.outer(t, k))
    q = np.stack([(a[j] / (w * k) * s - b[j] / (w * k) * c).sum(1) for j in range(6)], 1)
    qd = np.stack([(a[j] * c + b[j] * s).sum(1) for j in range(6)], 1)
    qdd = np.stack([(w * k * (b[j] * c - a[j] * s)).sum(1) for j in range(6)], 1)
    return t, q, qd, qdd


def _pinocchio(inertias=None):
    pm = pin.buildModelFromUrdf(PATH)
    for j, inertia in (inertias or {}).items():
        pm.inertias[j] = inertia
    pm.armature = ARM
    return pm


def _recording(pm, name, seed=2):
    t, q, qd, qdd = _motion()
    pd = pm.createData()
    tau = np.array([pin.rnea(pm, pd, *x) for x in zip(q, qd, qdd)]) + FV * qd + FC * np.tanh(qd / VC) + OFF
    rng = np.random.default_rng(seed)
    tau += rng.normal(0, 1, tau.shape) * 0.01 * np.sqrt(np.mean(tau ** 2, axis=0))
    return Recording(robot=name, time=t, q=q, qd=qd, tau=tau)


def _truth(pm, ident):
    """The true base parameters, regrouped by Pinocchio's regressor on states of the motion."""
    phi = np.concatenate([pm.inertias[j].toDynamicParameters()[ORDER] for j in range(1, 7)]
                         + [np.stack([ARM, FV, FC, OFF], 1).ravel()])
    pd = pm.createData()
    t, q, qd, qdd = _motion()
    rows = []
    for x in zip(q[::10], qd[::10], qdd[::10]):
        Y = pin.computeJointTorqueRegressor(pm, pd, *x)
        Y = np.concatenate([Y[:, 10 * j:10 * j + 10][:, ORDER] for j in range(6)], axis=1)
        drive = np.zeros((6, 24))
        for j in range(6):
            drive[j, 4 * j:4 * j + 4] = [x[2][j], x[1][j], np.tanh(x[1][j] / VC), 1.0]
        rows.append(np.concatenate([Y, drive], axis=1))
    Y = np.concatenate(rows)
    B, D = ident.base.independent, ident.base.dependent
    K = np.linalg.lstsq(Y[:, B], Y[:, D], rcond=None)[0]
    assert np.max(np.abs(Y[:, B] @ K - Y[:, D])) < 1e-9 * np.max(np.abs(Y))  # D truly depends on B
    return phi[B] + K @ phi[D]


@pytest.fixture(scope="module")
def arm():
    name = register_urdf(PATH, tip="tool0", name="ur5_ident")
    return name, Model(name, params={f"joint[{i}].coulomb_v": VC for i in range(1, 7)})


def test_regressor_is_pinocchios(arm):
    """The regressor built from the core by linearity is Pinocchio's joint-torque regressor."""
    pm = pin.buildModelFromUrdf(PATH)
    pd = pm.createData()
    t, q, qd, qdd = _motion()
    W = regressor(arm[1], q[::50], qd[::50], qdd[::50])[0]
    for k, x in enumerate(zip(q[::50], qd[::50], qdd[::50])):
        Y = pin.computeJointTorqueRegressor(pm, pd, *x)
        Y = np.concatenate([Y[:, 10 * j:10 * j + 10][:, ORDER] for j in range(6)], axis=1)
        assert np.max(np.abs(W[6 * k:6 * k + 6, :60] - Y)) < 1e-12 * np.max(np.abs(Y))


def test_base_parameters_recovered_within_their_intervals(arm):
    pm = _pinocchio()
    ident = identify(_recording(pm, arm[0]), arm[1], bootstrap=100)
    truth = _truth(pm, ident)
    assert len(ident.names) == 58  # the UR5's 60 link parameters and 24 drive terms have 58 combinations
    z = (ident.beta - truth) / ident.se
    inside = (ident.low <= truth) & (truth <= ident.high)
    assert np.max(np.abs(z)) < 4.0, ident.combinations[int(np.argmax(np.abs(z)))]
    assert inside.mean() > 0.9, inside.mean()
    assert ident.gap < ident.gap_bound
    # the identified model is a rigid arm the core accepts, and it predicts the efforts
    m = ident.model()
    t, q, qd, qdd = _motion(seed=5)
    pd = pm.createData()
    ref = np.array([pin.rnea(pm, pd, *x) for x in zip(q, qd, qdd)]) + FV * qd + FC * np.tanh(qd / VC) + OFF
    m.set_params({f"joint[{i}].coulomb_v": VC for i in range(1, 7)})
    err = np.sqrt(np.mean((m.inverse_dynamics(q, qd, qdd) - ref) ** 2, axis=0) / np.mean(ref ** 2, axis=0))
    assert np.all(err < 0.03), err


def test_a_recording_of_no_rigid_arm_is_refused(arm):
    """Link 5 of the truth weighs -3 kg: no rigid arm makes these efforts."""
    pm0 = pin.buildModelFromUrdf(PATH)
    bad = pin.Inertia(-3.0, pm0.inertias[5].lever, pm0.inertias[5].inertia)
    with pytest.raises(IdentificationError, match="not a rigid arm's"):
        identify(_recording(_pinocchio({5: bad}), arm[0]), arm[1], bootstrap=50)
