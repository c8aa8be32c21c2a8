"""Adept Quattro s650H (Virzi 2010): performance-index maps and figures.

Every number comes from the C++ core: :func:`index_map` is one batched call of
``pkm_quattro_indices`` over the whole grid.  Units are SI (m, rad, kg, N, N m, s);
grid arguments may be given in metres.

Example
-------
>>> import numpy as np
>>> from cosim import quattro
>>> mp = quattro.index_map(x=[0.0], y=[0.0], z=np.linspace(-1.26, -0.76, 51),
...                        param_set="appendix_a")
>>> mp["mu_T"].shape            # (nx, ny, nz), NaN where the pose is not reachable
(1, 1, 51)
>>> mp.argmax("mu_T")          # pose [m] of the largest value
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..core.facts import quattro_index_names, quattro_index_units
from ..core.model import Model
from ..errors import InputError, PkmError, UnsupportedError

__all__ = ["index_names", "index_units", "index_map", "IndexMap", "gimre", "points", "model", "require_indices",
           "centred_tool",
           "adept_to_model", "model_to_adept", "plot_maps", "benchmark"]

NINDEX = 22  # PKM_QUATTRO_NINDEX in pkm.h

# Which way is better for each index (for argbest and the figures' titles).
BETTER = {"mu_T": "max", "mu_xy": "max", "mu_z": "max", "mu_T_eig": "max", "mu_xy_eig": "max",
          "mu_z_eig": "max", "kappa_T": "min", "dTIM": "max", "dTIM_xy": "min", "dTIM_x": "min",
          "dTIM_y": "min", "dTIM_z": "min", "kat": "min", "kat_xy": "min", "kat_x": "min", "kat_y": "min",
          "kat_z": "min", "Fcc_z": "min", "Fcc_xy": "min", "Fgr": "min", "alfa_z": "max", "alfa_x": "max"}


def index_names() -> list[str]:
    """Names of the index columns, in the order of ``pkm_quattro_indices``."""
    return quattro_index_names()


def index_units() -> dict[str, str]:
    """Unit of each index by name."""
    return quattro_index_units()


def model(param_set: str | None = None, params: dict | None = None, robot: str = "quattro") -> Model:
    """A :class:`~cosim.core.Model` with the Quattro indices, by default the Quattro's.

    Parameters
    ----------
    param_set : str, optional
        Named parameter set ("default" = seed text values, "appendix_a").
    params : dict, optional
        Overrides by name.
    robot : str
        Robot name or description file; it must declare the Quattro indices
        (``Model.has("quattro_indices")``, see :func:`require_indices`).

    Example
    -------
    >>> m = model(param_set="appendix_a")
    >>> m.has("quattro_indices")
    True
    """
    return require_indices(Model(robot, param_set, params))


def centred_tool(m: Model) -> dict:
    """Parameters that put the tool point of ``m`` at its platform's centre.

    The thesis' maps (Virzi 2010 ch. 3.3) take the tool offset 0; the default set's tool point
    sits ``platform.cx`` (75 mm) from the centre along the platform's axis.  Moving it there
    shifts every leg's platform point ``leg[i].px`` by ``-platform.cx`` (the points are given
    from the tool point) and sets ``platform.cx = 0``.

    Parameters
    ----------
    m : Model
        A Quattro (four legs on an articulated platform, ``Model.has("quattro_indices")``).

    Returns
    -------
    dict
        Overrides by name for :func:`model` or ``Model.set_params``.

    Example
    -------
    >>> p = centred_tool(model())
    >>> p["platform.cx"], round(p["leg[1].px"], 6), round(p["leg[3].px"], 6)
    (0.0, 0.075, -0.075)
    """
    cx = require_indices(m).param("platform.cx")
    return {"platform.cx": 0.0, **{f"leg[{i}].px": m.param(f"leg[{i}].px") - cx for i in range(1, m.ndof + 1)}}


def require_indices(m: Model) -> Model:
    """``m`` itself if the core declares the Quattro indices for it (``Model.has``), else
    ``UnsupportedError`` naming the robot: the functions of :mod:`cosim.quattro` ask the
    model, never its name."""
    if not m.has("quattro_indices"):
        raise UnsupportedError(f"robot {m.robot!r} has no Quattro indices (Model.has('quattro_indices') is False): "
                               "cosim.quattro needs a model that declares them, e.g. Model('quattro')",
                               "PKM_ERR_UNSUPPORTED")
    return m


_quattro_model = model  # index_map's argument `model` shadows the function


@dataclass
class IndexMap:
    """Indices on a grid: ``values[name]`` has shape (nx, ny, nz), NaN where ``status != 0``.

    Attributes
    ----------
    x, y, z : ndarray
        Grid axes [m] (tool point, model frame of the seed; z in the Adept frame).
    theta : float
        Platform articulation angle of every pose [rad].
    values : dict of ndarray
        Index arrays by name (see :func:`index_names`).
    status : ndarray of int
        Core status per pose (0 reachable; -3 out of reach; -6 beyond the joint range...).
    param_set : str
    seconds : float
        Wall time of the core call.
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    theta: float
    values: dict
    status: np.ndarray
    param_set: str
    params: dict = field(default_factory=dict)
    seconds: float = 0.0

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def names(self) -> list[str]:
        return list(self.values)

    def argbest(self, name: str, better: str | None = None) -> np.ndarray:
        """Grid pose (x, y, z) [m] of the best value of index ``name`` (max or min per BETTER)."""
        v = self.values[name]
        if not np.isfinite(v).any():
            raise InputError(f"index {name} has no finite value on this grid")
        better = better or BETTER[name]
        k = np.nanargmax(v) if better == "max" else np.nanargmin(v)
        i, j, l = np.unravel_index(k, v.shape)
        return np.array([self.x[i], self.y[j], self.z[l]])

    def argmax(self, name: str) -> np.ndarray:
        return self.argbest(name, "max")

    def argmin(self, name: str) -> np.ndarray:
        return self.argbest(name, "min")


