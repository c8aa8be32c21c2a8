"""The discrepancy engine on recordings from MuJoCo, a simulator the project did not write.

    .venv/bin/python bench/foreign/mujoco_blind.py [--clean 4] [--seed 11] [--duration 9] [--out results/foreign]
        [--controller pid] [--two] [--hold-out type] [--only backlash,clean] [--any-rail] [--gap-model mujoco]

Each case is a 6-PUS run in MuJoCo (PyPI ``mujoco``; bench/requirements.txt): a model
built from the core's nominal parameters (free platform, six slide joints with their
carriages, six legs as capsules on ball joints, each loop closed by a stiff ``connect``
equality; MuJoCo's own integrator at 0.1 ms), driven at 1 kHz by a PD + gravity
controller designed on the nominal model (or, ``--controller pid``, a PID with a
filtered derivative and output limits), along the engine's exciting trajectory, with
sensor noise.  One effect per case is hidden *in MuJoCo's physics or in the drive
around it*, not in the core: joint ``frictionloss`` (MuJoCo's soft Coulomb friction),
joint ``damping``, joint ``armature`` (rotor inertia), a payload body on the platform, a
heavier platform, tilted gravity, a command delay, an encoder offset, a dead zone, and, as
two bodies (drive with the encoder and the motor, carriage with the leg) joined through the
rail, a backlash (a gap with stiff faces: the contact side is whatever the transmitted force
makes it) or an elasticity (a spring); with ``--gap-model mujoco`` the gap is MuJoCo's own joint
limit (soft faces of time constant ``LIMIT_TC``) and the spring the gap joint's stiffness.  The
recording is written in MuJoCo's joint coordinates (zero at home) with the convention
declared in the sidecar (``joint_convention``), so the reader converts it.

Then ``cosim.discrepancy.diagnose`` runs on every recording, blind; only afterwards the
case's answer (kept in this process, never written beside the recording) is compared
with the effect named first.  Nothing here tunes the engine: the magnitudes are the
ranges of ``scenarios/blind/config.toml``, the generator is not the engine's plant.
Prints a table per case and the summary (right effect first, parameter within 15 %,
clean cases called clean).  ``--two`` hides two effects at once (PAIRS, never two declared
look-alikes) and counts the cases where both are named.  ``--hold-out`` diagnoses each effect case with its type taken
out of the library and counts the cases where "structure left unexplained" is reported.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "bench"))

from closed_loop_bench import mujoco_xml  # noqa: E402  (the MJCF of the same 6-PUS)

from cosim.controllers import ControllerError, Reference  # noqa: E402
from cosim.errors import JointLimitError  # noqa: E402
from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.excitation import excitation  # noqa: E402
from cosim.master import make_reference  # noqa: E402
from cosim.discrepancy.diagnosis import GAP_MINORITY, UNEXPLAINED, tied  # noqa: E402
from cosim.discrepancy.keyed.elsewhere import KEYED_ELSEWHERE  # noqa: E402
from cosim.recording import Recording, write_recording  # noqa: E402

DT, SUBSTEPS = 1e-3, 10  # controller / recording period, MuJoCo steps per period (0.1 ms)
#: tolerance [s] of the delay line's comparison of times (sums of periods and steps in floating point)
TIME_TOL = 1e-12

#: effect type -> (range from scenarios/blind/config.toml, the core parameter the engine should find)
EFFECTS = {
    "coulomb": ("coulomb", "rail[{j}].coulomb"),
    "viscous": ("viscous", "rail[{j}].viscous"),
    "rotor_inertia": ("rotor_inertia", "rail[{j}].rotor_inertia"),
    "payload": ("payload_m", "payload.m"),
    "platform_mass": ("platform_mass", "platform.m"),
    "gravity_tilt": ("gravity_tilt", None),
    "actuator_delay": ("actuator_delay", "actuator.delay"),
    "encoder_offset": ("encoder_offset", "rail[{j}].encoder_offset"),
    "dead_zone": ("dead_zone", "rail[{j}].dead_zone"),
    # two bodies: the drive (encoder, motor) and the carriage, joined by a dead-band spring / a spring
    "backlash": ("backlash", "rail[{j}].backlash"),
    "compliance": ("compliance", "rail[{j}].compliance"),
    # a constant force on the rail (MuJoCo's qfrc_applied): the drive supplies that much less,
    # rail[j].offset = -force in the core's convention (effort = ID + friction + offset)
    "offset": ("offset", "rail[{j}].offset"),
}

#: library effects that are also a right name of a MuJoCo effect: its friction loss is a soft
#: constraint that fades at low speed, so a fading Coulomb friction is that physics too
ALSO_RIGHT = {"coulomb": {"smooth_coulomb"}}

#: the drive body of a two-body rail [kg] (motor rotor and nut: heavy enough that the 1 kHz PD does
#: not kick it across the gap; the recording's sidecar declares it, as a datasheet would, as the
#: rail's rotor inertia), the contact stiffness of the gap's faces [N/m] and the damping ratio of
#: the contact and of the spring
DRIVE_MASS, CONTACT_K, DAMPING_RATIO = 0.05, 1e6, 0.3
#: the effects that make a rail two bodies (drive and carriage)
TWO_BODY = ("backlash", "compliance")
#: time constant [s] of a gap's faces made as MuJoCo's joint limit (``--gap-model mujoco``):
#: MuJoCo's default is 0.02 (faces so soft that the effort deflects them by millimetres, a
#: spring rather than a gap); 0.0005 gives faces deflecting a few um under the rail's effort
LIMIT_TC = 0.0005


def euler_xyz(R):
    """(rx, ry, rz) with R = Rx(rx) Ry(ry) Rz(rz), the core's pose convention."""
    ry = math.asin(max(-1.0, min(1.0, R[0, 2])))
    return math.atan2(-R[1, 2], R[2, 2]), ry, math.atan2(-R[0, 1], R[0, 0])


