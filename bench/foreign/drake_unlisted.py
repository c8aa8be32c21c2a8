"""bench/foreign/mujoco_unlisted.py's mechanisms hidden in Drake's 6-PUS, diagnosed with the defaults.

    .venv/bin/python bench/foreign/drake_unlisted.py [--kinds-set 1|2|3|4] [--kinds cable_carrier,...]
        [--first-seed 91000] [--clean 4] [--jobs 1] [--out results/drake_unlisted]

A measurement, not a tuning set: the unlisted mechanisms (forces no library effect, term family
or platform force names) of bench/foreign/mujoco_unlisted.py's four kind sets, on a second
simulator, Drake (bench/foreign/drake_6pus.py's plant: SAP at 0.1 ms, loops closed by ball
constraints, the controller, trajectory, noise and recording of the MuJoCo cases).  Each case is
drawn by the kind's own code (``mujoco_unlisted.draw``: its parameters, its ``hook`` and the
inputs it is keyed on), diagnosed with the defaults and judged by the same code as on MuJoCo
(``mujoco_unlisted.run_case``: ``unlisted_common.judge``, ``judge_either`` and ``table``).

Every kind of the four sets runs.  A kind whose force is a hook, ``hook(model, data, t, q, qd,
cmd)``, of the rails' positions and rates, the commanded forces, time, states the hook keeps
itself, and the platform's pose and twist, runs through that hook.  The hook is called before every Drake step with a
view of Drake's state in the MuJoCo fields it reads (:class:`MuJoCoView`: the platform body's
``xpos``, ``xmat``, its free joint's ``qvel`` (linear velocity in the world frame, angular in
the body's, as MuJoCo's), ``model.body("platform").id``, ``body_jntadr``, ``jnt_dofadr`` and
``opt.gravity``); what it returns is applied as rail forces (Drake's applied generalized force),
what it writes in ``xfrc_applied`` as a spatial force on the platform at its origin (its centre
of mass, as MuJoCo's), and a change it makes to ``opt.gravity`` as the uniform field's change on
every body (m dg at each body's centre of mass).  MuJoCo's hook reads the platform's pose of the
previous step's start (``xpos`` after ``mj_step``); the view gives the current one.  Four kinds
MuJoCo builds by editing its model (:data:`BUILT`: the tendon, the soft pad, the coupling damper,
the coiled cord) run on Drake as hooks of its state from the same draw (:func:`drake_hook`), three (:data:`BODIES`:
the pendulum, the tuned mass damper, the loose payload) as the same body on the same joint in Drake's
plant (:func:`drake_body`; the payload's dry friction a force of the joint's rate, :func:`drake_load`),
and two in a leg's ball joint (:data:`LEGS`: its dry friction, the flexure's stiffness and damping)
as moments between the leg and its carriage (:func:`drake_load`).  Every model edit of MuJoCo's
kinds runs on Drake.

Seeds: ``--first-seed`` + the kind's index in its set, clean cases ``--first-seed`` + 90 +
(development seeds 91000-91999: 91000 the first set, 91100 the second, 91200 the third, 91300 the
fourth, by default).
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

import mujoco_unlisted as mu  # noqa: E402

#: the kinds MuJoCo builds by editing its model whose force Drake gets as a hook of its state,
#: from the same draw (the kind's truth): see :func:`drake_hook`
BUILT = ("tendon_slack", "soft_stop", "coupling_damper", "coiled_cord")
#: the kinds MuJoCo builds as a body on a joint in the platform, built as the same body and joint
#: in Drake's plant from the same draw: see :func:`drake_body` (the loose payload's dry friction:
#: :func:`drake_load`)
BODIES = ("slosh", "platform_tmd", "loose_payload")
#: the kinds MuJoCo builds as a property of a leg's ball joint, run on Drake as moments between
#: the leg and its carriage from the same draw: see :func:`drake_load`
LEGS = ("ball_joint_friction", "flexure_joint")
#: the default first seed of each set (development seeds)
FIRST_SEED = {1: 91000, 2: 91100, 3: 91200, 4: 91300}
PLATFORM_ID = 1  # the platform's body id in the view (0 is the world, as MuJoCo's)


class MuJoCoView:
    """The MuJoCo ``model`` and ``data`` fields a mechanism's hook reads and writes, kept for a
    Drake plant (:class:`drake_6pus.Drake6Pus`): two bodies (the world, the platform), the
    platform's free joint as the only joint (six dofs).  A hook asking for another body fails."""

    def __init__(self, sim):
        g = np.array(sim.plant.gravity_field().gravity_vector())
        self.gravity = g.copy()  # the plant's gravity [m/s^2]
        self.model = SimpleNamespace(body=self._body, body_jntadr=np.array([-1, 0]), jnt_dofadr=np.array([0]),
                                     opt=SimpleNamespace(gravity=g))
        self.data = SimpleNamespace(xpos=np.zeros((2, 3)), xmat=np.zeros((2, 9)), qvel=np.zeros(6),
                                    xfrc_applied=np.zeros((2, 6)))
        from pydrake.multibody.tree import BodyIndex

        self.bodies = [sim.plant.get_body(BodyIndex(i)) for i in range(1, sim.plant.num_bodies())]  # 0: the world

    @staticmethod
    def _body(name):
        if name != "platform":
            raise KeyError(f"the Drake view holds the platform only, not {name!r}")
        return SimpleNamespace(id=PLATFORM_ID)

    def fill(self, sim) -> None:
        """The platform's pose and twist (MuJoCo's conventions) from Drake's state."""
        p, R, v, w = sim.platform_motion()
        self.data.xpos[PLATFORM_ID] = p
        self.data.xmat[PLATFORM_ID] = R.reshape(9)
        self.data.qvel[:3] = v  # the free joint's linear velocity: world frame
        self.data.qvel[3:] = R.T @ w  # its angular velocity: the body's frame

    def loads(self, sim) -> list:
        """Drake's spatial forces of what the hook wrote: ``xfrc_applied`` on the platform (force,
        torque, world frame, at its centre of mass) and the change of ``opt.gravity`` on every body."""
        import drake_6pus as d6

        f = self.data.xfrc_applied[PLATFORM_ID]
        out = [d6.spatial_force(sim.platform, f[3:], f[:3])] if np.any(f) else []
        dg = np.asarray(self.model.opt.gravity) - self.gravity
        if np.any(dg):
            for b in self.bodies:
                out.append(d6.spatial_force(b, np.zeros(3), b.default_mass() * dg, at=b.default_com()))
        return out


