"""A scenario run's metrics: the step response (overshoot, settling, steady-state error against
the predicted equilibrium), the tracking errors and the held poses (:func:`compute_metrics`;
:mod:`cosim.scenario`).
"""
from __future__ import annotations

import numpy as np

from .. import controllers as ctl
from .. import trajectories as tr
from .spec import Scenario


# ------------------------------------------------------------------- metrics

def _window(res, sc):
    """Rows of the settling window at the end of the run."""
    w = float(sc.spec["output"].get("settle_window", max(0.1 * sc.spec["duration"], 0.05)))
    return res["time"] >= res["time"][-1] - w + 1e-12


def compute_metrics(sc: Scenario, res, model, traj, ctrl, design=None) -> dict:
    """Metrics of a run, by reference type (see docs/scenarios.md)."""
    m = {"scenario": sc.name, "robot": sc.spec["robot"], "plant": res.plant, "controller": res.controller,
         "step": res.step, "duration": float(res["time"][-1] - res["time"][0]), "wall_time": res.wall_time,
         "saturated_samples": int(res.saturated), "units": {"length": "m", "angle": "rad", "time": "s"}}
    kind = sc.spec["reference"]["type"]
    if kind == "step":
        m.update(step_response_metrics(sc, res, model, traj, ctrl))
    elif kind == "letter_m":
        m.update(tracking_metrics(sc, res))
    elif kind == "excitation":
        e = res["xref"] - res["x"]
        m["excitation"] = {"pose_error_rms": np.sqrt(np.mean(e ** 2, axis=0)).tolist(),
                           "effort_max": np.max(np.abs(res["tau_applied"]), axis=0).tolist()}
    else:
        m.update(pose_set_metrics(sc, res))
    return m


def step_response_metrics(sc, res, model, traj, ctrl) -> dict:
    """Step metrics (python-control ``step_info``), steady-state error and its prediction."""
    x0, x1 = traj.knots[0], traj.knots[-1]
    t_step = traj.times[0]
    after = res["time"] >= t_step
    win = _window(res, sc)
    t = res["time"][after]
    e_joint = (res["qref"] - res["q_true"])[win]
    e_pose = (res["xref"] - res["x"])[win]
    ess = e_joint.mean(axis=0)
    out = {"steady_state": {
        "window": [float(res["time"][win][0]), float(res["time"][-1])],
        "joint_error": ess.tolist(),
        "joint_error_max": float(np.max(np.abs(ess))),
        "joint_error_spread": float(np.max(np.ptp(e_joint, axis=0))),
        "pose_error": e_pose.mean(axis=0).tolist(),
        "joint_speed_max": float(np.max(np.abs(res["qd_true"][win]))),
    }}
    kind = ctrl.kind
    kp = ctrl.kp
    if kind == "pd":
        pred = ctl.predicted_steady_state_error(model, x1, kp)
        pred_eq = predicted_equilibrium_error(model, x1, kp)
        denom = np.max(np.abs(pred_eq))
        out["steady_state"]["predicted_joint_error"] = pred.tolist()
        out["steady_state"]["predicted_joint_error_equilibrium"] = pred_eq.tolist()
        out["steady_state"]["prediction_absolute_error"] = float(np.max(np.abs(ess - pred_eq)))
        # relative to the predicted error; undefined (None) where gravity loads no joint
        # (a planar robot in a horizontal plane: the prediction is 0, the absolute error tells)
        out["steady_state"]["prediction_relative_error"] = (float(np.max(np.abs(ess - pred_eq)) / denom)
                                                            if denom > 0 else None)
        out["steady_state"]["prediction_relative_error_first_order"] = (float(np.max(np.abs(ess - pred)) / denom)
                                                                        if denom > 0 else None)
    elif kind in ("pd_gravity", "pid"):  # gravity fed forward, or integrated away
        out["steady_state"]["predicted_joint_error"] = [0.0] * model.ndof
    # python-control step metrics on the moved pose coordinates and on each joint
    moved = np.flatnonzero(np.abs(x1 - x0) > 0)
    names = model.facts.pose_names
    pose_info = {}
    for i in moved:
        y = res["x"][after, i]
        try:
            pose_info[names[i]] = ctl.step_metrics(t, y, y0=x0[i])
        except ctl.ControllerError as e:
            pose_info[names[i]] = {"error": str(e)}
    joint_info = []
    q0, q1 = model.ik(x0), res["qref"][-1]
    qstart = res["q_true"][0]
    for j in range(model.ndof):
        if abs(q1[j] - q0[j]) < 1e-9:
            joint_info.append(None)
            continue
        joint_info.append(ctl.step_metrics(t, res["q_true"][after, j], y0=qstart[j]))
    out["step_info"] = {"pose": pose_info, "joints": joint_info, "amplitude_pose": (x1 - x0).tolist(),
                        "amplitude_joints": (q1 - q0).tolist()}
    # what python-control predicts on the decoupled joint with its effective mass
    if kind in ("pd", "pd_gravity"):
        mq = np.diag(ctl.joint_mass(model, x1))
        out["predicted_step_info"] = [ctl.analyse_pd(mass=float(mq[j]), kp=float(kp[j, j]), kd=float(ctrl.kd[j, j]),
                                                     dt=res.step) for j in range(model.ndof)]
    return out


