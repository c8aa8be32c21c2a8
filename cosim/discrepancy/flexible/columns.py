"""The flexible stage's inputs (:mod:`.flexible`): the columns its trees are given and their groups.

At the decimated samples, per joint: its position, rate (the smoothed reading; the commanded
rate and its sign smoothed as the efforts are, where the recording has a reference),
acceleration and the fitted model's effort, the low-passed |rate| and effort
(:data:`TIME_CONSTANTS`), the low-passed dissipated power |effort x rate|
(:data:`POWER_TIME_CONSTANTS`) and that power signed by the direction of motion, the time since
its direction last changed and that time signed by the direction; then the platform pose (the
core's forward kinematics of the smoothed joints, with a tracker's pose recorded or not; without
one, the coordinates that are not one joint's position scaled), and time.  :func:`input_groups`
gathers the columns into the inputs the stage names ("position of slider 3", the pose, time).
"""
from __future__ import annotations

import math

import numpy as np

from .select import POSE

#: time constants of the low-passed histories [s]: |rate| and effort (duty), and the dissipated
#: power |effort x rate| (a first-order thermal model's temperature rise)
TIME_CONSTANTS = (1.0, 4.0)
POWER_TIME_CONSTANTS = (0.5, 2.0, 8.0)
#: the time since a joint's direction last changed (its feature's name): its own contacts' state
SINCE = "time since"


def _lowpass(x, dt, tau, starts):
    """First-order low-pass of the columns of x (sample step dt) with time constant tau,
    restarted at each block start (rows ``starts``, the first among them):
    ``y[i] = a y[i-1] + (1 - a) x[i]``, ``a = exp(-dt / tau)``.

    The recursion runs on Python floats, column by column: the same double-precision products
    and sums as numpy's on each row (IEEE 754 rounds each alike), without a row's array operations
    (``tests/discrepancy/test_flexible_columns.py`` compares it with them, bit for bit)."""
    a = math.exp(-dt / tau)
    x = np.asarray(x)
    flat = x.reshape(len(x), -1)
    y = np.empty(flat.shape, x.dtype)  # written by column, then given x's shape (a reshape of any layout)
    fed = ((1 - a) * flat).T.tolist()  # each row's share of the input, as numpy multiplies it
    for c, (col, share) in enumerate(zip(flat.T.tolist(), fed)):
        out, prev = [], 0.0
        for i, v in enumerate(col):
            prev = v if i in starts else a * prev + share[i]
            out.append(prev)
        y[:, c] = out
    return y.reshape(x.shape)


def blocks(pipe) -> tuple:
    """``(starts, dt)``: the decimated rows where a stretch of motion starts (the histories
    restart there) and the decimated samples' step [s]."""
    idx = pipe.idx
    t = pipe.t[idx]
    starts = {0} | {int(np.searchsorted(idx, a)) for a, _ in pipe.segments[1:]}
    return starts, (float(np.median(np.diff(t))) if len(t) > 1 else pipe.dt)


