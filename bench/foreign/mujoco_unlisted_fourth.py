"""A fourth set of mechanisms for bench/foreign/mujoco_unlisted.py (``--kinds-set 4``), none of them
a kind of the first three sets, of the engine's own generators (the blind cases' unlisted forces,
the term families' forces, the flexible stage's proof cases), of the discovery step's families
or of the library's effects.  One is built in MuJoCo's model (a tendon); the others are forces
computed in MuJoCo's step from MuJoCo's state:

* ``end_cushion``: a pneumatic cushion at one end of rail j's stroke: past the entry q_c (the
  85-92 % quantile of the stroke on that side) the carriage's piston traps an air column of
  length L (2-4 times the deepest entry along the reference); moving in, the trapped air's force
  F rises polytropically, dF/dt = 1.4 (Fa + F) v_in / (L - x), and leaks out through the
  throttle over 0.05-0.2 s; moving out (or outside the cushion) a check valve vents it over
  5 ms: a one-way spring with a memory;
* ``misaligned_nut``: rail j's screw nut is aligned with its guide at one point q_a of the stroke
  (within its first or last 20 %) and misaligned in proportion to the distance from it: the edge
  load, and its friction, is the axial load |u_j| times |q_j - q_a| / h (h the reference's
  farthest distance from q_a): mu |u_j| |q_j - q_a| / h tanh(qd_j / v) (mu at most 0.5, sized
  with the loop's make-up of the friction along the reference, which raises the command);
* ``magnet_heating``: rail j's motor magnets weaken as its copper heats: the delivered force falls
  by beta theta u_j, theta the command's square over its mean along the reference low-passed over
  3-8 s, from cold at the run's start (beta at most 0.25, theta counted up to 1.5; beta sized
  with the loop's make-up of the loss along the reference, u x / (1 - x));
* ``coil_crosstalk``: the stray field of rail k's motor coil reaches carriage j's magnets when the
  carriages pass abreast: c u_k exp(-((q_j - q_k - d0) / w)^2) on rail j (c at most 0.5, d0 the
  30-70 % quantile of q_j - q_k, w 10-20 % of its range), its reaction on rail k;
* ``neighbour_heat``: rail k's motor, mounted beside rail j's guide, heats it: the guide's
  clearance closes and its Coulomb friction rises with k's copper heat, c theta_k tanh(qd_j / v),
  theta_k rail k's command squared over its mean along the reference low-passed over 2-6 s from
  cold;
* ``coiled_cord``: a coiled spring cord from carriage j's top to a point of the platform 20-50 mm
  off its centre: a MuJoCo spatial tendon with ``stiffness``, its rest length the cord's mean
  length along the reference (a tension of either sign about it, its RMS 0.1-0.2 N);
* ``eddy_plate``: a magnet under the platform over a fixed copper plate: an eddy-current drag on
  the platform's horizontal velocity, -c0 (g0 / h)^2 v_xy, h the magnet's height over the plate
  (g0 1-3 mm at the reference's lowest point), its RMS along the reference 0.1-0.2 N;
* ``air_jet_lift``: a horizontal air jet across the platform's top plate: a lift
  L0 (1 - v_d / U)^2 sin(2 alpha) along the vertical, alpha the plate's angle of attack (its tilt
  into the jet), v_d the platform's speed along the jet (U 2-4 times the reference's fastest),
  applied 5-15 mm upstream of the platform's centre (a pitching moment), its RMS along the
  reference 0.3-0.6 N;
* ``bundle_torsion``: a cable bundle through the platform twisted as the platform turns about the
  vertical: a torsion spring -k psi and the wires' rubbing, a Dahl friction h that builds over a
  twist psi_c (5-15 % of the reference's RMS yaw) towards +-T_f as psi turns (40-60 % of the
  torque's RMS, which is 8-16 mN m);
* ``floor_vibration``: a press beside the machine shakes the floor: the robot's base accelerates
  a0 sin(2 pi f t + phi) along a horizontal direction (a0 0.3-0.6 m/s^2, f 2-6 Hz): every body
  feels -m a (MuJoCo's gravity moved by -a in the step).

Magnitudes are physical guesses drawn as the third set's, relative to the rail's effort: a rail
force's RMS along the case's reference is 10-20 % of the rail's RMS effort (8-38 times the 5 mN
effort noise); the platform kinds' sizes are stated in N, N m and m/s^2 beside them.  The inputs
each is keyed on (:func:`keyed_fourth`) were written with the mechanisms, before any run of the
engine on them; their sizes over the noise were then checked from the truth alone (noise-free
MuJoCo runs, the mechanism on against off, no diagnosis) at seeds outside the bench's draws.
"""
from __future__ import annotations

