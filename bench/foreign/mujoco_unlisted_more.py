"""A second set of mechanisms for bench/foreign/mujoco_unlisted.py (``--kinds-set 2``), none of
them a kind of the first set, each computed in MuJoCo's step from MuJoCo's own state:

* ``cable_carrier``: a cable carrier between carriages j and k that pulls them together when the
  difference of their positions stretches it past its slack (a smooth one-sided spring on
  q_j - q_k), equal and opposite on the two rails;
* ``thermal_spring``: a magnetic return spring on rail j whose stiffness falls as the rail's motor
  heats: a first-order temperature driven by |u_j| (time constant 20-40 s), stiffness
  k0 (1 - drop theta) (at least 0.2 k0);
* ``detent_train``: 4-6 spring-loaded detents at irregular positions along rail j's stroke (each 5-10 %
  of the 10th-90th percentile span wide);
* ``platform_tmd``: a mass on a spring and damper along a guide in the platform (4-9 Hz, damping
  ratio 0.05-0.15), its mass taken off the platform's (a second-order body the platform drives);
* ``bellows_friction``: a bellows between base and platform rubbing on a guide: a friction on the
  platform's vertical motion whose level rises as the platform goes down and compresses it;
* ``gap_preload_friction``: a magnet on carriage j pulled towards the steel of carriage k: its
  pull, and so carriage j's guide friction, falls with the gap q_j - q_k - g0;
* ``spin_drag``: a quadratic drag moment -c |w| w on the platform's angular velocity (a paddle
  in a fluid);
* ``pulse_pump``: a piston pump's pressure pulses on rail j (raised-cosine pulses at 1.3-2.9 Hz,
  15-30 % of the period wide), on its own clock;
* ``accel_snubber``: a mechanical snubber on rail j that locks a mass to the carriage only above
  an acceleration threshold: -m_s sign(a) (|a| - a_th)+ (m_s at most the slider's mass, so its
  force's RMS may fall below the others');
* ``drive_saturation``: rail j's motor iron saturates above a force: the delivered force falls
  short by s (|u_j| - u_s)+ in the command's direction.

Magnitudes are physical guesses, not adjusted to the engine: a rail force's RMS along the case's
reference is 15-30 % of the rail's RMS effort (1.5 x a size drawn in 0.1-0.2, as the first set);
the platform kinds' sizes are stated in N, kg and N m beside them.  The inputs each is keyed on
(:func:`keyed_more`) were written with the mechanisms, before any run.
"""
from __future__ import annotations

import math

import numpy as np
from unlisted_common import excess as _excess
from unlisted_common import platform_dof as _platform
from unlisted_common import rms as _rms
from unlisted_common import slider_groups, two_rails
from unlisted_common import softplus as _softplus
from unlisted_common import unit_direction as _dir

KINDS_MORE = ("cable_carrier", "thermal_spring", "detent_train", "platform_tmd", "bellows_friction",
              "gap_preload_friction", "spin_drag", "pulse_pump", "accel_snubber", "drive_saturation")
PLATFORM_MORE = ("platform_tmd", "bellows_friction", "spin_drag")
#: seeds: SEED_MORE + the kind's index in KINDS_MORE, clean cases SEED_MORE + 90 + i (fixed before any run)
SEED_MORE = 50700
V_SIGN = 3e-4  # velocity scale of the smooth sign on a rail [m/s]
V_SIGN_PLATFORM = 1e-3  # on the platform's vertical velocity [m/s]


