"""A recording in memory: :class:`Recording` (``pkm-recording/1``), its error
(:class:`RecordingError`: file, row, column), the robot's facts it is checked against, the
full-pose tracker's columns and the checks before a write (:mod:`cosim.recording`).
"""
from __future__ import annotations

import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import RecordingError

FORMAT = "pkm-recording/1"


def _facts(robot):
    """The core's facts of a robot (joints, tracker columns; cached by the core module), or
    None if it knows none."""
    from ..core.model import robot_facts
    from ..errors import PkmError

    try:
        return robot_facts(robot)
    except (PkmError, TypeError):
        return None


def _described(side, name, file, text=None):
    """The facts of a robot the core does not know by name, from the description file the
    sidecar names (relative to the sidecar, or absolute in recordings written before the
    path was made relative), else from the description the sidecar carries.  The core then
    knows the robot by name for the rest of the process."""
    from ..core.model import Model
    from ..errors import PkmError

    src = None
    if isinstance(file, str):
        p = Path(file)
        p = p if p.is_absolute() else side.parent / p
        if p.exists():
            src = p
    if src is None and isinstance(text, str):
        # the sidecar's own copy, written where the core can read it for the whole process
        global _CARRIED
        if _CARRIED is None:
            _CARRIED = Path(tempfile.mkdtemp(prefix="pkm-robots-"))
        src = _CARRIED / (Path(file).name if isinstance(file, str) else f"{name}.toml")
        src.write_text(text)
    if src is None:
        raise RecordingError(side, f"robot {name!r} is not one the core knows and its description file {file} "
                                   f"is gone (known: {_known()}; or set PKM_ROBOT_PATH, docs/robots.md)")
    try:
        m = Model(str(src))
    except PkmError as e:
        raise RecordingError(side, f"robot {name!r}: its description file {file} does not load: {e}") from None
    if m.robot != name:
        raise RecordingError(side, f"the description file {file} is of robot {m.robot!r}, the recording of {name!r}")
    return _facts(name)


#: folder of the descriptions carried by sidecars (made on first use, kept for the process)
_CARRIED = None


#: the six components of a platform's pose, in the core's order, with their units
FULL_POSE = ("x", "y", "z", "rx", "ry", "rz")
FULL_POSE_UNITS = ("m", "m", "m", "rad", "rad", "rad")


def _declared(robot) -> list:
    """Indices in x y z rx ry rz of a robot's tracker columns (:func:`full_pose_allowed`)."""
    return [FULL_POSE.index(n) for n in _facts(robot).tracker_names]


def full_pose_allowed(facts) -> bool:
    """Whether a recording of this robot may carry the full pose ``x y z rx ry rz`` instead of
    its own tracker columns: a robot whose tracker columns are some, not all, of the six
    platform components (a 3-PRS or 3-RPS head, a Delta, a five-bar), whose other components
    the core holds or solves (``Model.platform_pose``).  A 6-DOF tracker measures all six."""
    names = tuple(facts.tracker_names)
    return bool(names) and len(names) < 6 and set(names) <= set(FULL_POSE)


def _known():
    from ..core.facts import robots

    return ", ".join(robots())