def indices(m: Model, poses) -> tuple[np.ndarray, np.ndarray]:
    """Indices of poses (..., 4) -> (values (..., NINDEX), status (...)); one core call."""
    return m.quattro_indices(poses)


def index_map(x=None, y=None, z=None, theta: float = 0.0, param_set: str | None = None,
              params: dict | None = None, model: Model | None = None) -> IndexMap:
    """Every performance index of Virzi 2010 on the grid x * y * z, in one core call.

    Parameters
    ----------
    x, y, z : array_like, optional
        Grid axes of the tool point [m].  Defaults: the seed's listing grid, x and y in
        -0.5..0.5 step 0.05 (21 each), z in 51 steps of 0.01 from -1.06 - base_height
        (:meth:`Model.quattro_constants`).
    theta : float
        Platform articulation angle [rad] (0 as in the seed's figures).
    param_set : {"default", "appendix_a"}
        Named parameter set; ``params`` overrides values by name.
    model : Model, optional
        Use this model instead of building one.

    Returns
    -------
    IndexMap
        Arrays of shape (nx, ny, nz) per index, NaN where the pose is unreachable, beyond
        the joint range or singular (the reason is in ``status``).
    """
    m = require_indices(model) if model is not None else _quattro_model(param_set, params)
    h = m.quattro_constants()["base_height"]
    x = np.linspace(-0.5, 0.5, 21) if x is None else np.atleast_1d(np.asarray(x, dtype=float))
    y = np.linspace(-0.5, 0.5, 21) if y is None else np.atleast_1d(np.asarray(y, dtype=float))
    z = np.linspace(-1.06 - h, -0.56 - h, 51) if z is None else np.atleast_1d(np.asarray(z, dtype=float))
    X, Y, Z = np.meshgrid(x, y, z, indexing="ij")
    poses = np.stack([X, Y, Z, np.full_like(X, theta)], axis=-1)
    t0 = time.perf_counter()
    vals, status = indices(m, poses)
    dt = time.perf_counter() - t0
    names = index_names()
    return IndexMap(x, y, z, theta, {n: vals[..., k] for k, n in enumerate(names)}, status,
                    m.param_set, dict(params or {}), dt)


