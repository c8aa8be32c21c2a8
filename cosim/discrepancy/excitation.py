"""Exciting task-space trajectories for discrepancy recordings.

A trajectory is a sequence of cycles; each cycle moves to a new centre pose, stands
still, then runs three bursts around the centre, each faded in and out with a
minimum-jerk window so the pose, rate and acceleration stay continuous:

1. ``multisine``: two sines per pose coordinate (one and two periods per burst): accelerations, velocity
   reversals at speed, rotations (platform inertia, payload offset);
2. ``sweep``: a rounded triangle wave along a random direction: constant-velocity
   legs at a few speeds joined by quick reversals (Coulomb vs viscous);
3. ``slow``: a small, slow oscillation: joint speeds of a few mm/s (or mrad/s) through
   many reversals (Stribeck, backlash).

Every cycle therefore holds standstill, acceleration peaks, constant velocity and
velocity reversals, and any 30 % of a recording of a few cycles holds most of them
(the held-out part of a diagnosis).  The derivatives are central differences of the
closed-form pose (step 1e-4 s: relative error ~1e-8).  The trajectory is checked
against the core (every pose reachable, strokes inside their range, away from
singularities) and shrunk until it is.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from ..errors import InputError

#: tuned excitation profiles by robot (a data file; robots without one get derived_profile)
PROFILE_FILE = Path(__file__).resolve().parents[2] / "scenarios" / "blind" / "excitation.toml"


@lru_cache(maxsize=1)
def tuned_profiles() -> dict:
    """The hand-tuned profiles of :data:`PROFILE_FILE` by robot name ({} if the file is absent)."""
    if not PROFILE_FILE.exists():
        return {}
    with open(PROFILE_FILE, "rb") as f:
        return tomllib.load(f)


def profile(model) -> dict:
    """The excitation profile of ``model``: its table in :data:`PROFILE_FILE`, else
    :func:`derived_profile`.  A table must give every key for every pose coordinate."""
    prof = tuned_profiles().get(model.robot)
    if prof is None:
        return derived_profile(model)
    for key in ("centre", "centre_offset", "amp", "slow"):
        if len(prof.get(key, ())) != model.ndof:
            raise ValueError(f"{PROFILE_FILE}: [{model.robot}] {key} needs {model.ndof} values (one per pose "
                             f"coordinate), got {len(prof.get(key, ()))}")
    return prof


LABELS = {"move": 1, "hold": 2, "multisine": 3, "sweep": 4, "slow": 5}


def _ramp(u):
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u**2)


def _window(tau, T, r):
    """C2 window on [0, T]: 0 -> 1 over r, 1 -> 0 over the last r."""
    return _ramp(tau / r) * _ramp((T - tau) / r)


@dataclass
class Excitation:
    """A closed-form pose trajectory (``evaluate``, ``label``, ``name``: the interface of
    :class:`cosim.trajectories.Trajectory` that :func:`cosim.master.make_reference` uses)."""

    home: np.ndarray
    segments: list
    duration: float
    name: str = "excitation"

    @property
    def ndof(self):
        return len(self.home)

    def pose(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        x = np.tile(self.home, (len(t), 1))
        for seg in self.segments:
            kind, a, b = seg["kind"], seg["t0"], seg["t1"]
            sel = (t >= a) & (t < b) if kind != "hold_end" else t >= a
            if not np.any(sel):
                continue
            tau = t[sel] - a
            T = b - a
            c = seg["c"]
            if kind == "move":
                s = _ramp(tau / T)[:, None]
                x[sel] = seg["c0"] + s * (c - seg["c0"])
            elif kind in ("hold", "hold_end"):
                x[sel] = c
            else:
                w = _window(tau, T, seg["ramp"])[:, None]
                if kind == "multisine":
                    A, f, ph = seg["A"], seg["f"], seg["ph"]
                    off = np.zeros((len(tau), self.ndof))
                    for m in range(f.shape[1]):
                        off += A[:, m] * (np.sin(2 * np.pi * f[:, m] * tau[:, None] + ph[:, m]) - np.sin(ph[:, m]))
                elif kind == "sweep":
                    k = seg["round"]
                    tri = np.arcsin(k * np.sin(2 * np.pi * tau / seg["period"])) / np.arcsin(k)
                    off = tri[:, None] * seg["dir"]
                else:  # slow
                    off = np.sin(2 * np.pi * seg["freq"] * tau)[:, None] * seg["dir"]
                x[sel] = c + w * off
        return x

    def evaluate(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        h = 1e-4
        x = self.pose(t)
        xp, xm = self.pose(t + h), self.pose(t - h)
        return x, (xp - xm) / (2 * h), (xp - 2 * x + xm) / h**2

    def label(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        out = np.zeros(len(t), dtype=int)
        for seg in self.segments:
            sel = (t >= seg["t0"]) & (t < seg["t1"])
            out[sel] = LABELS.get(seg["kind"], 2)
        return out


def excitation(model, duration: float, seed: int = 0, scale: float = 1.0, lead_in: float = 0.5) -> Excitation:
    """A random exciting trajectory of ``duration`` seconds for ``model`` (see module doc).

    Parameters
    ----------
    model : cosim.core.Model
        The robot (6-PUS or Quattro); its home pose is the centre of the workspace used.
    duration : float
        Length [s] after the lead-in.
    seed : int
        Random seed (centres, frequencies, phases, directions).
    scale : float
        Amplitude factor (shrunk automatically if a pose is unreachable).
    lead_in : float
        Initial standstill at home [s] (lets a delayed actuator fill its history).
    """
    for attempt in range(8):
        traj = _build(model, duration, seed, scale * 0.85**attempt, lead_in)
        problem = check_trajectory(model, traj)
        if problem is None:
            return traj
    raise ValueError(f"could not fit an excitation of {model.robot} inside its workspace: {problem}")


def _build(model, duration, seed, scale, lead_in):
    rng = np.random.default_rng(seed)
    prof = profile(model)
    home = model.home()
    nd = len(home)
    cr = np.asarray(prof["centre"]) * scale
    amp = np.asarray(prof["amp"]) * scale
    slow = np.asarray(prof["slow"])
    segs = [{"kind": "hold", "t0": 0.0, "t1": lead_in, "c": home}]
    t, c_prev = lead_in, home
    end = lead_in + duration
    done = False
    while not done:
        c = home + np.asarray(prof["centre_offset"]) + rng.uniform(-1, 1, nd) * cr
        plan = [("move", 0.3), ("hold", 0.25), ("multisine", 1.3), ("sweep", 1.0), ("slow", 0.7)]
        for kind, T in plan:
            if t + T > end + 1e-9:
                done = True  # only whole segments: the pose never jumps
                break
            seg = {"kind": kind, "t0": t, "t1": t + T, "c": c, "ramp": min(0.15, T / 2.5)}
            if kind == "move":
                seg["c0"] = c_prev
            elif kind == "multisine":
                # Whole periods in the burst: the offset returns to zero by itself and the
                # fade-out window only rounds the derivatives.
                seg["f"] = np.tile([1.0 / T, 2.0 / T], (nd, 1))
                seg["ph"] = rng.uniform(0, 2 * np.pi, (nd, 2))
                seg["A"] = amp[:, None] * rng.uniform(0.35, 0.6, (nd, 2))
            elif kind == "sweep":
                d = rng.normal(size=nd)
                seg["dir"] = amp * 0.8 * d / np.abs(d).max()
                seg["period"] = T / rng.choice([1, 2])
                seg["round"] = 0.9
            elif kind == "slow":
                d = rng.choice([-1.0, 1.0], nd) * rng.uniform(0.6, 1.0, nd)
                seg["dir"] = slow * d
                seg["freq"] = 1.0 / T
            segs.append(seg)
            t += T
            if kind == "move":
                c_prev = c
    segs.append({"kind": "hold_end", "t0": t, "t1": t + 1e9, "c": c_prev})
    return Excitation(home, segs, end, name=f"excitation(seed={seed})")


def derived_profile(model) -> dict:
    """The excitation profile of a robot without a table in :data:`PROFILE_FILE`, from the core alone.

    Per pose coordinate, the reach from home: the largest offset (both ways, the smaller one)
    at which the core still reaches the pose inside the joint ranges and away from
    singularities, probed on a doubling then halving search; an angle is probed up to half a
    turn (beyond it the orientation repeats: a planar robot's rotation or a crank that turns
    round would otherwise get amplitudes of many turns).  Centres span 15 % of it,
    bursts 30 %, the slow oscillation 1.5 % (the tuned tables are of that order of their
    robots' reach).
    """
    home = np.asarray(model.home(), float)
    units = model.facts.pose_units
    lo, hi = (np.asarray(v, float) for v in model.joint_limits())

    def fine(x):
        q, st = model.ik(x[None, :], errors="status")
        if st[0] != 0:
            return False
        span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
        if np.any(q[0] < lo + 0.1 * span) or np.any(q[0] > hi - 0.1 * span):
            return False
        return bool(np.all(model.singularity(x[None, :])[0] > 0.1))

    reach = np.empty(len(home))
    for i, u in enumerate(units):
        best = np.inf
        # an angle beyond half a turn is the same orientation again: the search stops there
        limit = np.pi if u == "rad" else 1e3
        for sign in (1.0, -1.0):
            d = 1e-3 if u == "m" else 1e-2
            ok = 0.0
            e = np.eye(len(home))[i]
            while d < limit and fine(home + sign * d * e):
                ok, d = d, 2 * d
            bad = min(d, limit)
            if bad == limit and fine(home + sign * limit * e):
                ok = bad
            for _ in range(20 if ok < bad else 0):
                mid = 0.5 * (ok + bad)
                ok, bad = (mid, bad) if fine(home + sign * mid * np.eye(len(home))[i]) else (ok, mid)
            best = min(best, ok)
        if not best > 0:
            raise InputError(f"{model.robot}: pose coordinate {model.facts.pose_names[i]} cannot move from home "
                             f"without leaving the workspace; no excitation possible")
        reach[i] = best
    return {"centre": 0.15 * reach, "centre_offset": np.zeros(len(home)), "amp": 0.30 * reach,
            "slow": 0.015 * reach}


def check_trajectory(model, traj, step: float = 2e-3):
    """None if every pose of ``traj`` is reachable, inside the joint ranges and away
    from singularities; else the first problem (with its time)."""
    t = np.arange(0.0, traj.duration + step, step)
    x = traj.pose(t)
    q, status = model.ik(x, errors="status")
    bad = np.flatnonzero(status != 0)
    if bad.size:
        return f"pose at t = {t[bad[0]]:.3f} s is unreachable"
    lo, hi = model.joint_limits()  # the core's facts (-inf / inf where a robot has none)
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    span = np.where(np.isfinite(hi - lo), hi - lo, 1.0)
    out = (q < lo + 0.05 * span) | (q > hi - 0.05 * span)
    if np.any(out):
        k = int(np.argmax(np.any(out, axis=1)))
        return f"a joint leaves its range at t = {t[k]:.3f} s"
    sing = model.singularity(x[::10])
    if np.any(sing < 0.02):
        k = int(np.argmax(np.any(sing < 0.02, axis=1)))
        return f"pose near a singularity at t = {t[10 * k]:.3f} s"
    return None