def as_load(hook):
    """A MuJoCo hook as drake_6pus's ``load(sim, t, cmd)``: the view made at the first call
    and filled before every one; (the hook's rail forces, the spatial forces of what it wrote)."""
    view = {}

    def load(sim, t, cmd):
        if not view:
            view["v"] = MuJoCoView(sim)
        v = view["v"]
        v.fill(sim)
        q, qd = sim.joints()
        rails = hook(v.model, v.data, t, q, qd.copy(), np.asarray(cmd, float).copy())
        return (None if rails is None else np.asarray(rails, float)), v.loads(sim)
    return load


def drake_hook(kind, truth, m):
    """The force of a :data:`BUILT` kind, which MuJoCo's case builds by editing its model, as a
    hook of Drake's state (:func:`as_load`), from the kind's drawn ``truth``:

    * ``coupling_damper``: -c (qd_j - qd_k) on rail j, the opposite on rail k (MuJoCo's fixed
      tendon with damping);
    * ``tendon_slack``: a tension k (d - L) + b dd/dt, never negative, while the distance d from
      the platform's origin to the anchor exceeds the slack length L, along that line (MuJoCo's
      length-limited spatial tendon, its soft limit's stiffness k and damping b,
      :data:`mujoco_unlisted.TENDON_DAMPING`);
    * ``soft_stop``: a push k p + b dp/dt, never negative, normal to the pad while the platform's
      origin is p past it along the drawn axis and side (MuJoCo's frictionless contact of a
      sphere on the platform with a plane, its solref stiffness k and damping b,
      :data:`mujoco_unlisted.PAD_DAMPING`);
    * ``coiled_cord``: a tension k (L - L0) along the cord from carriage j's top (5 mm above the
      rail's point, moving along the rail's axis) to the tie point of the platform, on the
      platform (a force and its moment) and on carriage j (its component along the rail), as
      MuJoCo's spatial tendon with stiffness and spring length."""
    if kind == "coupling_damper":
        j, k, c = truth["rail"] - 1, truth["other_rail"] - 1, truth["damping"]

        def damper(model, data, t, q, qd, u):
            f = np.zeros(len(q))
            f[j] = -c * (qd[j] - qd[k])
            f[k] = -f[j]
            return f
        return damper
    if kind == "tendon_slack":
        anchor, L, k = np.asarray(truth["anchor"], float), truth["slack_length"], truth["stiffness"]

        def tendon(model, data, t, q, qd, u):
            b = model.body("platform").id
            d = anchor - data.xpos[b]
            dist = float(np.linalg.norm(d))
            if dist > L:
                rate = -float(d @ data.qvel[:3]) / dist  # the stretch's rate
                data.xfrc_applied[b, :3] = max(k * (dist - L) + mu.TENDON_DAMPING * rate, 0.0) * d / dist
            else:
                data.xfrc_applied[b, :3] = 0.0
        return tendon
    if kind == "soft_stop":
        e = np.zeros(3)
        e["xyz".index(truth["axis"])] = truth["side"]
        at, k = truth["at"], truth["stiffness"]

        def pad(model, data, t, q, qd, u):
            b = model.body("platform").id
            depth = float(e @ data.xpos[b]) - at
            push = max(k * depth + mu.PAD_DAMPING * float(e @ data.qvel[:3]), 0.0) if depth > 0 else 0.0
            data.xfrc_applied[b, :3] = -push * e
        return pad
    if kind == "coiled_cord":
        p = m.params()
        j = truth["carriage"] - 1
        axis = np.array([p[f"rail[{j + 1}].s{c}"] for c in "xyz"])
        q0 = np.asarray(m.ik(m.home()))
        base = np.asarray(m.leg_points(m.home())[1][j]) + np.asarray(truth["top"], float)
        tie, k, L0 = np.asarray(truth["tie"], float), truth["stiffness"], truth["rest_length"]

        def cord(model, data, t, q, qd, u):
            b = model.body("platform").id
            R = data.xmat[b].reshape(3, 3)
            arm = R @ tie
            end = base + (q[j] - q0[j]) * axis
            d = end - (data.xpos[b] + arm)  # from the tie to the carriage
            length = float(np.linalg.norm(d))
            pull = k * (length - L0) * d / length  # on the platform, towards the carriage when stretched
            data.xfrc_applied[b, :3] = pull
            data.xfrc_applied[b, 3:] = np.cross(arm, pull)
            f = np.zeros(len(q))
            f[j] = -float(pull @ axis)
            return f
        return cord
    raise ValueError(f"{kind} is not built on Drake")


