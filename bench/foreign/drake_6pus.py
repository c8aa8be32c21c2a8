"""The 6-PUS as a Drake ``MultibodyPlant``, built from the core's nominal parameters.

Drake (PyPI ``drake``, pydrake; Tedrake 2019) is a simulator the project did not write.  The
plant: a free platform, six carriages on prismatic joints along their rails, six legs as
uniform slender rods on ball joints at the carriages, and each loop closed at the platform
by a ball constraint (a discrete plant stepped by Drake's SAP solver, Castro et al. 2023,
the solver Drake requires for such constraints; on a 0.3 s probe, the gravity load plus
sinusoids of 0.5 N on the rails, the loops stayed closed to 0.02 um).  Every number comes
from ``cosim.core.Model("6pus")``: the parameters (masses, inertias, platform points, rail
directions, gravity) and the geometry at home (``ik``, ``leg_points``).

Effects hidden in Drake's own physics (``hidden``: (type, value, joint) each, joint 0-based):

* ``viscous``: the prismatic joint's damping [N s/m];
* ``rotor_inertia``: the rail actuator's rotor inertia [kg] with gear ratio 1 (Drake's
  reflected inertia, added to the mass matrix's diagonal);
* ``payload``: a body of that mass [kg] welded to the platform at an offset drawn from ``rng``;
* ``platform_mass``: the platform's mass times (1 + value);
* ``gravity_tilt``: gravity tilted by value [deg] towards an azimuth drawn from ``rng``;
* ``offset``: a constant force [N] on the rail along +q (Drake's applied generalized force);
* ``compliance``, ``backlash``: the rail made two bodies as in mujoco_blind: the drive (a body
  of mass ``mujoco_blind.DRIVE_MASS`` on the rail's prismatic joint, the encoder reading it and
  the motor acting on it) and the carriage on a second prismatic joint relative to it (along the
  same axis); a compliance value [m/N] is Drake's ``PrismaticSpring`` of stiffness 1/value on
  that joint plus the joint's damping for mujoco_blind's ``DAMPING_RATIO`` with the drive's
  mass, a backlash value [m] the joint's position limits at +-value/2 (SAP's limit constraints:
  free inside the band, stiff faces);
* ``cable``: a cable of constant tension value [N] from the platform's reference point to an
  anchor drawn from ``rng`` (:func:`cable_anchor`), a force on the platform body renewed at
  every step (Drake's applied spatial force).

Loads computed at every step from the plant's state (``load``): a function of the plant, the
time and the rails' commanded forces returning more rail forces (Drake's applied generalized
force) and spatial forces on bodies (Drake's applied spatial forces), renewed at every step as
the cable's (bench/foreign/drake_unlisted.py's mechanisms).

The drive-side effects (encoder offset, actuator delay, dead zone) are applied around the
plant by ``mujoco_blind``'s :func:`drive_effects`, :func:`read_joints` and
:func:`drive_command`, as for MuJoCo.  :func:`simulate` runs one case and returns the
recording in the plant's joint coordinates (zero at home, declared by ``write_case``).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO / "bench" / "foreign"))

import mujoco_blind as mb  # noqa: E402  (the drive-side effects, the controller, the case plan)

from cosim.controllers import Reference  # noqa: E402
from cosim.core import Model  # noqa: E402
from cosim.discrepancy.excitation import excitation  # noqa: E402
from cosim.master import make_reference  # noqa: E402
from cosim.recording import Recording  # noqa: E402

#: Drake's time step [s] (the discrete plant's period; 10 per 1 kHz control period)
TIME_STEP = 1e-4
#: the effect types hidden in Drake's physics (the drive-side ones are mujoco_blind's)
PHYSICS = ("viscous", "rotor_inertia", "payload", "platform_mass", "gravity_tilt", "offset", "cable") + mb.TWO_BODY
#: radius [m] giving a leg's spin about its own axis an inertia (m r^2 / 2): the core's slender
#: rod has none, and a ball joint needs some (MuJoCo's capsule of bench/closed_loop_bench.py has
#: the same radius)
ROD_RADIUS = 1e-3


def cable_anchor(m: Model, rng) -> np.ndarray:
    """A cable's anchor [m] in the world frame: 0.2-0.5 m from the platform at home, in a
    direction drawn uniformly over the upper half of the sphere (the cable pulls up and
    sideways, as a hose hung above the robot)."""
    u = rng.normal(size=3)
    u[2] = abs(u[2])
    return m.home()[:3] + rng.uniform(0.2, 0.5) * u / np.linalg.norm(u)


def rotation_xyz(rx: float, ry: float, rz: float) -> np.ndarray:
    """R = Rx(rx) Ry(ry) Rz(rz), the core's pose convention (angles [rad])."""
    cx, sx, cy, sy, cz, sz = math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry), math.cos(rz), math.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rx @ Ry @ Rz


