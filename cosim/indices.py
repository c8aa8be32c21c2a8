"""Performance indices every robot has, computed by the core: per pose and on grids.

The Quattro has 22 indices of its own (Virzi 2010, ``pkm_quattro_indices``, :mod:`cosim.quattro`);
nothing like them is defined for other robots.  What any robot the core knows (hand-written
or compiled from a description file) offers, and what this module maps:

========================  ==================  ================================================
index                     unit                from the core
========================  ==================  ================================================
``reachable``             1 / 0               inverse kinematics succeeds, every joint inside
                                              its limits
``inverse``               1 (0 = singular)    ``pkm_singularity`` measure 0: inverse-kinematic
                                              (a leg at the edge of its reach)
``direct``                1 (0 = singular)    ``pkm_singularity`` measure 1: 1 / cond of the
                                              scaled Jacobian (the legs no longer hold the
                                              platform)
``speed_min/speed_max``   m/s per joint rate  extreme singular values of the map from joint
                                              rates to the translation rate (the rows of
                                              J^-1 of the pose coordinates in metres)
``turn_min/turn_max``     rad/s per joint     the same for the rotation rates (robots that
                          rate                rotate)
``mass_max``              kg or kg m2         largest eigenvalue of the joint-space mass
                                              matrix J^-T M J^-1 (``pkm_mass_matrix``)
``gravity_max``           N or N m            largest joint effort that holds the robot still
                                              (``pkm_gravity_load``)
========================  ==================  ================================================

Example
-------
>>> from cosim.core import Model
>>> from cosim.indices import index_map
>>> mp = index_map(Model("6pus"), x=np.linspace(-0.05, 0.05, 21), z=np.linspace(0.02, 0.10, 17))
>>> mp["direct"].shape, mp.argbest("direct")

Command line: ``cosim indices --robot <name or file.toml> --axis x=-0.05:0.05:21 --axis z=0.02:0.1:17``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np  # noqa: F401 (the example above)

from .errors import InputError

__all__ = ["pose_indices", "index_map", "IndexMap", "index_units", "BETTER", "ORDER"]

#: which way is better for the indices where one is (speed and turn gains: faster is less precise)
BETTER = {"reachable": "max", "inverse": "max", "direct": "max", "mass_max": "min", "gravity_max": "min"}
#: the order of the indices in a map
ORDER = ("reachable", "inverse", "direct", "speed_min", "speed_max", "turn_min", "turn_max", "mass_max",
         "gravity_max")


def index_units(model) -> dict:
    """The unit of each index of ``model`` (from the core's joint and effort units)."""
    f = model.facts
    ju = f.joint_unit
    inertia = "kg m2" if ju == "rad" else "kg"
    return {"reachable": "1", "inverse": "1", "direct": "1", "speed_min": f"m/s per {ju}/s",
            "speed_max": f"m/s per {ju}/s", "turn_min": f"rad/s per {ju}/s", "turn_max": f"rad/s per {ju}/s",
            "mass_max": inertia, "gravity_max": f.effort_unit}


def pose_indices(model, poses) -> dict:
    """The indices at ``poses`` (n, nd) [m, rad]: ``{name: (n,) array}``, NaN (``reachable`` 0)
    where the core cannot reach a pose or a joint is outside its limits.  The translation
    (rotation) indices are present when the robot has pose coordinates in metres (radians)."""
    x = np.atleast_2d(np.asarray(poses, float))
    n = x.shape[0]
    units = model.facts.pose_units
    lin = [i for i, u in enumerate(units) if u == "m"]
    ang = [i for i, u in enumerate(units) if u == "rad"]
    q, st = model.ik(x, errors="status")
    lo, hi = (np.asarray(v, float) for v in model.joint_limits())
    with np.errstate(invalid="ignore"):
        ok = (np.asarray(st) == 0) & ~np.any((q < lo) | (q > hi), axis=1)
    names = ["inverse", "direct", "mass_max", "gravity_max"] + (["speed_min", "speed_max"] if lin else []) \
        + (["turn_min", "turn_max"] if ang else [])
    out = {k: np.full(n, np.nan) for k in names}
    out["reachable"] = ok.astype(float)
    good = np.flatnonzero(ok)
    for k in good:
        xk = x[k]
        s = model.singularity(xk)
        out["inverse"][k], out["direct"][k] = s[0], s[1]
        J = model.jacobian(xk)
        try:
            Jinv = np.linalg.inv(J)
        except np.linalg.LinAlgError:
            continue
        Mq = Jinv.T @ model.mass_matrix(xk) @ Jinv
        out["mass_max"][k] = float(np.linalg.eigvalsh(0.5 * (Mq + Mq.T)).max())
        out["gravity_max"][k] = float(np.abs(model.gravity_load(xk)).max())
        for rows, a, b in ((lin, "speed_min", "speed_max"), (ang, "turn_min", "turn_max")):
            if rows:
                sv = np.linalg.svd(Jinv[rows], compute_uv=False)
                out[a][k], out[b][k] = sv.min(), sv.max()
    return out


@dataclass
class IndexMap:
    """Indices on a grid of poses: ``values[name]`` has the grid's shape (one axis per swept
    pose coordinate, in ``axes`` order), NaN where the pose is not reachable."""

    robot: str
    axes: dict            # coordinate name -> values
    fixed: dict           # the other coordinates -> value
    values: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def names(self) -> list:
        return list(self.values)

    def pose(self, index) -> dict:
        """The pose coordinates of a grid index (a tuple)."""
        out = dict(self.fixed)
        out.update({n: float(v[i]) for (n, v), i in zip(self.axes.items(), index)})
        return out

    def argbest(self, name: str, better: str | None = None) -> dict:
        """The pose of the best value of an index (``better`` = "max" or "min", default
        :data:`BETTER`), as ``{coordinate: value}``."""
        v = self.values[name]
        better = better or BETTER.get(name)
        if better not in ("max", "min"):
            raise InputError(f"index {name!r} has no better direction: give better='max' or 'min'")
        if not np.isfinite(v).any():
            raise InputError(f"index {name!r} has no value on this grid (nothing reachable)")
        f = np.nanargmax if better == "max" else np.nanargmin
        return self.pose(np.unravel_index(f(v), v.shape))

    def summary(self) -> str:
        """One line per index: range over the reachable poses and where the best one is."""
        reach = self.values["reachable"]
        L = [f"{self.robot}: {int(np.nansum(reach))} of {reach.size} grid poses reachable "
             f"({', '.join(f'{n} {len(v)} values in [{v.min():g}, {v.max():g}]' for n, v in self.axes.items())}"
             + (f"; {', '.join(f'{n} = {v:g}' for n, v in self.fixed.items())}" if self.fixed else "") + ")"]
        for name, v in self.values.items():
            if name == "reachable" or not np.isfinite(v).any():
                continue
            where = ""
            if name in BETTER:
                best = self.argbest(name)
                where = "best at " + ", ".join(f"{k} = {best[k]:.4g}" for k in self.axes)
            L.append(f"  {name:<12} {np.nanmin(v):11.4g} .. {np.nanmax(v):<11.4g} {self.units.get(name, ''):<22} "
                     + where)
        return "\n".join(L)


def index_map(model, fixed: dict | None = None, **axes) -> IndexMap:
    """The indices on the grid of the pose coordinates given as keyword arrays
    (``x=np.linspace(...)``), the others at ``fixed`` (default: home).

    Parameters
    ----------
    model : cosim.core.Model
    fixed : dict, optional
        Values of coordinates not swept (default: the home pose's).
    **axes : array_like
        One 1-D array per swept pose coordinate, by its name (``Model.facts.pose_names``).
    """
    names = list(model.facts.pose_names)
    unknown = [a for a in list(axes) + list(fixed or {}) if a not in names]
    if unknown:
        raise InputError(f"{model.robot} has no pose coordinate {unknown[0]!r} (its coordinates: {' '.join(names)})")
    if not axes:
        raise InputError("give at least one pose coordinate to sweep")
    home = dict(zip(names, model.home()))
    fixed = {n: float((fixed or {}).get(n, home[n])) for n in names if n not in axes}
    ax = {n: np.atleast_1d(np.asarray(v, float)) for n, v in axes.items()}
    mesh = np.meshgrid(*ax.values(), indexing="ij")
    shape = mesh[0].shape
    X = np.empty((mesh[0].size, len(names)))
    for i, n in enumerate(names):
        X[:, i] = mesh[list(ax).index(n)].ravel() if n in ax else fixed[n]
    vals = {k: v.reshape(shape) for k, v in pose_indices(model, X).items()}
    order = [k for k in ORDER if k in vals]
    return IndexMap(model.robot, ax, fixed, {k: vals[k] for k in order}, index_units(model))