def inputs(pipe, R, direction=False) -> tuple:
    """The flexible model's inputs at the decimated samples.

    ``R`` is the residual after the fitted model (decimated samples x channels); the effort
    input is the model's, measured minus ``R``; ``direction``: with the smoothed commanded
    direction and the time since each joint's direction last changed (the stage's own inputs;
    :mod:`..keyed.elsewhere` reads the others).  Returns
    ``(X, columns)``: X (n, p) and per column ``(feature, group, joint or None, quantity, unit)``."""
    idx, nd = pipe.idx, pipe.nd
    facts = pipe.model.facts
    noun, qu, eu = facts.joint_noun, facts.joint_unit, facts.effort_unit
    rate_u = f"{qu}/s"
    t = pipe.t[idx]
    starts, dt = blocks(pipe)
    effort = pipe.tau_s[idx, :nd] - np.asarray(R, float)[:, :nd]
    qref = getattr(pipe.rec, "qref", None)
    rate_ref = smoothed = None
    if qref is not None:
        rate_full = np.gradient(np.asarray(qref, float), pipe.dt, axis=0)
        # the commanded direction as the residual sees it: the residual is a smoothed effort, so a
        # force that switches with the direction of motion shows there as the smoothed sign
        rate_ref = rate_full[idx]
        smoothed = pipe.S(np.sign(rate_full))[idx] if direction else None
    cols, X = [], []
    for k in range(nd):
        q, qd, qdd = pipe.q_s[idx, k], pipe.qd_s[idx, k], pipe.qdd_s[idx, k]
        for name, v, quantity, unit in ((f"q{k + 1}", q, "position", qu), (f"qd{k + 1}", qd, "rate", rate_u),
                                        (f"qdd{k + 1}", qdd, "acceleration", f"{qu}/s^2"),
                                        (f"effort{k + 1}", effort[:, k], "effort", eu)):
            X.append(v)
            cols.append((name, f"{quantity} of {noun} {k + 1}", k + 1, quantity, unit))
        if rate_ref is not None:  # the commanded rate: the direction of motion where the smoothed reading lags
            X.append(rate_ref[:, k])
            cols.append((f"qd{k + 1} reference", f"rate of {noun} {k + 1}", k + 1, "rate", rate_u))
        if smoothed is not None:
            X.append(smoothed[:, k])
            cols.append((f"sign(qd{k + 1} reference) smoothed", f"rate of {noun} {k + 1}", k + 1, "rate", ""))
        group = f"history of {noun} {k + 1}"
        X += histories(qd, effort[:, k], dt, starts)
        for tc in TIME_CONSTANTS:
            cols += [(f"|qd{k + 1}| low-passed {tc:g} s", group, k + 1, "history", rate_u),
                     (f"effort{k + 1} low-passed {tc:g} s", group, k + 1, "history", eu)]
        for tc in POWER_TIME_CONSTANTS:
            cols += [(f"|effort{k + 1} qd{k + 1}| low-passed {tc:g} s", group, k + 1, "history", f"{eu} {rate_u}"),
                     (f"sign(qd{k + 1}) |effort{k + 1} qd{k + 1}| low-passed {tc:g} s", group, k + 1,
                      "history x direction", f"{eu} {rate_u}")]
        if direction:  # a friction state a reversal resets (a seal's lip, stiction): the time since it
            since, held = _since_reversal(qd, t, starts, 0.05) if rate_ref is None \
                else _since_reversal(rate_ref[:, k], t, starts)
            X.append(since)
            cols.append((f"{SINCE} qd{k + 1} reversed", group, k + 1, "history", "s"))
            # signed by the direction of motion: a friction a reversal's state sets is sign(qd) f(s), a
            # function of this one column that trees on (rate, s) learn from the product's corners only
            X.append(held * since)
            cols.append((f"{SINCE} qd{k + 1} reversed x sign(qd{k + 1})", group, k + 1, "history x direction", "s"))
    # the core's forward kinematics of the smoothed joints, tracker or not (a pipeline kept by a
    # bench's capture without a tracker's pose may hold none)
    x_s = getattr(pipe, "x_s", None)
    x = np.zeros((len(idx), 0)) if x_s is None else np.asarray(x_s)[idx]
    for i in range(x.shape[1]):
        if np.std(x[:, i]) > 0 and (pipe.has_pose or not _joint_copy(x[:, i], pipe.q_s[idx])):
            X.append(x[:, i])
            cols.append((f"pose[{i}]", POSE, None, "pose", ""))
    X.append(t)
    cols.append(("t", "time", None, "time", "s"))
    return np.column_stack(X), cols


def _joint_copy(x, q) -> bool:
    """Whether the pose coordinate ``x`` is one joint's position ``q[:, k]`` scaled and shifted
    (a rig whose pose is its joint: the column would name the joint twice)."""
    for k in range(q.shape[1]):
        if np.std(q[:, k]) > 0 and abs(np.corrcoef(x, q[:, k])[0, 1]) > 1.0 - 1e-9:
            return True
    return False


def histories(qd, effort, dt, starts) -> list:
    """A joint's low-passed histories (restarted at the rows ``starts``; sample step ``dt`` [s])
    from its rate ``qd`` and effort ``effort``, in the order of :func:`inputs`' columns: per
    :data:`TIME_CONSTANTS` |qd| and the effort, per :data:`POWER_TIME_CONSTANTS` the power
    |effort x qd| and that power signed by the direction of motion."""
    out = []
    for tc in TIME_CONSTANTS:
        hist = _lowpass(np.column_stack([np.abs(qd), effort]), dt, tc, starts)
        out += [hist[:, 0], hist[:, 1]]
    for tc in POWER_TIME_CONSTANTS:
        power = _lowpass(np.abs(effort * qd)[:, None], dt, tc, starts)[:, 0]
        out += [power, np.sign(qd) * power]
    return out


def _since_reversal(rate, t, starts, dead=0.0) -> tuple:
    """The time [s] since ``rate`` last changed sign, from each block's start (``starts``, rows),
    and the sign held (+-1, 0 before the first motion): within ``dead`` times its RMS of zero it
    keeps the last sign (noise about a standstill)."""
    out, held = np.zeros(len(rate)), np.zeros(len(rate))
    last, sign = t[0], 0.0
    for i, v in enumerate(np.where(np.abs(rate) > dead * np.sqrt(np.mean(rate ** 2)), np.sign(rate), 0.0)):
        if i in starts:
            last, sign = t[i], v
        elif v and v != sign:
            if sign:
                last = t[i]
            sign = v
        out[i], held[i] = t[i] - last, sign
    return out, held


def input_groups(columns) -> dict:
    """The inputs' groups: per group name, its columns (indices).  A column of a history signed
    by the direction of motion belongs to the joint's history and to its rate: a friction
    level that a slow state modulates is their product, which neither explains alone (greedy
    trees do not find a split in either), and permuting or leaving out either input removes it."""
    groups = {}
    for i, col in enumerate(columns):
        groups.setdefault(col[1], []).append(i)
        if col[3] == "history x direction":
            groups.setdefault(col[1].replace("history of", "rate of", 1), []).append(i)
    return groups