import math

import numpy as np
from unlisted_common import elapsed, lowpass, platform_dof, rms, slider_groups, two_rails

KINDS_FOURTH = ("end_cushion", "eddy_plate", "misaligned_nut", "air_jet_lift", "coil_crosstalk", "coiled_cord",
                "magnet_heating", "bundle_torsion", "neighbour_heat", "floor_vibration")
#: judged over every channel: the platform's mechanisms, the cord from a carriage to the platform, the floor's
PLATFORM_FOURTH = ("eddy_plate", "air_jet_lift", "coiled_cord", "bundle_torsion", "floor_vibration")
#: the rails' forces on two rails' channels
TWO_RAIL_FOURTH = ("coil_crosstalk",)
#: seeds: SEED_FOURTH + the kind's index in KINDS_FOURTH, clean cases SEED_FOURTH + 90 + i (fixed before any run)
SEED_FOURTH = 57700
V_SIGN = 3e-4  # velocity scale of the smooth sign on a rail [m/s]
GAMMA = 1.4  # air's polytropic exponent (adiabatic) in the cushion
VENT = 0.005  # the cushion's check valve's venting time [s]
#: the magnets' loss per unit of heat at most, and the heat counted at most: the delivered force falls by at most
#: 37.5 % (the made-up command heats the copper more: a loss unbounded there runs away)
LOSS, HOT = 0.25, 1.5