def case_xml(m: Model, hidden: list, rng, gap_model: str = "applied") -> tuple[str, dict]:
    """MJCF of the nominal robot with the ``hidden`` effects ((type, value, joint) each) that
    live in MuJoCo's physics; the truth.  ``gap_model`` (see :func:`simulate`) says how a
    two-body rail's gap or spring is made."""
    xml, truth = mujoco_xml(m), {}
    for effect, value, joint in hidden:
        xml = _hide(xml, m, effect, value, joint, rng, truth, gap_model)
    # stiff loop closure: MuJoCo's default connect (time constant 20 ms) sags by ~1 mm
    xml = xml.replace('"/>\n    <connect', '" solref="0.0002 1" solimp="0.999 0.9999 0.0001"/>\n    <connect')
    xml = xml.replace('"/>\n  </equality>', '" solref="0.0002 1" solimp="0.999 0.9999 0.0001"/>\n  </equality>')
    xml = xml.replace("<option ", '<option timestep="0.0001" integrator="implicitfast" ')
    return xml, truth


def payload_offset(rng) -> list:
    """A hidden payload's point on the platform [m] (platform frame): within 2 cm of the centre
    in x and y, 5-20 mm above it."""
    return [rng.uniform(-0.02, 0.02), rng.uniform(-0.02, 0.02), rng.uniform(0.005, 0.02)]


def _hide(xml: str, m: Model, effect, value: float, joint: int, rng, truth: dict, gap_model: str = "applied") -> str:
    p = m.params()
    j = joint
    rail = f'<joint name="rail{j}" type="slide"'
    if effect in ("coulomb", "viscous", "rotor_inertia"):
        attr = {"coulomb": "frictionloss", "viscous": "damping", "rotor_inertia": "armature"}[effect]
        xml = xml.replace(rail, f'{rail} {attr}="{value:.17g}"')
        truth[EFFECTS[effect][1].format(j=j + 1)] = value
    elif effect == "payload":
        off = payload_offset(rng)
        body = (f'\n      <body name="payload" pos="{off[0]:.17g} {off[1]:.17g} {off[2]:.17g}">'
                f'<inertial pos="0 0 0" mass="{value:.17g}" diaginertia="1e-9 1e-9 1e-9"/></body>')
        xml = xml.replace("<freejoint/>", "<freejoint/>" + body)
        truth.update({"payload.m": value, "payload.x": off[0], "payload.y": off[1], "payload.z": off[2]})
    elif effect == "platform_mass":
        new = p["platform.m"] * (1 + value)
        xml = xml.replace(f'mass="{p["platform.m"]:.17g}"', f'mass="{new:.17g}"', 1)
        truth["platform.m"] = new
    elif effect in TWO_BODY:
        # the rail's body becomes the drive (motor and encoder on its joint, a small mass) and the
        # carriage rides on it through a relative slide joint whose force is applied per step
        start = xml.index(f'<body name="slider{j}"')
        head = xml[start:xml.index("<geom", start)]
        axis = head.split('axis="')[1].split('"')[0]
        pos = head.split('pos="')[1].split('"')[0]
        gap_attr = ""
        if gap_model == "mujoco" and effect == "backlash":
            # MuJoCo's own joint limit: a soft constraint at +-b/2 (time constant LIMIT_TC,
            # critically damped), no force inside the band
            gap_attr = (f' limited="true" range="{-0.5 * value:.17g} {0.5 * value:.17g}" '
                        f'solreflimit="{LIMIT_TC:.17g} 1"')
        elif gap_model == "mujoco":
            k = 1.0 / value
            gap_attr = f' stiffness="{k:.17g}" damping="{2 * DAMPING_RATIO * math.sqrt(k * DRIVE_MASS):.17g}"'
        new_head = (f'<body name="drive{j}" pos="{pos}">\n      <joint name="rail{j}" type="slide" axis="{axis}"/>\n'
                    f'      <geom type="box" size="0.004 0.004 0.004" mass="{DRIVE_MASS}" contype="0" '
                    f'conaffinity="0"/>\n    <body name="slider{j}">\n      <joint name="gap{j}" type="slide" '
                    f'axis="{axis}"{gap_attr}/>\n      ')
        xml = xml[:start] + new_head + xml[start + len(head):]
        leg = xml.index(f'<body name="leg{j}"', start)
        close = xml.index("\n    </body>", leg)
        xml = xml[:close] + "\n    </body></body>" + xml[close + len("\n    </body>"):]
        truth[EFFECTS[effect][1].format(j=j + 1)] = value
    elif effect == "gravity_tilt":
        az = rng.uniform(0, 2 * math.pi)
        g = abs(p["gravity.z"])
        gx, gy = g * math.sin(math.radians(value)) * math.cos(az), g * math.sin(math.radians(value)) * math.sin(az)
        gz = -g * math.cos(math.radians(value))
        xml = xml.replace(f'<option gravity="{p["gravity.x"]} {p["gravity.y"]} {p["gravity.z"]}"/>',
                          f'<option gravity="{gx:.17g} {gy:.17g} {gz:.17g}"/>')
        truth.update({"gravity.x": gx, "gravity.y": gy})
    return xml