def gimre(m: Model, x) -> np.ndarray:
    """Generalized inertia matrix reduced to the end effector N (4, 4) at pose x [kg, kg m, kg m^2]."""
    return m.quattro_gimre(x)


def points(m: Model, x) -> dict:
    """World points A, B, C (4, 3) [m] of the four arms at pose x (motor axis, elbow, platform joint)."""
    return m.quattro_points(x)


# The Adept platform x axis is the model diagonal (-1, -1)/sqrt(2) (seed ch. 5.7: the model
# frame turned by -135 deg about z); its y axis completes a right-handed frame with z up.
_EX = np.array([-1.0, -1.0]) / np.sqrt(2.0)
_EY = np.array([1.0, -1.0]) / np.sqrt(2.0)


def adept_to_model(xa, ya=0.0):
    """Horizontal Adept-frame coordinates [m] -> model-frame (x, y) [m]."""
    xa, ya = np.asarray(xa, dtype=float), np.asarray(ya, dtype=float)
    return xa * _EX[0] + ya * _EY[0], xa * _EX[1] + ya * _EY[1]


def model_to_adept(x, y):
    """Model-frame (x, y) [m] -> Adept-frame (x, y) [m]."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    return x * _EX[0] + y * _EX[1], x * _EY[0] + y * _EY[1]


# ------------------------------------------------------------------------ figures

_TITLES = {
    "mu_T": "translational manipulability (sub-matrix, Fig. 3.2)",
    "mu_xy": "horizontal manipulability (sub-matrix, Fig. 3.3)",
    "mu_z": "vertical manipulability (sub-matrix, Fig. 3.4)",
    "mu_T_eig": "translational manipulability (eigenvalues, Fig. 3.5a)",
    "mu_xy_eig": "horizontal manipulability (eigenvalues, Fig. 3.5b)",
    "mu_z_eig": "vertical manipulability (eigenvalues, Fig. 3.5c)",
    "kappa_T": "condition number of b_r J_T",
    "dTIM": "dynamic isotropy dTIM (Fig. 4.8)",
    "dTIM_xy": "dTIM_xy", "dTIM_x": "dTIM_x", "dTIM_y": "dTIM_y",
    "dTIM_z": "dTIM_z (Fig. 4.9)",
    "kat": "mass index kat (Fig. 5.6)", "kat_xy": "mass index kat_xy", "kat_x": "kat_x", "kat_y": "kat_y",
    "kat_z": "mass index kat_z (Fig. 5.7)",
    "Fcc_z": "|F_cc| at 1 m/s along z (Fig. 5.4a)",
    "Fcc_xy": "|F_cc| at 1 m/s along the x-y diagonal (Fig. 5.4b)",
    "Fgr": "|F_gr| gravity force (Fig. 5.5)",
    "alfa_z": "alfa_z vertical acceleration capability (Fig. 5.8)",
    "alfa_x": "alfa_x acceleration along the platform x axis (Fig. 5.9)",
}


def plot_maps(mp: IndexMap, out_dir, names=None, planes_z=(-0.95, -1.05, -1.15), fmt: str = "png") -> list:
    """Write one figure per index: the x-z section at y = 0 and x-y planes at ``planes_z`` [m].

    Returns the list of files written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from pathlib import Path

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names = names or mp.names()
    units = index_units()
    j0 = int(np.argmin(np.abs(mp.y)))
    files = []
    for name in names:
        v = mp[name]
        # constrained layout keeps each panel's labels clear of its neighbour and the colour bar
        fig, axes = plt.subplots(1, 1 + len(planes_z), figsize=(4.4 * (1 + len(planes_z)) + 1, 4.0),
                                 layout="constrained")
        finite = v[np.isfinite(v)]
        if finite.size == 0:
            plt.close(fig)
            continue
        lo, hi = np.percentile(finite, [2, 98])
        ax = axes[0]
        im = ax.pcolormesh(mp.x * 1e3, mp.z * 1e3, v[:, j0, :].T, shading="nearest", vmin=lo, vmax=hi,
                           cmap="viridis")
        ax.set_xlabel("x [mm]")
        ax.set_ylabel("z [mm]")
        ax.set_title(f"x-z section, y = {mp.y[j0] * 1e3:.0f} mm", fontsize=9)
        for ax, zp in zip(axes[1:], planes_z):
            l0 = int(np.argmin(np.abs(mp.z - zp)))
            ax.pcolormesh(mp.x * 1e3, mp.y * 1e3, v[:, :, l0].T, shading="nearest", vmin=lo, vmax=hi,
                          cmap="viridis")
            ax.set_aspect("equal")
            ax.set_xlabel("x [mm]")
            ax.set_ylabel("y [mm]")
            ax.set_title(f"x-y plane, z = {mp.z[l0] * 1e3:.0f} mm", fontsize=9)
        fig.colorbar(im, ax=axes, shrink=0.85, label=f"{name} [{units.get(name, '')}]")
        best = mp.argbest(name)
        fig.suptitle(f"{_TITLES.get(name, name)}  -  set '{mp.param_set}', best ({BETTER[name]}) at "
                     f"({best[0] * 1e3:.0f}, {best[1] * 1e3:.0f}, {best[2] * 1e3:.0f}) mm", fontsize=10)
        f = out / f"quattro_{name}.{fmt}"
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(f)
    return files