@dataclass
class Recording:
    """One recorded (or simulated) run.

    Arrays have one row per sample: ``time`` (n,) [s]; ``q``, ``qd``, ``tau``, ``qref``
    (n, nd); ``pose`` (n, npose) in the robot's tracker columns (the core's
    ``RobotFacts.tracker_names``: the pose coordinates; ``X`` for the four-bar);
    ``f_ext`` (n, nd) [N or N m], the measured external effort on each joint (positive
    along +q_i), None when the recording has none; ``pose_full`` (n, 6), the full pose of a
    6-DOF tracker (:meth:`set_full_pose`), None when not recorded.
    """

    robot: str
    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    qref: np.ndarray | None = None
    pose: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)
    notes: str = ""
    path: Path | None = None
    #: the joint convention the file declared (``sign``, ``offset`` per joint); the arrays
    #: are already in the model's convention.  Empty: the model's own.
    joint_convention: dict = field(default_factory=dict)
    #: measured external effort per joint (n, nd) [N or N m], None when not recorded
    f_ext: np.ndarray | None = None
    #: further sidecar fields, kept verbatim (``units``, ``derived``, ``sensors``, ``source``)
    sidecar: dict = field(default_factory=dict)
    #: the full pose x y z rx ry rz [m, rad] a 6-DOF tracker measured (n, 6), for a robot that
    #: declares some of the six (its parasitic components too); ``pose`` is then its declared
    #: columns.  None when the recording has the robot's own tracker columns only.
    pose_full: np.ndarray | None = None

    @property
    def ndof(self) -> int:
        return _facts(self.robot).ndof

    @property
    def pose_columns(self) -> list[str]:
        return list(_facts(self.robot).tracker_names)

    def set_full_pose(self, X) -> None:
        """Set the full pose a 6-DOF tracker measured, (n, 6) x y z rx ry rz [m, rad], and
        ``pose`` to its declared columns (a robot that declares some of the six:
        :func:`full_pose_allowed`)."""
        X = np.asarray(X, float)
        self.pose_full = X
        self.pose = X[:, _declared(self.robot)] if X.ndim == 2 and X.shape[1] == 6 else None

    def __len__(self) -> int:
        return len(self.time)

    def slice(self, start: int, stop: int) -> "Recording":
        """Rows ``start:stop`` as a new recording (same metadata)."""
        s = slice(start, stop)
        return Recording(
            self.robot, self.time[s], self.q[s], self.qd[s], self.tau[s],
            None if self.qref is None else self.qref[s],
            None if self.pose is None else self.pose[s],
            {k: v[s] for k, v in self.extra.items()},
            dict(self.parameters), dict(self.controller), self.notes, self.path, dict(self.joint_convention),
            f_ext=None if self.f_ext is None else self.f_ext[s], sidecar=dict(self.sidecar),
            pose_full=None if self.pose_full is None else self.pose_full[s],
        )

    def column_names(self) -> list[str]:
        nd = self.ndof
        cols = ["time"]
        for i in range(1, nd + 1):
            cols += [f"q{i}", f"qd{i}", f"tau{i}"] + ([f"qref{i}"] if self.qref is not None else [])
            cols += [f"f_ext{i}"] if self.f_ext is not None else []
        if self.pose_full is not None:
            cols += list(FULL_POSE)
        elif self.pose is not None:
            cols += self.pose_columns
        cols += list(self.extra)
        return cols

    def table(self) -> np.ndarray:
        """All columns as one (n, ncol) array in ``column_names()`` order."""
        nd, parts = self.ndof, [self.time[:, None]]
        for i in range(nd):
            parts += [self.q[:, i:i + 1], self.qd[:, i:i + 1], self.tau[:, i:i + 1]]
            if self.qref is not None:
                parts.append(self.qref[:, i:i + 1])
            if self.f_ext is not None:
                parts.append(self.f_ext[:, i:i + 1])
        if self.pose_full is not None:
            parts.append(self.pose_full)
        elif self.pose is not None:
            parts.append(self.pose)
        parts += [np.asarray(v, float)[:, None] for v in self.extra.values()]
        return np.hstack(parts)


def sidecar_path(csv_path) -> Path:
    return Path(csv_path).with_suffix(".json")


def _validate(rec: Recording, path) -> None:
    if _facts(rec.robot) is None:
        raise RecordingError(path, f"unknown robot {rec.robot!r} (known: {_known()})")
    n, nd = len(rec.time), rec.ndof
    for name in ("q", "qd", "tau", "qref", "f_ext"):
        a = getattr(rec, name)
        if a is None:
            continue
        if a.shape != (n, nd):
            raise RecordingError(path, f"{name} has shape {a.shape}, expected ({n}, {nd}) for robot {rec.robot}")
    if rec.pose is not None and rec.pose.shape != (n, len(rec.pose_columns)):
        raise RecordingError(path, f"pose has shape {rec.pose.shape}, expected ({n}, {len(rec.pose_columns)})")
    if rec.pose_full is not None:
        if not full_pose_allowed(_facts(rec.robot)):
            raise RecordingError(path, f"a full pose (x y z rx ry rz) is for a robot that declares some of them; "
                                       f"{rec.robot} declares {' '.join(rec.pose_columns)}")
        if rec.pose_full.shape != (n, 6):
            raise RecordingError(path, f"pose_full has shape {rec.pose_full.shape}, expected ({n}, 6)")
    bad = np.flatnonzero(np.diff(rec.time) <= 0)
    if bad.size:
        k = bad[0] + 1
        raise RecordingError(path, f"time is not strictly increasing ({rec.time[k - 1]!r} then {rec.time[k]!r})",
                             row=k + 2, column="time")
    tab = rec.table()
    nonfinite = np.argwhere(~np.isfinite(tab))
    if nonfinite.size:
        r, c = nonfinite[0]
        raise RecordingError(path, f"value {float(tab[r, c])!r} is not a finite number", row=r + 2,
                             column=rec.column_names()[c])


#: sidecar fields the format defines itself (``Recording.sidecar`` cannot override them)
_RESERVED = ("format", "robot", "parameters", "controller", "notes", "joint_convention", "robot_file",
             "robot_description")


def _si_units(facts, rec: Recording) -> dict:
    """The sidecar's ``units`` of a written recording: the robot's SI units, per kind of column."""
    ju, eu = facts.joint_unit, facts.effort_unit
    units = {"time": "s", "q": ju, "qd": f"{ju}/s", "tau": eu}
    if rec.pose_full is not None:
        units["pose"] = list(FULL_POSE_UNITS)
    if rec.qref is not None:
        units["qref"] = ju
    if rec.f_ext is not None:
        units["f_ext"] = eu
    if "tau_meas1" in rec.extra:  # a measured effort (a torque sensor, a current times its constant)
        units["tau_meas"] = eu
    if "inject1" in rec.extra:  # an injected signal (cosim.injection): an effort at the command
        point = (rec.sidecar.get("injection") or {}).get("point")
        units["inject"] = eu if point in ("command", "command_after_saturation") else ju
    return units