def rod_inertia(mass: float, a: np.ndarray):
    """Drake spatial inertia about a leg's joint (its end S, the body origin) of a uniform
    slender rod of ``mass`` [kg] from S to S + ``a`` [m]: m L^2 / 12 about its centre across
    the rod, m ROD_RADIUS^2 / 2 about its axis."""
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia

    u = a / np.linalg.norm(a)
    across, along = mass * float(a @ a) / 12.0, 0.5 * mass * ROD_RADIUS ** 2
    I = across * (np.eye(3) - np.outer(u, u)) + along * np.outer(u, u)
    central = RotationalInertia(I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2])
    return SpatialInertia.MakeFromCentralInertia(mass, 0.5 * a, central)


def point_inertia(mass: float):
    """Drake spatial inertia of a point-like body of ``mass`` [kg] at its origin (a small
    central inertia, 1e-9 kg m^2, as MuJoCo's payload of mujoco_blind)."""
    from pydrake.multibody.tree import RotationalInertia, SpatialInertia

    return SpatialInertia.MakeFromCentralInertia(mass, np.zeros(3), RotationalInertia(1e-9, 1e-9, 1e-9))


class Drake6Pus:
    """The 6-PUS of ``m``'s parameters as a discrete Drake plant, at rest at home.

    Parameters
    ----------
    m : Model
        The core model whose parameters and home pose build the plant.
    hidden : list of (str, float, int)
        Effects hidden in the plant's physics (types of :data:`PHYSICS`; others are ignored).
    rng : numpy.random.Generator, optional
        Draws the payload's offset and the tilt's azimuth (required for those two).
    truth : dict, optional
        Receives each hidden effect's answer under the core's parameter names.
    time_step : float
        Drake's discrete period [s].
    body : (float, callable), optional
        A body the platform carries on a joint of its own: its mass [kg], taken off the
        platform's (as a model edit of MuJoCo's case takes it), and ``add(plant, platform)``,
        which adds the body and its joint before the plant is finalised.
    """

    def __init__(self, m: Model, hidden=(), rng=None, truth: dict | None = None, time_step: float = TIME_STEP,
                 body=None):
        from pydrake.math import RigidTransform, RotationMatrix
        from pydrake.multibody.plant import DiscreteContactApproximation, MultibodyPlant
        from pydrake.multibody.tree import (BallRpyJoint, FixedOffsetFrame, PrismaticJoint, PrismaticSpring,
                                            RotationalInertia, SpatialInertia)
        from pydrake.systems.analysis import Simulator

        truth = {} if truth is None else truth
        self.cable = None  # (tension [N], anchor [m])
        p = m.params()
        x0 = m.home()
        self.q0 = m.ik(x0)
        P, S = m.leg_points(x0)
        plant = MultibodyPlant(time_step=time_step)
        plant.set_discrete_contact_approximation(DiscreteContactApproximation.kSap)
        damping, rotor, force = np.zeros(6), np.zeros(6), np.zeros(6)
        platform_m = p["platform.m"]
        g = np.array([p["gravity.x"], p["gravity.y"], p["gravity.z"]])
        payloads, two_body = [], {}  # two_body: rail -> (type, value)
        if p.get("payload.m", 0.0) > 0:
            payloads.append((p["payload.m"], np.array([p["payload.x"], p["payload.y"], p["payload.z"]])))
        for effect, value, j in hidden:
            if effect == "viscous":
                damping[j] += value
                truth[mb.EFFECTS[effect][1].format(j=j + 1)] = value
            elif effect == "rotor_inertia":
                rotor[j] += value
                truth[mb.EFFECTS[effect][1].format(j=j + 1)] = value
            elif effect == "offset":
                force[j] += value
                truth[mb.EFFECTS[effect][1].format(j=j + 1)] = -value
            elif effect in mb.TWO_BODY:
                two_body[j] = (effect, value)
                truth[mb.EFFECTS[effect][1].format(j=j + 1)] = value
            elif effect == "payload":
                off = np.array(mb.payload_offset(rng))
                payloads.append((value, off))
                truth.update({"payload.m": value, "payload.x": off[0], "payload.y": off[1], "payload.z": off[2]})
            elif effect == "platform_mass":
                platform_m = p["platform.m"] * (1 + value)
                truth["platform.m"] = platform_m
            elif effect == "cable":
                self.cable = (value, cable_anchor(m, rng))
                truth.update({"cable.tension": value, **{f"cable.anchor_{a}": float(v)
                                                         for a, v in zip("xyz", self.cable[1])}})
            elif effect == "gravity_tilt":
                az = rng.uniform(0, 2 * math.pi)
                gn = abs(p["gravity.z"])
                tilt = math.radians(value)
                g = np.array([gn * math.sin(tilt) * math.cos(az), gn * math.sin(tilt) * math.sin(az),
                              -gn * math.cos(tilt)])
                truth.update({"gravity.x": g[0], "gravity.y": g[1]})
        if body is not None:
            platform_m -= body[0]
        platform = plant.AddRigidBody("platform", SpatialInertia.MakeFromCentralInertia(
            platform_m, np.zeros(3), RotationalInertia(p["platform.Ixx"], p["platform.Iyy"], p["platform.Izz"])))
        for k, (mass, off) in enumerate(payloads):
            body = plant.AddRigidBody(f"payload{k}", point_inertia(mass))
            plant.WeldFrames(platform.body_frame(), body.body_frame(), RigidTransform(off))
        self.rails = []
        for i in range(6):
            axis = np.array([p[f"rail[{i + 1}].s{c}"] for c in "xyz"])
            origin = plant.AddFrame(FixedOffsetFrame(f"rail{i}", plant.world_frame(), RigidTransform(S[i])))
            slider = plant.AddRigidBody(f"slider{i}", point_inertia(p[f"slider[{i + 1}].m"]))
            driven = slider  # the body the rail's joint moves: the drive of a two-body rail
            if i in two_body:
                driven = plant.AddRigidBody(f"drive{i}", point_inertia(mb.DRIVE_MASS))
            rail = plant.AddJoint(PrismaticJoint(f"rail{i}", origin, driven.body_frame(), axis,
                                                 damping=float(damping[i])))
            if i in two_body:
                kind, size = two_body[i]
                if kind == "compliance":
                    k = 1.0 / size
                    gap = plant.AddJoint(PrismaticJoint(
                        f"gap{i}", driven.body_frame(), slider.body_frame(), axis,
                        damping=2 * mb.DAMPING_RATIO * math.sqrt(k * mb.DRIVE_MASS)))
                    plant.AddForceElement(PrismaticSpring(gap, 0.0, k))
                else:
                    plant.AddJoint(PrismaticJoint(f"gap{i}", driven.body_frame(), slider.body_frame(), axis,
                                                  pos_lower_limit=-0.5 * size, pos_upper_limit=0.5 * size))
            actuator = plant.AddJointActuator(f"drive{i}", rail)
            actuator.set_default_rotor_inertia(float(rotor[i]))
            actuator.set_default_gear_ratio(1.0)
            a = P[i] - S[i]  # the leg at home, its frame parallel to the world's
            leg = plant.AddRigidBody(f"leg{i}", rod_inertia(p[f"leg[{i + 1}].m"], a))
            plant.AddJoint(BallRpyJoint(f"ball{i}", slider.body_frame(), leg.body_frame()))
            plant.AddBallConstraint(leg, a, platform, np.array([p[f"leg[{i + 1}].p{c}"] for c in "xyz"]))
            self.rails.append(rail)
        if body is not None:
            body[1](plant, platform)
        plant.mutable_gravity_field().set_gravity_vector(g)
        plant.SetDefaultFloatingBaseBodyPose(platform, RigidTransform(RotationMatrix(rotation_xyz(*x0[3:])), x0[:3]))
        plant.Finalize()
        self.plant, self.platform, self.time_step = plant, platform, time_step
        self.context = plant.CreateDefaultContext()
        self._cmd = plant.get_actuation_input_port().FixValue(self.context, np.zeros(6))
        self.offset = np.zeros(plant.num_velocities())  # the constant applied generalized force (``offset``)
        self.rail_dofs = [rail.velocity_start() for rail in self.rails]
        self.offset[self.rail_dofs] = force
        self._applied = plant.get_applied_generalized_force_input_port().FixValue(self.context, self.offset)
        self._spatial = plant.get_applied_spatial_force_input_port().FixValue(self.context, [])
        self.simulator = Simulator(plant, self.context)
        self.simulator.Initialize()
        self.steps = 0  # updates made

    def joints(self) -> tuple[np.ndarray, np.ndarray]:
        """The rails' true positions [m] (the core's coordinates) and rates [m/s] (a two-body
        rail's drive's: what its encoder reads)."""
        q = np.array([r.get_translation(self.context) for r in self.rails])
        qd = np.array([r.get_translation_rate(self.context) for r in self.rails])
        return self.q0 + q, qd

    def pose(self) -> np.ndarray:
        """The platform's true pose (x, y, z, rx, ry, rz) [m, rad], the core's convention."""
        X = self.plant.EvalBodyPoseInWorld(self.context, self.platform)
        return np.r_[X.translation(), mb.euler_xyz(X.rotation().matrix())]

    def platform_motion(self) -> tuple:
        """The platform body's origin [m], rotation matrix (body to world), and its origin's
        velocity [m/s] and angular velocity [rad/s], both in the world frame."""
        X = self.plant.EvalBodyPoseInWorld(self.context, self.platform)
        V = self.plant.EvalBodySpatialVelocityInWorld(self.context, self.platform)
        return X.translation(), X.rotation().matrix(), V.translational(), V.rotational()

    def step(self, force, steps: int = 1, load=None) -> None:
        """``steps`` time steps with the six rail forces ``force`` [N] (along +q) held over them.

        ``load``, if given, is called before every step as ``load(self, t, force)`` (t [s] the
        step's start) and returns (six more rail forces [N] along +q or None, a list of Drake
        ``ExternallyAppliedSpatialForce``), applied over that step beside a cable's pull.
        Drake's simulator, advanced to a time ``t``, has made the plant's updates at the step
        times before ``t``; it is advanced to half a step before the next step time, so that
        the rounding of a sum of steps never leaves one update out."""
        self._cmd.GetMutableData().get_mutable_value().SetFromVector(force)
        if self.cable is None and load is None:
            self.steps += steps
            self.simulator.AdvanceTo((self.steps - 0.5) * self.time_step)
            return
        for _ in range(steps):  # forces that follow the state: renewed every step
            rails, spatial = None, [self._pull()] if self.cable is not None else []
            if load is not None:
                rails, more = load(self, self.steps * self.time_step, force)
                spatial += list(more)
            applied = self.offset.copy()
            if rails is not None:
                applied[self.rail_dofs] += rails
            self._applied.GetMutableData().get_mutable_value().SetFromVector(applied)
            self._spatial.GetMutableData().set_value(spatial)
            self.steps += 1
            self.simulator.AdvanceTo((self.steps - 0.5) * self.time_step)

    def _pull(self):
        """The cable's force on the platform at its reference point, for the coming step."""
        tension, anchor = self.cable
        d = anchor - self.plant.EvalBodyPoseInWorld(self.context, self.platform).translation()
        return spatial_force(self.platform, np.zeros(3), tension * d / np.linalg.norm(d))


