"""Mechanisms no issue and no family names, hidden in MuJoCo's 6-PUS, diagnosed with the defaults.

    .venv/bin/python bench/foreign/mujoco_unlisted.py [--kinds tendon_slack,...] [--clean 4] [--jobs 1]
        [--kinds-set 1|2|3|4] [--second | --first-seed 32700] [--sets 1] [--scale 1] [--out results/mujoco_unlisted]

``--scale 0.01,0.03,0.1,0.3`` runs every rail kind with its force multiplied by each factor (the
same draws: rail, band, time constant), the detection limit to beyond ten times it; the sweep table
then counts per kind and scale the library effects named with confidence, tied, structure left,
"no missing physics found", and the confidence rule's statistics (docs/records/discovery_unnamed_runs.md, "The rail
kinds from the detection limit to 10 times it").

``--kinds-set 2`` runs a second set of mechanisms, none of them a kind below
(bench/foreign/mujoco_unlisted_more.py: a cable carrier between two carriages, a spring that
softens as its motor heats, detents at irregular positions, a mass on a spring in the platform, a
bellows' friction keyed on the platform's height, a magnet's preload keyed on the gap to a
neighbouring carriage, a drag on the platform's angular velocity, a pump's pulses, a snubber
that locks above an acceleration, a drive's saturation), seeds ``SEED_MORE`` + (50700 +).
``--kinds-set 3`` runs a third set, none of them a kind of the first two
(bench/foreign/mujoco_unlisted_third.py: a linear motor's thrust ripple, a viscoelastic vacuum
hose on the platform, a rail wiper collecting debris, a payload loose in a tray, a damper between
two carriages, a drive's back-EMF limit, a brake dragging over a window of time, a leg's elastic
flexure joint, a shared DC bus sagging under a neighbour's current, a grease thinning as it
warms), seeds ``SEED_THIRD`` + (53700 +).  ``--kinds-set 4`` runs a fourth set, none of them a
kind of the first three, of the engine's generators, of the discovery families or of the library
(bench/foreign/mujoco_unlisted_fourth.py: a pneumatic cushion at a stroke's end, an eddy-current
plate under the platform, a screw nut misaligned over the stroke, an air jet's lift on the
platform's tilt, the stray field of a neighbouring motor's coil, a coiled cord from a carriage to
the platform, a motor's magnets weakening as its copper heats, a cable bundle's torsion with its
wires' friction, a guide heated by a neighbouring motor, a floor shaken by a press), seeds
``SEED_FOURTH`` + (57700 +).  The code the sets share (helpers of the draws, the
judgement, the tables) is bench/foreign/unlisted_common.py.

``--capture DIR`` keeps, per case, what the flexible stage was given (bench/flexible_bench.py's
capture); ``--replay DIR`` re-runs only the stage on it (its ``refit``: the diagnosis's calls) and
judges it against the declarations as they are now; the CPU column is then the stage's.  A set
re-runs in 1-2 minutes instead of 10-15.

A measurement, not a tuning set: the engine has no library effect,
no term family and no platform force for any of these, so the honest answer is the structure
and what it is keyed on (the flexible stage, cosim.discrepancy.flexible), and no library effect
named with confidence.  The MuJoCo set-up is bench/foreign/mujoco_blind.py's (the hand-written
6-PUS, PD + gravity at 1 kHz, MuJoCo's implicitfast integrator at 0.1 ms, the engine's exciting
trajectory, the generator's sensor noise, 9 s run of which 8.5 s recorded); each case changes
MuJoCo's model (``edit``: a body, a tendon, a contact or a joint property) or adds a force in
MuJoCo's step computed from MuJoCo's own state (``hook``).  The mechanisms:

* ``tendon_slack``: an elastic tendon from a fixed anchor to the platform that pulls only when
  taut (MuJoCo spatial tendon with a length limit, soft limit of given stiffness);
* ``magnet``: a magnet pulling the platform's reference point towards a point near its path,
  F0 / (1 + (d/r)^2)^2 (``xfrc_applied``);
* ``soft_stop``: the platform meets a soft pad on one side (a sphere on the platform against a
  plane, MuJoCo's own frictionless contact with solref stiffness and damping);
* ``gyro_spindle``: a spindle spinning on the platform (angular momentum H along the platform's
  z axis): the moment H x omega on the platform (``xfrc_applied``);
* ``slosh``: a pendulum (a sloshing liquid's usual model) hung in the platform, damped ball
  joint, whose mass is taken off the platform's (the same mass and centre of mass at rest);
* ``fan_unbalance``: an eccentric mass on a fan rotor on the platform, spinning at constant
  speed: a force m e w^2 turning in the platform's xy plane (``xfrc_applied``);
* ``ball_joint_friction``: a dry friction in the passive spherical joint of one leg, a moment on
  the ball's three dofs (:func:`ball_friction`, ``qfrc_applied``).  MuJoCo's own ``frictionloss``
  there barely acts (under 0.1 mN at the rails, as at 100 times the loss: its soft constraint's
  regulariser follows the dofs' inverse inertia, which the thin leg's spin sets; the recorded
  runs at seeds up to 70706 used it: docs/discrepancy.md, "On Drake");
* ``rate_coupled_friction``: a Coulomb friction on rail j in proportion to the speed of rail k,
  c |qd_k| / V_k tanh(qd_j / v) (a shared bearing warmed by its neighbour's belt);
* ``reversal_seal``: a seal whose friction grows with the time since rail j last reversed,
  c (1 - exp(-s / tau)) tanh(qd_j / v);
* ``eddy_brake_zone``: a damping c qd_j only over a band of rail j's stroke (a conducting plate
  under part of the rail: an eddy-current brake), smooth edges;
* ``cross_effort_friction``: a Coulomb friction on rail j in proportion to the force of rail k's
  motor, mu |u_k| tanh(qd_j / v) (a bearing block preloaded by the neighbouring drive).

The inputs the flexible stage should name were fixed with the mechanisms, before any run
(:func:`keyed`; after set 6 the physics of three was read again, the reasons written there: the
pendulum is driven by the platform's pose as by its acceleration, and the tendon's and the pad's
soft constraints are damped, so the rates may be named beside their positions): per case the groups that must be named (all of ``need``, or one of ``any``) and
those that may be (``allowed``); a platform mechanism is judged over every channel the stage
explains, a rail's on that rail's channel.  The seeds (``SEED`` + the kind's index, clean cases
``SEED`` + 90 +) were fixed before any output was seen (``--second``, the same + 1000, after the
first set's output, before its own; ``--first-seed 32700``, the same kinds drawn at other seeds,
a third set run once as a report set after the spectral-line rule of the structure test was
fixed; ``--first-seed 33700``, a fourth, run once after the keyed-elsewhere rule of the
confidence, :mod:`cosim.discrepancy.keyed.elsewhere`, was fixed on the first three); the magnitudes are physical guesses at
10-30 % of the rails' RMS efforts (0.4-0.9 N), not adjusted to the engine.

Per case: what is named with confidence (library effects without a declared tie, discovered
terms not flagged partial, a platform force and drifts where no structure is left: beside
structure left the conclusion says they "may stand in"), whether a library effect is named with
confidence (a failure: the truth is outside the library), the flexible stage's channels,
inputs and held-out share and whether the inputs are the keyed-on ones, the held-out gain, the
nominal residual's RMS over the noise on the most affected channel (the mechanism's size as the
engine sees it), and the diagnosis's CPU time; and a second judgement, the declared inputs against
what either stage models (the flexible stage's inputs with the groups the discovery's terms, a
platform force and drifts read: :func:`unlisted_common.judge_either`, docs/flexible.md, "Modelled
by either stage"), with the discovery's confident terms and with its partial ones too.
"""
from __future__ import annotations

