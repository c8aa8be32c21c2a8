"""What a residual pipeline (:class:`.residuals.Pipeline`) can take from another pipeline of the
same recording whose model has the same kinematics: the poses, pose rates and accelerations of
the recorded and smoothed joints and of the reference, and the kinematic entries of its
evaluation cache (the joint motion along a pose motion, the nominal pose rates, whether a
parameter moves the joints, the poses of a geometry change), and, when no actuator or sensor
parameter differs either, the actuators' efforts for the recorded command and the sensors'
readings at the tracker's poses.

The platform-force stage (:mod:`.platform_force`) builds a second pipeline for the model with a
force on the platform; a force, a mass or an inertia leaves the kinematics as they are, and
these are the costly part of a pipeline that does not depend on them.  What is taken is the
value the pipeline would compute, bit for bit (the same core calls on the same inputs): the
readings where a backlash or a compliance makes them read the dynamics are not taken.
"""
from __future__ import annotations

import numpy as np

#: first element of the keys of a pipeline's evaluation cache whose values depend on the
#: model's kinematics only (``Pipeline._inverse_dynamics``'s "J", ``_pose_term``'s "P0" and
#: "X", ``_moves_joints``'s "moves joints")
KINEMATIC_KEYS = ("J", "P0", "X", "moves joints")
#: first element of the keys whose values depend on the kinematics and on the actuators' and the
#: sensors' parameters only (``Pipeline._applied``'s "A": the efforts the actuators apply for the
#: recorded command; ``Pipeline._readings``' "K": the readings the sensors give at the tracker's
#: poses); taken when no parameter of either kind differs (a saturation's or a dead zone's
#: profile is some 50 of them)
COMMAND_KEYS = ("A", "K")


def same_kinematics(prev, rec, model, *, window: int, polyorder: int, segments, zoh: bool) -> bool:
    """Can a pipeline of ``rec`` for ``model`` take the kinematics of the pipeline ``prev``?

    Yes when ``prev`` is a pipeline of the same recording object with the same smoothing,
    segments and effort hold, and every parameter of ``model`` that differs from ``prev``'s
    model is one that moves no joint (``prev._moves_joints``: not a geometry parameter, and
    the joint motion of a few recorded samples unchanged when it is moved; a mass, an inertia,
    gravity or a force on the platform)."""
    if prev is None or prev.rec is not rec or prev.model.robot != model.robot:
        return False
    if (prev.window, prev.polyorder, prev.zoh) != (window, polyorder, zoh):
        return False
    if prev.segments != ([(0, prev.n)] if segments is None else [(int(a), int(b)) for a, b in segments]):
        return False
    if set(model.params()) != set(prev.nominal):
        return False
    return not any(prev._moves_joints(k) for k in changed(prev, model))


def changed(prev, model) -> list:
    """The parameters of ``model`` whose values differ from those of ``prev``'s model (a NaN
    equals a NaN)."""
    theirs = prev.nominal
    return [k for k, v in model.params().items() if theirs[k] != v and not (np.isnan(v) and np.isnan(theirs[k]))]


def kinematic_entries(prev, command: bool = False) -> list:
    """The entries of ``prev``'s evaluation cache that hold kinematics only, and with ``command``
    those of :data:`COMMAND_KEYS` too, oldest first; readings ("K") only where no backlash or
    compliance acts (:func:`reads_dynamics`)."""
    keys = KINEMATIC_KEYS + (COMMAND_KEYS if command else ())
    flexible_nominal = reads_dynamics(prev.nominal.items())
    return [(k, v) for k, v in prev._memo.entries.items()
            if k[0] in keys and not (k[0] == "K" and (flexible_nominal or reads_dynamics(k[1])))]


def reads_dynamics(params) -> bool:
    """Do the sensors' readings with these ``(name, value)`` parameters depend on the model's
    dynamics?  With a backlash or a compliance they do: the encoder reads the drive side of the
    transmission, which leans or deflects with the effort the transmission carries, the applied
    effort less the drive's friction, inertia and joint force and the force on the platform
    (``pkm_measure_joints``); a model with another force on the platform reads otherwise."""
    return any(k.endswith((".backlash", ".compliance")) and v != 0 for k, v in params)
