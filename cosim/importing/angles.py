"""Angle columns and joint limits of an import (docs/importing.md, Angles and joint limits).

* :func:`wrap` and :func:`unwrap`: a column entry's ``angle = "wrap"`` (into (-pi, pi]) or
  ``angle = "unwrap"`` (the 2 pi jumps of a wrapped encoder removed: the continuous angle a
  ``continuous`` joint's q is, docs/robots.md).  Only an angle column may take them.
* :func:`check_limits`: every position column inside its joint's limits (a continuous joint
  has none), or an error naming the file, the row (as the file counts) and the time.
"""
from __future__ import annotations

import re

import numpy as np

from .errors import ImportFailure

#: the values of a column's ``angle`` field and what each does
ANGLE_OPTIONS = {
    "wrap": "the angle brought into (-pi, pi] rad",
    "unwrap": "jumps of more than pi between samples taken as turns of 2 pi: the continuous angle",
}


def wrap(a) -> np.ndarray:
    """Angles [rad] brought into (-pi, pi].

    Example
    -------
    >>> wrap([3 * np.pi / 2, -np.pi, np.pi, 7.0]).round(4)
    array([-1.5708,  3.1416,  3.1416,  0.7168])
    """
    a = np.asarray(a, float)
    return np.pi - np.mod(np.pi - a, 2 * np.pi)


def unwrap(a) -> np.ndarray:
    """The continuous angle [rad] of samples that jump by about 2 pi where the angle was
    wrapped: each step between samples is taken as its wrapped value (in (-pi, pi]), the
    first sample kept.  Right while the true angle moves less than pi per sample.

    Example
    -------
    >>> unwrap([3.0, -3.0, -2.9]).round(4)
    array([3.    , 3.2832, 3.3832])
    """
    a = np.asarray(a, float)
    if a.size < 2:
        return a.copy()
    return a[0] + np.concatenate([[0.0], np.cumsum(wrap(np.diff(a)))])


def angle_column_error(name: str, si: str | None, facts) -> str | None:
    """Why column ``name`` (SI unit ``si``) of robot ``facts`` cannot be wrapped or
    unwrapped, or None if it can: only a joint position or reference (``q<i>``, ``qref<i>``)
    of a revolute joint or an angle of the pose (unit rad) is an angle."""
    if si == "rad" and (re.match(r"^(q|qref)[1-9][0-9]*$", name) or name in facts.tracker_names):
        return None
    what = ("a time" if name == "time" else
            f"a position in {si} (a prismatic joint)" if si == "m" and name[:1] == "q" and "d" not in name[:2] else
            f"in {si}" if si else "not a recording column")
    return f"{name} is {what}: only an angle column (a revolute joint's q<i> or qref<i>, a pose angle; unit rad) " \
           f"can be wrapped or unwrapped"


def check_limits(model, src, cols: dict, columns: dict) -> None:
    """Refuse a recording whose joint positions (``q<i>``, ``qref<i>``, SI values in
    ``cols``) leave the joint limits of ``model`` (the robot with the map's parameters);
    ``columns`` are the map's column entries (for the variable's name).

    Raises
    ------
    ImportFailure
        Naming the file, the variable and column, the first row outside (as the file counts
        it) with its time, the value and the limits, and what to do.
    """
    lo, hi = model.joint_limits()
    unit, t = model.joint_unit, cols["time"]
    for i in range(model.ndof):
        if not (np.isfinite(lo[i]) or np.isfinite(hi[i])):
            continue  # a continuous joint: no limits
        for name in (f"q{i + 1}", f"qref{i + 1}"):
            v = cols.get(name)
            if v is None:
                continue
            out = np.flatnonzero((v < lo[i]) | (v > hi[i]))
            if not out.size:
                continue
            k = int(out[0])
            hint = ("declare the joint continuous (continuous = true, docs/robots.md) if it turns without limit, "
                    "wrap or unwrap the column (angle = ...), or fix the map's unit, scale or offset"
                    if unit == "rad" else "check the map's unit, scale and offset of the column")
            more = f" ({out.size} rows outside in all)" if out.size > 1 else ""
            raise ImportFailure(src.path, f"{src.row_label([k])} (t = {float(t[k]):.6g} s): {name} = "
                                          f"{float(v[k]):.6g} {unit} is outside the joint limits [{lo[i]:.6g}, "
                                          f"{hi[i]:.6g}] {unit} of robot {model.robot}{more}; {hint}",
                                variable=columns[name].variable, column=name)