def predicted_equilibrium_error(model, x_ref, kp, iterations: int = 20) -> np.ndarray:
    """``e`` solving ``Kp e = g(x(qref - e))``: the PD equilibrium, from the core's statics.

    :func:`cosim.controllers.predicted_steady_state_error` evaluates the gravity load at
    the reference pose; the robot settles ``e`` away from it, where the load differs a
    little.  This fixed point (forward kinematics of ``qref - e``, gravity load there)
    is the exact static prediction; it converges because ``Kp^-1 dg/dq`` is small.

    Parameters
    ----------
    model : cosim.core.Model
        The controller's model (kinematics and gravity load).
    x_ref : array_like, shape (nd,)
        Reference pose [m, rad]; ``qref = ik(x_ref)``.
    kp : float or array_like
        Proportional gain [N/m or N m/rad].
    iterations : int
        Largest number of fixed-point iterations.

    Returns
    -------
    ndarray, shape (nd,)
        ``qref - q`` at the equilibrium [m or rad].
    """
    nd = model.ndof
    K = ctl._gain(kp, nd, "kp", "N/m")
    qref = model.ik(x_ref)
    e = np.linalg.solve(K, model.gravity_load(x_ref))
    x = np.asarray(x_ref, float)
    for _ in range(iterations):
        x = model.fk(qref - e, x_guess=x)
        e_new = np.linalg.solve(K, model.gravity_load(x))
        if np.max(np.abs(e_new - e)) < 1e-15:
            e = e_new
            break
        e = e_new
    return e


def tracking_metrics(sc, res) -> dict:
    """Pen-point tracking error of a traced path (true pose vs reference pose)."""
    tool = sc.spec["output"].get("tool", [0.0, 0.0, 0.0])
    pen, pen_ref = tr.pen_point(res.robot, res["x"], tool), tr.pen_point(res.robot, res["xref"], tool)
    err = np.linalg.norm(pen - pen_ref, axis=1)
    ej = res["qref"] - res["q_true"]
    return {"tracking": {
        "tool_offset": list(tool),
        "pen_error_rms": float(np.sqrt(np.mean(err**2))),
        "pen_error_max": float(err.max()),
        "pen_error_max_time": float(res["time"][int(err.argmax())]),
        "joint_error_rms": float(np.sqrt(np.mean(ej**2))),
        "joint_error_max": float(np.max(np.abs(ej))),
        "effort_max": float(np.max(np.abs(res["tau_applied"]))),
    }}


def pose_set_metrics(sc, res) -> dict:
    """Per held pose: rows, final pose error (``position_error``: the norm over the pose
    coordinates in metres, as the core names their units), tracker scatter; over the whole
    run (``motion``): the joint and pose tracking errors and the largest effort."""
    from ..core.model import robot_facts

    units = robot_facts(sc.spec["robot"]).pose_units
    lengths = [i for i, u in enumerate(units) if u == "m"]
    poses = []
    lab = res["label"]
    for k in sorted(set(lab.tolist()) - {0}):
        rows = np.flatnonzero(lab == k)
        last = rows[len(rows) // 2:]
        err = (res["xref"][last] - res["x"][last]).mean(axis=0)
        poses.append({"label": int(k), "rows": int(len(rows)), "t_start": float(res["time"][rows[0]]),
                      "t_end": float(res["time"][rows[-1]]), "pose_ref": res["xref"][rows[0]].tolist(),
                      "pose_error": err.tolist(), "position_error": float(np.linalg.norm(err[lengths])),
                      "tracker_std": res["pose"][last].std(axis=0).tolist(),
                      "joint_speed_max": float(np.max(np.abs(res["qd_true"][last])))})
    ej = res["qref"] - res["q_true"]
    ex = res["xref"] - res["x"]
    motion = {"joint_error_rms": np.sqrt(np.mean(ej ** 2, axis=0)).tolist(),
              "joint_error_max": float(np.max(np.abs(ej))),
              "joint_error_max_time": float(res["time"][int(np.argmax(np.max(np.abs(ej), axis=1)))]),
              "pose_error_rms": np.sqrt(np.mean(ex ** 2, axis=0)).tolist(),
              "effort_max": np.max(np.abs(res["tau_applied"]), axis=0).tolist()}
    return {"poses": poses, "held_poses": len(poses), "motion": motion}
