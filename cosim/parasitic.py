"""Parasitic motion of lower-mobility robots: the pose components a robot does not declare.

A 3-PRS head or a 3-RPS tripod is commanded in z, rx, ry; its legs' passive revolute joints
force small coupled motions of the other components, x, y and rz (the *parasitic* motion,
docs/robots.md, Dependent coordinates).  The core solves them (``Model.platform_pose``); this
module tabulates them over poses, maps them over a grid of two coordinates, and gives their
sensitivity to a geometric parameter (how an error of, say, a revolute axis or a platform
joint changes the parasitic motion), by central differences of the core's solution.
"""
from __future__ import annotations

import math

import numpy as np

from .errors import InputError

POSE_NAMES = ("x", "y", "z", "rx", "ry", "rz")
POSE_UNITS = ("m", "m", "m", "rad", "rad", "rad")


def parasitic_components(model) -> list[int]:
    """Indices (0..5 in x y z rx ry rz) of the pose components ``model`` does not declare."""
    declared = set(model.facts.pose_names)
    return [k for k, n in enumerate(POSE_NAMES) if n not in declared]


def parasitic_motion(model, poses) -> np.ndarray:
    """The undeclared pose components at poses of the declared coordinates.

    Parameters
    ----------
    model : cosim.core.Model
        A described robot (``Model("robots/tripod_3rps.toml")``).
    poses : array_like, shape (..., nd)
        Poses in the robot's coordinates [m, rad].

    Returns
    -------
    numpy.ndarray, shape (..., 6 - nd)
        The components of ``parasitic_components(model)`` in that order [m, rad]: dependent
        ones as the legs force them, held ones 0.

    Example
    -------
    >>> from cosim.core import Model
    >>> m = Model("robots/tripod_3rps.toml")
    >>> parasitic_motion(m, [0.45, 0.1, 0.05])     # x, y [m], rz [rad]    # doctest: +SKIP
    """
    X, _ = model.platform_pose(np.asarray(poses, float))
    return X[..., parasitic_components(model)]


def parasitic_sensitivity(model, poses, param: str, *, rel_step: float = 1e-6) -> np.ndarray:
    """d(parasitic components)/d(param) at poses, by central differences of the core's solve.

    Parameters
    ----------
    model : cosim.core.Model
        The robot (left unchanged: the differences use copies).
    poses : array_like, shape (..., nd)
        Poses [m, rad].
    param : str
        A parameter name (``cosim params ROBOT``), e.g. ``"leg[1].ax"`` or ``"leg[2].px"``.
    rel_step : float
        Step relative to max(|value|, 1e-3) in the parameter's unit.

    Returns
    -------
    numpy.ndarray, shape (..., 6 - nd)
        [m or rad per the parameter's unit].

    Example
    -------
    >>> parasitic_sensitivity(Model("robots/tripod_3rps.toml"), [0.45, 0.1, 0.05], "leg[1].px")   # doctest: +SKIP
    """
    v = model.param(param)
    h = rel_step * max(abs(v), 1e-3)
    plus, minus = model.copy(), model.copy()
    plus.set_params({param: v + h})
    minus.set_params({param: v - h})
    return (parasitic_motion(plus, poses) - parasitic_motion(minus, poses)) / (2 * h)


def _half_width(name: str, span=None) -> float:
    """A map's default half-width about home: 0.35 rad for an angle, 0.05 m for a length."""
    if span is not None:
        if not (math.isfinite(float(span)) and float(span) > 0):
            raise InputError(f"span = {span}: give the map's half-width about home as a positive number [m or rad]")
        return float(span)
    return 0.35 if POSE_UNITS[POSE_NAMES.index(name)] == "rad" else 0.05


