"""Calibration problems: measured data + a nominal core model = residuals and Jacobians.

A problem maps a vector ``p`` of calibrated parameters (the solver's coordinates) to the
predicted measurements ``predict(p)`` and their Jacobian ``jacobian(p)``; the residual is
``y - predict(p)``.  All physics comes from the core (:class:`cosim.core.Model`); a problem
only chooses which parameters move and stacks the core's outputs.

* :class:`Problem`: the interface; :class:`LinearProblem`: a fixed J and dy (e.g. a table
  typed from a source).
* :class:`cosim.calibration.joint_problem.JointProblem`: any robot, with its error model
  declared as data (:mod:`cosim.calibration.error_model`).
* the helpers that find a robot's geometric parameters (:func:`geometry_candidates`) and the
  independent blocks of a joint-space regression matrix.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError, PkmError

__all__ = [
    "CalibrationDataError",
    "CalibrationWarning",
    "Problem",
    "LinearProblem",
    "geometry_candidates",
    "calib_rows",
]

PKM_FRAME_WORLD, PKM_FRAME_PLATFORM = 0, 1


class CalibrationDataError(InputError):
    """Calibration data cannot be used: too few poses, unreachable poses, NaN..."""


class CalibrationWarning(UserWarning):
    """Calibration can go on, but something about the data deserves attention."""


def calib_rows(model, x, frame: int = PKM_FRAME_PLATFORM) -> np.ndarray:
    """Regression rows dq_i/d eta_i of the core at pose(s) x: shape (..., 6, 10)
    (:meth:`cosim.core.Model.calib_rows`; ``frame`` is ``PKM_FRAME_WORLD`` or ``PKM_FRAME_PLATFORM``)."""
    return model.calib_rows(x, ("world", "platform")[int(frame)])


def _set_params_fast(model, values: dict) -> None:
    """Set the parameters of a working model (rewritten at each evaluation; the direct search
    makes tens of thousands): :meth:`cosim.core.Model.set_params_unchecked`."""
    model.set_params_unchecked(values)


class Problem:
    """Base class: see the module docstring.

    Attributes
    ----------
    robot : str
    names, units : list of str
        The calibrated coordinates.
    p0 : ndarray
        Their nominal values.
    y : ndarray, shape (m,)
        The measurements.
    row_labels : list of str
        Where each measurement comes from (recording row, time, leg), for messages.
    blocks : list of (label, rows, cols) or None
        Independent blocks of the (block-diagonal) Jacobian.
    prior : ndarray
        Expected size of each parameter's error (search intervals, pose design).
    weights : ndarray or None
        Relative weight of each equation (inverse of its expected noise).
    """

    robot = ""
    names: list
    units: list
    p0: np.ndarray
    y: np.ndarray
    row_labels: list
    blocks = None
    prior: np.ndarray
    weights = None  # per-equation weights (1 / expected noise, relative), or None
    measurement_unit = "m"  # unit of y (the joint unit for a JointProblem)

    def predict(self, p) -> np.ndarray:
        raise NotImplementedError

    def jacobian(self, p) -> np.ndarray:
        raise NotImplementedError

    def residual(self, p) -> np.ndarray:
        return self.y - self.predict(p)

    def wresidual(self, p) -> np.ndarray:
        """Weighted residual: what the solvers minimise."""
        r = self.residual(p)
        return r if self.weights is None else self.weights * r

    def wjacobian(self, p) -> np.ndarray:
        """Weighted Jacobian (rows scaled like :meth:`wresidual`)."""
        J = self.jacobian(p)
        return J if self.weights is None else self.weights[:, None] * J

    def model_params(self, p) -> dict:
        """Core parameter values for calibrated coordinates p."""
        return dict(zip(self.names, map(float, p)))

    _p = None  # the coordinates last written into self.model

    def _set(self, p):
        """Write coordinates p into the problem's core model (skipped if unchanged)."""
        p = np.asarray(p, float)
        if self._p is None or not np.array_equal(p, self._p):
            _set_params_fast(self.model, self.model_params(p))
            self._p = p.copy()

    @property
    def nmeas(self) -> int:
        return int(self.y.size)


