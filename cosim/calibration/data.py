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

from .error_model import error_model
from ..core.model import Model
from ..recording import Recording, write_recording

__all__ = [
    "SEED000_POSES",
    "sixpus_real_params",
    "sixpus_candidate_poses",
    "sixpus_campaign",
    "fourbar_campaign",
    "real_params",
    "candidate_poses",
    "joint_campaign",
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


def sixpus_real_params(nominal: Model, max_length: float = 0.5e-3, max_angle_deg: float = 0.5,
                       rng=None) -> dict:
    """A "real" 6-PUS: the 60 geometric parameters of ``nominal`` with random errors.

    Lengths and points (platform points, rail origins, leg lengths) get errors uniform in
    +-``max_length`` [m]; each rail direction is tilted by an angle uniform in
    [0, ``max_angle_deg``] about a random axis perpendicular to it (so it stays a unit
    vector).  Returns the overrides ``{name: value}``.
    """
    rng = np.random.default_rng(rng)
    out = {}
    for names in error_model(nominal).joint_parameters:  # Tiberi 2020 eq. 4.1, per leg
        for n in names[:7]:
            out[n] = nominal.param(n) + rng.uniform(-max_length, max_length)
        s = np.array([nominal.param(n) for n in names[7:]])
        a = rng.normal(size=3)
        a -= (a @ s) * s
        a /= np.linalg.norm(a)
        ang = np.radians(rng.uniform(0.0, max_angle_deg))
        s2 = s * np.cos(ang) + np.cross(a, s) * np.sin(ang)  # Rodrigues, axis a perpendicular to s
        s2 /= np.linalg.norm(s2)
        out.update(zip(names[7:], map(float, s2)))
    return out


def sixpus_candidate_poses(model: Model, n: int, rng=None, xy: float = 0.05, z=(0.02, 0.10),
                           rot_deg: float = 5.0, stroke_margin: float = 5e-3, min_direct: float = 0.02,
                           min_inverse: float = 0.15) -> np.ndarray:
    """Up to n random poses in the Tiberi 2020 workspace that ``model`` reaches comfortably.

    Poses are uniform in x, y in +-``xy``, z in ``z``, each rotation in +-``rot_deg``;
    kept if every stroke is at least ``stroke_margin`` inside its range (a real robot that
    differs by a fraction of a millimetre reaches them too), the direct-singularity
    measure is above ``min_direct`` and the inverse one (a leg close to perpendicular to
    its rail, at the edge of its reach) above ``min_inverse``.
    """
    rng = np.random.default_rng(rng)
    out = []
    qmin = np.array([model.param(f"rail[{i}].qmin") for i in range(1, 7)])
    qmax = np.array([model.param(f"rail[{i}].qmax") for i in range(1, 7)])
    tries = 0
    while sum(len(o) for o in out) < n and tries < 50:
        tries += 1
        m = max(4 * n, 100)
        X = np.zeros((m, 6))
        X[:, :2] = rng.uniform(-xy, xy, (m, 2))
        X[:, 2] = rng.uniform(z[0], z[1], m)
        X[:, 3:] = np.radians(rng.uniform(-rot_deg, rot_deg, (m, 3)))
        q, st = model.ik(X, errors="status")
        ok = st == 0
        ok[ok] &= np.all((q[ok] > qmin + stroke_margin) & (q[ok] < qmax - stroke_margin), axis=1)
        X = X[ok]
        if X.size:
            meas = model.singularity(X)
            X = X[(meas[:, 1] > min_direct) & (meas[:, 0] > min_inverse)]
        out.append(X)
    X = np.concatenate(out)[:n]
    return X


def _tau_hold(real: Model, poses):
    """Actuator efforts that hold the real robot still (0 if the core has no dynamics)."""
    try:
        return real.gravity_load(poses)
    except Exception:  # a build without dynamics: the effort columns are not used here
        return np.zeros_like(poses)


def sixpus_campaign(real_params: dict, poses, tracker_noise: float = 10e-6, angle_noise: float | None = None,
                    encoder_noise: float = 0.0, rng=None, nominal_params: dict | None = None,
                    dwell: float = 1.0, notes: str = "") -> Recording:
    """A 6-PUS calibration recording: the real robot held at ``poses``.

    Parameters
    ----------
    real_params : dict
        Overrides of the default parameters that make the real robot.
    poses : array_like, shape (n, 6)
        True poses [m, rad].
    tracker_noise : float
        Standard deviation of the tracker's position noise [m] (default 10 um).
    angle_noise : float, optional
        Standard deviation of its orientation noise [rad]; default: ``tracker_noise``
        over the platform radius (a tracker that sees the platform points with
        ``tracker_noise``).
    encoder_noise : float
        Standard deviation of the joint readings' noise [m].
    nominal_params : dict, optional
        Overrides of the nominal model, stored in the sidecar.
    dwell : float
        Time between two held poses [s] (the ``time`` column).

    Returns
    -------
    Recording
        Columns q, qd (0: held), tau (gravity load), pose (x, y, z, rx, ry, rz as measured).
        Poses the real robot cannot reach are skipped (counted in the notes).
    """
    rng = np.random.default_rng(rng)
    real = Model("6pus", params=real_params)
    poses = np.asarray(poses, float).reshape(-1, 6)
    q, st = real.ik(poses, errors="status")
    skipped = int(np.sum(st != 0))
    poses, q = poses[st == 0], q[st == 0]  # a real robot skips the poses it cannot reach
    n = poses.shape[0]
    r = np.mean([np.hypot(real.param(f"leg[{i}].px"), real.param(f"leg[{i}].py")) for i in range(1, 7)])
    if angle_noise is None:
        angle_noise = tracker_noise / r
    meas = poses.copy()
    meas[:, :3] += rng.normal(0.0, tracker_noise, (n, 3))
    meas[:, 3:] += rng.normal(0.0, angle_noise, (n, 3))
    qm = q + (rng.normal(0.0, encoder_noise, q.shape) if encoder_noise > 0 else 0.0)
    return Recording(
        robot="6pus", time=np.arange(n) * dwell, q=qm, qd=np.zeros_like(q), tau=_tau_hold(real, poses), pose=meas,
        parameters=dict(nominal_params or {}),
        notes=(notes or "6-PUS calibration campaign (synthetic): the robot is held at each pose; q are its joint "
               "readings, x..rz the pose measured by an external tracker")
        + f"; tracker noise {tracker_noise:g} m and {angle_noise:g} rad, encoder noise {encoder_noise:g} m"
        + (f"; {skipped} planned pose(s) skipped (out of the real robot's reach)" if skipped else ""),
    )


def fourbar_campaign(real_params: dict, theta, noise: float = 0.0, rng=None, nominal_params: dict | None = None,
                     dwell: float = 1.0, notes: str = "") -> Recording:
    """A four-bar calibration recording: X of the real linkage measured at crank angles theta [rad]."""
    from ..fourbar import output

    rng = np.random.default_rng(rng)
    real = Model("fourbar", params=real_params)
    theta = np.asarray(theta, float).ravel()
    X = output(real, theta, jacobian=False)
    if noise > 0:
        X = X + rng.normal(0.0, noise, X.shape)
    n = theta.size
    return Recording(
        robot="fourbar", time=np.arange(n) * dwell, q=theta[:, None], qd=np.zeros((n, 1)), tau=np.zeros((n, 1)),
        pose=X[:, None], parameters=dict(nominal_params or {}),
        notes=(notes or "four-bar calibration campaign (synthetic): crank angle q1 = theta, X measured") +
        f"; measurement noise {noise:g} m",
    )


def real_params(nominal: Model, max_length: float = 0.5e-3, rng=None, names=None, poses=None) -> dict:
    """A "real" robot for any model: its geometric parameters with errors uniform in
    +-``max_length`` [m].

    ``names`` (names or shell patterns, e.g. ``["leg[*].L"]``) chooses the parameters;
    default every length that moves a joint at ``poses`` (default: home), as the generic
    calibration fits them (:func:`cosim.calibration.problems.geometry_candidates`).
    Returns the overrides ``{name: value}``.
    """
    from .problems import _select, geometry_candidates

    rng = np.random.default_rng(rng)
    x = nominal.home()[None, :] if poses is None else np.atleast_2d(poses)
    geo = geometry_candidates(nominal, x)
    chosen = geo if names is None else _select(nominal, geo, list(names))
    return {n: nominal.param(n) + float(rng.uniform(-max_length, max_length)) for n in chosen}


def candidate_poses(model: Model, n: int, rng=None, fraction: float = 0.5, joint_margin: float = 0.05,
                    min_singularity: float = 0.05) -> np.ndarray:
    """Up to n random poses of any robot that ``model`` reaches comfortably.

    Uniform in a box about home of ``fraction`` of the robot's reach along each pose
    coordinate (the core's reach, as the discrepancy engine's excitation probes it:
    :func:`cosim.discrepancy.excitation.derived_profile`); kept if every joint is at least
    ``joint_margin`` of its range inside it and both singularity measures are above
    ``min_singularity``.
    """
    from ..discrepancy.excitation import derived_profile

    rng = np.random.default_rng(rng)
    home = np.asarray(model.home(), float)
    reach = np.asarray(derived_profile(model)["amp"], float) / 0.30
    lo, hi = (np.asarray(v, float) for v in model.joint_limits())
    span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    out, tries = [], 0
    while sum(len(o) for o in out) < n and tries < 50:
        tries += 1
        m = max(4 * n, 100)
        X = home + rng.uniform(-1.0, 1.0, (m, home.size)) * fraction * reach
        q, st = model.ik(X, errors="status")
        ok = st == 0
        with np.errstate(invalid="ignore"):
            ok[ok] &= np.all(~(q[ok] < lo + joint_margin * span) & ~(q[ok] > hi - joint_margin * span), axis=1)
        X = X[ok]
        if X.size:
            X = X[np.all(model.singularity(X) > min_singularity, axis=1)]
        out.append(X)
    return np.concatenate(out)[:n]


def joint_campaign(nominal: Model, real_params: dict, poses, tracker_noise: float = 10e-6,
                   angle_noise: float | None = None, encoder_noise: float = 0.0, rng=None, dwell: float = 1.0,
                   notes: str = "", full_pose: bool = False) -> Recording:
    """A calibration recording of any robot: the real robot (``nominal`` with ``real_params``)
    held at ``poses``, its joints read (its inverse kinematics at the true pose, plus
    ``encoder_noise``) and the pose measured by a tracker (``tracker_noise`` [m] on the
    coordinates in metres, ``angle_noise`` [rad] on those in radians; default
    ``tracker_noise`` / 0.1 m: a tracker seeing points 10 cm apart).  Poses the real robot
    cannot reach are skipped (counted in the notes).  The sidecar names the nominal model
    (its robot and parameter set overrides), never the real one.

    ``full_pose``: a 6-DOF tracker measures all of x, y, z [m], rx, ry, rz [rad] (a robot
    that declares fewer: the real robot's undeclared components as the core holds or solves
    them, the parasitic motion of a 3-PRS or 3-RPS head, ``Model.platform_pose``)."""
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
        angle_noise = tracker_noise / 0.1
    units = nominal.facts.pose_units
    seen = poses
    if full_pose:
        seen = np.asarray(real.platform_pose(poses)[0], float).reshape(-1, 6)
        units = ("m", "m", "m", "rad", "rad", "rad")
    sd = np.array([tracker_noise if u == "m" else angle_noise for u in units])
    meas = seen + rng.normal(0.0, 1.0, seen.shape) * sd
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
    real = sixpus_real_params(nominal, rng=20240501)
    poses = sixpus_candidate_poses(nominal, 120, rng=7)
    rec = sixpus_campaign(real, poses, tracker_noise=10e-6, rng=11)
    print(*write_campaign(out / "calibration_6pus_campaign.csv", rec, real))
    # four-bar: the Vitali 2020 linkage, theta = 30..60 deg, noise-free
    real4 = {"link[1].l": 0.60030, "link[2].l": 0.75050, "link[3].l": 0.79055, "link[4].l": 0.90070}
    rec4 = fourbar_campaign(real4, np.radians(np.arange(30, 61, 5)),
                            notes="Vitali 2020: four-bar with true errors (0.30, 0.50, 0.55, 0.70) mm, "
                                  "crank angle q1 = theta, X of the coupler mid point measured (noise-free)")
    print(*write_campaign(out / "calibration_fourbar_seed002.csv", rec4, real4))


if __name__ == "__main__":
    _main()