import argparse
import json
import math
import pickle
import sys
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

from mujoco_unlisted_more import KINDS_MORE, SEED_MORE, draw_more, keyed_more  # noqa: E402
from mujoco_unlisted_fourth import KINDS_FOURTH, SEED_FOURTH, draw_fourth, keyed_fourth  # noqa: E402
from mujoco_unlisted_third import KINDS_THIRD, SEED_THIRD, draw_third, keyed_third  # noqa: E402
from unlisted_common import RuleLog as _RuleLog  # noqa: E402
from unlisted_common import judge, judge_either, slider_groups, stage_reads, sweep_table, table, two_rails  # noqa: E402
from unlisted_common import unit_direction as _dir  # noqa: E402

#: the damping [N s/m] of the tendon's soft length limit and of the pad's soft contact (the
#: second number of MuJoCo's ``solreflimit`` / ``solref`` "-k -b": a direct damping)
TENDON_DAMPING, PAD_DAMPING = 2.0, 3.0
KINDS = ("tendon_slack", "magnet", "soft_stop", "gyro_spindle", "slosh", "fan_unbalance", "ball_joint_friction",
         "rate_coupled_friction", "reversal_seal", "eddy_brake_zone", "cross_effort_friction", "coulomb_zone",
         "reversal_stiction")