def spatial_force(body, torque, force, at=None):
    """Drake's ``ExternallyAppliedSpatialForce`` on ``body``: ``force`` [N] and ``torque`` [N m],
    both in the world frame, at the point ``at`` [m] of the body's frame (its origin if None)."""
    from pydrake.multibody.math import SpatialForce
    from pydrake.multibody.plant import ExternallyAppliedSpatialForce

    out = ExternallyAppliedSpatialForce()
    out.body_index = body.index()
    out.p_BoBq_B = np.zeros(3) if at is None else np.asarray(at, float)
    out.F_Bq_W = SpatialForce(np.asarray(torque, float), np.asarray(force, float))
    return out


def simulate(m: Model, effect, value, joint, seed, duration, noise, kind="pd_gravity", physics: Model | None = None,
             time_step: float = TIME_STEP, motion: bool = False, load=None, body=None):
    """One case on Drake: (Recording in the plant's joint coordinates, zero at home, truth).

    Parameters
    ----------
    m : Model
        The nominal model: the controller, the trajectory and (unless ``physics``) the plant.
    effect, value, joint
        The hidden effect's type, size and rail (0-based); ``effect`` None is a clean case,
        a list of (type, value, joint) hides several.
    seed : int
        Seeds the trajectory, the payload's offset / the tilt's azimuth and the noise.
    duration : float
        Recorded seconds [s] (after a 0.5 s lead-in standstill, as mujoco_blind).
    noise : dict
        Standard deviations of the readings (the blind configuration's ``noise.6pus``).
    kind : str
        The controller (``pd_gravity`` or ``pid``, mujoco_blind's :func:`controller`).
    physics : Model, optional
        The model Drake's plant is built from, when not ``m`` (a plant unlike the nominal).
    time_step : float
        Drake's period [s]; a divisor of the 1 ms control period.
    motion : bool
        Also return the true motion: ``{"q", "qd"}`` [m, m/s] of the rails at every control
        instant and the end (n + 1 rows), ``"force"`` [N] the mean applied rail force over each
        period (n rows), ``"t"`` [s] the control instants, ``"k0"`` the first recorded row.
    load : callable, optional
        Loads renewed at every Drake step from the plant's state (:meth:`Drake6Pus.step`).
    body : (float, callable), optional
        A body the platform carries on a joint of its own (:class:`Drake6Pus`).
    """
    rng = np.random.default_rng(seed)
    hidden = effect if isinstance(effect, list) else ([] if effect is None else [(effect, value, joint)])
    truth = {}
    sim = Drake6Pus(m if physics is None else physics, hidden, rng, truth, time_step, body=body)
    substeps = int(round(mb.DT / time_step))
    drive = mb.drive_effects(hidden, truth, step=mb.DT / substeps)
    q0 = m.ik(m.home())
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=mb.DT, duration=round(traj.duration / mb.DT) * mb.DT)
    ctrl = mb.controller(kind, m)
    ctrl.reset(0.0, q0, m.home())
    n = len(ref.time)
    rows = {k: np.empty((n, 6)) for k in ("q", "qd", "tau", "pose")}
    true = {"q": np.empty((n + 1, 6)), "qd": np.empty((n + 1, 6)), "force": np.zeros((n, 6))}
    issued = []  # (time, command) for the delay line
    for k in range(n):
        t = k * mb.DT
        q_true, qd_true = sim.joints()
        true["q"][k], true["qd"][k] = q_true, qd_true
        q_read, qd_read, pose = mb.read_joints(rng, noise, drive, q_true, qd_true, sim.pose())
        tau = ctrl(t, q_read, qd_read, Reference(ref.q[k], ref.qd[k], ref.qdd[k], ref.x[k]))
        rows["q"][k], rows["qd"][k], rows["tau"][k], rows["pose"][k] = q_read, qd_read, tau, pose
        rows["tau"][k] += rng.normal(0, noise["tau"], 6)
        issued.append((t, tau.copy()))
        cmds = [mb.drive_command(issued, t + s * mb.DT / substeps, drive) for s in range(substeps)]
        true["force"][k] = np.mean(cmds, axis=0)
        run = 1
        for s in range(substeps):  # a command held over several steps: one call
            if s + 1 < substeps and np.array_equal(cmds[s + 1], cmds[s]):
                run += 1
                continue
            sim.step(cmds[s], run, load)
            run = 1
        if len(issued) > 20:
            issued = issued[-20:]
    true["q"][n], true["qd"][n] = sim.joints()
    k0 = int(round(0.5 / mb.DT))  # after the lead-in standstill, as the engine's own generator
    s = slice(k0, n)
    rec = Recording("6pus", ref.time[s] - ref.time[k0], rows["q"][s] - q0, rows["qd"][s], rows["tau"][s],
                    qref=ref.q[s] - q0, pose=rows["pose"][s], controller=ctrl.describe(),
                    parameters=mb.drive_declared(hidden), notes="Drake run (bench/foreign/drake_6pus.py)")
    if motion:
        return rec, truth, dict(true, t=ref.time, k0=k0)
    return rec, truth