def held_delay(delay: float, step: float = DT / SUBSTEPS) -> float:
    """The actuator delay [s] the plant has when :func:`simulate` draws ``delay`` [s].

    The delay line applies a command issued at ``t`` from the first simulator step (``step``
    [s], default MuJoCo's ``DT / SUBSTEPS`` = 0.1 ms) at or after ``t + delay`` until the next
    command takes over one period later: the applied effort is the recorded one, held over each period, shifted by ``delay``
    rounded up to a whole step, with no other change (a drawn 2.74 ms and 2.8 ms give the same
    recording).  The answer key is that shift, not the drawn value.

    Example
    -------
    >>> round(held_delay(2.74e-3) * 1e3, 6), round(held_delay(2.8e-3) * 1e3, 6), held_delay(0.0)
    (2.8, 2.8, 0.0)
    """
    return max(math.ceil((delay - TIME_TOL) / step), 0) * step


class DriveEffects(NamedTuple):
    """The hidden effects that live in the drive and its encoder, not in a simulator's physics."""

    offset: np.ndarray  #: encoder offset per rail, added to the reading [m]
    delay: float  #: actuator delay drawn [s] (the plant's is :func:`held_delay` of it)
    dead: float  #: dead zone half width [N] (0: none)
    dead_joint: int  #: the rail of the dead zone (0-based)


def drive_effects(hidden, truth: dict, step: float = DT / SUBSTEPS) -> DriveEffects:
    """The drive-side effects among ``hidden`` ((type, value, joint) each: an encoder offset,
    an actuator delay, a dead zone); their answers are written into ``truth`` under the core's
    parameter names (the delay as the one the delay line makes on the simulator's ``step`` [s],
    :func:`held_delay`)."""
    offset = np.zeros(6)
    delay = dead = 0.0
    dead_joint = 0
    for eff, val, jnt in hidden:
        if eff == "encoder_offset":
            offset[jnt] = val
            truth[EFFECTS[eff][1].format(j=jnt + 1)] = val
        elif eff == "actuator_delay":
            delay = val
            truth["actuator.delay"] = held_delay(val, step)
        elif eff == "dead_zone":
            dead, dead_joint = val, jnt
            truth[EFFECTS[eff][1].format(j=jnt + 1)] = val
    return DriveEffects(offset, delay, dead, dead_joint)


def read_joints(rng, noise: dict, drive: DriveEffects, q_true, qd_true, pose_true):
    """The recorded readings (q [m], qd [m/s], pose [m, rad]) of the rails' true positions and
    rates and the platform's true pose (x, y, z, rx, ry, rz in the core's convention): the
    encoder offset added, then the noise of ``noise`` (the blind configuration's standard
    deviations ``q``, ``qd`` and per coordinate ``pose``) drawn from ``rng`` in that order."""
    q_read = q_true + drive.offset + rng.normal(0, noise["q"], 6)
    qd_read = qd_true + rng.normal(0, noise["qd"], 6)
    pose = pose_true + rng.normal(0, 1, 6) * np.asarray(noise["pose"])
    return q_read, qd_read, pose