def keyed_more(kind, j=None, k=None) -> dict:
    """The inputs (flexible-stage groups) a second-set mechanism is keyed on: ``need`` (all
    named), ``any`` (one of them named), ``allowed`` (nothing else named); ``j``, ``k`` 1-based
    rails.  Written before any run; the reason for each is the physics beside it."""
    pos, rate, acc, pose = slider_groups()
    if kind == "platform_tmd":
        # the guided mass follows the platform's acceleration through its spring (below 4-9 Hz its
        # force is mb a, near the resonance it lags: the rates), and a tilt of the platform puts
        # gravity along its guide (the pose, which the rails' positions set); its force is the
        # platform's acceleration through its resonance (the platform's motion, a group added to the
        # stage after this declaration: this body is what that input is for)
        motion = {"the platform's motion"}
        return {"need": set(), "any": acc | pos | pose | motion, "allowed": acc | rate | pos | pose | motion}
    if kind == "bellows_friction":
        # a friction on the platform's vertical velocity (the rails' rates through the Jacobian),
        # its level set by the height (the pose, or the rails' positions that set it)
        return {"need": set(), "any": rate, "allowed": rate | pos | pose}
    if kind == "spin_drag":
        # a moment on the platform's angular velocity: the rails' rates through the Jacobian, which
        # the pose (the rails' positions) sets
        return {"need": set(), "any": rate, "allowed": rate | pos | pose}
    own = lambda q: f"{q} of slider {j}"  # noqa: E731
    other = lambda q: f"{q} of slider {k}"  # noqa: E731
    if kind == "cable_carrier":
        # the tension is a function of q_j - q_k alone: both positions, on the two rails' channels
        need = {own("position"), other("position")}
        return {"need": need, "any": set(), "allowed": set(need)}
    if kind == "thermal_spring":
        # a spring on the position; its stiffness falls with the motor's temperature, the integral
        # of |u_j| over tens of seconds (the effort's low-passed history carries it), which over a
        # run that starts cold rises with time
        return {"need": {own("position")}, "any": set(), "allowed": {own("position"), own("history"), "time"}}
    if kind == "detent_train":
        # a detent's ball in its notches: a function of the carriage's position alone
        return {"need": {own("position")}, "any": set(), "allowed": {own("position")}}
    if kind == "gap_preload_friction":
        # a Coulomb friction (the sign of rail j's rate) whose level is the magnet's pull, a
        # function of the gap q_j - q_k
        need = {own("rate"), own("position"), other("position")}
        return {"need": need, "any": set(), "allowed": need | {own("history")}}
    if kind == "pulse_pump":
        # the pump runs on its own clock: time alone
        return {"need": {"time"}, "any": set(), "allowed": {"time"}}
    if kind == "accel_snubber":
        # the snubber's lock and its force are set by the carriage's acceleration alone
        return {"need": {own("acceleration")}, "any": set(), "allowed": {own("acceleration")}}
    if kind == "drive_saturation":
        # the shortfall is a function of the command, the drive's effort, alone
        return {"need": {own("effort")}, "any": set(), "allowed": {own("effort")}}
    raise ValueError(kind)


def _platform_mechanism(kind, rng, m, mo):
    """(hook, edit, truth) of a second-set mechanism on the platform."""
    M = m.params()["platform.m"]
    if kind == "platform_tmd":
        mb = float(rng.uniform(0.1, 0.2)) * M
        f0, zeta = float(rng.uniform(4.0, 9.0)), float(rng.uniform(0.05, 0.15))
        axis = _dir(rng)  # the guide, in the platform's frame (level at home)
        w0 = 2 * math.pi * f0
        k, c = mb * w0 * w0, 2 * zeta * mb * w0
        ref = mb * 9.81 * axis[2] / k  # the spring's rest length offset: at rest at home with gravity on it

        def edit(xml):
            head = '<inertial pos="0 0 0" mass='
            xml = xml.replace(f'{head}"{M:.17g}"', f'{head}"{M - mb:.17g}"', 1)
            return xml.replace("<freejoint/>", f'''<freejoint/>
      <body name="tmd" pos="0 0 0"><joint name="tmd" type="slide" axis="{axis[0]:.9g} {axis[1]:.9g} {axis[2]:.9g}"
        stiffness="{k:.9g}" damping="{c:.9g}" springref="{ref:.9g}"/>
        <inertial pos="0 0 0" mass="{mb:.9g}" diaginertia="1e-9 1e-9 1e-9"/></body>''', 1)
        return None, edit, {"mass": mb, "frequency": f0, "damping_ratio": zeta, "axis": axis.tolist(),
                            "stiffness": k, "damping": c, "rest_offset": ref}
    if kind == "bellows_friction":
        z = mo["xp"][:, 2]
        z_mid = float(np.quantile(z, rng.uniform(0.4, 0.6)))
        width = float(rng.uniform(0.1, 0.2)) * float(np.std(z))
        level = float(rng.uniform(0.5, 1.0))  # [N] fully compressed
        ids = {}

        def hook(model, data, t, q, qd, u):
            if not ids:
                ids["b"], ids["adr"] = _platform(model)
            b = ids["b"]
            c = level / (1.0 + math.exp(-(z_mid - data.xpos[b][2]) / width))
            data.xfrc_applied[b, :] = 0.0
            data.xfrc_applied[b, 2] = -c * math.tanh(data.qvel[ids["adr"] + 2] / V_SIGN_PLATFORM)
        return hook, None, {"level": level, "height": z_mid, "width": width}
    if kind == "spin_drag":
        from mujoco_blind import DT

        w = np.gradient(np.asarray(mo["xr"])[:, 3:6], DT, axis=0)  # small angles: the Euler rates
        wn = np.linalg.norm(w, axis=1)
        moment = float(rng.uniform(0.01, 0.02))  # the drag moment's RMS along the reference [N m]
        c = moment / max(_rms(wn * wn), 1e-9)
        ids = {}

        def hook(model, data, t, q, qd, u):
            if not ids:
                ids["b"], ids["adr"] = _platform(model)
            b, adr = ids["b"], ids["adr"]
            om = data.xmat[b].reshape(3, 3) @ data.qvel[adr + 3:adr + 6]  # the free joint's is in the body frame
            data.xfrc_applied[b, :3] = 0.0
            data.xfrc_applied[b, 3:] = -c * float(np.linalg.norm(om)) * om
        return hook, None, {"coefficient": c, "moment_rms": moment}
    raise ValueError(kind)


