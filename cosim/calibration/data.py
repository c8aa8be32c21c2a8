"""Synthetic calibration campaigns, generated through the core.

Until real measurements exist, a "real" robot is a :class:`cosim.core.Model` whose
geometric parameters differ from the nominal ones by random errors.  A campaign holds
the real robot still at chosen poses, reads its joints (the real robot's inverse
kinematics at the true pose) and measures the pose with an external tracker (the true
pose plus Gaussian noise).  The result is a ``pkm-recording/1`` file: calibration reads
only that file, never the truth.  The truth is written beside it
(``<name>.truth.json``) for tests and demonstrations.

The recording's sidecar ``parameters`` are overrides of the *nominal* model (the model
the calibration starts from), not of the real robot.

Command line (writes the scenario data of ``scenarios/``)::

    python -m cosim.calibration.data scenarios/
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from .error_model import error_model, output
from ..core.model import Model
from ..recording import Recording, write_recording

__all__ = [
    "SEED000_POSES",
    "real_params",
    "candidate_poses",
    "joint_campaign",
    "output_campaign",
    "write_campaign",
    "read_truth",
]

#: Tiberi 2020 Tables 4.2-4.20: the ten measurement poses (x, y, z [m], rx, ry, rz [deg]).
SEED000_POSES_DEG = np.array([
    [0.000, 0.000, 0.085, 0, 0, 0],
    [0.000, 0.000, 0.085, 1, 1, 1],
    [0.050, 0.050, 0.090, 1, 4, -3],
    [0.020, 0.000, 0.075, -1, 1, 2],
    [0.015, 0.020, 0.040, 0, 4, 0],
    [-0.010, 0.070, 0.018, 5, 4, 1],
    [-0.040, 0.010, 0.065, -4, 3, -5],
    [-0.023, -0.019, 0.100, 0, 2, -3],
    [-0.038, -0.009, 0.100, 5, 5, 5],
    [0.050, -0.040, 0.063, 2, 5, 0],
])
#: the same poses with the angles in radians (the core's units)
SEED000_POSES = np.column_stack([SEED000_POSES_DEG[:, :3], np.radians(SEED000_POSES_DEG[:, 3:])])


def _tilt(s, max_angle_deg, rng):
    """The unit vector s tilted by an angle uniform in [0, max_angle_deg] about a random axis
    perpendicular to it (Rodrigues), so that it stays a unit vector."""
    a = rng.normal(size=3)
    a -= (a @ s) * s
    a /= np.linalg.norm(a)
    ang = np.radians(rng.uniform(0.0, max_angle_deg))
    s2 = s * np.cos(ang) + np.cross(a, s) * np.sin(ang)
    return s2 / np.linalg.norm(s2)


def real_params(nominal: Model, max_length: float = 0.5e-3, rng=None, names=None, poses=None,
                max_angle_deg: float = 0.5) -> dict:
    """A "real" robot for any model: its geometric parameters with random errors.

    Lengths get errors uniform in +-``max_length`` [m].  ``names`` (names or shell patterns,
    e.g. ``["leg[*].L"]``) chooses the parameters; default the robot's error model
    (:mod:`cosim.calibration.error_model`: the 6-PUS's 60, whose rail directions are tilted by an
    angle uniform in [0, ``max_angle_deg``] about a random axis perpendicular to them, so they
    stay unit vectors), else every length that moves a joint at ``poses`` (default: home), as
    the generic calibration fits them (:func:`cosim.calibration.problems.geometry_candidates`).
    Returns the overrides ``{name: value}``.
    """
    from .problems import _select, geometry_candidates

    rng = np.random.default_rng(rng)
    em = error_model(nominal) if names is None else None
    if em is not None:
        units = {n: u for u in em.unit_vectors for n in u}
        out = {}
        for n in em.parameters:  # in the error model's order (Tiberi 2020 eq. 4.1, leg by leg)
            if n not in units:
                out[n] = nominal.param(n) + rng.uniform(-max_length, max_length)
            elif n not in out:
                u = units[n]
                s = _tilt(np.array([nominal.param(c) for c in u]), max_angle_deg, rng)
                out.update(zip(u, map(float, s)))
        return out
    x = nominal.home()[None, :] if poses is None else np.atleast_2d(poses)
    geo = geometry_candidates(nominal, x)
    chosen = geo if names is None else _select(nominal, geo, list(names))
    return {n: nominal.param(n) + float(rng.uniform(-max_length, max_length)) for n in chosen}


def _box_draw(box, m, rng):
    """m poses uniform in ``box`` (per coordinate (low, high, in degrees)); consecutive
    coordinates with the same range are drawn together."""
    X = np.zeros((m, len(box)))
    k = 0
    while k < len(box):
        j = k
        while j + 1 < len(box) and box[j + 1] == box[k]:
            j += 1
        lo, hi, deg = box[k]
        v = rng.uniform(lo, hi, (m, j - k + 1))
        X[:, k:j + 1] = np.radians(v) if deg else v
        k = j + 1
    return X


def candidate_poses(model: Model, n: int, rng=None, fraction: float = 0.5, joint_margin: float = 0.05,
                    min_singularity: float = 0.05, workspace: dict | None = None) -> np.ndarray:
    """Up to n random poses of any robot that ``model`` reaches comfortably.

    A robot whose error model declares a ``workspace`` (the 6-PUS: Tiberi 2020's box, x, y in
    +-50 mm, z in 20-100 mm, rotations in +-5 deg) gets poses uniform in that box, kept if every
    joint is at least its ``joint_margin`` [joint unit] inside its range and the singularity
    measures (inverse, direct) are above its ``min_singularity``; ``workspace`` overrides its
    entries (``{"rx_deg": [0, 0], ...}``).  Any other robot: uniform in a box about home of
    ``fraction`` of its reach along each pose coordinate (the core's reach, as the discrepancy
    engine's excitation probes it: :func:`cosim.discrepancy.excitation.derived_profile`); kept
    if every joint is at least ``joint_margin`` of its range inside it and both singularity
    measures are above ``min_singularity``.
    """
    rng = np.random.default_rng(rng)
    lo, hi = (np.asarray(v, float) for v in model.joint_limits())
    em = error_model(model)
    ws = {**(em.workspace if em is not None else {}), **(workspace or {})}
    if ws:
        box = [(*ws[c], False) if c in ws else (*ws[c + "_deg"], True) for c in model.facts.pose_names]
        margin, mins = np.full(lo.shape, ws["joint_margin"]), np.asarray(ws["min_singularity"], float)
        draw = lambda m: _box_draw(box, m, rng)  # noqa: E731
    else:
        from ..discrepancy.excitation import derived_profile

        home = np.asarray(model.home(), float)
        reach = np.asarray(derived_profile(model)["amp"], float) / 0.30
        margin = joint_margin * np.where(np.isfinite(hi - lo), hi - lo, np.inf)
        mins = min_singularity
        draw = lambda m: home + rng.uniform(-1.0, 1.0, (m, home.size)) * fraction * reach  # noqa: E731
    out, tries = [], 0
    while sum(len(o) for o in out) < n and tries < 50:
        tries += 1
        X = draw(max(4 * n, 100))
        q, st = model.ik(X, errors="status")
        ok = st == 0
        with np.errstate(invalid="ignore"):
            ok[ok] &= np.all(~(q[ok] < lo + margin) & ~(q[ok] > hi - margin), axis=1)
        X = X[ok]
        if X.size:
            X = X[np.all(model.singularity(X) > mins, axis=1)]
        out.append(X)
    return np.concatenate(out)[:n]


def _tau_hold(real: Model, poses):
    """Actuator efforts that hold the real robot still (0 if the core has no dynamics)."""
    try:
        return real.gravity_load(poses)
    except Exception:  # a build without dynamics: the effort columns are not used here
        return np.zeros_like(poses)


def _tracker_noise(seen, units, tracker_noise, angle_noise, rng):
    """The tracker's noise on ``seen``: ``tracker_noise`` on the coordinates in metres, then
    ``angle_noise`` on those in radians (each group drawn at once)."""
    meas = seen.copy()
    for unit, sd in (("m", tracker_noise), ("rad", angle_noise)):
        cols = [k for k, u in enumerate(units) if u == unit]
        if cols:
            meas[:, cols] += rng.normal(0.0, sd, (seen.shape[0], len(cols)))
    return meas


def joint_campaign(nominal: Model, real_params: dict, poses, tracker_noise: float = 10e-6,
                   angle_noise: float | None = None, encoder_noise: float = 0.0, rng=None, dwell: float = 1.0,
                   notes: str = "", full_pose: bool = False) -> Recording:
    """A calibration recording of any robot: the real robot (``nominal`` with ``real_params``)
    held at ``poses``, its joints read (its inverse kinematics at the true pose, plus
    ``encoder_noise``) and the pose measured by a tracker (``tracker_noise`` [m] on the
    coordinates in metres, ``angle_noise`` [rad] on those in radians; default
    ``tracker_noise`` over the mean distance of the tracker's points when the robot's error
    model names them (the 6-PUS: its platform points), else over 0.1 m: a tracker seeing points
    10 cm apart).  Poses the real robot cannot reach are skipped (counted in the notes).  The
    sidecar names the nominal model (its robot and parameter set overrides), never the real one.

    ``full_pose``: a 6-DOF tracker measures all of x, y, z [m], rx, ry, rz [rad] (a robot
    that declares fewer: the real robot's undeclared components as the core holds or solves
    them, the parasitic motion of a 3-PRS or 3-RPS head, ``Model.platform_pose``).

    Returns
    -------
    Recording
        Columns q, qd (0: held), tau (gravity load), pose (as measured).
    """
    rng = np.random.default_rng(rng)
    real = nominal.copy()
    real.set_params(real_params)
    nd = nominal.ndof
    poses = np.asarray(poses, float).reshape(-1, nd)
    q, st = real.ik(poses, errors="status")
    skipped = int(np.sum(st != 0))
    poses, q = poses[st == 0], q[st == 0]
    n = poses.shape[0]
    if angle_noise is None:
        em = error_model(nominal)
        r = (np.mean([np.hypot(*(real.param(c) for c in pt)) for pt in em.tracker_points])
             if em is not None and em.tracker_points else 0.1)
        angle_noise = tracker_noise / r
    units = nominal.facts.pose_units
    seen = poses
    if full_pose:
        seen = np.asarray(real.platform_pose(poses)[0], float).reshape(-1, 6)
        units = ("m", "m", "m", "rad", "rad", "rad")
    meas = _tracker_noise(seen, units, tracker_noise, angle_noise, rng)
    qm = q + (rng.normal(0.0, encoder_noise, q.shape) if encoder_noise > 0 else 0.0)
    base = Model(nominal.source, nominal.param_set)
    overrides = {k: v for k, v in nominal.params().items() if v != base.param(k)}
    rec = Recording(
        robot=nominal.robot, time=np.arange(n) * dwell, q=qm, qd=np.zeros_like(q), tau=_tau_hold(real, poses),
        pose=None if full_pose else meas, parameters=overrides,
        notes=(notes or f"{nominal.robot} calibration campaign (synthetic): the robot is held at each pose; q are "
               f"its joint readings, the pose columns what an external tracker measured")
        + ("; a 6-DOF tracker: the full pose x y z rx ry rz" if full_pose else "")
        + f"; tracker noise {tracker_noise:g} m and {angle_noise:g} rad, encoder noise {encoder_noise:g}"
        + (f"; {skipped} planned pose(s) skipped (out of the real robot's reach)" if skipped else ""),
    )
    if full_pose:
        rec.set_full_pose(meas)
    return rec


def output_campaign(nominal: Model, real_params: dict, q, noise: float = 0.0, rng=None, dwell: float = 1.0,
                    notes: str = "") -> Recording:
    """A calibration recording of a robot whose error model measures an output (the four-bar's
    X, :func:`cosim.calibration.error_model.output`): the real robot's output at joint values
    ``q`` (the crank angle theta [rad]), plus Gaussian ``noise`` [m]."""
    rng = np.random.default_rng(rng)
    real = nominal.copy()
    real.set_params(real_params)
    q = np.asarray(q, float).reshape(-1, nominal.ndof)
    X = output(real, q, jacobian=False)
    if noise > 0:
        X = X + rng.normal(0.0, noise, X.shape)
    n = q.shape[0]
    base = Model(nominal.source, nominal.param_set)
    overrides = {k: v for k, v in nominal.params().items() if v != base.param(k)}
    return Recording(
        robot=nominal.robot, time=np.arange(n) * dwell, q=q, qd=np.zeros_like(q), tau=np.zeros_like(q),
        pose=X[:, None], parameters=overrides,
        notes=(notes or f"{nominal.robot} calibration campaign (synthetic): joint q1 set, the output X measured")
        + f"; measurement noise {noise:g} m",
    )


def truth_path(csv_path) -> Path:
    p = Path(csv_path)
    return p.with_name(p.stem + ".truth.json")


def write_campaign(path, rec: Recording, real_params: dict, extra: dict | None = None):
    """Write the recording and, beside it, the truth (``<name>.truth.json``)."""
    csv_path, side = write_recording(path, rec)
    truth = {"robot": rec.robot, "real_parameters": real_params,
             "note": "the real robot of this synthetic campaign; calibration never reads this file"}
    truth.update(extra or {})
    truth_path(csv_path).write_text(json.dumps(truth, indent=2))
    return csv_path, side, truth_path(csv_path)


def read_truth(csv_path) -> dict:
    return json.loads(truth_path(csv_path).read_text())


def _main(argv=None):
    import argparse

    ap = argparse.ArgumentParser(prog="python -m cosim.calibration.data",
                                 description="write the synthetic calibration campaigns of scenarios/")
    ap.add_argument("outdir", nargs="?", default="scenarios")
    a = ap.parse_args(argv)
    out = Path(a.outdir)
    # 6-PUS: a real robot with errors up to 0.5 mm / 0.5 deg, 120 poses, 10 um tracker
    nominal = Model("6pus")
    real = real_params(nominal, rng=20240501)
    poses = candidate_poses(nominal, 120, rng=7)
    rec = joint_campaign(nominal, real, poses, tracker_noise=10e-6, rng=11)
    print(*write_campaign(out / "calibration_6pus_campaign.csv", rec, real))
    # four-bar: the Vitali 2020 linkage, theta = 30..60 deg, noise-free
    real4 = {"link[1].l": 0.60030, "link[2].l": 0.75050, "link[3].l": 0.79055, "link[4].l": 0.90070}
    rec4 = output_campaign(Model("fourbar"), real4, np.radians(np.arange(30, 61, 5)),
                           notes="Vitali 2020: four-bar with true errors (0.30, 0.50, 0.55, 0.70) mm, "
                                  "crank angle q1 = theta, X of the coupler mid point measured (noise-free)")
    print(*write_campaign(out / "calibration_fourbar_seed002.csv", rec4, real4))


if __name__ == "__main__":
    _main()