class DrakeLoad:
    """A force computed from Drake's own state, drake_6pus's ``load(sim, t, cmd)`` as it is
    (not a MuJoCo hook to be viewed through :class:`MuJoCoView`): :func:`load_of` passes it on."""

    def __init__(self, load):
        self.load = load

    def __call__(self, sim, t, cmd):
        return self.load(sim, t, cmd)


def load_of(hook):
    """drake_6pus's ``load`` of a drawn hook: a :class:`DrakeLoad` as it is, a MuJoCo hook
    through :func:`as_load`, None for none."""
    if hook is None or isinstance(hook, DrakeLoad):
        return hook
    return as_load(hook)


def drake_load(kind, truth, m):
    """The force of a :data:`LEGS` kind, or the loose payload's dry friction, as a
    :class:`DrakeLoad` of Drake's state, from the kind's drawn ``truth``:

    * ``ball_joint_friction``: MuJoCo's moment (``mujoco_unlisted.ball_friction``), -L tanh(w_i /
      W) on each of the ball joint's three rotations in the leg's frame (w the leg's angular rate
      relative to its carriage, which does not turn), of the drawn friction L;
    * ``flexure_joint``: MuJoCo's ball-joint ``stiffness`` k and ``damping`` c about the home
      pose, -k r - c w (r the rotation vector of the leg from home, w its angular rate);
    * ``loose_payload``: the tray's ``frictionloss`` L as -L tanh(v / mujoco_unlisted's
      ``V_FRICTION``) on the tray's slide joint (v its rate), on the payload and the opposite on
      the platform at the payload's place (the body and joint: :func:`drake_body`).

    A leg's moment acts on the leg and the opposite on its carriage, less its part along the
    leg (``mujoco_unlisted.across_leg``: on Drake's 1 mm rod a damping's explicit bound c dt / I
    < 2 fails above c = 0.3 uN m s)."""
    import drake_6pus as d6

    if kind == "loose_payload":
        loss, axis = truth["frictionloss"], np.asarray(truth["axis"], float)
        ids = {}

        def tray(sim, t, cmd):
            if not ids:
                ids["joint"] = sim.plant.GetJointByName("tray")
                ids["body"] = sim.plant.GetBodyByName("tray")
            x = ids["joint"].get_translation(sim.context)
            f = -loss * math.tanh(ids["joint"].get_translation_rate(sim.context) / mu.V_FRICTION)
            R = sim.plant.EvalBodyPoseInWorld(sim.context, sim.platform).rotation().matrix()
            push = f * (R @ axis)
            return None, [d6.spatial_force(ids["body"], np.zeros(3), push),
                          d6.spatial_force(sim.platform, np.zeros(3), -push, at=x * axis)]
        return DrakeLoad(tray)
    if kind not in LEGS:
        raise ValueError(f"{kind} is not a Drake load")
    from scipy.spatial.transform import Rotation

    i = truth["leg"] - 1
    along = mu.leg_axis(m, i)
    ids = {}

    def moment(R, w):
        if kind == "ball_joint_friction":  # MuJoCo's moment, in the leg's frame
            return R @ mu.ball_friction(R.T @ w, truth["frictionloss"], along)
        tau = -truth["stiffness"] * Rotation.from_matrix(R).as_rotvec() - truth["damping"] * w
        return mu.across_leg(tau, R @ along)  # (the leg's axis now)

    def leg(sim, t, cmd):
        if not ids:
            ids["leg"] = sim.plant.GetBodyByName(f"leg{i}")
            ids["slider"] = sim.plant.GetBodyByName(f"slider{i}")
        R = sim.plant.EvalBodyPoseInWorld(sim.context, ids["leg"]).rotation().matrix()
        w = sim.plant.EvalBodySpatialVelocityInWorld(sim.context, ids["leg"]).rotational()
        tau = moment(R, w)
        return None, [d6.spatial_force(ids["leg"], tau, np.zeros(3)),
                      d6.spatial_force(ids["slider"], -tau, np.zeros(3))]
    return DrakeLoad(leg)


