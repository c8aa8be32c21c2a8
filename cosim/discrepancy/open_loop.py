"""Open-loop replay: a recording made without a controller (recorded effort in, motion out).

A recording whose sidecar names no controller and that has no reference (``qref``) cannot be
replayed in closed loop: there is no controller to rebuild.  Its recorded effort is then the
plant's input, and the replay drives the core plant with it and compares the motion it makes
with the recorded one.  Integrated over a whole run, an open-loop model drifts: a small error
of the friction or of the mass adds up to a position error that grows without bound (a
free axis has no restoring force), and the comparison then measures the drift, not the model.

The replay is therefore **multiple shooting**: the held-out part is cut into consecutive
windows of ``window`` seconds (0.5 s by default), and each window starts again from the
recorded state at its first sample (the smoothed reading and rate: a Savitzky-Golay fit over
``smooth`` seconds, so the rate noise of one sample does not set the start).  A held-out part of
more than :data:`MAX_WINDOWS` windows is replayed on that many, spread evenly over it (the plant
is stepped sample by sample from Python).  Inside a window
the plant is the core's (:class:`cosim.plants.CorePlant`, drive layer included), the recorded
effort held over each sample period as the rig's zero-order hold held it, and a measured
external effort (``f_ext``) added as a known input.  The error is the RMS over all windows
of the difference of the readings and of the rates to the recording, and the velocity error
relative to the recorded rates' RMS.

Example
-------
>>> from cosim.discrepancy.open_loop import open_loop_replay
>>> out = open_loop_replay(rec, {"nominal": m, "fitted": m_fit}, start=k0)  # doctest: +SKIP
>>> out["method"], out["runs"]["fitted"]["rel_qd"]                          # doctest: +SKIP
"""
from __future__ import annotations

import numpy as np
from scipy.signal import savgol_filter

#: length of a shooting window [s]
WINDOW = 0.5
#: smoothing span of the start state of each window [s]
SMOOTH = 0.02
#: most windows replayed (spread evenly over a longer held-out part): the replay steps the plant
#: sample by sample, so a long part at a high rate is sampled, not replayed whole
MAX_WINDOWS = 20


def declared_open_loop(rec) -> bool:
    """Whether the sidecar declares the recorded effort the plant's input to replay open loop
    (``"controller": {"kind": "open loop"}``, an import map's ``[controller] kind = "open loop"``):
    a closed-loop recording whose controller is not described (a reference but no controller
    law), replayed with its recorded efforts."""
    return isinstance(rec.controller, dict) and rec.controller.get("kind") == "open loop"


def can_replay_open_loop(rec) -> tuple[bool, str]:
    """Whether ``rec`` is replayed open loop: no controller in its sidecar and no reference
    columns, or the sidecar declares it (:func:`declared_open_loop`).  Returns (True, "") or
    (False, why not)."""
    if declared_open_loop(rec):
        return True, ""
    if rec.controller:
        return False, "the sidecar describes a controller (a closed-loop recording)"
    if rec.qref is not None:
        return False, "the recording has a reference (qref): a closed-loop recording without its controller"
    return True, ""


def _state(model, q, qd):
    """Pose and pose rate of the recorded (smoothed) joint reading and rate."""
    x = model.fk(q[None, :])[0]
    xd = model.pose_velocity(x[None, :], qd[None, :])[0]
    return x, xd


def _window(plant, drive, model, t, q0, qd0, tau, f_ext):
    """One shooting window: readings and rates (len(t), nd) from the state (q0, qd0) at t[0]."""
    n, nd = len(t), len(q0)
    q_out, qd_out = np.full((n, nd), np.nan), np.full((n, nd), np.nan)
    x0, xd0 = _state(model, q0, qd0)
    plant.initialize(float(t[0]), x0, xd0)
    drive.reset_delay()
    for k in range(n):
        y = plant.outputs()
        q_out[k], qd_out[k] = drive.read(y, plant.applied_effort())
        if k == n - 1:
            break
        if f_ext is not None:
            plant.set_external(f_ext[k])
        plant.set_input(tau[k])
        plant.do_step(float(t[k]), float(t[k + 1] - t[k]))
    return q_out, qd_out


