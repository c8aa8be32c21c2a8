"""A third set of mechanisms for bench/foreign/mujoco_unlisted.py (``--kinds-set 3``), none of them
a kind of the first two sets.  Three are built in MuJoCo's model (a body and joint, a tendon, a
joint's own stiffness); the others are forces computed in MuJoCo's step from MuJoCo's state:

* ``thrust_ripple``: rail j's linear motor delivers its command with a ripple that depends on the
  current and the carriage's position together (the magnets' pole pitch): the extra force
  r u_j sin(2 pi q_j / p + phi) (r at most 0.3, p 10-30 mm);
* ``vacuum_hose``: a vacuum hose hung on the platform, viscoelastic: a Maxwell element (a spring
  k in series with a dashpot c, relaxation time c / k 0.1-0.4 s) between the hose's clamp on the
  platform, 20-40 mm off its centre, and its anchor, along a fixed direction (its state is the
  dashpot's stretch);
* ``wiper_debris``: a wiper on rail j that collects debris: a Coulomb friction starting at zero,
  its level rising with the distance the carriage has travelled, c (1 - exp(-s / s0)) (s0 30-60 %
  of the run's distance along the reference);
* ``loose_payload``: a payload (15-30 % of the platform's mass, taken off the platform's) loose in
  a tray on the platform: a MuJoCo slide joint along a direction level in the platform with a
  play of +-5-15 mm (joint limits) and a dry friction (``frictionloss``) that holds it until the
  pull along the tray (gravity through the platform's tilt less its acceleration) passes the
  50-70 % quantile of the reference's; it then slides to the play's end, moving the carried
  mass's centre (a moment the platform's tilt history sets);
* ``coupling_damper``: a damper between carriages j and k (a MuJoCo fixed tendon q_j - q_k with
  ``damping``): -c (qd_j - qd_k) on rail j, the opposite on rail k;
* ``backemf_limit``: rail j's drive runs out of voltage at speed (back-EMF): the force it can
  deliver falls as Fs (1 - |qd_j| / v0) (v0 1.5-3 times the rail's fastest reference rate, Fs the
  60-80 % quantile of what the reference asks at its speed); the delivered force falls short by
  s (|u_j| - Fs (1 - |qd_j| / v0))+ (s at most 0.8, the current loop's finite gain), so the
  position loop asks s / (1 - s) times the reference's excess over the limit more;
* ``brake_window``: rail j's holding brake drags while not fully released over a window of the
  run (1.5-3 s wide, starting 1.5-5.5 s after the run's start, edges 0.1 s): a Coulomb friction
  in that window only;
* ``flexure_joint``: one leg's passive spherical joint is an elastic flexure: MuJoCo's ball
  joint with a rotational ``stiffness`` of 0.1-0.4 N m/rad (rest at the home pose) and a
  ``damping`` of 0.5-1 % of it per second;
* ``shared_bus_sag``: rails j and k share a DC bus that sags under k's current: rail j's
  delivered force falls by the fraction x = s |u_k| / mean |u_k| (x and s at most 0.5; s sized so
  the command's rise that makes the sag up along the reference, u_j x / (1 - x), has the target
  RMS about its mean, the mean being an offset);
* ``grease_warming``: rail j's grease thins as it warms: a viscous friction c0 (1 - 0.5 theta)
  whose temperature theta follows the dissipated power |u_j qd_j| over its mean along the
  reference with a time constant of 2-5 s, from cold at the run's start.

Magnitudes are physical guesses drawn as the second set's, relative to the rail's effort: a rail
force's RMS along the case's reference is 10-20 % of the rail's RMS effort (0.4-0.95 N: 8-38
times the 5 mN effort noise); the platform and leg kinds' sizes are stated in N, kg and N m / rad
beside them.  Their sizes over the noise (the effort's RMS change over 5 mN on the most affected
channel) were checked on noise-free MuJoCo runs, the mechanism on against off, at seeds outside
the bench's draws, before any diagnosis.  The inputs each is keyed on
(:func:`keyed_third`) were written with the mechanisms, before any run of the engine.
"""
from __future__ import annotations