def drake_body(kind, truth):
    """The body of a :data:`BODIES` kind, which MuJoCo's case adds to the platform by editing its
    model, as drake_6pus's ``body`` (its mass, taken off the platform's, and the function adding
    it to Drake's plant), from the kind's drawn ``truth``:

    * ``slosh``: a point mass m_b hung L below a pivot L above the platform's origin on a ball
      joint (Drake's roll-pitch-yaw ball joint) with the angular damping c = 2 zeta m_b L^2
      sqrt(g / L) of MuJoCo's ball joint;
    * ``platform_tmd``: a point mass m_b on a slide joint along the guide (the platform's frame)
      with a spring k = m_b w0^2 (Drake's PrismaticSpring) whose rest offset m_b g a_z / k holds it
      at home, and the joint's damping 2 zeta m_b w0, as MuJoCo's slide joint;
    * ``loose_payload``: a point mass m_p at the platform's origin on a slide joint along the
      tray's level axis (the platform's frame) with limits at +-play (SAP's limit constraints,
      stiffer than MuJoCo's soft limit of 5 ms); its dry friction: :func:`drake_load`."""
    from pydrake.math import RigidTransform
    from pydrake.multibody.tree import (BallRpyJoint, FixedOffsetFrame, PrismaticJoint, PrismaticSpring,
                                        RotationalInertia, SpatialInertia)

    mass = truth["mass"]
    tiny = RotationalInertia(1e-9, 1e-9, 1e-9)
    if kind == "slosh":
        L, c = truth["length"], truth["damping"]

        def add(plant, platform):
            bob = plant.AddRigidBody("bob", SpatialInertia.MakeFromCentralInertia(mass, np.array([0.0, 0.0, -L]), tiny))
            pivot = plant.AddFrame(FixedOffsetFrame("pivot", platform.body_frame(), RigidTransform([0.0, 0.0, L])))
            plant.AddJoint(BallRpyJoint("slosh", pivot, bob.body_frame(), damping=c))
        return mass, add
    if kind == "platform_tmd":
        axis = np.asarray(truth["axis"], float)
        k, c, ref = truth["stiffness"], truth["damping"], truth["rest_offset"]

        def add(plant, platform):
            tmd = plant.AddRigidBody("tmd", SpatialInertia.MakeFromCentralInertia(mass, np.zeros(3), tiny))
            guide = plant.AddJoint(PrismaticJoint("tmd", platform.body_frame(), tmd.body_frame(), axis, damping=c))
            plant.AddForceElement(PrismaticSpring(guide, ref, k))
        return mass, add
    if kind == "loose_payload":
        axis, play = np.asarray(truth["axis"], float), truth["play"]

        def add(plant, platform):
            tray = plant.AddRigidBody("tray", SpatialInertia.MakeFromCentralInertia(mass, np.zeros(3), tiny))
            plant.AddJoint(PrismaticJoint("tray", platform.body_frame(), tray.body_frame(), axis,
                                          pos_lower_limit=-play, pos_upper_limit=play))
        return mass, add
    raise ValueError(f"{kind} is not a body on Drake")