def _carrier(rng, mo, j, k, target):
    dq = mo["qref"][:, j] - mo["qref"][:, k]
    slack = float(np.quantile(dq, rng.uniform(0.6, 0.8)))  # taut over the last 20-40 % of the difference
    w = 0.05 * float(np.ptp(dq))
    stiff = target / max(_rms(w * _softplus((dq - slack) / w)), 1e-12)
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        x = (q[j] - q[k] - slack) / w
        tension = stiff * w * (x if x > 30 else math.log1p(math.exp(x)))
        f = np.zeros(n)
        f[j], f[k] = -tension, tension
        return f
    return hook, {"stiffness": stiff, "slack": slack}


def _thermal(rng, mo, j, target):
    qc = float(np.mean(mo["qref"][:, j]))
    k0 = target / max(_rms(mo["qref"][:, j] - qc), 1e-12)
    tau, drop = float(rng.uniform(20.0, 40.0)), float(rng.uniform(1.0, 1.5))
    u_scale = float(mo["absu"][j])  # theta -> 1 at a steady |u_j| of its mean along the reference
    state = {"t": None, "theta": 0.0}
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        if state["t"] is not None and t > state["t"]:
            state["theta"] += (t - state["t"]) / tau * (abs(u[j]) / u_scale - state["theta"])
        state["t"] = t
        f = np.zeros(n)
        f[j] = -k0 * max(0.2, 1.0 - drop * state["theta"]) * (q[j] - qc)
        return f
    return hook, {"k0": k0, "centre": qc, "tau": tau, "drop": drop}


def _detents(rng, mo, j, target):
    lo, hi = mo["q10"][j], mo["q90"][j]
    at = np.sort(rng.uniform(lo, hi, int(rng.integers(4, 7))))
    w = float(rng.uniform(0.05, 0.1)) * float(hi - lo)
    depth = rng.uniform(0.6, 1.4, len(at))

    def shape(x):
        s = (np.asarray(x)[..., None] - at) / w
        return -np.sum(depth * s * np.exp(0.5 - 0.5 * s * s), axis=-1)  # each peak depth at +-w
    amp = target / max(_rms(shape(mo["qref"][:, j])), 1e-12)
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        f = np.zeros(n)
        f[j] = amp * float(shape(q[j]))
        return f
    return hook, {"at": at.tolist(), "width": w, "peak": (amp * depth).tolist()}


def _gap_preload(rng, mo, j, k, target):
    dq = mo["qref"][:, j] - mo["qref"][:, k]
    g0 = float(np.quantile(dq, rng.uniform(0.3, 0.7)))
    r = float(rng.uniform(0.1, 0.2)) * float(np.ptp(dq))
    pull = lambda g: 1.0 / (1.0 + (g / r) ** 2) ** 2  # noqa: E731
    c = target / max(_rms(pull(dq - g0)), 1e-12)
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        f = np.zeros(n)
        f[j] = -c * pull(q[j] - q[k] - g0) * math.tanh(qd[j] / V_SIGN)
        return f
    return hook, {"peak": c, "gap": g0, "radius": r}