PLATFORM = KINDS[:7]
#: the kind sets of ``--kinds-set``: 1 the kinds above, 2 bench/foreign/mujoco_unlisted_more.py's,
#: 3 bench/foreign/mujoco_unlisted_third.py's, 4 bench/foreign/mujoco_unlisted_fourth.py's
KIND_SETS = {1: KINDS, 2: KINDS_MORE, 3: KINDS_THIRD, 4: KINDS_FOURTH}
ALL_KINDS = KINDS + KINDS_MORE + KINDS_THIRD + KINDS_FOURTH
#: seeds: SEED + the kind's index, clean cases SEED + 90 + i (fixed before any run); ``--second``
#: draws every case again at SEED + 1000 + (the same): added after the first set's output was seen
#: (and after the platform-drag sign rule), before any of its own
SEED = 30700
V_FRICTION = 3e-4  # velocity scale of the smooth sign [m/s]
#: the angular rate [rad/s] of the smooth sign of a ball joint's dry friction (:func:`ball_friction`:
#: the legs swing at about 1 rad/s; at the 0.1 ms step, a leg's 1.1e-4 kg m^2 about its joint and
#: the largest friction drawn, 6 mN m, the explicit force's slope stays at 0.55 of the stable bound)
W_BALL = 0.01
DURATION, LEAD = 9.0, 0.5


def keyed(kind, j=None, k=None) -> dict:
    """The inputs (flexible-stage groups) a mechanism is keyed on: ``need`` (all named),
    ``any`` (one of them named), ``allowed`` (nothing else named)."""
    if kind in KINDS_MORE:
        return keyed_more(kind, j, k)
    if kind in KINDS_THIRD:
        return keyed_third(kind, j, k)
    if kind in KINDS_FOURTH:
        return keyed_fourth(kind, j, k)
    pos, rate, acc, pose = slider_groups()
    if kind == "magnet":
        return {"need": set(), "any": pos | pose, "allowed": pos | pose}
    if kind in ("tendon_slack", "soft_stop"):
        # MuJoCo's soft limit and soft contact (solref -k -b) push with a stiffness on the stretch or
        # the penetration and a damping b on its rate: the platform's velocity, the rails' rates
        return {"need": set(), "any": pos | pose, "allowed": pos | pose | rate}
    if kind in ("gyro_spindle", "ball_joint_friction"):
        return {"need": set(), "any": rate, "allowed": rate | pos | pose}
    if kind == "slosh":
        # the bob hangs from a pivot L above the platform's reference point, its restoring moment
        # set by the world's vertical, not the platform's: tilted by theta, the platform carries the
        # bob's weight L sin(theta) off the point where the model's rigid mass sits (a moment about
        # mb g L theta, keyed on the pose, which the rails' positions set), and below its own
        # frequency the bob lines up with the effective gravity g - a (a shift of about L a / g):
        # the pose drives it as an acceleration does; the bob is a second-order body the platform's
        # acceleration drives through its resonance (the platform's motion, a group added to the stage
        # after this declaration: this body is what that input is for)
        motion = {"the platform's motion"}
        return {"need": set(), "any": acc | pos | pose | motion, "allowed": acc | rate | pos | pose | motion}
    if kind == "fan_unbalance":
        return {"need": {"time"}, "any": set(), "allowed": {"time"} | pos | pose}
    own = lambda q: f"{q} of slider {j}"  # noqa: E731
    other = lambda q: f"{q} of slider {k}"  # noqa: E731
    if kind == "rate_coupled_friction":
        need = {own("rate"), other("rate")}
        return {"need": need, "any": set(), "allowed": need | {own("history"), other("history")}}
    if kind == "cross_effort_friction":
        need = {own("rate"), other("effort")}
        return {"need": need, "any": set(), "allowed": need | {own("history"), other("history")}}
    if kind in ("reversal_seal", "reversal_stiction"):
        return {"need": {own("rate")}, "any": set(), "allowed": {own(q) for q in ("rate", "history", "acceleration")}}
    if kind in ("eddy_brake_zone", "coulomb_zone"):
        need = {own("position"), own("rate")}
        return {"need": need, "any": set(), "allowed": need | {own("history")}}
    raise ValueError(kind)