import math

import numpy as np
from unlisted_common import lowpass, platform_dof, rms, slider_groups, two_rails

KINDS_THIRD = ("thrust_ripple", "vacuum_hose", "wiper_debris", "loose_payload", "coupling_damper",
               "backemf_limit", "brake_window", "flexure_joint", "shared_bus_sag", "grease_warming")
#: judged over every channel: the platform's and the leg's mechanisms
PLATFORM_THIRD = ("vacuum_hose", "loose_payload", "flexure_joint")
#: seeds: SEED_THIRD + the kind's index in KINDS_THIRD, clean cases SEED_THIRD + 90 + i (fixed before any run)
SEED_THIRD = 53700
V_SIGN = 3e-4  # velocity scale of the smooth sign on a rail [m/s]
LEAD = 0.5  # the run's standstill before the recording [s] (mujoco_unlisted.LEAD)


def keyed_third(kind, j=None, k=None) -> dict:
    """The inputs (flexible-stage groups) a third-set mechanism is keyed on: ``need`` (all
    named), ``any`` (one of them named), ``allowed`` (nothing else named); ``j``, ``k`` 1-based
    rails.  Written before any run; the reason for each is the physics beside it."""
    pos, rate, acc, pose = slider_groups()
    if kind == "vacuum_hose":
        # the Maxwell element's force is c times the clamp's velocity low-passed over c / k: the
        # rails' rates (and, the lag, their accelerations) through the Jacobian the pose sets; its
        # stretch is the clamp's displacement high-passed (positions)
        return {"need": set(), "any": rate | pos | pose, "allowed": rate | acc | pos | pose}
    if kind == "loose_payload":
        # held by its friction the payload moves with the platform; it slides when the pull along
        # the tray (gravity through the tilt, less the acceleration) passes its friction's, and
        # rests at the play's ends off the platform's centre: its weight's moment is set by where
        # the tilt last pushed it (the pose, the rails' positions), the slide by the accelerations
        return {"need": set(), "any": acc | pos | pose, "allowed": acc | rate | pos | pose}
    if kind == "flexure_joint":
        # an elastic joint: a moment on the leg's angles from home, functions of the pose (the
        # rails' positions set it); its damping on their rates
        return {"need": set(), "any": pos | pose, "allowed": pos | pose | rate}
    own = lambda q: f"{q} of slider {j}"  # noqa: E731
    other = lambda q: f"{q} of slider {k}"  # noqa: E731
    if kind == "thrust_ripple":
        # the ripple is the command times a function of the carriage's position: both
        need = {own("effort"), own("position")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "wiper_debris":
        # a Coulomb friction (the sign of the rate) whose level is the distance travelled, which
        # rises over the run (time) and with the carriage's past speed (its history)
        return {"need": {own("rate")}, "any": {own("history"), "time"},
                "allowed": {own("rate"), own("history"), "time"}}
    if kind == "coupling_damper":
        # a force on the difference of the two rates, on both rails' channels
        need = {own("rate"), other("rate")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "backemf_limit":
        # the shortfall is a function of the command and the carriage's speed
        need = {own("effort"), own("rate")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "brake_window":
        # a Coulomb friction (the rate's sign) over a window of time
        need = {own("rate"), "time"}
        return {"need": need, "any": set(), "allowed": need | {own("history")}}
    if kind == "shared_bus_sag":
        # the command of rail j times the magnitude of rail k's: both efforts
        need = {own("effort"), other("effort")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "grease_warming":
        # a viscous friction (the rate) whose level falls with a temperature, the dissipated power
        # low-passed over seconds (the history's power columns), rising over a run that starts cold
        return {"need": {own("rate")}, "any": {own("history"), "time"},
                "allowed": {own("rate"), own("history"), "time"}}
    raise ValueError(kind)


def _platform_mechanism(kind, rng, m, mo):
    """(hook, edit, truth) of a third-set mechanism on the platform or a leg."""
    from mujoco_blind import DT

    M = m.params()["platform.m"]
    home = np.asarray(m.home()[:3])
    if kind == "vacuum_hose":
        a = float(rng.uniform(0, 2 * math.pi))
        clamp = float(rng.uniform(0.02, 0.04)) * np.array([math.cos(a), math.sin(a), 0.0])  # platform frame [m]
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        tau = float(rng.uniform(0.1, 0.4))
        force = float(rng.uniform(0.05, 0.15))  # the force's RMS along the reference [N]
        s_ref = (np.asarray(mo["xp"]) - home) @ d  # the clamp's displacement, the platform's rotation aside
        k = force / max(rms(s_ref - lowpass(s_ref, DT, tau)), 1e-12)
        state = {"t": None, "sd": 0.0}
        ids = {}

        def hook(model, data, t, q, qd, u):
            if not ids:
                ids["b"], _ = platform_dof(model)
            b = ids["b"]
            R = data.xmat[b].reshape(3, 3)
            p = data.xpos[b] + R @ clamp
            s = float(d @ (p - home - clamp))
            if state["t"] is not None and t > state["t"]:
                state["sd"] += (t - state["t"]) / tau * (s - state["sd"])
            state["t"] = t
            f = -k * (s - state["sd"]) * d
            data.xfrc_applied[b, :3] = f
            data.xfrc_applied[b, 3:] = np.cross(p - data.xpos[b], f)
        return hook, None, {"clamp": clamp.tolist(), "direction": d.tolist(), "stiffness": k, "relaxation": tau,
                            "force_rms": force}
    if kind == "loose_payload":
        mp = float(rng.uniform(0.15, 0.3)) * M
        a = float(rng.uniform(0, 2 * math.pi))
        axis = np.array([math.cos(a), math.sin(a), 0.0])
        play = float(rng.uniform(5e-3, 15e-3))
        acc = np.gradient(np.gradient(np.asarray(mo["xp"]), DT, axis=0), DT, axis=0) @ axis
        tilt = np.asarray(mo["xr"])[:, 3:5]  # small angles: gravity along the level axis g (ty ax - tx ay)
        pull = 9.81 * (tilt[:, 1] * axis[0] - tilt[:, 0] * axis[1]) - acc
        a_hold = float(np.quantile(np.abs(pull), rng.uniform(0.5, 0.7)))
        loss = mp * a_hold  # [N]

        def edit(xml):
            head = '<inertial pos="0 0 0" mass='
            xml = xml.replace(f'{head}"{M:.17g}"', f'{head}"{M - mp:.17g}"', 1)
            return xml.replace("<freejoint/>", f'''<freejoint/>
      <body name="tray" pos="0 0 0"><joint name="tray" type="slide" axis="{axis[0]:.9g} {axis[1]:.9g} 0"
        limited="true" range="{-play:.9g} {play:.9g}" solreflimit="0.005 1" frictionloss="{loss:.9g}"/>
        <inertial pos="0 0 0" mass="{mp:.9g}" diaginertia="1e-9 1e-9 1e-9"/></body>''', 1)
        return None, edit, {"mass": mp, "axis": axis.tolist(), "play": play, "frictionloss": loss,
                            "holds_below": a_hold}
    if kind == "flexure_joint":
        leg = int(rng.integers(6))
        k = float(rng.uniform(0.1, 0.4))  # [N m/rad]
        c = k * float(rng.uniform(0.005, 0.01))  # [N m s/rad]: the flexure's material loss

        def edit(xml):
            return xml.replace(f'<joint name="u{leg}" type="ball"/>',
                               f'<joint name="u{leg}" type="ball" stiffness="{k:.9g}" damping="{c:.9g}"/>', 1)
        return None, edit, {"leg": leg + 1, "stiffness": k, "damping": c}
    raise ValueError(kind)


def _coupling(rng, mo, j, k, target):
    from mujoco_blind import DT

    dv = np.gradient(np.asarray(mo["qref"])[:, j] - np.asarray(mo["qref"])[:, k], DT)
    c = target / max(rms(dv), 1e-12)

    def edit(xml):
        return xml.replace("</equality>", f'''</equality>
  <tendon>
    <fixed name="coupler" damping="{c:.9g}"><joint joint="rail{j}" coef="1"/><joint joint="rail{k}" coef="-1"/></fixed>
  </tendon>''', 1)
    return edit, {"damping": c}


def _ripple(rng, mo, j, target):
    qj, uj = np.asarray(mo["qref"])[:, j], np.asarray(mo["u"])[:, j]
    pitch, ph = float(rng.uniform(0.010, 0.030)), float(rng.uniform(0, 2 * math.pi))
    r = min(target / max(rms(uj * np.sin(2 * math.pi * qj / pitch + ph)), 1e-12), 0.3)

    def hook(model, data, t, q, qd, u):
        f = np.zeros(len(q))
        f[j] = r * u[j] * math.sin(2 * math.pi * q[j] / pitch + ph)
        return f
    return hook, {"ripple": r, "pitch": pitch, "phase": ph}


def _wiper(rng, mo, j, target):
    from mujoco_blind import DT

    qd_ref = np.gradient(np.asarray(mo["qref"])[:, j], DT)
    s_ref = np.cumsum(np.abs(qd_ref)) * DT  # the distance from the recording's start (a standstill before it)
    s0 = float(rng.uniform(0.3, 0.6)) * float(s_ref[-1])
    c = target / max(rms((1 - np.exp(-s_ref / s0)) * np.tanh(qd_ref / V_SIGN)), 1e-12)
    state = {"t": None, "s": 0.0}

    def hook(model, data, t, q, qd, u):
        if state["t"] is not None and t > state["t"]:
            state["s"] += (t - state["t"]) * abs(qd[j])
        state["t"] = t
        f = np.zeros(len(q))
        f[j] = -c * (1 - math.exp(-state["s"] / s0)) * math.tanh(qd[j] / V_SIGN)
        return f
    return hook, {"level": c, "distance_scale": s0}


def _backemf(rng, mo, j, target):
    from mujoco_blind import DT

    uj = np.asarray(mo["u"])[:, j]
    vj = np.abs(np.gradient(np.asarray(mo["qref"])[:, j], DT))
    v0 = float(rng.uniform(1.5, 3.0)) * float(vj.max())
    fs = float(np.quantile(np.abs(uj) / (1 - vj / v0), rng.uniform(0.6, 0.8)))
    short = np.maximum(np.abs(uj) - fs * (1 - vj / v0), 0.0)
    # the loop makes up the shortfall: it asks e more, e = s (|u| + e - avail)+, e = s / (1 - s) short
    x = min(target / max(rms(short), 1e-12), 4.0)
    s = x / (1 + x)

    def hook(model, data, t, q, qd, u):
        f = np.zeros(len(q))
        avail = fs * max(1 - abs(qd[j]) / v0, 0.0)
        f[j] = -s * math.copysign(max(abs(u[j]) - avail, 0.0), u[j])
        return f
    return hook, {"stall": fs, "no_load_speed": v0, "gain": s, "rms_reference": x * rms(short)}


def _window(t, t1, t2, edge=0.1):
    return 0.5 * (math.tanh((t - t1) / edge) - math.tanh((t - t2) / edge))


def _brake(rng, mo, j, target):
    from mujoco_blind import DT

    qd_ref = np.gradient(np.asarray(mo["qref"])[:, j], DT)
    t1 = float(rng.uniform(1.5, 5.5))  # the run's time, its standstill included [s]
    t2 = t1 + float(rng.uniform(1.5, 3.0))
    t_ref = LEAD + np.arange(len(qd_ref)) * DT
    w = np.array([_window(t, t1, t2) for t in t_ref])
    c = target / max(rms(w * np.tanh(qd_ref / V_SIGN)), 1e-12)

    def hook(model, data, t, q, qd, u):
        f = np.zeros(len(q))
        f[j] = -c * _window(t, t1, t2) * math.tanh(qd[j] / V_SIGN)
        return f
    return hook, {"level": c, "from": t1, "to": t2}


def _bus_sag(rng, mo, j, k, target):
    u = np.asarray(mo["u"])
    uk = float(mo["absu"][k])

    def made_up(s):
        """The command's rise along the reference that makes up the sag x (at most 0.5): u x / (1 - x),
        its RMS about its mean (the mean is an offset)."""
        x = np.minimum(s * np.abs(u[:, k]) / uk, 0.5)
        e = u[:, j] * x / (1 - x)
        return rms(e - e.mean())
    grid = np.linspace(0.0, 0.5, 501)[1:]
    s = float(grid[max(int(np.searchsorted([made_up(g) for g in grid], target)) - 1, 0)])

    def hook(model, data, t, q, qd, cmd):
        f = np.zeros(len(q))
        f[j] = -min(s * abs(cmd[k]) / uk, 0.5) * cmd[j]
        return f
    return hook, {"sag": s, "mean_other": uk}


def _grease(rng, mo, j, target):
    from mujoco_blind import DT

    qd_ref = np.gradient(np.asarray(mo["qref"])[:, j], DT)
    power = np.abs(np.asarray(mo["u"])[:, j] * qd_ref)
    p_ref = float(np.mean(power))
    tau = float(rng.uniform(2.0, 5.0))
    theta = np.minimum(lowpass(np.r_[0.0, power[1:] / p_ref], DT, tau), 1.0)  # cold at the start
    c0 = target / max(rms(qd_ref * (1 - 0.5 * theta)), 1e-12)
    state = {"t": None, "theta": 0.0}

    def hook(model, data, t, q, qd, u):
        if state["t"] is not None and t > state["t"]:
            state["theta"] += (t - state["t"]) / tau * (abs(u[j] * qd[j]) / p_ref - state["theta"])
        state["t"] = t
        f = np.zeros(len(q))
        f[j] = -c0 * (1 - 0.5 * min(state["theta"], 1.0)) * qd[j]
        return f
    return hook, {"cold_damping": c0, "power_scale": p_ref, "tau": tau}


def _rail_mechanism(kind, rng, m, mo):
    """(hook, edit, truth, j, k) of a third-set force on rails (0-based j; k the other rail or None)."""
    n = len(mo["E"])
    j, k = two_rails(rng, n)
    target = float(rng.uniform(0.1, 0.2)) * float(mo["E"][j])  # the force's RMS along the reference [N]
    if kind == "coupling_damper":
        edit, truth = _coupling(rng, mo, j, k, target)
        return None, edit, {**truth, "rms_target": target}, j, k
    if kind == "shared_bus_sag":
        hook, truth = _bus_sag(rng, mo, j, k, target)
        return hook, None, {**truth, "rms_target": target}, j, k
    made = {"thrust_ripple": _ripple, "wiper_debris": _wiper, "backemf_limit": _backemf, "brake_window": _brake,
            "grease_warming": _grease}
    if kind not in made:
        raise ValueError(kind)
    hook, truth = made[kind](rng, mo, j, target)
    return hook, None, {**truth, "rms_target": target}, j, None


def draw_third(kind, rng, m, mo):
    """(hook, edit, truth, keyed-on inputs, the rails the force acts on (1-based; an int, a tuple
    of two for the coupling damper, or None for the platform and the leg)) of one third-set case;
    ``mo`` is mujoco_unlisted.motion's."""
    if kind in PLATFORM_THIRD:
        hook, edit, truth = _platform_mechanism(kind, rng, m, mo)
        return hook, edit, truth, keyed_third(kind), None
    hook, edit, truth, j, k = _rail_mechanism(kind, rng, m, mo)
    truth.update(rail=j + 1, **({"other_rail": k + 1} if k is not None else {}))
    joint = (j + 1, k + 1) if kind == "coupling_damper" else j + 1
    return hook, edit, truth, keyed_third(kind, j + 1, None if k is None else k + 1), joint