def _pulse_pump(rng, mo, j, target):
    f0, wd = float(rng.uniform(1.3, 2.9)), float(rng.uniform(0.15, 0.3))
    ph = float(rng.uniform(0.0, 1.0))
    pulse = lambda p: 0.5 * (1.0 - math.cos(2 * math.pi * p / wd)) if p < wd else 0.0  # noqa: E731
    grid = np.linspace(0.0, 1.0, 2001)[:-1]
    shape = np.array([pulse(p) for p in grid]) - wd / 2  # zero mean over a period
    amp = float(rng.choice([-1.0, 1.0])) * target / _rms(shape)
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        f = np.zeros(n)
        f[j] = amp * (pulse((f0 * t + ph) % 1.0) - wd / 2)
        return f
    return hook, {"amplitude": amp, "frequency": f0, "width": wd}


def _snubber(rng, mo, j, target, slider_mass):
    a = np.asarray(mo["qddref"])[:, j]
    a_th = float(np.quantile(np.abs(a), rng.uniform(0.6, 0.8)))
    # a mass beyond the slider's own, fed back through the acceleration, would ring (the lag of the sensor)
    ms = min(target / max(_excess(a, a_th), 1e-12), slider_mass)
    tau = 2e-3  # the acceleration's low-pass [s] (the snubber's inertial sensor)
    state = {"t": None, "v": 0.0, "a": 0.0}
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        if state["t"] is not None and t > state["t"]:
            dt = t - state["t"]
            state["a"] += dt / (tau + dt) * ((qd[j] - state["v"]) / dt - state["a"])
        state["t"], state["v"] = t, qd[j]
        x = state["a"]
        f = np.zeros(n)
        f[j] = -ms * math.copysign(max(abs(x) - a_th, 0.0), x)
        return f
    return hook, {"mass": ms, "threshold": a_th, "rms_reference": ms * _excess(a, a_th)}


def _saturation(rng, mo, j, target):
    uj = np.asarray(mo["u"])[:, j]
    u_s = float(np.quantile(np.abs(uj), rng.uniform(0.6, 0.8)))
    s = min(target / max(_excess(uj, u_s), 1e-12), 0.8)  # the force constant falls by at most 80 %
    n = len(mo["E"])

    def hook(model, data, t, q, qd, u):
        f = np.zeros(n)
        f[j] = -s * math.copysign(max(abs(u[j]) - u_s, 0.0), u[j])
        return f
    return hook, {"shortfall": s, "from": u_s, "rms_reference": s * _excess(uj, u_s)}


def _rail_mechanism(kind, rng, m, mo):
    """(hook, truth, j, k) of a second-set force on rails (0-based j; k the other rail or None)."""
    n = len(mo["E"])
    j, k = two_rails(rng, n)
    target = 1.5 * float(rng.uniform(0.1, 0.2)) * float(mo["E"][j])  # the force's RMS along the reference [N]
    if kind == "cable_carrier":
        return (*_carrier(rng, mo, j, k, target), j, k)
    if kind == "gap_preload_friction":
        return (*_gap_preload(rng, mo, j, k, target), j, k)
    made = {"thermal_spring": lambda: _thermal(rng, mo, j, target),
            "detent_train": lambda: _detents(rng, mo, j, target),
            "pulse_pump": lambda: _pulse_pump(rng, mo, j, target),
            "accel_snubber": lambda: _snubber(rng, mo, j, target, m.params()[f"slider[{j + 1}].m"]),
            "drive_saturation": lambda: _saturation(rng, mo, j, target)}
    if kind not in made:
        raise ValueError(kind)
    hook, truth = made[kind]()
    truth["rms_target"] = target
    return hook, truth, j, None


def draw_more(kind, rng, m, mo):
    """(hook, edit, truth, keyed-on inputs, the rails the force acts on (1-based; an int, a tuple
    of two, or None for the platform)) of one second-set case; ``mo`` is
    mujoco_unlisted.motion's."""
    if kind in PLATFORM_MORE:
        hook, edit, truth = _platform_mechanism(kind, rng, m, mo)
        return hook, edit, truth, keyed_more(kind), None
    hook, truth, j, k = _rail_mechanism(kind, rng, m, mo)
    truth.update(rail=j + 1, **({"other_rail": k + 1} if k is not None else {}))
    joint = (j + 1, k + 1) if kind == "cable_carrier" else j + 1
    return hook, None, truth, keyed_more(kind, j + 1, None if k is None else k + 1), joint