def _platform_mechanism(kind, rng, m, mo):
    """(hook, edit, truth) of a mechanism acting on the platform."""
    p = m.params()
    M = p["platform.m"]
    xp = mo["xp"]  # the reference's platform positions (rows x 3) [m]
    if kind == "tendon_slack":
        anchor = np.asarray(m.home()[:3]) + _dir(rng) * float(rng.uniform(0.2, 0.4))
        dist = np.linalg.norm(xp - anchor, axis=1)
        length = float(np.quantile(dist, rng.uniform(0.6, 0.8)))  # taut over the last 20-40 % of its stretch
        k = float(rng.uniform(80.0, 160.0))

        def edit(xml):
            site = f'<site name="anchor" pos="{anchor[0]:.9g} {anchor[1]:.9g} {anchor[2]:.9g}"/>'
            xml = xml.replace("<worldbody>", f"<worldbody>\n    {site}", 1)
            xml = xml.replace("<freejoint/>", '<freejoint/>\n      <site name="tie" pos="0 0 0"/>', 1)
            return xml.replace("</equality>", f'''</equality>
  <tendon>
    <spatial name="cord" limited="true" range="0 {length:.9g}" solreflimit="{-k:.9g} {-TENDON_DAMPING:g}">
      <site site="anchor"/><site site="tie"/>
    </spatial>
  </tendon>''', 1)
        return None, edit, {"anchor": anchor.tolist(), "slack_length": length, "stiffness": k}
    if kind == "magnet":
        pick = xp[int(rng.integers(len(xp)))]
        centre = pick + _dir(rng) * float(rng.uniform(0.003, 0.008))
        r, f0 = float(rng.uniform(0.006, 0.012)), float(rng.uniform(0.5, 1.0))

        def hook(model, data, t, q, qd, u):
            b = model.body("platform").id
            d = centre - data.xpos[b]
            n = float(np.linalg.norm(d))
            data.xfrc_applied[b, :3] = f0 / (1.0 + (n / r) ** 2) ** 2 * d / max(n, 1e-12)
            data.xfrc_applied[b, 3:] = 0.0
        return hook, None, {"centre": centre.tolist(), "radius": r, "peak_force": f0}
    if kind == "soft_stop":
        axis = int(rng.integers(3))
        sign = float(rng.choice([-1.0, 1.0]))
        s = sign * xp[:, axis]
        at = float(np.quantile(s, rng.uniform(0.8, 0.9)))  # the pad is reached over the last 10-20 %
        radius, k = 0.002, float(rng.uniform(150.0, 300.0))
        e = np.zeros(3)
        e[axis] = sign
        plane = e * (at + radius)  # the plane's point on the axis; its normal -e faces the platform

        def edit(xml):
            xml = xml.replace("<freejoint/>", f'<freejoint/>\n      <geom name="bumper" type="sphere" size="{radius}" '
                                              'contype="1" conaffinity="1" condim="1"/>', 1)
            pos = np.asarray(m.home()[:3]) * (1 - np.abs(e)) + plane
            return xml.replace("<worldbody>", f'<worldbody>\n    <geom name="pad" type="plane" size="0.2 0.2 0.01" '
                                              f'pos="{pos[0]:.9g} {pos[1]:.9g} {pos[2]:.9g}" zaxis="{-e[0]:g} '
                                              f'{-e[1]:g} {-e[2]:g}" contype="1" conaffinity="1" condim="1" '
                                              f'solref="{-k:.9g} {-PAD_DAMPING:g}"/>', 1)
        return None, edit, {"axis": "xyz"[axis], "side": sign, "at": at, "stiffness": k}
    if kind == "gyro_spindle":
        h = float(rng.uniform(0.02, 0.04))  # angular momentum [N m s]

        def hook(model, data, t, q, qd, u):
            b = model.body("platform").id
            R = data.xmat[b].reshape(3, 3)
            adr = model.jnt_dofadr[model.body_jntadr[b]]
            w = R @ data.qvel[adr + 3:adr + 6]  # the free joint's angular rate is in the body frame
            data.xfrc_applied[b, :3] = 0.0
            data.xfrc_applied[b, 3:] = np.cross(h * R[:, 2], w)
        return hook, None, {"angular_momentum": h}
    if kind == "slosh":
        mb = float(rng.uniform(0.2, 0.3)) * M
        L = float(rng.uniform(0.03, 0.06))
        zeta = float(rng.uniform(0.05, 0.2))
        c = 2 * zeta * mb * L * L * math.sqrt(9.81 / L)

        def edit(xml):
            head = '<inertial pos="0 0 0" mass='
            xml = xml.replace(f'{head}"{M:.17g}"', f'{head}"{M - mb:.17g}"', 1)
            return xml.replace("<freejoint/>", f'''<freejoint/>
      <body name="bob" pos="0 0 {L:.9g}"><joint name="slosh" type="ball" damping="{c:.9g}"/>
        <inertial pos="0 0 {-L:.9g}" mass="{mb:.9g}" diaginertia="1e-9 1e-9 1e-9"/></body>''', 1)
        return None, edit, {"mass": mb, "length": L, "damping_ratio": zeta, "damping": c}
    if kind == "fan_unbalance":
        amp, f = float(rng.uniform(0.3, 0.6)), float(rng.uniform(3.0, 7.0))
        phase = float(rng.uniform(0, 2 * math.pi))

        def hook(model, data, t, q, qd, u):
            b = model.body("platform").id
            R = data.xmat[b].reshape(3, 3)
            a = 2 * math.pi * f * t + phase
            data.xfrc_applied[b, :3] = amp * (R[:, 0] * math.cos(a) + R[:, 1] * math.sin(a))
            data.xfrc_applied[b, 3:] = 0.0
        return hook, None, {"force": amp, "frequency": f}
    if kind == "ball_joint_friction":
        leg = int(rng.integers(6))
        loss = float(rng.uniform(0.003, 0.006))
        along = leg_axis(m, leg)
        dofs = []

        def hook(model, data, t, q, qd, u):
            if not dofs:
                dofs.append(model.joint(f"u{leg}").dofadr[0])
            d = dofs[0]
            data.qfrc_applied[d:d + 3] = ball_friction(data.qvel[d:d + 3], loss, along)
        return hook, None, {"leg": leg + 1, "frictionloss": loss}
    raise ValueError(kind)