def drive_command(issued: list, ts: float, drive: DriveEffects) -> np.ndarray:
    """The six rail forces [N] the drive applies at time ``ts`` [s]: the latest command of
    ``issued`` ((time [s], command [N]) pairs, oldest first) issued at or before ``ts`` less the
    delay (zero before the first), less the dead zone on its rail."""
    cmd = np.zeros(6)
    for ti, c in reversed(issued):
        if ti <= ts - drive.delay + TIME_TOL:
            cmd = c
            break
    if drive.dead > 0:
        cmd = cmd.copy()
        u = cmd[drive.dead_joint]
        cmd[drive.dead_joint] = 0.0 if abs(u) <= drive.dead else u - math.copysign(drive.dead, u)
    return cmd


def controller(kind: str, m: Model):
    """The recording's controller, designed on the nominal model: the engine generator's PD +
    gravity, or a PID with a filtered derivative and output limits (the core's law; the
    sidecar describes it and the engine rebuilds it)."""
    from cosim import controllers as ctl

    pdg = blind._controller("pd_gravity", m, blind.load_config(), DT)
    if kind == "pd_gravity":
        return pdg
    kp, kd = pdg.kp, pdg.kd
    return ctl.pid(m, kp=kp, ki=kp * 5.0, kd=kd, dt=DT, deriv_filter=1e-3, saturation=20.0,
                   gravity_feedforward=True)


def simulate(m: Model, effect, value, joint, seed, duration, noise, kind="pd_gravity", force=None,
             gap_model="applied", hook=None, edit=None):
    """One case: (Recording in MuJoCo's joint coordinates with the convention declared, truth).
    ``effect`` is a type (with ``value`` and ``joint``), None (clean) or a list of
    ``(type, value, joint)`` to hide several at once.  ``force``, if given, is a force law
    hidden in MuJoCo's physics: ``force(q, qd)`` of the six rails' true positions (the model's
    coordinates) and rates gives the six forces [N] pushing them along +q, applied at every
    MuJoCo step (``qfrc_applied``).  ``gap_model`` makes a two-body rail's backlash or
    elasticity: ``"applied"`` a force of :func:`gap_force` applied at every step (stiff,
    damped faces), ``"mujoco"`` MuJoCo's own constraint (a joint limit at +-b/2 with its default
    soft reference, or the gap joint's ``stiffness`` and ``damping``).  ``hook``, if given, is
    called before every MuJoCo step as ``hook(model, data, t, q, qd, cmd)`` (t [s], the rails'
    true positions and rates, the six commanded forces [N]) and returns six more rail forces
    along +q [N] or None; it may also set MuJoCo's ``xfrc_applied`` or the model's masses
    (bench/foreign/mujoco_unnamed.py).  ``edit``, if given, maps the case's MJCF text to the one
    simulated (a body, a tendon, a contact or a joint property added to MuJoCo's model;
    bench/foreign/mujoco_unlisted.py)."""
    import mujoco

    rng = np.random.default_rng(seed)
    hidden = effect if isinstance(effect, list) else ([] if effect is None else [(effect, value, joint)])
    xml, truth = case_xml(m, hidden, rng, gap_model)
    model = mujoco.MjModel.from_xml_string(xml if edit is None else edit(xml))
    gaps = [(model.joint(f"gap{j}").qposadr[0], model.joint(f"gap{j}").dofadr[0], eff, val)
            for eff, val, j in hidden if eff in TWO_BODY]
    substeps = SUBSTEPS
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    rails = [model.joint(f"rail{i}").qposadr[0] for i in range(6)]
    drails = [model.joint(f"rail{i}").dofadr[0] for i in range(6)]
    plat = model.body("platform").id
    q0 = m.ik(m.home())
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    ctrl = controller(kind, m)
    ctrl.reset(0.0, q0, m.home())
    drive = drive_effects(hidden, truth)
    for eff, val, jnt in hidden:
        if eff == "offset":
            data.qfrc_applied[drails[jnt]] += val
            truth[EFFECTS[eff][1].format(j=jnt + 1)] = -val
    applied = data.qfrc_applied[drails].copy()  # the constant part (a hidden offset)
    n = len(ref.time)
    rows = {k: np.empty((n, 6)) for k in ("q", "qd", "tau", "pose")}
    issued = []  # (time, command) for the delay line
    sig = noise
    for k in range(n):
        t = k * DT
        mujoco.mj_kinematics(model, data)  # xpos/xmat of mj_step are those at the start of the step
        R = data.xmat[plat].reshape(3, 3)
        q_read, qd_read, pose = read_joints(rng, sig, drive, q0 + data.qpos[rails], data.qvel[drails],
                                            np.r_[data.xpos[plat], euler_xyz(R)])
        tau = ctrl(t, q_read, qd_read, Reference(ref.q[k], ref.qd[k], ref.qdd[k], ref.x[k]))
        rows["q"][k], rows["qd"][k], rows["tau"][k], rows["pose"][k] = q_read, qd_read, tau, pose
        rows["tau"][k] += rng.normal(0, sig["tau"], 6)
        issued.append((t, tau.copy()))
        for s in range(substeps):
            ts = t + s * DT / substeps
            cmd = drive_command(issued, ts, drive)
            data.ctrl[:] = cmd
            if force is not None:
                data.qfrc_applied[drails] = applied + force(q0 + data.qpos[rails], data.qvel[drails])
            if hook is not None:
                more = hook(model, data, ts, q0 + data.qpos[rails], data.qvel[drails].copy(), cmd)
                base = data.qfrc_applied[drails] if force is not None else applied
                data.qfrc_applied[drails] = base + (0.0 if more is None else more)
            for adr, dof, eff, val in (gaps if gap_model == "applied" else ()):
                data.qfrc_applied[dof] = gap_force(eff, val, data.qpos[adr], data.qvel[dof])
            mujoco.mj_step(model, data)
        if len(issued) > 20:
            issued = issued[-20:]
    k0 = int(round(0.5 / DT))  # after the lead-in standstill, as the engine's own generator
    s = slice(k0, n)
    # written in MuJoCo's joint coordinates: zero at home (recorded = model - q0)
    known = drive_declared(hidden)
    rec = Recording("6pus", ref.time[s] - ref.time[k0], rows["q"][s] - q0, rows["qd"][s], rows["tau"][s],
                    qref=ref.q[s] - q0, pose=rows["pose"][s], controller=ctrl.describe(), parameters=known,
                    notes="MuJoCo run (bench/foreign/mujoco_blind.py)")
    return rec, truth