# ---------------------------------------------------------------------- benchmark

def benchmark(param_set: str = "appendix_a", baseline_points: int = 400, repeat: int = 3) -> dict:
    """Time of the full 21 x 21 x 51 map (every index, one core call) against the 1 s target.

    The baseline is what a Python user would write without the batched call: a numpy loop
    over the core's per-pose Jacobian and mass-matrix calls computing three of the indices
    (mu_T, kat, alfa_z); it is timed on ``baseline_points`` poses and scaled to the map.
    """
    m = model(param_set)
    best = np.inf
    for _ in range(repeat):
        mp = index_map(model=m)
        best = min(best, mp.seconds)
    n = mp.status.size
    reach = int((mp.status == 0).sum())
    # Baseline: per-pose core calls from Python.
    rng = np.random.default_rng(0)
    c = m.quattro_constants()
    h = c["base_height"]
    poses = np.column_stack([rng.uniform(-0.2, 0.2, baseline_points), rng.uniform(-0.2, 0.2, baseline_points),
                             rng.uniform(-1.0 - h, -0.7 - h, baseline_points), np.zeros(baseline_points)])
    br, lim = c["link_length"], c["tau_arm_max"]
    t0 = time.perf_counter()
    for x in poses:
        try:
            _, _, J = m.jacobians(x)
            M = m.mass_matrix(x)
        except PkmError:
            continue
        JD = br * J[:, :3]
        _ = 1 / np.sqrt(np.linalg.det(JD.T @ JD))
        _ = np.mean(np.linalg.norm(M[:3, :3], axis=1))
        tau = np.linalg.solve(J.T, M @ np.array([0, 0, 1.0, 0]))
        _ = lim / np.abs(tau).max()
    base = (time.perf_counter() - t0) / baseline_points * n
    return {"points": n, "reachable": reach, "indices": NINDEX, "map_s": best, "per_pose_us": best / n * 1e6,
            "target_s": 1.0, "baseline_s": base, "baseline_indices": 3, "speedup": base / best}