def keyed_fourth(kind, j=None, k=None) -> dict:
    """The inputs (flexible-stage groups) a fourth-set mechanism is keyed on: ``need`` (all
    named), ``any`` (one of them named), ``allowed`` (nothing else named); ``j``, ``k`` 1-based
    rails.  Written before any run; the reason for each is the physics beside it."""
    pos, rate, acc, pose = slider_groups()
    hist = {f"history of slider {i}" for i in range(1, 7)}
    if kind == "coiled_cord":
        # a spring on the cord's length, a function of carriage j's position and the platform's
        # pose (which the rails' positions set); no damping
        return {"need": set(), "any": pos | pose, "allowed": pos | pose}
    if kind == "eddy_plate":
        # a drag on the platform's velocity (the rails' rates through the Jacobian), its level set
        # by the height (the pose, the rails' positions)
        return {"need": set(), "any": rate, "allowed": rate | pos | pose}
    if kind == "air_jet_lift":
        # a function of the plate's tilt (the pose, the rails' positions), scaled by the flow's
        # speed relative to the platform (the rails' rates)
        return {"need": set(), "any": pos | pose, "allowed": pos | pose | rate}
    if kind == "bundle_torsion":
        # a spring on the yaw (the pose, the rails' positions) and a friction whose state is the
        # yaw's path since it last turned (the direction of motion: the rails' rates and histories)
        return {"need": set(), "any": pos | pose, "allowed": pos | pose | rate | hist}
    if kind == "floor_vibration":
        # the base's shake runs on its own clock (time); its inertial force reaches each rail
        # through the pose (the rails' positions)
        return {"need": {"time"}, "any": set(), "allowed": {"time"} | pos | pose}
    own = lambda q: f"{q} of slider {j}"  # noqa: E731
    other = lambda q: f"{q} of slider {k}"  # noqa: E731
    if kind == "end_cushion":
        # the trapped air pushes only inside the cushion (the position) while the carriage moves
        # in (the rate's sign); its pressure remembers the way in (the history)
        need = {own("position"), own("rate")}
        return {"need": need, "any": set(), "allowed": need | {own("history")}}
    if kind == "misaligned_nut":
        # a friction (the rate's sign) whose level is the axial load (the effort) times the
        # misalignment (the position)
        need = {own("effort"), own("position"), own("rate")}
        return {"need": need, "any": set(), "allowed": need | {own("history")}}
    if kind == "magnet_heating":
        # the command times the copper's heat, the command's square low-passed over seconds (the
        # history), rising over a run that starts cold (time)
        return {"need": {own("effort")}, "any": {own("history"), "time"},
                "allowed": {own("effort"), own("history"), "time"}}
    if kind == "coil_crosstalk":
        # rail k's command times a function of the carriages' offset q_j - q_k, on both channels
        need = {other("effort"), own("position"), other("position")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "neighbour_heat":
        # a Coulomb friction (rail j's rate's sign) whose level is rail k's copper heat (its
        # history), rising over a run that starts cold (time)
        return {"need": {own("rate")}, "any": {other("history"), "time"},
                "allowed": {own("rate"), own("history"), other("history"), "time"}}
    raise ValueError(kind)


def _rotation(xr):
    """The platform's rotation matrices (n, 3, 3) of the core's poses' angles, R = Rx Ry Rz."""
    a, b, c = (np.asarray(xr)[:, i] for i in (3, 4, 5))
    o, z = np.ones_like(a), np.zeros_like(a)
    rx = np.stack([o, z, z, z, np.cos(a), -np.sin(a), z, np.sin(a), np.cos(a)], -1).reshape(-1, 3, 3)
    ry = np.stack([np.cos(b), z, np.sin(b), z, o, z, -np.sin(b), z, np.cos(b)], -1).reshape(-1, 3, 3)
    rz = np.stack([np.cos(c), -np.sin(c), z, np.sin(c), np.cos(c), z, z, z, o], -1).reshape(-1, 3, 3)
    return rx @ ry @ rz


def _cord(rng, m, mo):
    import mujoco
    import mujoco_blind as mb

    j = int(rng.integers(6))
    a = float(rng.uniform(0, 2 * math.pi))
    tie = float(rng.uniform(0.02, 0.05)) * np.array([math.cos(a), math.sin(a), 0.0])  # platform frame [m]
    top = np.array([0.0, 0.0, 0.005])  # the carriage's top [m]
    model = mujoco.MjModel.from_xml_string(mb.case_xml(m, [], None)[0])
    base = np.asarray(model.body(f"slider{j}").pos) + top
    q0 = np.asarray(m.ik(m.home()))
    ends = base + np.outer(np.asarray(mo["qref"])[:, j] - q0[j], [1.0, 0.0, 0.0])
    tips = np.asarray(mo["xp"]) + _rotation(mo["xr"]) @ tie
    length = np.linalg.norm(tips - ends, axis=1)
    rest = float(np.mean(length))
    force = float(rng.uniform(0.1, 0.2))  # the tension's RMS along the reference [N]
    k = force / max(rms(length - rest), 1e-12)

    def edit(xml):
        head = f'<joint name="rail{j}" type="slide" axis="1 0 0"/>'
        xml = xml.replace(head, f'{head}\n      <site name="cord_a" pos="{top[0]:g} {top[1]:g} {top[2]:g}"/>', 1)
        tip = f'<site name="cord_b" pos="{tie[0]:.9g} {tie[1]:.9g} 0"/>'
        xml = xml.replace("<freejoint/>", f"<freejoint/>\n      {tip}", 1)
        return xml.replace("</equality>", f'''</equality>
  <tendon>
    <spatial name="cord" stiffness="{k:.9g}" springlength="{rest:.9g}">
      <site site="cord_a"/><site site="cord_b"/></spatial>
  </tendon>''', 1)
    return None, edit, {"carriage": j + 1, "tie": tie.tolist(), "top": top.tolist(), "stiffness": k,
                        "rest_length": rest, "tension_rms": force}


def _eddy(rng, mo):
    from mujoco_blind import DT

    xp = np.asarray(mo["xp"])
    g0 = float(rng.uniform(1e-3, 3e-3))
    plate = float(xp[:, 2].min()) - g0  # the plate's surface [m]
    level = lambda h: (g0 / np.maximum(h, 0.2 * g0)) ** 2  # noqa: E731
    v = np.gradient(xp, DT, axis=0)
    force = float(rng.uniform(0.1, 0.2))  # the drag's RMS along the reference [N]
    c0 = force / max(rms(level(xp[:, 2] - plate)[:, None] * v[:, :2]) * math.sqrt(2), 1e-12)
    ids = {}

    def hook(model, data, t, q, qd, u):
        if not ids:
            ids["b"], ids["adr"] = platform_dof(model)
        b, adr = ids["b"], ids["adr"]
        c = c0 * float(level(data.xpos[b][2] - plate))
        data.xfrc_applied[b, :] = 0.0
        data.xfrc_applied[b, :2] = -c * data.qvel[adr:adr + 2]  # the free joint's linear velocity: world frame
    return hook, None, {"damping_at_g0": c0, "gap": g0, "plate": plate, "force_rms": force}


def _jet(rng, mo):
    from mujoco_blind import DT

    a = float(rng.uniform(0, 2 * math.pi))
    d = np.array([math.cos(a), math.sin(a), 0.0])  # the jet's direction (world, level)
    xp = np.asarray(mo["xp"])
    v_d = np.gradient(xp, DT, axis=0) @ d
    U = float(rng.uniform(2.0, 4.0)) * float(np.abs(v_d).max())
    r = -float(rng.uniform(0.005, 0.015)) * d  # the centre of pressure, upstream [m]
    alpha = np.arcsin(np.clip(-(_rotation(mo["xr"])[:, :, 2] @ d), -1, 1))
    lift = float(rng.uniform(0.3, 0.6))  # the lift's RMS along the reference [N]
    L0 = lift / max(rms((1 - v_d / U) ** 2 * np.sin(2 * alpha)), 1e-12)
    ids = {}

    def hook(model, data, t, q, qd, u):
        if not ids:
            ids["b"], ids["adr"] = platform_dof(model)
        b, adr = ids["b"], ids["adr"]
        n = data.xmat[b].reshape(3, 3)[:, 2]
        al = math.asin(max(-1.0, min(1.0, -float(n @ d))))
        rel = 1.0 - float(data.qvel[adr:adr + 3] @ d) / U
        f = np.array([0.0, 0.0, L0 * rel * rel * math.sin(2 * al)])
        data.xfrc_applied[b, :3] = f
        data.xfrc_applied[b, 3:] = np.cross(r, f)
    return hook, None, {"direction": d.tolist(), "jet_speed": U, "lift_scale": L0, "centre_of_pressure": r.tolist(),
                        "lift_rms": lift}


def dahl(g, dpsi, psi_c):
    """The Dahl friction's state (its torque over T_f) after a turn ``dpsi`` [rad]: towards the
    turn's sign over the twist ``psi_c`` [rad] (the exact solution of dg/dpsi = (1 - g sign) / psi_c)."""
    if dpsi == 0.0:
        return g
    s = math.copysign(1.0, dpsi)
    return s + (g - s) * math.exp(-abs(dpsi) / psi_c)


def _yaw(R):
    return math.atan2(-R[0, 1], R[0, 0])  # mujoco_blind.euler_xyz's third angle


def _torsion(rng, mo):
    psi_ref = np.asarray(mo["xr"])[:, 5]
    psi_c = float(rng.uniform(0.05, 0.15)) * rms(psi_ref)
    g = np.zeros(len(psi_ref))
    for i in range(1, len(g)):
        g[i] = dahl(g[i - 1], float(psi_ref[i] - psi_ref[i - 1]), psi_c)
    torque = float(rng.uniform(0.008, 0.016))  # the torque's RMS along the reference [N m]
    share = float(rng.uniform(0.4, 0.6))  # the friction's part of it
    t_f = share * torque / max(rms(g), 1e-12)
    k = (1 - share) * torque / max(rms(psi_ref), 1e-12)
    state, ids = {"g": 0.0, "psi": None}, {}

    def hook(model, data, t, q, qd, u):
        if not ids:
            ids["b"], _ = platform_dof(model)
        b = ids["b"]
        psi = _yaw(data.xmat[b].reshape(3, 3))
        if state["psi"] is not None:
            state["g"] = dahl(state["g"], psi - state["psi"], psi_c)
        state["psi"] = psi
        data.xfrc_applied[b, :] = 0.0
        data.xfrc_applied[b, 5] = -k * psi - t_f * state["g"]
    return hook, None, {"stiffness": k, "friction": t_f, "twist_scale": psi_c, "torque_rms": torque}


def _floor(rng):
    a0, f = float(rng.uniform(0.3, 0.6)), float(rng.uniform(2.0, 6.0))
    ph, a = float(rng.uniform(0, 2 * math.pi)), float(rng.uniform(0, 2 * math.pi))
    e = np.array([math.cos(a), math.sin(a), 0.0])
    g = {}

    def hook(model, data, t, q, qd, u):
        if not g:
            g["g"] = np.array(model.opt.gravity)
        model.opt.gravity[:] = g["g"] - a0 * math.sin(2 * math.pi * f * t + ph) * e
    return hook, None, {"amplitude": a0, "frequency": f, "phase": ph, "direction": e.tolist()}


def _platform_mechanism(kind, rng, m, mo):
    """(hook, edit, truth) of a fourth-set mechanism judged over every channel."""
    if kind == "coiled_cord":
        return _cord(rng, m, mo)
    made = {"eddy_plate": lambda: _eddy(rng, mo), "air_jet_lift": lambda: _jet(rng, mo),
            "bundle_torsion": lambda: _torsion(rng, mo), "floor_vibration": lambda: _floor(rng)}
    if kind not in made:
        raise ValueError(kind)
    return made[kind]()


def cushion(F, x, v_in, dt, Fa, L, leak):
    """The cushion's force [N] after ``dt`` [s] from ``F``: rising polytropically while the carriage
    is ``x`` [m] inside it moving in at ``v_in`` [m/s] (the air column ``L`` [m], the atmosphere's
    force on the piston ``Fa`` [N]) and leaking over ``leak`` [s]; vented over VENT otherwise."""
    if x > 0.0 and v_in > 0.0:
        F += GAMMA * (Fa + F) * v_in / max(L - x, 0.1 * L) * dt
        return F * math.exp(-dt / leak)
    return F * math.exp(-dt / VENT)


def _end_cushion(rng, mo, j, target):
    from mujoco_blind import DT

    side = float(rng.choice([-1.0, 1.0]))
    s_ref = side * np.asarray(mo["qref"])[:, j]
    entry = float(np.quantile(s_ref, rng.uniform(0.85, 0.92)))
    L = float(rng.uniform(2.0, 4.0)) * float(s_ref.max() - entry)
    leak = float(rng.uniform(0.05, 0.2))
    v_ref = np.gradient(s_ref, DT)
    unit = np.zeros(len(s_ref))  # the force with Fa = 1 N: the force is linear in Fa
    for i in range(1, len(unit)):
        unit[i] = cushion(unit[i - 1], float(s_ref[i] - entry), float(v_ref[i]), DT, 1.0, L, leak)
    Fa = target / max(rms(unit), 1e-12)
    state = {"F": 0.0}

    def hook(model, data, t, q, qd, u):
        dt = elapsed(state, t)
        state["F"] = cushion(state["F"], side * q[j] - entry, side * qd[j], dt, Fa, L, leak)
        f = np.zeros(len(q))
        f[j] = -side * state["F"]
        return f
    return hook, {"side": side, "entry": side * entry, "air_column": L, "atmosphere_force": Fa, "leak": leak}


def _nut(rng, mo, j, target):
    from mujoco_blind import DT

    q, u = np.asarray(mo["qref"])[:, j], np.asarray(mo["u"])[:, j]
    end = rng.uniform(0.0, 0.2)
    q_a = float(np.quantile(q, end if rng.uniform() < 0.5 else 1.0 - end))
    h = float(np.abs(q - q_a).max())  # the misalignment is largest, mu, at the reference's farthest point
    s = np.tanh(np.gradient(q, DT) / V_SIGN)
    w = np.abs(q - q_a) / h

    def made_up(mu):
        """The friction along the reference with the loop making it up: the command's magnitude
        |u'| = |u| + mu w |u'| s sign(u), so the friction mu w |u'| is mu w |u| / (1 - mu w s sign(u))."""
        return rms(mu * w * np.abs(u) * s / (1 - mu * w * s * np.sign(u)))
    grid = np.linspace(0.0, 0.5, 501)[1:]  # mu at most 0.5: the loop's make-up at most doubles the friction
    mu = float(grid[max(int(np.searchsorted([made_up(g) for g in grid], target)) - 1, 0)])

    def hook(model, data, t, q, qd, cmd):
        f = np.zeros(len(q))
        f[j] = -mu * abs(cmd[j]) * abs(q[j] - q_a) / h * math.tanh(qd[j] / V_SIGN)
        return f
    return hook, {"mu": mu, "aligned_at": q_a, "farthest": h}


def heat(state, t, u, u_ms, tau) -> float:
    """A copper's temperature over its steady value at the mean square command ``u_ms`` [N^2]: the
    command's square low-passed over ``tau`` [s] from cold; returns the value at the step's start
    and steps it to time ``t`` [s] with the command ``u`` [N] held over the step."""
    theta = state.get("theta", 0.0)
    state["theta"] = theta + (1 - math.exp(-elapsed(state, t) / tau)) * (u * u / u_ms - theta)
    return theta


def _magnet_heating(rng, mo, j, target):
    from mujoco_blind import DT

    u = np.asarray(mo["u"])[:, j]
    u_ms, tau = float(np.mean(u * u)), float(rng.uniform(3.0, 8.0))
    theta = np.minimum(lowpass(np.r_[0.0, 0.0, u[1:-1] ** 2 / u_ms], DT, tau), HOT)  # cold at the recording's start

    def made_up(beta):
        """The command's rise along the reference that makes up the loss x = beta theta: u x / (1 - x)."""
        return rms(u * beta * theta / (1 - beta * theta))
    grid = np.linspace(0.0, LOSS, 501)[1:]
    beta = float(grid[max(int(np.searchsorted([made_up(g) for g in grid], target)) - 1, 0)])
    state = {}

    def hook(model, data, t, q, qd, cmd):
        f = np.zeros(len(q))
        f[j] = -beta * min(heat(state, t, cmd[j], u_ms, tau), HOT) * cmd[j]
        return f
    return hook, {"loss": beta, "tau": tau, "mean_square": u_ms}


def _neighbour_heat(rng, mo, j, k, target):
    from mujoco_blind import DT

    u = np.asarray(mo["u"])[:, k]
    u_ms, tau = float(np.mean(u * u)), float(rng.uniform(2.0, 6.0))
    theta = np.minimum(lowpass(np.r_[0.0, 0.0, u[1:-1] ** 2 / u_ms], DT, tau), 2.0)
    c = target / max(rms(theta * np.tanh(np.gradient(np.asarray(mo["qref"])[:, j], DT) / V_SIGN)), 1e-12)
    state = {}

    def hook(model, data, t, q, qd, cmd):
        f = np.zeros(len(q))
        f[j] = -c * min(heat(state, t, cmd[k], u_ms, tau), 2.0) * math.tanh(qd[j] / V_SIGN)  # 2: as the draw's
        return f
    return hook, {"level": c, "tau": tau, "mean_square_other": u_ms}


def _crosstalk(rng, mo, j, k, target):
    q, u = np.asarray(mo["qref"]), np.asarray(mo["u"])
    dq = q[:, j] - q[:, k]
    d0 = float(np.quantile(dq, rng.uniform(0.3, 0.7)))
    w = float(rng.uniform(0.1, 0.2)) * float(np.ptp(dq))
    c = min(target / max(rms(u[:, k] * np.exp(-(((dq - d0) / w) ** 2))), 1e-12), 0.5)

    def hook(model, data, t, q, qd, cmd):
        f = np.zeros(len(q))
        f[j] = c * cmd[k] * math.exp(-(((q[j] - q[k] - d0) / w) ** 2))
        f[k] = -f[j]
        return f
    return hook, {"coupling": c, "offset": d0, "width": w}


def _rail_mechanism(kind, rng, m, mo):
    """(hook, truth, j, k) of a fourth-set force on rails (0-based j; k the other rail or None)."""
    n = len(mo["E"])
    j, k = two_rails(rng, n)
    target = float(rng.uniform(0.1, 0.2)) * float(mo["E"][j])  # the force's RMS along the reference [N]
    if kind in ("coil_crosstalk", "neighbour_heat"):
        hook, truth = (_crosstalk if kind == "coil_crosstalk" else _neighbour_heat)(rng, mo, j, k, target)
        return hook, {**truth, "rms_target": target}, j, k
    made = {"end_cushion": _end_cushion, "misaligned_nut": _nut, "magnet_heating": _magnet_heating}
    if kind not in made:
        raise ValueError(kind)
    hook, truth = made[kind](rng, mo, j, target)
    return hook, {**truth, "rms_target": target}, j, None


def draw_fourth(kind, rng, m, mo):
    """(hook, edit, truth, keyed-on inputs, the rails the force acts on (1-based; an int, a tuple
    of two for the coils' crosstalk, or None where every channel is judged)) of one fourth-set
    case; ``mo`` is mujoco_unlisted.motion's."""
    if kind in PLATFORM_FOURTH:
        hook, edit, truth = _platform_mechanism(kind, rng, m, mo)
        return hook, edit, truth, keyed_fourth(kind), None
    hook, truth, j, k = _rail_mechanism(kind, rng, m, mo)
    truth.update(rail=j + 1, **({"other_rail": k + 1} if k is not None else {}))
    joint = (j + 1, k + 1) if kind in TWO_RAIL_FOURTH else j + 1
    return hook, None, truth, keyed_fourth(kind, j + 1, None if k is None else k + 1), joint