def drive_declared(hidden) -> dict:
    """The parameters a recording's sidecar declares for its two-body rails (``hidden``:
    (type, value, joint) each): the drive body's mass DRIVE_MASS [kg] as the rail's rotor
    inertia, as a datasheet would give the motor's."""
    return {f"rail[{j + 1}].rotor_inertia": DRIVE_MASS for eff, _, j in hidden if eff in TWO_BODY}


def gap_as_offset(d, effect, value: float, joint: int):
    """A backlash of total gap ``value`` [m] on rail ``joint`` (0-based) whose effort keeps one
    sign is a constant offset of b/2 on that recording: None unless diagnosis ``d`` names an
    encoder offset first with the backlash listed as not excited on that rail, else whether the
    offset found is b/2 within 10 % (right: the carriage rests on one face, the side the effort
    pushes to giving the sign)."""
    named = d.named()
    if not (effect == "backlash" and named and named[0] == "encoder_offset"
            and any(x.startswith("backlash") and f"joint {joint + 1})" in x for x in d.not_excited)):
        return None
    found = d.plant_parameters().get(f"rail[{joint + 1}].encoder_offset", 0.0)
    return bool(abs(abs(found) - value / 2) < 0.1 * value / 2)


def gap_force(effect: str, value: float, gap: float, rate: float) -> float:
    """Force on the carriage relative to the drive [N] (gap = carriage - drive [m]): a spring of
    compliance ``value`` [m/N], or, for a backlash of total gap ``value`` [m], nothing inside the
    band and stiff, damped faces at +-value/2.  The encoder reads the drive, so it reads the
    carriage -(gap): + value/2 on the side the transmitted force pushes to, + force x compliance."""
    k = 1.0 / value if effect == "compliance" else CONTACT_K
    c = 2 * DAMPING_RATIO * math.sqrt(k * DRIVE_MASS)
    if effect == "compliance":
        return -k * gap - c * rate
    half = 0.5 * value
    if abs(gap) <= half:
        return 0.0
    return -k * (gap - math.copysign(half, gap)) - c * rate


#: pairs hidden together with --two (no pair of declared look-alikes)
PAIRS = [("coulomb", "payload"), ("viscous", "gravity_tilt"), ("dead_zone", "rotor_inertia"),
         ("encoder_offset", "actuator_delay"), ("platform_mass", "dead_zone"), ("rotor_inertia", "coulomb")]


