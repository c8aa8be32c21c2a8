"""Calibration error models declared as data: ``robots/calibration/<robot>.toml``.

A robot that ships such a file is calibrated by the parameters it lists (the thesis' error
model: Tiberi 2020's 60 parameters of the 6-PUS, Vitali 2020's four link lengths); any other
robot by every length parameter that moves a joint
(:func:`cosim.calibration.problems.geometry_candidates`).  The file names parameters only;
their values, units and the physics come from the core.

Keys (all optional but ``parameters`` or ``per_joint``):

``source``
    Where the error model comes from (for the report).
``measure``
    ``"joints"`` (default): joint readings at poses a tracker measured; ``"output"``: a robot's
    scalar output measured at joint values (the four-bar's X, the core's ``Model.fourbar_output``).
``parameters``
    Parameter names, in the order of the core's analytic columns.
``per_joint``
    Name templates with ``{i}`` = 1 .. ndof: the parameters of joint i, whose equations depend on
    them only (one independent block per joint, labelled ``block_label`` i).
``columns``
    ``"core"``: the core's analytic columns (``Model.calib_rows`` in the platform frame for
    ``measure = "joints"``, ``Model.fourbar_output`` for ``"output"``); ``"differences"``
    (default): central differences of the core's inverse kinematics.
``unit_vectors``
    Groups of three templates forming a unit vector: the component largest at nominal is
    computed from the other two (|s| = 1), which are calibrated.
``working_overrides``
    Parameter values set in the working models (a machine limit such as a stroke range opened).
``weighting``
    ``"tracker"``: each joint equation weighted by the inverse of the joint noise a tracker causes
    when it sees the points ``tracker_points`` (x, y templates; their mean distance from the
    origin turns orientation into position noise) with one accuracy; default none.
``prior``
    Expected size of the errors by unit, e.g. ``{m = 1e-3, "1" = 1e-2}``.
``workspace``
    Where synthetic campaigns put their poses (:func:`cosim.calibration.data.candidate_poses`):
    per pose coordinate a range ``[low, high]`` (``<name>_deg`` for an angle given in degrees),
    ``joint_margin`` (how far inside its range every joint stays, in the joint unit) and
    ``min_singularity`` (the lowest inverse and direct singularity measures kept).

Example
-------
>>> from cosim.core import Model
>>> from cosim.calibration.error_model import error_model
>>> em = error_model(Model("6pus"))
>>> len(em.parameters), em.block_label, em.measure
(60, 'leg', 'joints')
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError

__all__ = ["ErrorModel", "error_model", "output", "ERROR_MODEL_DIR"]

#: where the robots' calibration error models live
ERROR_MODEL_DIR = Path(__file__).resolve().parents[2] / "robots" / "calibration"

_KEYS = {"source", "measure", "parameters", "per_joint", "block_label", "columns", "unit_vectors",
         "working_overrides", "weighting", "tracker_points", "prior", "workspace"}


@dataclass(frozen=True)
class ErrorModel:
    """A robot's calibration error model (see the module docstring).

    Attributes
    ----------
    robot, source, measure, columns, weighting, block_label : str
    parameters : tuple of str
        Every parameter of the error model, in order (joint by joint with ``per_joint``).
    joint_parameters : tuple of tuple of str
        Per joint, its parameters (empty without ``per_joint``).
    unit_vectors : tuple of tuple of str
        Triples of parameter names that form a unit vector.
    working_overrides : dict
    tracker_points : tuple of tuple of str
        Per joint, the names of a point's x and y seen by the tracker.
    prior : dict
        Expected error size by unit.
    workspace : dict
        The pose box of synthetic campaigns (empty: the core's reach).
    path : str
    """

    robot: str
    parameters: tuple
    source: str = ""
    measure: str = "joints"
    columns: str = "differences"
    weighting: str = "none"
    block_label: str = "joint"
    joint_parameters: tuple = ()
    unit_vectors: tuple = ()
    working_overrides: dict = field(default_factory=dict)
    tracker_points: tuple = ()
    prior: dict = field(default_factory=dict)
    workspace: dict = field(default_factory=dict)
    path: str = ""


def _expand(templates, nd):
    return [[t.format(i=i) for t in templates] for i in range(1, nd + 1)]


def error_model(model, path=None) -> ErrorModel | None:
    """The calibration error model ``model``'s robot ships (``robots/calibration/<robot>.toml``),
    or the one in ``path``; None if the robot ships none.

    Every name must be a parameter of ``model``: a wrong one raises :class:`InputError` naming
    the file and the key.
    """
    p = Path(path) if path is not None else ERROR_MODEL_DIR / f"{model.robot}.toml"
    if not p.is_file():
        if path is not None:
            raise InputError(f"{p}: no such error-model file")
        return None
    try:
        d = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as e:
        raise InputError(f"{p}: {e}") from None
    unknown = sorted(set(d) - _KEYS)
    if unknown:
        raise InputError(f"{p}: unknown key {unknown[0]!r} (known: {', '.join(sorted(_KEYS))})")
    nd = model.ndof
    if "per_joint" in d:
        joint = tuple(tuple(n) for n in _expand(d["per_joint"], nd))
        params = tuple(n for j in joint for n in j)
    elif "parameters" in d:
        joint, params = (), tuple(d["parameters"])
    else:
        raise InputError(f"{p}: an error model lists 'parameters' or 'per_joint'")
    units = [u for group in d.get("unit_vectors", []) for u in _expand(group, nd)]
    overrides = {t.format(i=i): float(v) for t, v in d.get("working_overrides", {}).items()
                 for i in range(1, nd + 1)}
    points = tuple(tuple(x) for x in _expand(d.get("tracker_points", []), nd)) if "tracker_points" in d else ()
    known = set(model.param_names())
    for key, names in (("parameters", params), ("unit_vectors", [n for u in units for n in u]),
                       ("working_overrides", overrides), ("tracker_points", [n for x in points for n in x])):
        bad = [n for n in names if n not in known]
        if bad:
            raise InputError(f"{p}: {key}: {model.robot} has no parameter {bad[0]!r}")
    choices = {"measure": ("joints", "output"), "columns": ("core", "differences"), "weighting": ("tracker", "none")}
    for key, allowed in choices.items():
        if key in d and d[key] not in allowed:
            raise InputError(f"{p}: {key} must be one of {', '.join(allowed)}, got {d[key]!r}")
    return ErrorModel(robot=model.robot, parameters=params, source=d.get("source", ""),
                      measure=d.get("measure", "joints"), columns=d.get("columns", "differences"),
                      weighting=d.get("weighting", "none"), block_label=d.get("block_label", "joint"),
                      joint_parameters=joint, unit_vectors=tuple(tuple(u) for u in units),
                      working_overrides=overrides, tracker_points=points,
                      prior={str(k): float(v) for k, v in d.get("prior", {}).items()},
                      workspace=_workspace(d.get("workspace", {}), model, p), path=str(p))


def _workspace(ws, model, p) -> dict:
    if not ws:
        return {}
    names = list(model.facts.pose_names)
    need = [n for n in names if n not in ws and n + "_deg" not in ws]
    extra = sorted(set(ws) - set(names) - {n + "_deg" for n in names} - {"joint_margin", "min_singularity"})
    if need or extra or "joint_margin" not in ws or "min_singularity" not in ws:
        raise InputError(f"{p}: workspace needs a range for each of {', '.join(names)} (or <name>_deg), "
                         f"joint_margin and min_singularity"
                         + (f"; missing {need[0]!r}" if need else "") + (f"; unknown {extra[0]!r}" if extra else ""))
    return dict(ws)


def output(model, q, jacobian: bool = True):
    """The core's output of a robot whose error model measures one (``measure = "output"``: the
    four-bar's X [m] of the coupler mid point, ``Model.fourbar_output``) at joint values q,
    shape (n, 1) or (n,); with ``jacobian`` also its derivatives over the error model's
    parameters, shape (n, k)."""
    return model.fourbar_output(np.asarray(q, float).reshape(-1), jacobian=jacobian)
