"""Recordings hiding forces that no term family covers: the proof cases of :mod:`.flexible`.

Each case is a closed-loop recording made like a blind case (:mod:`.blind`: the engine's
exciting trajectory, its noise and a PD + gravity controller designed on the nominal model)
with a force added to the plant as a known external effort along the reference
(:func:`cosim.discrepancy.runs.closed_loop`, ``f_ext``) that the recording does not carry.
None of the forces is a family of the discovery step, and none is added as one:

* ``position_threshold``: on one joint, zero below a position q0 (the 55-70 % quantile of its
  stroke) and A tanh((q - q0) / w)^2 above it (w a third of the stroke above q0);
* ``heating``: a friction that falls as the drive warms, sign(qd) c (1 - 0.6 T / T_max), its
  temperature rise T the joint's dissipated power |effort x rate| low-passed over a thermal
  time constant of 1.5-3 s (a first-order thermal model: T the dissipated energy history);
* ``cross_position``: on joint j, a bump A exp(-((q_k - c) / w)^2) keyed on another joint k's
  position (a hose or a cable carrier that catches when joint k passes c);
* ``cross_acceleration``: on joint j, A tanh(qdd_k / s_k) keyed on another joint k's
  acceleration (s_k its RMS);
* ``time_on``: on one joint, a force A that switches on smoothly at a time in the first half
  of the fitted part and stays (a hose snagged, a brake dragging).

The answer key gives the force at every recording row (``force``, (n, joints), the effort it
costs the drive, so the residual sees +force), the joint, and the true inputs as the flexible
stage's groups (``truth``).  :func:`clean` gives the same recording without a force.
"""
from __future__ import annotations

import math

import numpy as np

from ...errors import InputError

KINDS = ("position_threshold", "heating", "cross_acceleration", "cross_position", "time_on")


def _lowpass(x, dt, tau):
    a = math.exp(-dt / tau)
    y = np.empty_like(x)
    y[0] = x[0]
    for i in range(1, len(x)):
        y[i] = a * y[i - 1] + (1 - a) * x[i]
    return y


def hidden_force(kind, rng, t, q, qd, qdd, E, noun, tau=None):
    """The force (the effort it costs each joint, (n, nd)) of ``kind`` along the reference
    ``q, qd, qdd`` (n, nd) at times ``t``; ``E`` the joints' RMS effort, ``tau`` (n, nd) the
    nominal effort along the reference (for ``heating``; default E).  Returns
    ``(force, joint (1-based), truth groups, description)``."""
    n, nd = q.shape
    j = int(rng.integers(0, nd))
    f = np.zeros((n, nd))
    size = float(rng.uniform(0.15, 0.3)) * E[j]
    if kind == "position_threshold":
        q0 = float(np.quantile(q[:, j], rng.uniform(0.55, 0.7)))
        w = (q[:, j].max() - q0) / 3.0
        f[:, j] = np.where(q[:, j] > q0, size * np.tanh((q[:, j] - q0) / w) ** 2, 0.0) * 2.0
        truth, what = [f"position of {noun} {j + 1}"], f"{2 * size:.3g} tanh((q - {q0:.4g})/{w:.3g})^2 above q0"
    elif kind == "heating":
        dt = float(t[1] - t[0])
        V = float(np.sqrt(np.mean(qd[:, j] ** 2)))
        effort = np.full(n, E[j]) if tau is None else tau[:, j]
        tc = float(rng.uniform(1.5, 3.0))
        T = _lowpass(np.abs(effort * qd[:, j]), dt, tc)
        f[:, j] = np.tanh(qd[:, j] / (0.02 * V)) * size * (1.0 - 0.6 * T / T.max())
        truth = [f"rate of {noun} {j + 1}", f"history of {noun} {j + 1}"]
        what = f"sign(qd) {size:.3g} (1 - 0.6 T/T_max), T = |tau qd| low-passed over {tc:.2g} s"
    elif kind == "cross_acceleration":
        k = int((j + rng.integers(1, nd)) % nd)
        s = float(np.sqrt(np.mean(qdd[:, k] ** 2)))
        f[:, j] = size * np.tanh(qdd[:, k] / s)
        truth, what = [f"acceleration of {noun} {k + 1}"], f"{size:.3g} tanh(qdd{k + 1}/{s:.3g})"
    elif kind == "cross_position":
        k = int((j + rng.integers(1, nd)) % nd)
        c = float(np.quantile(q[:, k], rng.uniform(0.3, 0.7)))
        w = 0.15 * float(q[:, k].max() - q[:, k].min())
        f[:, j] = 2.0 * size * np.exp(-(((q[:, k] - c) / w) ** 2))
        truth, what = [f"position of {noun} {k + 1}"], f"{2 * size:.3g} exp(-((q{k + 1} - {c:.4g})/{w:.3g})^2)"
    elif kind == "time_on":
        t_on = float(t[0] + rng.uniform(0.15, 0.35) * (t[-1] - t[0]))
        f[:, j] = size * 0.5 * (1 + np.tanh((t - t_on) / 0.2))
        truth, what = ["time"], f"{size:.3g} on from t = {t_on:.3g} s"
    else:
        raise InputError(f"no flexible case {kind!r} (cases: {', '.join(KINDS)})")
    return f, j + 1, truth, what