def leg_axis(m, leg) -> np.ndarray:
    """The unit vector from leg ``leg``'s (0-based) carriage joint to its platform joint at home
    (the leg's frame is the world's there, on MuJoCo as on Drake)."""
    P, S = m.leg_points(m.home())
    a = np.asarray(P[leg], float) - np.asarray(S[leg], float)
    return a / np.linalg.norm(a)


def across_leg(tau, along) -> np.ndarray:
    """The moment ``tau`` less its part along the leg (``along``, a unit vector in the same
    frame): a leg's spin about its own axis moves nothing else in the robot, and on a thin rod's
    axial inertia (the 1 mm capsule's 1.3e-8 kg m^2) an explicit moment about it would be unstable."""
    along = np.asarray(along, float)
    return tau - float(tau @ along) * along


def ball_friction(w, loss, along) -> np.ndarray:
    """The dry friction moment [N m] of a ball joint, -``loss`` tanh(w_i / :data:`W_BALL`) on each
    of its rotations (``w``: the child's angular rate relative to its parent in the child's frame
    [rad/s], MuJoCo's ball dofs), across the leg (:func:`across_leg`; ``along`` in the same frame)."""
    return across_leg(-loss * np.tanh(np.asarray(w, float) / W_BALL), along)


def _stroke_band(rng, mo, j):
    """A band of rail j's stroke drawn between its 10th and 90th percentiles (at least 30 % of that
    span, smooth edges of 5 %): ``(band(q) in 0..1, from, to)``."""
    lo, hi = sorted(rng.uniform(mo["q10"][j], mo["q90"][j], 2))
    hi = max(hi, lo + 0.3 * (mo["q90"][j] - mo["q10"][j]))
    w = 0.05 * (mo["q90"][j] - mo["q10"][j])
    return (lambda x: 0.5 * (math.tanh((x - lo) / w) - math.tanh((x - hi) / w))), lo, hi


def _since_reversal(j):
    """``since(t, qd)``: the time [s] since rail j last reversed (its speed beyond twice the smooth
    sign's scale with the other sign), kept across MuJoCo's steps."""
    state = {"sign": 0.0, "since": 0.0}

    def since(t, qd):
        s = math.copysign(1.0, qd[j]) if abs(qd[j]) > 2 * V_FRICTION else state["sign"]
        if s != state["sign"]:
            state["sign"], state["since"] = s, t
        return t - state["since"]
    return since


def _rail_mechanism(kind, rng, mo, scale=1.0):
    """(hook, truth, j, k) of a force on one rail (0-based j; k the other rail or None); ``scale``
    multiplies the force's magnitude (its levels, not its shape: the same draws at every scale)."""
    n = len(mo["E"])
    j, k = two_rails(rng, n)
    size = scale * float(rng.uniform(0.1, 0.2))
    E, V = mo["E"], mo["V"]
    if kind == "rate_coupled_friction":
        c = 1.5 * size * E[j]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -c * abs(qd[k]) / V[k] * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {"level": c}, j, k
    if kind == "cross_effort_friction":
        mu = 1.5 * size * E[j] / mo["absu"][k]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -mu * abs(u[k]) * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {"mu": mu}, j, k
    if kind == "reversal_seal":
        c, tau = 2.0 * size * E[j], float(rng.uniform(0.2, 0.5))
        since = _since_reversal(j)

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -c * (1.0 - math.exp(-since(t, qd) / tau)) * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {"level": c, "tau": tau}, j, None
    if kind == "eddy_brake_zone":
        band, lo, hi = _stroke_band(rng, mo, j)
        c = 2.0 * size * E[j] / V[j]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -c * qd[j] * band(q[j])
            return f
        return hook, {"damping": c, "from": lo, "to": hi}, j, None
    if kind == "coulomb_zone":
        band, lo, hi = _stroke_band(rng, mo, j)
        c0, c1 = size * E[j], 1.5 * size * E[j]

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -(c0 + c1 * band(q[j])) * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {"level": c0, "rise": c1, "from": lo, "to": hi}, j, None
    if kind == "reversal_stiction":
        c0, c1, tau = size * E[j], 1.5 * size * E[j], float(rng.uniform(0.1, 0.3))
        since = _since_reversal(j)

        def hook(model, data, t, q, qd, u):
            f = np.zeros(n)
            f[j] = -(c0 + c1 * math.exp(-since(t, qd) / tau)) * math.tanh(qd[j] / V_FRICTION)
            return f
        return hook, {"level": c0, "peak": c1, "tau": tau}, j, None
    raise ValueError(kind)