def _draw(effect, cfg, rng):
    lo, hi = cfg[EFFECTS[effect][0]]
    v = rng.uniform(lo, hi)
    if effect in ("platform_mass", "encoder_offset", "offset"):
        v *= rng.choice([-1, 1])
    return float(v)


def write_case(m: Model, rec: Recording, path) -> Path:
    """Write a run (MuJoCo's joint coordinates, zero at home) with that convention declared
    in its sidecar: recorded = model - q0.  Returns the CSV path."""
    csv, side = write_recording(path, rec)
    meta = json.loads(side.read_text())
    meta["joint_convention"] = {"sign": [1.0] * 6, "offset": (-m.ik(m.home())).tolist()}
    side.write_text(json.dumps(meta, indent=1))
    return csv


def plan(seed: int, n_clean: int, two: bool = False):
    """The cases: every effect type once (joint and magnitude drawn), or with ``two`` the
    PAIRS (two effects at once, on different joints), then the clean ones."""
    cfg = blind.load_config()["effects"]["6pus"]
    rng = np.random.default_rng(seed)
    cases = []
    if two:
        for i, pair in enumerate(PAIRS):
            joints = rng.choice(6, size=2, replace=False)
            cases.append(([(e, _draw(e, cfg, rng), int(j)) for e, j in zip(pair, joints)], 0.0, 0, seed * 100 + i))
    else:
        for i, effect in enumerate(EFFECTS):
            cases.append((effect, _draw(effect, cfg, rng), int(rng.integers(6)), seed * 100 + i))
    cases += [(None, 0.0, 0, seed * 100 + 50 + i) for i in range(n_clean)]
    return cases


def gap_joint(m: Model, seed: int, duration: float, joint: int) -> int:
    """The rail a backlash is put on: the drawn one if its feed-forward effort along this
    case's trajectory changes sign (the engine's GAP_MINORITY of the samples on the minority
    side, or more), else the next one that does (a gap on a one-signed rail is an offset of
    b/2 there, whatever its size: no recording can measure it).  The drawn rail when none does."""
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    neg = np.mean(m.inverse_dynamics(ref.x, ref.xd, ref.xdd) < 0, axis=0)
    ok = [j for j in range(6) if min(neg[j], 1 - neg[j]) >= GAP_MINORITY]
    return joint if joint in ok or not ok else min(ok, key=lambda j: (j - joint) % 6)


def _pair(m, hidden, seed, a, noise, rows):
    """A case hiding two effects: both must be named, each parameter within 15 %."""
    name = "+".join(e for e, _, _ in hidden) + f"_{seed}"
    rec, truth = simulate(m, hidden, 0.0, 0, seed, a.duration, noise, a.controller, gap_model=a.gap_model)
    csv = write_case(m, rec, a.out / f"{name}.csv")
    d = diagnose(csv, figures=False, replay=False)
    named = d.named()
    found = [e for e, _, _ in hidden if e in named or ALSO_RIGHT.get(e, set()) & set(named)
             or any(e in d.ties(k) for k in named)]
    est, nominal = d.plant_parameters(), m.params()
    n_par = ok_par = 0
    for e, _, j in hidden:
        key = EFFECTS[e][1]
        if key is None:
            continue
        key = key.format(j=j + 1)
        n_par += 1
        if key in est:
            ok_par += abs(est[key] - truth[key]) < 0.15 * abs(truth[key] - nominal.get(key, 0.0))
    rows.append({"case": name, "hidden": "+".join(e for e, _, _ in hidden), "named": named,
                 "ok": len(found) == len(hidden), "first_ok": bool(named) and any(named[0] == e or named[0] in ALSO_RIGHT.get(e, ()) for e, _, _ in hidden),
                 "params_ok": int(ok_par), "params_n": n_par, "conclusion": d.conclusion})
    print(f"{name:34s} named {', '.join(named[:4]) or 'none':40s} {'ok ' if rows[-1]['ok'] else 'MISS'}  "
          f"params {ok_par}/{n_par}", flush=True)


