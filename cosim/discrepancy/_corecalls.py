"""Per-sample calls of core functions over a whole recording (the batched form where the
core has one).

Thin layer over ``cosim.core.Model``'s per-item loop (integer addresses, about 1 us a
sample), adding the sample's time to the error of the first failing sample.  Nothing here
computes physics.
"""
from __future__ import annotations

_NAMES = {
    "pkm_joint_velocity": ["x", "xd"],
    "pkm_joint_friction": ["qd"],
}


def per_sample(model, name, *inputs, what="sample", times=None):
    """Call ``name(m, d, in_1[k], ..., out[k])`` for every row k; returns ``out`` (n, nd).

    Raises the core's error for the first failing row, naming the row and, if
    ``times`` is given, its time.
    """
    return model._loop(name, inputs, _NAMES[name], (model.ndof,), times=times, what=what)


def pose_velocity(model, x, qd, times=None):
    """Pose rates xd (n, nd) of joint rates qd at poses x (core ``pkm_pose_velocity``)."""
    return model.pose_velocity(x, qd, times=times, what="sample")


def pose_acceleration(model, x, xd, qdd, times=None):
    """Pose accelerations (n, nd) (core ``pkm_pose_acceleration``)."""
    return model.pose_acceleration(x, xd, qdd, times=times, what="sample")


def measure_joints(model, x, xd, tau, times=None):
    """Joint readings (n, nd) of the model's sensors at (x, xd) with applied effort tau
    (core ``pkm_measure_joints``: encoder offset, backlash, compliance)."""
    return model.measure_joints(x, xd, tau, times=times, what="sample")


def actuator_effort(model, tau_cmd, times=None):
    """Effort reaching the mechanism for commanded efforts (n, nd) (core saturation)."""
    return model.actuator_effort(tau_cmd, times=times, what="sample")
