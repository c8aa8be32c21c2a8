"""Reference trajectories in task space: steps, rest-to-rest paths, the laser-cut "M", pose sets.

A trajectory gives the pose ``x(t)`` and its first two time derivatives ``xd(t)``,
``xdd(t)``, each of shape ``(n, nd)`` for ``n`` sample times, in the robot's pose
coordinates (6-PUS: ``x, y, z`` [m], ``rx, ry, rz`` [rad], fixed-axis angles, the
derivatives are angle rates).  Joint references are derived from it by the core
(:func:`joint_reference`): nothing here knows the robot's geometry.

Rest-to-rest moves use the quintic minimum-jerk blend
``s(u) = 10 u^3 - 15 u^4 + 6 u^5``, ``u = (t - t0) / T``: position, velocity and
acceleration are continuous at the knots, so a computed-torque controller sees a
continuous feed-forward and the actuator efforts have no jumps.

Example
-------
>>> import numpy as np
>>> from cosim.trajectories import letter_m
>>> traj = letter_m(center=(0.0, 0.0), z=0.075, width=0.03, height=0.03, segment_time=0.4)
>>> x, xd, xdd = traj.evaluate(np.array([0.0, 0.2]))
>>> x.shape
(2, 6)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import TrajectoryError


def _blend(u):
    """Minimum-jerk blend s(u) and its derivatives ds/du, d2s/du2 for u in [0, 1]."""
    u = np.clip(u, 0.0, 1.0)
    s = u**3 * (10 - 15 * u + 6 * u**2)
    ds = 30 * u**2 * (1 - u) ** 2
    dds = 60 * u * (1 - u) * (1 - 2 * u)
    return s, ds, dds


@dataclass
class Trajectory:
    """Piecewise trajectory through knots, rest at every knot.

    Between ``knots[k]`` (time ``times[k]``) and ``knots[k+1]`` the pose follows a
    minimum-jerk blend when ``kind[k] == "blend"``, holds ``knots[k]`` when
    ``kind[k] == "hold"`` and jumps to ``knots[k+1]`` at ``times[k]`` when
    ``kind[k] == "jump"`` (a step).  Before ``times[0]`` the pose is ``knots[0]``;
    after ``times[-1]`` it is ``knots[-1]``.

    Attributes
    ----------
    times : ndarray, shape (m,)
        Knot times [s], non-decreasing.
    knots : ndarray, shape (m, nd)
        Poses at the knots [m, rad].
    kind : list of str, length m - 1
        Segment kinds: ``"blend"``, ``"hold"`` or ``"jump"``.
    labels : ndarray of int, shape (m - 1,)
        A tag per segment (e.g. the index of the held pose of a calibration
        campaign, 0 while moving); see :meth:`label`.
    name : str
        A short description for figures and sidecars.
    """

    times: np.ndarray
    knots: np.ndarray
    kind: list
    labels: np.ndarray = None
    name: str = ""
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.times = np.asarray(self.times, dtype=float)
        self.knots = np.atleast_2d(np.asarray(self.knots, dtype=float))
        m = len(self.times)
        if self.knots.shape[0] != m:
            raise TrajectoryError(f"{m} knot times but {self.knots.shape[0]} knot poses")
        if len(self.kind) != m - 1:
            raise TrajectoryError(f"{m} knots need {m - 1} segment kinds, got {len(self.kind)}")
        bad = [k for k, s in enumerate(self.kind) if s not in ("blend", "hold", "jump")]
        if bad:
            raise TrajectoryError(f"segment {bad[0]} has unknown kind {self.kind[bad[0]]!r}")
        if not np.all(np.isfinite(self.times)) or not np.all(np.isfinite(self.knots)):
            raise TrajectoryError("knot times and poses must be finite numbers")
        dt = np.diff(self.times)
        k = np.flatnonzero(dt < 0)
        if k.size:
            raise TrajectoryError(f"knot times must not decrease (knot {k[0] + 1}: {self.times[k[0] + 1]} s "
                                  f"after {self.times[k[0]]} s)")
        for j, s in enumerate(self.kind):
            if s == "blend" and dt[j] <= 0:
                raise TrajectoryError(f"blend segment {j} has zero duration")
        if self.labels is None:
            self.labels = np.zeros(m - 1, dtype=int)
        self.labels = np.asarray(self.labels, dtype=int)

    @property
    def ndof(self) -> int:
        return self.knots.shape[1]

    @property
    def duration(self) -> float:
        """Time of the last knot [s]."""
        return float(self.times[-1])

    def _segment(self, t):
        # Index of the segment containing each t (-1 before the first knot, m-1 after the last).
        return np.searchsorted(self.times, t, side="right") - 1

    def evaluate(self, t):
        """Pose, velocity and acceleration at times t.

        Parameters
        ----------
        t : array_like, shape (n,)
            Sample times [s].

        Returns
        -------
        x, xd, xdd : ndarray, each shape (n, nd)
            Pose [m, rad], its rate [m/s, rad/s] and acceleration [m/s^2, rad/s^2].
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        m, nd = len(self.times), self.ndof
        seg = self._segment(t)
        x = np.empty((len(t), nd))
        xd = np.zeros((len(t), nd))
        xdd = np.zeros((len(t), nd))
        x[seg < 0] = self.knots[0]
        x[seg >= m - 1] = self.knots[-1]
        for j, s in enumerate(self.kind):
            sel = seg == j
            if not np.any(sel):
                continue
            a, b = self.knots[j], self.knots[j + 1]
            if s == "hold":
                x[sel] = a
            elif s == "jump":
                x[sel] = b
            else:
                T = self.times[j + 1] - self.times[j]
                u = (t[sel] - self.times[j]) / T
                s0, s1, s2 = _blend(u)
                x[sel] = a + np.outer(s0, b - a)
                xd[sel] = np.outer(s1 / T, b - a)
                xdd[sel] = np.outer(s2 / T**2, b - a)
        return x, xd, xdd

    def label(self, t):
        """Segment tag at times t (0 before the first and after the last knot)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        seg = self._segment(t)
        out = np.zeros(len(t), dtype=int)
        inside = (seg >= 0) & (seg < len(self.kind))
        out[inside] = self.labels[seg[inside]]
        return out


def step(x0, x1, t_step: float = 0.0, name: str = "step") -> Trajectory:
    """A step of the pose reference from ``x0`` to ``x1`` at ``t_step`` [s].

    At ``t == t_step`` the reference is already ``x1``.  Velocity and acceleration
    references are zero (the controller sees the whole step as an error).

    Parameters
    ----------
    x0, x1 : array_like, shape (nd,)
        Pose before and after the step [m, rad].
    t_step : float
        Time of the step [s].
    name : str
        Description.
    """
    x0, x1 = np.asarray(x0, float), np.asarray(x1, float)
    if x0.shape != x1.shape:
        raise TrajectoryError(f"step: x0 has shape {x0.shape}, x1 {x1.shape}")
    return Trajectory([t_step, t_step], [x0, x1], ["jump"], name=name)


def waypoints(poses, move_time, hold_time=0.0, t0: float = 0.0, start_hold: float = 0.0,
              labels=None, name: str = "waypoints") -> Trajectory:
    """Rest-to-rest minimum-jerk moves through ``poses``, optionally holding each one.

    Parameters
    ----------
    poses : array_like, shape (p, nd)
        Poses to visit in order [m, rad]; the trajectory starts at rest at ``poses[0]``.
    move_time : float or array_like, shape (p - 1,)
        Duration of each move [s].
    hold_time : float or array_like, shape (p,)
        Time held at each pose after reaching it [s] (the first pose: ``start_hold``).
    t0 : float
        Start time [s].
    start_hold : float
        Time at rest at ``poses[0]`` before the first move [s].
    labels : array_like of int, shape (p,), optional
        Tag of the hold at each pose (default: ``1..p``); moves are tagged 0.
    name : str
        Description.
    """
    poses = np.atleast_2d(np.asarray(poses, float))
    p = poses.shape[0]
    if p < 1:
        raise TrajectoryError("waypoints: at least one pose is needed")
    move = np.broadcast_to(np.asarray(move_time, float), (max(p - 1, 0),))
    hold = np.broadcast_to(np.asarray(hold_time, float), (p,)).copy()
    hold[0] = max(hold[0], start_hold) if start_hold else hold[0]
    if np.any(move <= 0):
        raise TrajectoryError(f"waypoints: move {int(np.argmax(move <= 0)) + 1} has a non-positive duration")
    if np.any(hold < 0):
        raise TrajectoryError("waypoints: hold times must be >= 0")
    lab = np.arange(1, p + 1) if labels is None else np.asarray(labels, int)
    times, knots, kind, tags = [t0], [poses[0]], [], []
    t = t0
    for k in range(p):
        if k > 0:
            t += move[k - 1]
            times.append(t)
            knots.append(poses[k])
            kind.append("blend")
            tags.append(0)
        if hold[k] > 0:
            t += hold[k]
            times.append(t)
            knots.append(poses[k])
            kind.append("hold")
            tags.append(int(lab[k]))
    if len(times) == 1:  # a single pose, no hold: a degenerate hold of zero length
        times.append(t0)
        knots.append(poses[0])
        kind.append("hold")
        tags.append(int(lab[0]))
    return Trajectory(times, knots, kind, labels=tags, name=name)


def letter_m_corners(center=(0.0, 0.0), width: float = 0.03, height: float = 0.03,
                     middle_depth: float = 0.5):
    """The five corners of a block letter "M" in the x-y plane [m].

    Parameters
    ----------
    center : (float, float)
        Centre of the letter's bounding box [m].
    width, height : float
        Size of the bounding box [m].
    middle_depth : float
        How far below the top the middle vertex lies, as a fraction of the height.

    Returns
    -------
    ndarray, shape (5, 2)
        Bottom-left, top-left, middle vertex, top-right, bottom-right.
    """
    cx, cy = center
    w, h = width / 2, height / 2
    return np.array([
        [cx - w, cy - h],
        [cx - w, cy + h],
        [cx, cy + h - middle_depth * height],
        [cx + w, cy + h],
        [cx + w, cy - h],
    ])


def letter_m(center=(0.0, 0.0), z: float = 0.075, width: float = 0.03, height: float = 0.03,
             segment_time: float = 0.4, hold_time: float = 0.1, middle_depth: float = 0.5,
             orientation=(0.0, 0.0, 0.0), t0: float = 0.0, coordinates=None) -> Trajectory:
    """The laser-cut letter "M" (Zavala-Yoe et al. 2015 sec. 8.1, 8.9) traced at constant height.

    Four straight strokes through :func:`letter_m_corners`, each a rest-to-rest
    minimum-jerk move of ``segment_time`` [s] (a cutting head stops at the corners so
    they come out sharp), with ``hold_time`` [s] at rest before the first and after the
    last stroke.  The platform keeps height ``z`` [m] and ``orientation``
    (rx, ry, rz) [rad].  The seed gives no size or speed; the defaults (30 x 30 mm,
    0.4 s per stroke: mean 75 mm/s on the verticals, 53 mm/s on the diagonals, peak
    15/8 of the mean) are documented in docs/scenarios.md.

    Parameters
    ----------
    center : (float, float)
        Centre of the letter [m].
    z : float
        Platform height [m].
    width, height : float
        Size of the letter [m].
    segment_time : float
        Duration of each of the four strokes [s].
    hold_time : float
        Rest before the first and after the last stroke [s].
    middle_depth : float
        Depth of the middle vertex below the top, as a fraction of the height.
    orientation : (float, float, float)
        Platform orientation (rx, ry, rz) [rad], constant.
    t0 : float
        Start time [s].
    coordinates : sequence of str, optional
        The robot's pose coordinates (``Model.facts.pose_names``), a subset of
        x y z rx ry rz in any order: the poses keep those (a Delta's x y z, a planar robot's
        x y rz). Default: all six.
    """
    corners = letter_m_corners(center, width, height, middle_depth)
    poses = np.column_stack([corners, np.full(len(corners), z), np.tile(orientation, (len(corners), 1))])
    if coordinates is not None:
        full = ("x", "y", "z", "rx", "ry", "rz")
        other = [c for c in coordinates if c not in full]
        if other or not {"x", "y"} <= set(coordinates):
            raise TrajectoryError(f"the letter M is traced in x and y by a robot with coordinates among "
                             f"{' '.join(full)}; this one has {' '.join(coordinates)}")
        poses = poses[:, [full.index(c) for c in coordinates]]
    hold = np.zeros(len(poses))
    hold[-1] = hold_time
    traj = waypoints(poses, segment_time, hold, t0=t0, start_hold=hold_time,
                     labels=np.zeros(len(poses), int), name="letter M")
    traj.meta = {"width": width, "height": height, "z": z, "segment_time": segment_time, "center": list(center)}
    return traj


def pose_set(poses, move_time: float = 0.5, hold_time: float = 0.5, start=None, t0: float = 0.0,
             name: str = "pose set") -> Trajectory:
    """A calibration campaign: go to each pose, hold it, go on.

    Parameters
    ----------
    poses : array_like, shape (p, nd)
        Measurement poses [m, rad].
    move_time, hold_time : float
        Duration of each move and of each hold [s].
    start : array_like, shape (nd,), optional
        Where the robot starts (default: the first pose, held from ``t0``).
    t0 : float
        Start time [s].
    name : str
        Description.

    The hold at pose ``k`` (1-based) carries the label ``k`` (see
    :meth:`Trajectory.label`); moves and the start carry 0.
    """
    poses = np.atleast_2d(np.asarray(poses, float))
    if start is None:
        return waypoints(poses, move_time, hold_time, t0=t0, name=name)
    allp = np.vstack([np.asarray(start, float)[None, :], poses])
    labels = np.concatenate([[0], np.arange(1, len(poses) + 1)])
    hold = np.full(len(allp), hold_time)
    hold[0] = 0.0
    return waypoints(allp, move_time, hold, t0=t0, labels=labels, name=name)


def joint_reference(model, x, xd, xdd):
    """Joint-space reference from a task-space one, through the core.

    Parameters
    ----------
    model : cosim.core.Model
        The model the controller believes in.
    x, xd, xdd : ndarray, shape (n, nd)
        Pose [m, rad], rate and acceleration.

    Returns
    -------
    q, qd, qdd : ndarray, shape (n, nd)
        Joint positions [m or rad], velocities and accelerations (``q = ik(x)``,
        ``qd = J xd``, ``qdd = J xdd + Jdot xd``, all computed by the core).
    """
    q = model.ik(x)
    moving = np.any(xd != 0, axis=1) | np.any(xdd != 0, axis=1)
    qd = np.zeros_like(q)
    qdd = np.zeros_like(q)
    if np.any(moving):
        qd[moving] = model.joint_velocity(x[moving], xd[moving])
        qdd[moving] = model.joint_acceleration(x[moving], xd[moving], xdd[moving])
    return q, qd, qdd


def rotation(r):
    """Rotation matrices R = Rx(rx) Ry(ry) Rz(rz) (the pose convention of pkm.h), shape (..., 3, 3)."""
    r = np.asarray(r, float)
    cx, cy, cz = np.cos(r[..., 0]), np.cos(r[..., 1]), np.cos(r[..., 2])
    sx, sy, sz = np.sin(r[..., 0]), np.sin(r[..., 1]), np.sin(r[..., 2])
    R = np.empty(r.shape[:-1] + (3, 3))
    R[..., 0, 0] = cy * cz
    R[..., 0, 1] = -cy * sz
    R[..., 0, 2] = sy
    R[..., 1, 0] = sx * sy * cz + cx * sz
    R[..., 1, 1] = -sx * sy * sz + cx * cz
    R[..., 1, 2] = -sx * cy
    R[..., 2, 0] = -cx * sy * cz + sx * sz
    R[..., 2, 1] = cx * sy * sz + sx * cz
    R[..., 2, 2] = cx * cy
    return R


def tool_point(x, offset=(0.0, 0.0, 0.0)):
    """World position [m] of a tool point fixed on a 6-PUS platform, shape (n, 3).

    ``offset`` is the point in platform coordinates [m] (the laser nozzle / pen tip).
    """
    x = np.atleast_2d(np.asarray(x, float))
    return x[:, :3] + rotation(x[:, 3:6]) @ np.asarray(offset, float)


def pen_point(robot: str, x, offset=(0.0, 0.0, 0.0)):
    """The traced point of poses of a robot, shape (n, k) [m].

    Parameters
    ----------
    robot : str
        Robot name: its pose names and units come from the core.
    x : array_like, shape (n, nd)
        Poses [m, rad].
    offset : array_like, shape (3,)
        Tool point in platform coordinates [m], used where the pose carries the rotations
        rx, ry, rz (:func:`tool_point`); otherwise the pose's position coordinates (those in
        metres) are the traced point.
    """
    from .core.model import robot_facts

    f = robot_facts(robot)
    x = np.atleast_2d(np.asarray(x, float))
    if tuple(f.pose_names[:6]) == ("x", "y", "z", "rx", "ry", "rz"):
        return tool_point(x, offset)
    return x[:, [i for i, u in enumerate(f.pose_units) if u == "m"][:3]]