def case_options(ap: argparse.ArgumentParser, seed: int, out: Path) -> None:
    """Add the options of a blind run on a foreign simulator to ``ap``: the plan's ``--seed``
    (default ``seed``), ``--clean`` cases, ``--duration`` [s], ``--out`` folder (default
    ``out``) and ``--controller``."""
    ap.add_argument("--clean", type=int, default=4, help="clean cases (default 4)")
    ap.add_argument("--seed", type=int, default=seed, help=f"seed of the case plan (default {seed})")
    ap.add_argument("--duration", type=float, default=9.0, help="recorded seconds per case (default 9)")
    ap.add_argument("--out", type=Path, default=out, help="where the recordings go")
    ap.add_argument("--controller", choices=["pd_gravity", "pid"], default="pd_gravity",
                    help="the recordings' controller (default pd_gravity)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    case_options(ap, 11, REPO / "results" / "foreign")
    ap.add_argument("--gap-model", choices=["applied", "mujoco"], default="applied",
                    help="a two-body rail's gap or spring: a force applied per step (stiff faces, default) or "
                         "MuJoCo's own soft joint limit / joint stiffness")
    ap.add_argument("--two", action="store_true", help="hide two effects at once (PAIRS) instead of one")
    ap.add_argument("--hold-out", choices=["type", "family"], default=None,
                    help="diagnose each effect case with its type (or its type and the type's declared "
                         "look-alikes) taken out of the library: the check of 'structure left unexplained' (a case "
                         "counts when structure is reported)")
    ap.add_argument("--any-rail", action="store_true",
                    help="put a backlash on the drawn rail even where its effort keeps one sign (by default it "
                         "moves to a rail whose effort changes sign, where a gap can be measured)")
    ap.add_argument("--only", default=None, metavar="TYPE[,TYPE]",
                    help="run only these cases of the plan (effect types, or 'clean'); the others are drawn as usual")
    a = ap.parse_args(argv)
    only = None if a.only is None else set(a.only.split(","))
    if only and not only <= set(EFFECTS) | {"clean"}:
        ap.error(f"--only: unknown type(s) {', '.join(sorted(only - set(EFFECTS) - {'clean'}))}; "
                 f"known: {', '.join(EFFECTS)}, clean")
    m = Model("6pus")
    noise = blind.load_config()["noise"]["6pus"]
    a.out.mkdir(parents=True, exist_ok=True)
    rows, t_start = [], time.perf_counter()
    for effect, value, joint, seed in plan(a.seed, a.clean, a.two):
        if isinstance(effect, list):
            _pair(m, effect, seed, a, noise, rows)
            continue
        name = f"{effect or 'clean'}_{seed}"
        if only and (effect or "clean") not in only:
            continue
        if effect == "backlash" and not a.any_rail:
            joint = gap_joint(m, seed, a.duration, joint)
        try:
            rec, truth = simulate(m, effect, value, joint, seed, a.duration, noise, a.controller,
                                  gap_model=a.gap_model)
        except (ControllerError, JointLimitError) as e:  # the drawn case drove a rail off its stroke: not a recording
            print(f"{name:22s} NOT GENERATED ({e})", flush=True)
            continue
        csv = write_case(m, rec, a.out / f"{name}.csv")
        t0 = time.perf_counter()
        library = None
        if a.hold_out and effect:
            from cosim.discrepancy.effects import groups_for

            groups = groups_for(m, True)[0]
            out = {effect} | ALSO_RIGHT.get(effect, set())
            if a.hold_out == "family":
                out |= {k for g in groups if g.effect.key == effect for k in g.effect.lookalikes}
            library = sorted({g.effect.key for g in groups} - out)
        d = diagnose(csv, figures=False, replay=False, effects=library)  # blind: truth stays in this process
        wall = time.perf_counter() - t0
        named = d.named()
        first = named[0] if named else None
        ok = (first == effect or first in ALSO_RIGHT.get(effect, ())
              or (effect is not None and first is not None and effect in d.ties(first)))
        # a gap on a joint whose effort keeps one sign is a constant offset of b/2 on this recording:
        # right when the engine says so (offset b/2 within 10 %, backlash listed as not excited there)
        same = gap_as_offset(d, effect, value, joint)
        if same is not None:
            ok = same
        stand_in = False
        if a.hold_out and effect:
            ok = bool(d.unexplained)  # its type is not in the library: the structure must be reported
            key_p = EFFECTS[effect][1].format(j=joint + 1) if EFFECTS[effect][1] else None
            changes = {key_p: truth[key_p] - m.params().get(key_p, 0.0)} if key_p in truth else {}
            stand_in = not ok and bool(changes) and blind.same_physics_stand_in(effect, changes, d)
        # named first with confidence: right, and no tie among its look-alikes; "before" without
        # the look-alike that marks a fit leaving structure unexplained
        looks = d.effects[0]["lookalikes"] if d.effects else []
        confident = bool(ok and effect and not a.hold_out and not any(tied(x) for x in looks))
        confident_before = bool(ok and effect and not a.hold_out
                                and not any(tied(x) for x in looks if x["group"] != UNEXPLAINED))
        # ... and without the look-alike that marks a part left keyed on another joint
        confident_elsewhere = bool(ok and effect and not a.hold_out
                                   and not any(tied(x) for x in looks if x["group"] != KEYED_ELSEWHERE))
        est = d.plant_parameters()
        perr = None
        key = EFFECTS[effect][1].format(j=joint + 1) if effect and EFFECTS[effect][1] else None
        if key and key in est and key in truth:
            nominal = m.params()[key] if key in m.params() else 0.0
            perr = abs(est[key] - truth[key]) / max(abs(truth[key] - nominal), 1e-12)
        # the stated 95 % intervals against the truth, every hidden parameter the engine fitted
        stated = {p: v for e in d.effects for p, v in e["params"].items()}
        holds = [bool(abs(stated[p]["value"] - v) <= stated[p]["ci95"]) for p, v in truth.items()
                 if p in stated and np.isfinite(stated[p]["ci95"])]
        rows.append({"case": name, "hidden": effect or "clean", "value": value, "joint": joint + 1, "holds": holds,
                     "named": first or "none", "ok": bool(ok if effect else first is None), "param_error": perr,
                     "same_physics": same is not None, "stand_in": bool(stand_in), "confident": confident,
                     "confident_before": confident_before, "confident_elsewhere": confident_elsewhere,
                     "warnings": d.warnings, "unexplained": [e["channel"] for e in d.unexplained],
                     "conclusion": d.conclusion, "wall_s": wall,
                     "flexible": [(f.channel, round(f.share, 3), list(f.named)) for f in d.flexible
                                  if f.explained]})
        pe = "-" if perr is None else f"{100 * perr:.1f} %"
        print(f"{name:22s} hidden {effect or 'clean':15s} named {first or 'none':15s} "
              f"{'ok ' if rows[-1]['ok'] else 'MISS'}  param err {pe:>8s}  interval holds {sum(holds)}/{len(holds)}  ({wall:.1f} s)"
              f"{'  [one-signed effort: the gap is an offset b/2]' if same is not None else ''}"
              f"{'  [held out: named its same-physics stand-in at the right size]' if stand_in else ''}", flush=True)
    if a.two:
        pairs = [r for r in rows if "+" in r["hidden"]]
        print(f"\ntwo effects at once: both named {sum(r['ok'] for r in pairs)}/{len(pairs)}, the first named one of "
              f"the two {sum(r['first_ok'] for r in pairs)}/{len(pairs)}, parameters within 15 % "
              f"{sum(r['params_ok'] for r in pairs)}/{sum(r['params_n'] for r in pairs)}")
        rows = [r for r in rows if "+" not in r["hidden"]]
    eff = [r for r in rows if r["hidden"] != "clean"]
    clean = [r for r in rows if r["hidden"] == "clean"]
    if not rows:
        return 0
    comparable = [r for r in eff if r["param_error"] is not None]
    print(f"\nMuJoCo {__import__('mujoco').__version__}, controller {a.controller}, seed {a.seed}: {len(eff)} effect "
          f"cases over {len(eff)} types, {len(clean)} clean; {time.perf_counter() - t_start:.0f} s")
    if a.hold_out:
        print(f"type held out of the library, structure reported: {sum(r['ok'] for r in eff)}/{len(eff)}; "
              f"of the others, the same physics named at the right size: {sum(r['stand_in'] for r in eff)}")
    else:
        print(f"right effect named first:  {sum(r['ok'] for r in eff)}/{len(eff)} (of which a gap read as the offset "
              f"it is on a one-signed joint: {sum(r.get('same_physics', False) and r['ok'] for r in eff)})")
        print(f"right and named with confidence: {sum(r['confident'] for r in eff)}/{len(eff)} (without the "
              f"structure rule: {sum(r['confident_before'] for r in eff)}/{len(eff)}; without the keyed-elsewhere "
              f"rule: {sum(r['confident_elsewhere'] for r in eff)}/{len(eff)})")
    print(f"parameter within 15 %:     {sum(r['param_error'] < 0.15 for r in comparable)}/{len(comparable)} "
          f"comparable")
    print(f"clean cases called clean:  {sum(r['ok'] for r in clean)}/{len(clean)}")
    holds = [h for r in eff for h in r["holds"]]
    if holds:
        print(f"stated 95 % intervals containing the truth: {sum(holds)}/{len(holds)} hidden parameters fitted")
    print(f"structure left unexplained: {sum(bool(r['unexplained']) for r in eff)}/{len(eff)} effect cases, "
          f"{sum(bool(r['unexplained']) for r in clean)}/{len(clean)} clean cases")
    (a.out / "summary.json").write_text(json.dumps(rows, indent=1, default=float))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