def parasitic_map(model, *, axes=None, span=None, grid: int = 21, at=None) -> dict:
    """The parasitic components over a grid of two declared coordinates, the others at home
    (or at ``at``).

    Parameters
    ----------
    model : cosim.core.Model
    axes : tuple of two str, optional
        The coordinates the grid spans (default: the last two declared, rx ry for a 3-PRS).
    span : float, optional
        Half-width of the grid about home in each coordinate's unit (default 0.35 rad for an
        angle, 0.05 m for a length).
    grid : int
        Points per axis.
    at : dict, optional
        Values of the other declared coordinates, ``{"z": 0.42}`` [m, rad] (default: home).

    Returns
    -------
    dict
        ``axes`` (names), ``u``, ``v`` (grid vectors), ``names``, ``units`` and ``values``
        (grid x grid x components; NaN where the robot cannot reach).

    Example
    -------
    >>> parasitic_map(Model("robots/tripod_3prs.toml"), grid=11)["values"].shape            # doctest: +SKIP
    (11, 11, 3)
    """
    names = list(model.facts.pose_names)
    axes = tuple(axes or names[-2:])
    for a in axes:
        if a not in names:
            raise InputError(f"--axes: {a!r} is not a coordinate of {model.robot} ({' '.join(names)})")
    idx = [names.index(a) for a in axes]
    home = model.home()
    half = [_half_width(a, span) for a in axes]
    u = home[idx[0]] + np.linspace(-half[0], half[0], grid)
    v = home[idx[1]] + np.linspace(-half[1], half[1], grid)
    comps = parasitic_components(model)
    values = np.full((grid, grid, len(comps)), np.nan)
    x = home.copy()
    for name, val in (at or {}).items():
        if name not in names or name in axes:
            raise InputError(f"at: {name!r} is not a coordinate of {model.robot} outside the map's axes "
                             f"({' '.join(n for n in names if n not in axes)})")
        x[names.index(name)] = float(val)
    from .errors import PkmError

    for i, a in enumerate(u):
        for j, b in enumerate(v):
            x[idx[0]], x[idx[1]] = a, b
            try:
                model.ik(x)  # inside the joints' limits
                values[i, j] = parasitic_motion(model, x)
            except PkmError:
                pass
    return {"axes": axes, "u": u, "v": v, "names": [POSE_NAMES[k] for k in comps],
            "units": [POSE_UNITS[k] for k in comps], "values": values,
            "at": {n: float(x[k]) for k, n in enumerate(names) if n not in axes}}


def plot_parasitic_map(model, path, *, axes=None, span=None, grid: int = 21, slices: int = 3):
    """Draw the parasitic motion over the workspace: each parasitic component (columns: x, y
    [mm], rz [mrad] for a 3-PRS) over a grid of two declared coordinates (rx, ry), one row per
    value of the remaining one (z at home and ``slices`` values across its span), one colour
    scale per component so the rows compare.  Points the robot cannot reach are left blank.

    Parameters
    ----------
    model : cosim.core.Model
    path : str or Path
        The figure (PNG).
    axes, span, grid
        As :func:`parasitic_map` (``span`` also the remaining coordinate's half-width).
    slices : int
        Rows: values of the declared coordinate outside ``axes`` (1: home only).

    Returns
    -------
    dict
        The maps drawn, one :func:`parasitic_map` per row.

    Example
    -------
    >>> plot_parasitic_map(Model("robots/tripod_3prs.toml"), "out/parasitic_3prs.png", grid=31)   # doctest: +SKIP
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(model.facts.pose_names)
    axes = tuple(axes or names[-2:])
    rest = [n for n in names if n not in axes]
    home = model.home()
    if rest and slices > 1:
        k = names.index(rest[0])
        h = _half_width(rest[0], span)
        levels = [{rest[0]: v} for v in home[k] + np.linspace(-h, h, slices)]
    else:
        levels = [{}]
    maps = [parasitic_map(model, axes=axes, span=span, grid=grid, at=lv) for lv in levels]
    comps = maps[0]["names"]
    units = maps[0]["units"]
    shown = {"m": (1e3, "mm"), "rad": (1e3, "mrad")}
    pose_units = dict(zip(names, model.facts.pose_units))
    fig, axs = plt.subplots(len(maps), len(comps), figsize=(4.2 * len(comps), 3.6 * len(maps)), squeeze=False)
    for c, (name, unit) in enumerate(zip(comps, units)):
        s, label = shown[unit]
        allv = np.concatenate([s * mp["values"][:, :, c].ravel() for mp in maps])
        lim = float(np.nanmax(np.abs(allv))) if np.isfinite(allv).any() else 1.0
        lim = lim or 1.0
        for r, mp in enumerate(maps):
            ax = axs[r, c]
            im = ax.contourf(mp["u"], mp["v"], s * mp["values"][:, :, c].T, levels=np.linspace(-lim, lim, 21),
                             cmap="RdBu_r")
            fig.colorbar(im, ax=ax, label=f"{name} [{label}]")
            ax.set_xlabel(f"{axes[0]} [{pose_units[axes[0]]}]")
            ax.set_ylabel(f"{axes[1]} [{pose_units[axes[1]]}]")
            where = ", ".join(f"{n} = {v:.4g} {pose_units[n]}" for n, v in mp["at"].items())
            ax.set_title(f"parasitic {name}" + (f" at {where}" if where else ""), fontsize=9)
    fig.suptitle(f"{model.robot}: parasitic motion over {', '.join(names)}")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return maps