def simulate(kind: str | None, seed: int, robot: str = "6pus", duration: float | None = None):
    """One recording hiding a force of ``kind`` (None: clean).  Returns ``(recording, key)``;
    the key holds ``kind``, ``joint``, ``truth`` (groups), ``what`` and ``force`` (at every
    recording row)."""
    from ... import controllers as ctl
    from ...core.model import Model
    from ...master import make_reference
    from ...recording import Recording
    from ..blind import load_config, with_robot
    from ..excitation import excitation
    from ..runs import closed_loop

    model = Model(robot)
    cfg = with_robot(load_config(), model)
    gen = cfg["general"]
    dt, lead = 1.0 / gen["rate"], gen.get("lead_in", 0.5)
    k0 = int(round(lead / dt))
    rng = np.random.default_rng(seed)
    traj = excitation(model, duration or gen["duration"], seed=seed, lead_in=lead)
    ref = make_reference(model, traj, step=dt, duration=round(traj.duration / dt) * dt)
    tau_ff = model.inverse_dynamics(ref.x[k0:], ref.xd[k0:], ref.xdd[k0:])
    E = np.sqrt(np.mean(tau_ff ** 2, axis=0))
    qd = np.gradient(ref.q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    force = np.zeros_like(ref.q)
    key = {"kind": kind or "clean", "seed": seed, "robot": robot, "joint": None, "truth": [], "what": ""}
    if kind is not None:
        tau_ref = np.vstack([np.repeat(tau_ff[:1], k0, axis=0), tau_ff])[: len(ref.q)]
        force, key["joint"], key["truth"], key["what"] = hidden_force(kind, rng, ref.time, ref.q, qd, qdd, E,
                                                                      model.facts.joint_noun, tau=tau_ref)
        force[:k0] = 0.0
    wn = 2 * math.pi * gen.get("bandwidth_hz", 8.0)
    mass = float(ctl.joint_mass(model, model.home()).diagonal().max())
    ctrl = ctl.pd_gravity(model, kp=mass * wn ** 2, kd=2 * wn * mass)
    res = closed_loop(model, ctrl, ref, noise=cfg["noise"][robot], seed=seed + 7919, f_ext=-force)
    s = slice(k0, None)
    rec = Recording(robot, res.time[s].copy(), res.q[s].copy(), res.qd[s].copy(), res.tau_logged[s].copy(),
                    qref=ref.q[s].copy(), pose=res.pose[s].copy(), controller=dict(ctrl.describe(), rate_hz=gen["rate"]),
                    notes="flexible case: a closed-loop recording that may hide a force (the key is elsewhere)")
    key["force"] = force[s][: len(rec.time)]
    key["time"] = rec.time
    return rec, key


def truth_share(diag, key, flexible=None, held_out=False) -> float:
    """The hidden force's share of what is left on its channel, from the answer key and the
    fitted model (never from the flexible model's answer): the part of the force the fitted
    model did not take, g = force - (residual before - residual after), as a predictor of the
    residual after, 1 - var(after - g) / var(after) over every decimated sample, as the
    flexible stage judges its own share out of fold (``held_out``: on the engine's held-out
    samples only); what it leaves is the noise.  The residual after is the one the flexible stage fitted: without a discovered
    term it set aside as a stand-in (``flexible``: its :class:`~.flexible.FlexibleFit`)."""
    c = key["joint"] - 1
    t = np.asarray(diag.residual["time"])
    held = t >= diag.heldout["start"] if held_out else np.ones(len(t), bool)
    f = np.interp(t[held], np.asarray(key["time"]), key["force"][:, c])
    before = np.asarray(diag.residual["before"])[held, c]
    after = np.asarray(diag.residual["after"])[held, c]
    if flexible is not None and flexible.target is not None:
        after = np.asarray(flexible.target)[held]
    g = f - (before - after)
    return float(1.0 - np.var(after - g) / np.var(after))
