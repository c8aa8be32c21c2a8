"""What the core says of its robots: their names, a model's named parameters, a robot's facts
(``pkm.h`` "robot facts") and the Quattro index names.  Nothing in Python restates them.
"""
from __future__ import annotations

from dataclasses import dataclass

from .._native import lib


@dataclass(frozen=True)
class ParamInfo:
    """One named parameter of a model."""

    name: str
    value: float
    unit: str
    description: str



def robots() -> list[str]:
    """Names of the robots compiled into the core (``pkm_robot_name``), e.g. ``["6pus", ...]``."""
    return [lib.pkm_robot_name(i).decode() for i in range(lib.pkm_robot_count())]


#: PKM_QUATTRO_NINDEX in pkm.h
_QUATTRO_NINDEX = 22


def quattro_index_names() -> list[str]:
    """Names of the Quattro performance indices, in the column order of
    :meth:`Model.quattro_indices` (``pkm_quattro_index_name``)."""
    return [lib.pkm_quattro_index_name(i).decode() for i in range(_QUATTRO_NINDEX)]


def quattro_index_units() -> dict[str, str]:
    """Unit of each Quattro performance index by name (``pkm_quattro_index_unit``)."""
    return {lib.pkm_quattro_index_name(i).decode(): lib.pkm_quattro_index_unit(i).decode()
            for i in range(_QUATTRO_NINDEX)}


@dataclass(frozen=True)
class RobotFacts:
    """What the core says of a robot (``pkm.h`` "robot facts"); nothing in Python restates it.

    Attributes
    ----------
    name : str
        Robot name (``pkm_model_create``).
    ndof : int
        Actuated joints = pose coordinates.
    param_sets : tuple of str
        Named parameter sets, ``"default"`` first.
    pose_names, pose_units : tuple of str
        Pose coordinates (``"x"``, ..., ``"theta"``) and their units (``"m"``, ``"rad"``).
    tracker_names, tracker_units : tuple of str
        What an external tracker measures (a recording's pose columns): the pose
        coordinates, or what the robot measures instead (the four-bar: ``"X"`` in m).
    joint_unit, effort_unit : str
        Unit of the joint coordinates q (``"m"`` or ``"rad"``) and of the efforts
        (``"N"`` or ``"N m"``).
    joint_noun, joint_prefix : str
        How messages name an actuated joint, and the drive parameters' prefix
        (``"rail"`` -> ``"rail[i].coulomb"``).
    geometry_params : tuple of str
        The parameters a geometric error is described by (``pkm_model_geometry_param``:
        the 6-PUS ``leg[i].L``, one per joint); empty where the robot names none (then
        :meth:`Model.geometry_params` derives them).
    title, file : str
        One line saying what the robot is, and the description file it was compiled from
        (``""`` for the robots written in C++; docs/robots.md).
    features : tuple of str
        The robot-specific function families it provides beyond the common set
        (``pkm_model_has``): ``"6pus_calib_rows"`` (the 60-parameter calibration rows),
        ``"6pus_leg_points"``, ``"fourbar_output"``, ``"quattro_indices"``,
        ``"quattro_gimre"``, ``"quattro_points"``.  Capabilities are asked of the model
        (:meth:`Model.has`), never inferred from its name.
    """

    name: str
    ndof: int
    param_sets: tuple
    pose_names: tuple
    pose_units: tuple
    tracker_names: tuple
    tracker_units: tuple
    joint_unit: str
    effort_unit: str
    joint_noun: str
    joint_prefix: str
    geometry_params: tuple = ()
    title: str = ""
    file: str = ""
    features: tuple = ()

    @property
    def angular_joints(self) -> bool:
        """True for revolute actuated joints (q in rad, efforts in N m)."""
        return self.joint_unit == "rad"