def drawn(kind, rng, m, mo, scale=1.0):
    """``mujoco_unlisted.draw`` with a :data:`BUILT` kind's model edit replaced by its force as a
    hook of Drake's state (:func:`drake_hook`), a :data:`BODIES` kind's by its body in Drake's
    plant (:func:`drake_body`, as the edit; the loose payload's dry friction as a load,
    :func:`drake_load`), a :data:`LEGS` kind's by its moments in the leg's ball joint
    (:func:`drake_load`), from the same draw."""
    hook, edit, truth, key, joint = mu.draw(kind, rng, m, mo, scale)
    if kind in BUILT:
        hook, edit = drake_hook(kind, truth, m), None
    elif kind in BODIES:
        hook = drake_load(kind, truth, m) if kind == "loose_payload" else None
        edit = drake_body(kind, truth)
    elif kind in LEGS:
        hook, edit = drake_load(kind, truth, m), None
    return hook, edit, truth, key, joint


def _drake(m, seed, noise, hook, edit):
    """The case's recording on Drake (drake_6pus's :func:`simulate`), the hook as a load, the
    edit a body on the platform (:func:`drake_body`)."""
    import drake_6pus as d6

    if edit is not None and not isinstance(edit, tuple):
        raise ValueError("a kind that edits MuJoCo's model does not run on Drake")
    return d6.simulate(m, None, 0.0, 0, seed, mu.DURATION, noise, load=load_of(hook), body=edit)[0]


def _run(job):
    return mu.run_case(job, _drake, drawn)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kinds", default=None, help="comma-separated kinds of one set (default: --kinds-set's)")
    ap.add_argument("--kinds-set", type=int, choices=sorted(mu.KIND_SETS), default=1,
                    help="the set of bench/foreign/mujoco_unlisted.py (1-4) whose kinds run")
    ap.add_argument("--first-seed", type=int, default=None,
                    help="this seed + the kind's index in its set, clean cases this + 90 + (default: "
                         + ", ".join(f"set {n} {s}" for n, s in FIRST_SEED.items()) + ")")
    ap.add_argument("--clean", type=int, default=4)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", type=Path, default=REPO / "results" / "drake_unlisted")
    a = ap.parse_args(argv)
    kinds, kinds_set = mu.kinds_of(ap, a.kinds if a.kinds is not None else ",".join(mu.KIND_SETS[a.kinds_set]),
                                   a.kinds_set)
    a.out.mkdir(parents=True, exist_ok=True)
    s0 = a.first_seed if a.first_seed is not None else FIRST_SEED[kinds_set]
    mu.run_jobs(_run, mu.jobs(kinds, kinds_set, s0, a.clean, a.out), a.jobs, a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