def open_loop_replay(rec, plants: dict, *, start: int = 0, stop: int | None = None, window: float = WINDOW,
                     smooth: float = SMOOTH, max_windows: int = MAX_WINDOWS) -> dict:
    """Replay rows ``start:stop`` of an open-loop recording with each plant, by multiple
    shooting over windows of ``window`` seconds (see the module's text).

    Parameters
    ----------
    rec : cosim.recording.Recording
        The recording (its ``tau`` the effort put in, ``q``, ``qd`` the motion that came out).
    plants : dict
        ``{name: cosim.core.Model}``, the plants to replay (drive and sensor parameters
        included).
    start, stop : int
        Rows replayed (default: all).
    window : float
        Length of a shooting window [s]; each starts from the recorded state.
    smooth : float
        Span of the smoothing of that start state [s].
    max_windows : int
        Most windows replayed: a held-out part holding more is replayed on that many,
        spread evenly over it.

    Returns
    -------
    dict
        ``method`` (one sentence: multiple shooting, the window, the windows), ``window`` [s],
        ``windows``, ``start``, ``end`` [s], and ``runs``: per plant ``rms_q``, ``rms_qd``
        (per joint, in the joint's units and per s) and ``rel_qd`` (RMS rate difference over
        the recorded rates' RMS), or ``error`` (why that plant stopped: a stroke limit).

    Example
    -------
    >>> out = open_loop_replay(rec, {"nominal": Model(rec.robot)}, window=0.5)  # doctest: +SKIP
    """
    from ..plants import CoreDrive, CorePlant

    t = np.asarray(rec.time, float)
    stop = len(t) if stop is None else int(stop)
    dt = float(t[-1] - t[0]) / (len(t) - 1)
    w = max(5, int(round(smooth / dt)) | 1)
    q_s = savgol_filter(rec.q, w, 2, axis=0, mode="interp") if len(t) > w else np.asarray(rec.q, float)
    qd_s = savgol_filter(rec.qd, w, 2, axis=0, mode="interp") if len(t) > w else np.asarray(rec.qd, float)
    tau = np.asarray(rec.tau, float)
    f_ext = getattr(rec, "f_ext", None)
    per = max(2, int(round(window / dt)))
    cuts = list(range(int(start), stop - 1, per))
    spread = ""
    if len(cuts) > max_windows:
        spread = f" spread over {len(cuts)}"
        cuts = [cuts[i] for i in np.linspace(0, len(cuts) - 1, max_windows).round().astype(int)]
    out = {"window": per * dt, "windows": len(cuts), "start": float(t[start]), "end": float(t[stop - 1]),
           "method": (f"open loop (the recorded effort in, the motion out), multiple shooting: {len(cuts)} windows "
                      f"of {per * dt:.3g} s{spread}, each started from the recorded state (smoothed over "
                      f"{w * dt:.3g} s)"),
           "runs": {}}
    for name, model in plants.items():
        plant, drive = CorePlant(model, rtol=1e-8, atol=1e-10), CoreDrive(model)
        dq, dqd = [], []
        try:
            for a in cuts:
                b = min(a + per + 1, stop)
                q, qd = _window(plant, drive, model, t[a:b], q_s[a], qd_s[a], tau[a:b],
                                None if f_ext is None else f_ext[a:b])
                dq.append(q[1:] - rec.q[a + 1:b])
                dqd.append(qd[1:] - rec.qd[a + 1:b])
        except Exception as e:  # noqa: BLE001 - a plant that stops (a limit) is reported, not fatal
            out["runs"][name] = {"error": f"{type(e).__name__}: {e}"}
            continue
        dq, dqd = np.vstack(dq), np.vstack(dqd)
        seen = np.vstack([np.asarray(rec.qd[a + 1:min(a + per + 1, stop)], float) for a in cuts])
        ref = np.sqrt(np.mean(seen ** 2, axis=0))  # the recorded rates of the replayed windows
        rms_qd = np.sqrt(np.mean(dqd ** 2, axis=0))
        out["runs"][name] = {"rms_q": np.sqrt(np.mean(dq ** 2, axis=0)).tolist(), "rms_qd": rms_qd.tolist(),
                             "rel_qd": (rms_qd / np.maximum(ref, 1e-300)).tolist()}
    return out


def sentence(replay: dict | None) -> str:
    """What the replay of a diagnosis was, in one line for the CLI: which replay ran (closed
    loop, or open loop with its method) and its errors, or why none ran."""
    if not replay:
        return "no replay (not asked for)"
    if replay.get("skipped"):
        return f"no replay: {replay['skipped']}"
    if replay.get("kind") == "open loop":
        unit = replay.get("unit", "")
        runs = "; ".join(f"{name}: rate RMS " + " ".join(f"{v:.3g}" for v in r["rms_qd"])
                         + f" {unit}/s (" + " ".join(f"{100 * v:.2f} %" for v in r["rel_qd"])
                         + " of the recorded rates' RMS)"
                         if "rms_qd" in r else f"{name}: {r.get('error')}" for name, r in replay["runs"].items())
        return f"replay: {replay['method']}; {runs}"
    return (f"replay: closed loop from {replay.get('start', 0):.2f} s (the recorded controller and reference, "
            f"started from the recorded state)")


def heldout_replay(rec, eng, theta: dict, compared: dict | None = None, drifts=()) -> dict:
    """The open-loop replay of a diagnosis: the held-out part of the stretch of motion where
    it starts (a block, a run), with the nominal, the fitted and the ``compared`` plants; or
    ``{"skipped": why}`` when the recording is not an open-loop experiment.  ``drifts`` with a
    course (:func:`.drift.for_plant`): the fitted plant carries them, "fitted, mean" does not."""
    ok, why = can_replay_open_loop(rec)
    if not ok:
        return {"skipped": f"the recording has no qref columns (the reference is needed to replay in closed loop), "
                           f"and {why}, so no open-loop replay either"}
    pipe, test = eng.pipe, eng.test
    if not test.any():
        return {"skipped": "no held-out samples"}
    k0 = int(pipe.idx[test][0])
    plants = {"nominal": eng.model.copy(), "fitted": eng.model.copy()}
    if theta:
        plants["fitted"].set_params(theta)
    if any(d.course is not None for d in drifts):
        from .drift import apply

        plants["fitted, mean"] = plants["fitted"].copy()
        apply(plants["fitted"], drifts)
    plants.update(compared or {})
    out = open_loop_replay(rec, plants, start=k0, stop=pipe.segment_of(k0)[1])
    out["kind"], out["unit"] = "open loop", eng.model.joint_unit
    return out