class LinearProblem(Problem):
    """A linear model dy = J dp around p0 (e.g. the seed's printed tables)."""

    def __init__(self, J, dy, names, units=None, p0=None, blocks=None, prior=None):
        self.J = np.asarray(J, float)
        self.y = np.asarray(dy, float)
        self.names = list(names)
        self.units = list(units) if units is not None else [""] * len(self.names)
        self.p0 = np.zeros(len(self.names)) if p0 is None else np.asarray(p0, float)
        self.blocks = blocks
        self.prior = np.ones(len(self.names)) if prior is None else np.asarray(prior, float)
        self.row_labels = [f"row {k}" for k in range(self.y.size)]

    def predict(self, p):
        return self.J @ (np.asarray(p, float) - self.p0)

    def jacobian(self, p):
        return self.J


def _check_finite(a, what, columns):
    a = np.asarray(a, float)
    bad = np.argwhere(~np.isfinite(a.reshape(a.shape[0], -1)))
    if bad.size:
        r, c = bad[0]
        raise CalibrationDataError(f"{what}: row {r}, column {columns[c]!r} is not a finite number")
    return a


#: parameter groups that are never geometry (the joint's own drive parameters are told apart by
#: the inverse kinematics: they do not move a joint)
_NOT_GEOMETRY = ("gravity.", "drive.", "actuator.", "sensor.", "payload.")


def geometry_candidates(model, poses, measure=None) -> list:
    """Every length parameter [m] of ``model`` (outside gravity, payload and the drive and
    sensor layers) whose change moves a joint of the core's inverse kinematics at ``poses``:
    a central difference of the IK per parameter, all poses in one call.

    Unlike :meth:`cosim.core.Model.geometry_params` (``declared=False``) it keeps the
    parameters named after the joint (a described robot's ``arm[i].Ax``, ``arm[i].r``,
    ``rail[i].S0x``): the drive parameters under the same prefix (friction, offsets,
    limits) do not move the inverse kinematics, so the difference leaves them out.
    ``measure(model, poses)``: what must move instead of the joints (an array).
    """
    x = np.atleast_2d(np.asarray(poses, float))
    if measure is None:
        measure = lambda m, xs: np.asarray(m.ik(xs), float)  # noqa: E731
    base = measure(model, x)
    trial = model.copy()
    keep = []
    for info in model.param_info():
        if info.unit != "m" or info.name.startswith(_NOT_GEOMETRY):
            continue
        h = 1e-6 * max(abs(info.value), 1e-3)
        try:
            trial.set_params({info.name: info.value + h})
            moved = np.max(np.abs(measure(trial, x) - base)) > 1e-9 * h
        except PkmError:
            moved = False
        finally:
            trial.set_params({info.name: info.value})
        if moved:
            keep.append(info.name)
    return keep


def _select(model, candidates, patterns):
    """The names of ``candidates`` (or of any parameter of the model) matching ``patterns``
    (names or shell patterns: ``leg[*].L``; square brackets are literal)."""
    import fnmatch

    every = model.param_names()
    out = []
    for pat in patterns:
        hit = [n for n in every if fnmatch.fnmatchcase(n, _literal_brackets(pat))]
        if not hit:
            raise CalibrationDataError(f"{model.robot} has no parameter matching {pat!r} (its geometric "
                                       f"parameters: {', '.join(candidates)})")
        out += [n for n in hit if n not in out]
    return out


def _literal_brackets(pat: str) -> str:
    """A shell pattern whose square brackets match themselves (``leg[1].L``, ``leg[*].L``)."""
    return "".join({"[": "[[]", "]": "[]]"}.get(c, c) for c in pat)


def _joint_blocks(J, nd):
    """Independent blocks of a joint-space regression matrix: the joints and parameters
    connected through non-zero columns (a described robot's legs, one block each)."""
    npose = J.shape[0] // nd
    scale = np.abs(J).max() or 1.0
    touch = np.abs(J).reshape(npose, nd, -1).max(axis=0) > 1e-12 * scale  # (joint, parameter)
    parent = list(range(nd))

    def find(a):
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    for c in range(touch.shape[1]):
        js = np.flatnonzero(touch[:, c])
        for j in js[1:]:
            parent[find(j)] = find(js[0])
    groups = {}
    for j in range(nd):
        groups.setdefault(find(j), []).append(j)
    if len(groups) == 1:
        return None
    blocks = []
    for js in groups.values():
        cols = np.flatnonzero(touch[js].any(axis=0))
        if cols.size == 0:
            continue
        rows = np.array([k * nd + j for k in range(npose) for j in js])
        label = f"joint {js[0] + 1}" if len(js) == 1 else "joints " + ", ".join(str(j + 1) for j in js)
        blocks.append((label, rows, cols))
    return blocks