def draw(kind, rng, m, mo, scale=1.0):
    """(hook, edit, truth, keyed-on inputs, joint of the force or None) of one case; ``scale``
    multiplies a rail mechanism's force (a platform mechanism's must be 1); a second-set kind's
    joint is a tuple of two rails when its force acts on both."""
    later = {**dict.fromkeys(KINDS_MORE, draw_more), **dict.fromkeys(KINDS_THIRD, draw_third),
             **dict.fromkeys(KINDS_FOURTH, draw_fourth)}
    if kind in later:
        if scale != 1.0:
            raise ValueError(f"--scale applies to the first set's rail kinds only, not to {kind}")
        return later[kind](kind, rng, m, mo)
    if kind in PLATFORM:
        if scale != 1.0:
            raise ValueError(f"--scale applies to the rail kinds only, not to {kind}")
        hook, edit, truth = _platform_mechanism(kind, rng, m, mo)
        return hook, edit, truth, keyed(kind), None
    hook, truth, j, k = _rail_mechanism(kind, rng, mo, scale)
    truth.update(rail=j + 1, **({"other_rail": k + 1} if k is not None else {}))
    return hook, None, truth, keyed(kind, j + 1, None if k is None else k + 1), j + 1


def motion(m, seed):
    """The discovery bench's per-rail motion figures, the mean |feed-forward effort| per rail
    and the reference's platform positions."""
    from discovery_mujoco_bench import motion as mo
    from mujoco_blind import DT

    from cosim.discrepancy.excitation import excitation
    from cosim.master import make_reference

    out = mo(m, seed, DURATION)
    traj = excitation(m, DURATION, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    k0 = int(round(LEAD / DT))
    u = np.asarray(m.inverse_dynamics(ref.x[k0:], ref.xd[k0:], ref.xdd[k0:]))
    out["absu"] = np.mean(np.abs(u), axis=0)
    out["xp"] = np.asarray(ref.x[k0:, :3])
    # the second set's draws: the efforts, the pose, the rails' positions and accelerations
    out.update(u=u, xr=np.asarray(ref.x[k0:]), qref=np.asarray(ref.q[k0:]), qddref=np.asarray(ref.qdd[k0:]))
    return out


def case_name(kind, seed, scale=1.0) -> str:
    """The case's key: ``kind_seed``, with ``_x<scale>`` when the force is scaled."""
    return f"{kind}_{seed}" + ("" if scale == 1.0 else f"_x{scale:g}")


def _mujoco(m, seed, noise, hook, edit):
    """The case's recording on MuJoCo (bench/foreign/mujoco_blind.py's :func:`simulate`)."""
    import mujoco_blind as mb

    return mb.simulate(m, None, 0.0, 0, seed, DURATION, noise, hook=hook, edit=edit)[0]


def _run(job):
    return run_case(job, _mujoco)


def run_case(job, simulate, drawn=None) -> dict:
    """The judged row of one case ``job`` (kind, seed, out, scale, capture, recordings: as
    :func:`jobs` makes them): the mechanism drawn (``drawn``, :func:`draw`'s signature; default
    :func:`draw`), its recording made by ``simulate(m, seed, noise, hook, edit)`` (a
    :class:`cosim.recording.Recording` of ``DURATION`` s after ``LEAD``) and written, then
    diagnosed with the defaults."""
    import mujoco_blind as mb

    from cosim.core import Model
    from cosim.discrepancy import blind, diagnose

    kind, seed, out, scale, capture, recordings = job
    m = Model("6pus")
    hook = edit = joint = None
    truth, key = {}, None
    if kind != "clean":
        hook, edit, truth, key, joint = (drawn or draw)(kind, np.random.default_rng(seed), m, motion(m, seed), scale)
    noise = blind.load_config()["noise"]["6pus"]
    name = case_name(kind, seed, scale)
    csv = Path(recordings or out) / f"{name}.csv"
    if recordings is None or not csv.exists():  # else the recording a run with this seed wrote (--recordings)
        csv = mb.write_case(m, simulate(m, seed, noise, hook, edit), Path(out) / f"{name}.csv")
    t0 = time.process_time()
    with _RuleLog() as rule:  # the rule's statistics, for the record (computed on tied effects too)
        # the defaults: families, platform, drift, flexible on; the stage's inputs kept for --replay
        d, kept = _captured(lambda: diagnose(csv, figures=False, replay=False))
    cpu = time.process_time() - t0
    row = diagnosed_row(d, kind, seed, scale, truth, joint, noise["tau"], cpu, rule)
    _judged(row, d.flexible, key)
    if capture is not None:
        Path(capture).mkdir(parents=True, exist_ok=True)
        with open(Path(capture) / f"{name}.pkl", "wb") as fh:
            pickle.dump({"row": row, "kept": kept, "key": key}, fh)
    return row


def diagnosed_row(d, kind, seed, scale, truth, joint, tau_noise, cpu, rule) -> dict:
    """The row of a case from its diagnosis ``d``: what is named (with confidence, tied, the
    flexible stage's channels), the mechanism's size over the effort noise ``tau_noise`` [N] on
    its most affected channel, ``cpu`` [s] and the confidence rule's statistics ``rule``
    (:class:`unlisted_common.RuleLog`); the judgement against the declaration is :func:`_judged`'s."""
    from cosim.discrepancy.diagnosis import tied

    library = [e["key"] + (f"[{e['joint']}]" if e["joint"] else "") for e in d.effects
               if not any(tied(a) for a in e["lookalikes"])]
    ties = {e["key"] + (f"[{e['joint']}]" if e["joint"] else ""): [a["group"] for a in e["lookalikes"] if tied(a)]
            for e in d.effects if any(tied(a) for a in e["lookalikes"])}
    terms = [("(partial) " if t.partial else "") + t.equation for t in d.discovered if not t.repeats_its_pair]
    before = np.asarray(d.residual["before"])[:, :6]
    size = np.sqrt(np.mean((before - before.mean(axis=0)) ** 2, axis=0)) / tau_noise
    row = {"case": case_name(kind, seed, scale), "kind": kind, "seed": seed, "scale": scale, "cpu": cpu, "truth": truth, "joint": joint,
           "library_confident": library, "library_tied": ties, "library_all": d.named(), "discovered": terms,
           "platform": d.platform_force.equation if d.platform_force else "",
           "drifts": [f"{x.param} {x.kind}" for x in d.drifts],
           "unexplained": [f"{e['channel']} {e['signature']}" for e in d.unexplained],
           "periodic": [f"{e['channel']}: {e['keyed_on']}" for e in d.unexplained if e["signature"] == "periodic"],
           "flexible": [(f.channel, round(f.share, 3), list(f.named)) for f in d.flexible if f.explained],
           "gain": d.heldout.get("gain"), "size_over_noise": float(size.max()),
           "size_channel": int(np.argmax(size)) + 1, "conclusion": d.conclusion, "rule": rule.rows,
           "power": rule.power, "leaning": rule.leaning}
    row["found_before_flexible"] = bool(d.effects or d.discovered or d.unexplained or d.platform_force or d.drifts)
    row["stage_reads"] = stage_reads(d)  # for judge_either
    return row


def _captured(run):
    """``run()`` (a diagnosis) with the flexible stage's inputs kept (bench/flexible_bench.py's)."""
    from flexible_bench import _captured as captured

    return captured(run)


def _judged(row, fits, key):
    """``row`` with the flexible stage's ``fits`` and their judgement against ``key`` (clean: no
    claim and nothing found before the stage)."""
    row["flexible"] = [(f.channel, round(f.share, 3), list(f.named)) for f in fits if f.explained]
    if row["kind"] == "clean":
        row["clean"] = not (row["found_before_flexible"] or row["flexible"])
    else:
        row["inputs_right"], row["share"], row["named"] = judge(fits, key, row["joint"])
        if "stage_reads" in row:  # a run's whole diagnosis (a capture made before it was kept has none)
            row["either_right"] = {v: judge_either(fits, reads, key, row["joint"])
                                   for v, reads in row["stage_reads"].items()}
        row["keyed_on"] = {k: sorted(v) for k, v in key.items()}
    return row


def _replayed(job):
    """The row of a case captured by ``--capture`` with only the flexible stage re-run on its kept
    inputs (bench/flexible_bench.py's :func:`refit`); ``key`` re-read from :func:`keyed` (the
    declaration as it is now), ``cpu`` the stage's alone."""
    from flexible_bench import refit

    kind, seed, _, scale, capture = job[:5]
    with open(Path(capture) / f"{case_name(kind, seed, scale)}.pkl", "rb") as fh:
        got = pickle.load(fh)
    row = dict(got["row"])
    key = None
    if kind != "clean":
        truth = row["truth"]
        key = keyed(kind, truth.get("rail"), truth.get("other_rail"))
    fits, row["cpu"] = refit(got["kept"])
    return _judged(row, fits, key)


def kinds_of(ap, text, kinds_set) -> tuple:
    """(kinds, their set) of ``--kinds`` ``text`` (comma-separated; None: ``kinds_set``'s), or
    ``ap``'s error: a kind no set holds, or kinds of several sets (their seeds count from
    different first seeds)."""
    kinds = [k for k in text.split(",") if k] if text is not None else list(KIND_SETS[kinds_set])
    bad = [k for k in kinds if k not in ALL_KINDS]
    if bad:
        ap.error(f"unknown kind(s) {', '.join(bad)}; known: {', '.join(ALL_KINDS)}")
    sets = sorted({n for n, ks in KIND_SETS.items() for k in kinds if k in ks})
    if len(sets) > 1:
        ap.error("--kinds: kinds of one set at a time (their seeds count from different first seeds)")
    return kinds, sets[0] if sets else kinds_set


def jobs(kinds, kinds_set, base, clean, out, scales=(1.0,), capture=None, recordings=None) -> list:
    """The cases of one seed set: each of ``kinds`` at ``base`` + its index in ``kinds_set``'s
    order, at each of ``scales``, then ``clean`` clean ones at ``base`` + 90 +; each a job
    (kind, seed, out, scale, capture, recordings) of :func:`run_case`."""
    order = KIND_SETS[kinds_set]
    return ([(k, base + order.index(k), str(out), x, capture, recordings) for x in scales for k in kinds]
            + [("clean", base + 90 + i, str(out), 1.0, capture, recordings) for i in range(clean)])


def run_jobs(run, todo, n_jobs, out) -> list:
    """The rows of ``run`` over the jobs ``todo`` on ``n_jobs`` processes, each printed as it
    comes, all written to ``out``/rows.json, then the table (:func:`unlisted_common.table`)."""
    rows = []
    with Pool(n_jobs) as pool:
        for row in pool.imap_unordered(run, todo):
            rows.append(row)
            print(json.dumps(row, default=str), flush=True)
    (Path(out) / "rows.json").write_text(json.dumps(rows, indent=1, default=str))
    print("\n" + "\n".join(table(rows, ALL_KINDS)))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kinds", default=None, help="comma-separated kinds of either set (default: --kinds-set's)")
    ap.add_argument("--kinds-set", type=int, choices=sorted(KIND_SETS), default=1,
                    help="1: the kinds above; 2: bench/foreign/mujoco_unlisted_more.py's (seeds SEED_MORE +); "
                         "3: bench/foreign/mujoco_unlisted_third.py's (seeds SEED_THIRD +); "
                         "4: bench/foreign/mujoco_unlisted_fourth.py's (seeds SEED_FOURTH +)")
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--second", action="store_true", help="the second seed set (SEED + 1000 +)")
    ap.add_argument("--first-seed", type=int, default=None,
                    help="another seed set: this seed + the kind's index, clean cases this + 90 + (e.g. 32700)")
    ap.add_argument("--scale", default="1",
                    help="comma-separated factors on the rail kinds' force magnitudes (e.g. 0.05,0.15,0.5); every "
                         "rail kind is run at each; a platform kind only at 1")
    ap.add_argument("--sets", type=int, default=1,
                    help="seed sets from the first one on, 1000 apart (e.g. --first-seed 30700 --sets 5: sets 1-5)")
    ap.add_argument("--out", type=Path, default=REPO / "results" / "mujoco_unlisted")
    ap.add_argument("--capture", default=None, help="keep each case's flexible-stage inputs in this directory")
    ap.add_argument("--replay", default=None,
                    help="re-run only the flexible stage on the inputs kept there (--capture); cpu is the stage's")
    ap.add_argument("--recordings", default=None,
                    help="diagnose the recordings a run of the same seeds wrote there (its --out) instead of "
                         "simulating them again (a case without one is simulated)")
    a = ap.parse_args(argv)
    kinds, kinds_set = kinds_of(ap, a.kinds, a.kinds_set)
    a.out.mkdir(parents=True, exist_ok=True)
    try:
        scales = [float(x) for x in a.scale.split(",") if x]
    except ValueError:
        ap.error(f"--scale {a.scale!r}: comma-separated numbers expected")
    if not scales or not all(math.isfinite(x) and x > 0 for x in scales):
        ap.error(f"--scale {a.scale!r}: positive factors expected")
    if any(x != 1.0 for x in scales) and any(k in PLATFORM or k not in KINDS for k in kinds):
        ap.error(f"--scale applies to the rail kinds only ({', '.join(KINDS[len(PLATFORM):])})")
    first = {1: SEED, 2: SEED_MORE, 3: SEED_THIRD, 4: SEED_FOURTH}[kinds_set]
    s0 = a.first_seed if a.first_seed is not None else first + (1000 if a.second else 0)
    todo = [job for base in range(s0, s0 + 1000 * a.sets, 1000)
            for job in jobs(kinds, kinds_set, base, a.clean, a.out, scales,
                            a.replay or a.capture, a.recordings)]
    rows = run_jobs(_replayed if a.replay else _run, todo, a.jobs, a.out)
    if len(scales) > 1 or scales != [1.0]:
        print("\n" + "\n".join(sweep_table(rows, ALL_KINDS)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
