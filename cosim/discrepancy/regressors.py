"""Regressors of the attribution: :func:`candidates` (step 1 of the engine, see :mod:`.engine`).

Every candidate group (an effect on a joint, or a global effect) gets its columns from the
residual pipeline by finite differences over its core parameters at the nominal model:
one-sided for the parameters the core's residual is linear in (friction amplitudes, masses,
inertias, gravity, encoder offset, gap, compliance), central for the others (payload offset,
geometry).  Drive-layer and sensor parameters act on their own joint only (pkm.h), so one
evaluation with the parameter moved on every joint gives the columns of all joints.
Non-linear hyper-parameters are profiled on a grid: the Stribeck velocity (linear amplitude
per grid value), the delays and the saturation level (the exact residual change per grid
value, no free amplitude).  Also the recording's scales and each effect's reference size.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._native import ParameterError
from .effects import Group

#: effects whose core parameter acts on its own joint's channels only
LOCAL = {"coulomb", "viscous", "stribeck", "smooth_coulomb", "rotor_inertia", "saturation", "dead_zone", "encoder_offset", "backlash",
         "compliance", "offset"}
#: effects whose Jacobian is taken as the regressor columns at the nominal model: the
#: residual is linear in them, or nearly (geometry: errors of 1e-3 of a length change the
#: inverse kinematics at second order, 1e-6)
LINEARISED = {"coulomb", "viscous", "rotor_inertia", "platform_mass", "platform_inertia", "gravity_tilt",
              "encoder_offset", "backlash", "compliance", "geometry", "offset"}
#: effects whose columns carry the measured rates and accelerations (errors in variables): with a
#: reference in the recording they are estimated by instrumental variables, the instrument being the
#: same column along the reference motion (docs/discrepancy.md, "errors in variables")
INSTRUMENTED = {"rotor_inertia", "viscous", "platform_mass", "platform_inertia", "payload"}
#: smallest correlation of an instrument with its column for it to be used (a weaker one would
#: trade the bias for a variance larger than the bias: least squares instead)
MIN_RELEVANCE = 0.3
#: effects of an amplitude (linear) and a velocity scale (a profile grid): (amplitude, velocity)
VELOCITY_SCALED = {"stribeck", "smooth_coulomb"}
#: core parameters that cannot be negative
_NONNEGATIVE = (".coulomb", ".coulomb_v", ".viscous", ".stribeck", ".stribeck_v", ".rotor_inertia", ".backlash", ".compliance",
                ".effort_max", "payload.m", ".delay")
#: effects whose residual is linear in the core parameter
LINEAR = {"coulomb", "viscous", "rotor_inertia", "platform_mass", "platform_inertia", "gravity_tilt",
          "encoder_offset", "backlash", "compliance", "offset"}


def fit(X, t, Z=None, rcond=None):
    """Coefficients c making ``t + X c`` smallest: least squares, or with instruments ``Z``
    (same shape as X) the instrumental-variables estimate, ``Z' (t + X c) = 0``.  With
    ``rcond`` the singular values of X below rcond times the largest are dropped (of Z' X
    below its square, the same directions)."""
    if Z is None:
        if rcond is not None:
            return -(np.linalg.pinv(X, rcond=rcond) @ t)
        return -np.linalg.lstsq(X, t, rcond=None)[0]
    A = Z.T @ X
    if rcond is not None:
        return -(np.linalg.pinv(A, rcond=rcond**2) @ (Z.T @ t))
    return -np.linalg.lstsq(A, Z.T @ t, rcond=None)[0]


@dataclass(frozen=True)
class Scales:
    """Typical magnitudes of the recording, per joint (used for finite-difference steps
    and the reference size of each effect)."""

    effort: np.ndarray   # RMS of the smoothed effort [N or N m]
    rate: np.ndarray     # RMS of the joint rate
    accel: np.ndarray    # RMS of the joint acceleration
    travel: np.ndarray   # standard deviation of the joint position
    angular: bool        # joints in rad

    @classmethod
    def of(cls, pipe):
        tr = pipe.idx
        return cls(np.sqrt(np.mean(pipe.tau_s[tr] ** 2, axis=0)) + 1e-12,
                   np.sqrt(np.mean(pipe.qd_s[tr] ** 2, axis=0)) + 1e-12,
                   np.sqrt(np.mean(pipe.qdd_s[tr] ** 2, axis=0)) + 1e-12,
                   np.std(pipe.q[tr], axis=0) + 1e-12,
                   pipe.model.facts.angular_joints)


#: a typical joint speed [m/s for sliders, rad/s for revolute joints] (sizes a 'small'
#: viscous friction), by the kind of the robot's actuated joints (RobotFacts.joint_unit)
TYPICAL_RATE = {"m": 0.05, "rad": 1.0}


def _joint_mass(model):
    """Diagonal of the joint-space mass matrix at home, J^-T M J^-1 (core)."""
    x = model.home()
    Jinv = np.linalg.inv(model.jacobian(x))
    return np.diag(Jinv.T @ model.mass_matrix(x) @ Jinv)


def reference_size(group: Group, sc: Scales, model) -> float:
    """A 'small but relevant' magnitude of the effect, in its parameter's unit (what
    the detectability check compares with).  Set by the robot, not by the recording's
    motion: a recording that hardly moves must come out as not exciting."""
    k, i = group.key, group.joint
    qref = 1e-3 if sc.angular else 5e-5  # 1 mrad / 50 um on a joint reading
    if k in ("coulomb", "stribeck", "smooth_coulomb", "offset"):
        return 0.02 * sc.effort[i]
    if k == "viscous":
        return 0.02 * sc.effort[i] / TYPICAL_RATE[model.joint_unit]
    if k == "rotor_inertia":
        return 0.05 * float(_joint_mass(model)[i])
    if k in ("payload", "platform_mass"):
        return 0.1 * max(model.params().get("platform.m", 0.0), 0.05)  # a serial arm has no platform
    if k == "platform_inertia":
        return 0.2 * model.param("platform.Izz") if "platform.Izz" in model.param_names() else 1e-4
    if k == "gravity_tilt":
        return 9.81 * math.sin(math.radians(0.5))
    if k in ("actuator_delay", "sensor_delay"):
        return 2e-3
    if k == "saturation":
        return 0.9 * sc.effort[i]
    if k == "dead_zone":
        return 0.02 * sc.effort[i]
    if k in ("encoder_offset", "backlash"):
        return qref
    if k == "compliance":
        return qref / sc.effort[i]
    if k == "geometry":
        return 1e-3 * abs(model.param(group.params[0]))
    return 0.0


@dataclass(frozen=True)
class Option:
    """One way a group can enter: linear columns (m, C, k) and/or a fixed offset (m, C)
    of the residual, with the native parameters a coefficient vector maps to."""

    group: Group
    cols: np.ndarray | None
    offset: np.ndarray | None
    hyper: dict
    k: int
    expand: list | None = None   # the per-joint groups of an all-joints option
    instr: np.ndarray | None = None  # instruments of the columns (m, C, k), or None: least squares

    def __post_init__(self):
        # an option is shared by every step that tries it: its arrays are read-only
        for a in (self.cols, self.offset, self.instr):
            if isinstance(a, np.ndarray):
                a.setflags(write=False)

    def native(self, coef, nominal):
        g, e = self.group, self.group.key
        if self.expand is not None and self.cols is not None:
            return {gg.params[0]: nominal[gg.params[0]] + c for gg, c in zip(self.expand, coef)}
        p = g.params
        if e == "payload" and len(p) == 4:
            m = nominal[p[0]] + coef[0]
            c = coef[1:4] / coef[0] if coef[0] > 1e-9 else np.zeros(3)
            return {p[0]: m, p[1]: nominal[p[1]] + c[0], p[2]: nominal[p[2]] + c[1], p[3]: nominal[p[3]] + c[2]}
        if e in VELOCITY_SCALED:
            return {p[0]: nominal[p[0]] + coef[0], p[1]: self.hyper["v"]}
        if self.cols is None:
            return dict(self.hyper["params"])
        return {name: nominal[name] + c for name, c in zip(self.hyper.get("names", p), coef)}

    def sign_ok(self, coef) -> bool:
        if self.group.effect.sign != ">=0" or coef is None or len(coef) == 0:
            return True
        return bool(coef[0] >= 0)


@dataclass(frozen=True)
class Candidates:
    """The result of :func:`candidates`.

    Attributes
    ----------
    options : dict
        Group label -> tuple of :class:`Option` (one for a linear group, one per grid value
        of a profiled one), in the library's order.
    instrument_cols : dict
        Delay group label -> the residual change per second of delay (m, C) with the effort
        channels from the reference effort: the delay's instrument (a recording with a
        reference only).
    """

    options: dict
    instrument_cols: dict


def candidates(st) -> Candidates:
    """The ways every candidate group can enter the model, computed through the core.

    One-sided differences for the parameters the residual is linear in (drive-layer and
    sensor parameters moved on every joint at once: each acts on its own joint only),
    central ones for the payload's offset and the geometry, profile grids for the velocity
    scales, the delays, the saturation level and the dead-zone width; instruments (the same
    columns along the reference motion) for the effects in ``INSTRUMENTED``.

    Parameters
    ----------
    st : FitState
        The recording's state (:func:`.fitstate.fit_state`); its weights are not used
        (the instruments' relevance is judged on the unweighted samples).

    Returns
    -------
    Candidates
        The options per group label and the delays' instrument columns.

    Examples
    --------
    >>> st = fit_state(pipe, groups)                                   # doctest: +SKIP
    >>> c = candidates(st)                                             # doctest: +SKIP
    >>> c.options["coulomb[1]"][0].cols.shape == st.R0.shape + (1,)    # doctest: +SKIP
    True
    """
    options, instrument_cols = {}, {}
    R0 = st.R0
    m = R0.shape[0]
    by_key = {}
    for g in st.groups:
        by_key.setdefault(g.key, []).append(g)
    for key, gs in by_key.items():
        if key in LINEAR and key in LOCAL:
            steps = {g.params[0]: st.step(g, g.params[0]) for g in gs}
            moved = {p: st.nominal[p] + h for p, h in steps.items()}
            D = st.R(moved) - R0
            Dz = _reference_change(st, key, moved)
            for g in gs:
                col = np.zeros((m, st.C, 1))
                h = steps[g.params[0]]
                for c in st.channels(g):
                    col[:, c, 0] = D[:, c] / h
                if g.effect.family == "kinematic":
                    # A sensor error also moves the pose the dynamics is evaluated at:
                    # that part reaches every effort channel, so it is taken per joint.
                    col[:, :st.nd, 0] = st.pipe.pose_term({g.params[0]: st.nominal[g.params[0]] + h}) / h
                instr = None
                if Dz is not None:
                    instr = col.copy()
                    instr[:, g.joint, 0] = Dz[:, g.joint] / h
                options[g.label] = [Option(g, col, None, {}, 1, instr=_relevant(st, col, instr))]
        elif key in LINEAR or (key == "payload" and len(gs[0].params) == 1):
            for g in gs:
                cols = np.zeros((m, st.C, len(g.params)))
                instr = cols.copy() if key in INSTRUMENTED and st.use_instruments else None
                for j, p in enumerate(g.params):
                    cols[:, :, j], h = _one_sided(st, g, p, R0)
                    if instr is not None:
                        instr[:, :, j] = cols[:, :, j]
                        instr[:, :st.nd, j] = _reference_change(st, key, {p: st.nominal[p] + h}) / h
                options[g.label] = [Option(g, cols, None, {}, len(g.params), instr=_relevant(st, cols, instr))]
        elif key == "payload":
            options.update(_payload_options(st, key, gs[0], R0))
        elif key == "geometry":
            for g in gs:
                cols = np.zeros((m, st.C, len(g.params)))
                for j, p in enumerate(g.params):
                    h = st.step(g, p)
                    cols[:, :, j] = (st.R({p: st.nominal[p] + h}) - st.R({p: st.nominal[p] - h})) / (2 * h)
                vw = st.vec_cols(cols, w=np.ones(st.C) / np.maximum(np.std(R0[st.train], axis=0), 1e-15))
                s = np.linalg.svd(vw, compute_uv=False)
                rank = int(np.sum(s > 1e-6 * s[0])) if s[0] > 0 else 0
                if rank == 0:
                    continue
                options[g.label] = [Option(g, cols, None, {"rank": rank}, rank)]
        elif key in VELOCITY_SCALED:
            options.update(_velocity_scaled_options(st, gs, R0))
        elif key in ("actuator_delay", "sensor_delay"):
            label, opts, instrument = _delay_options(st, gs[0], R0)
            options[label] = opts
            if instrument is not None:
                instrument_cols[label] = instrument
        elif key in ("saturation", "dead_zone"):
            options.update(_level_options(st, key, gs, R0))
        if st.settings.verbose:
            print(f"  columns of {key}: done")
    return Candidates({lab: tuple(o) for lab, o in options.items()}, instrument_cols)


def _payload_options(st, key, g, R0) -> dict:
    """The payload's option {label: [Option]}: its mass's column, and its offset's as central
    differences of a reference mass moved (instruments along the reference motion when used)."""
    m = R0.shape[0]
    pm = g.params[0]
    mref = max(0.1 * st.nominal.get("platform.m", 0.1), 1e-3)
    cols = np.zeros((m, st.C, 4))
    Rm = st.R({pm: st.nominal[pm] + mref})
    cols[:, :, 0] = (Rm - R0) / mref
    hc = 0.01
    moves = [({p: st.nominal[p] + hc}, {p: st.nominal[p] - hc}) for p in g.params[1:]]
    for j, (up, down) in enumerate(moves):
        Rp = st.R({pm: st.nominal[pm] + mref, **up})
        Rn = st.R({pm: st.nominal[pm] + mref, **down})
        cols[:, :, j + 1] = (Rp - Rn) / (2 * hc * mref)
    instr = None
    if st.use_instruments:
        instr = cols.copy()
        instr[:, :st.nd, 0] = _reference_change(st, key, {pm: st.nominal[pm] + mref}) / mref
        for j, (up, down) in enumerate(moves):
            instr[:, :st.nd, j + 1] = (_reference_change(st, key, {pm: st.nominal[pm] + mref, **up})
                                         - _reference_change(st, key, {pm: st.nominal[pm] + mref,
                                                                        **down})) / (2 * hc * mref)
    return {g.label: [Option(g, cols, None, {}, 4, instr=_relevant(st, cols, instr))]}


def _velocity_scaled_options(st, gs, R0) -> dict:
    """{label: [Option per velocity scale of the grid]} of the groups ``gs`` of a velocity-scaled
    effect (fading or Stribeck friction): the column of the amplitude at each scale."""
    m = R0.shape[0]
    grid = st.velocity_grid()
    opts = {g.label: [] for g in gs}
    for vs in grid:
        steps = {g: st.step(g, g.params[0]) for g in gs}
        par = {}
        for g, h in steps.items():
            par[g.params[0]] = st.nominal[g.params[0]] + h
            par[g.params[1]] = vs
        D = st.R(par) - R0
        for g in gs:
            col = np.zeros((m, st.C, 1))
            for c in st.channels(g):
                col[:, c, 0] = D[:, c] / steps[g]
            opts[g.label].append(Option(g, col, None, {"v": float(vs)}, 2))
    return opts


def _delay_options(st, g, R0) -> tuple:
    """``(label, options, instrument)`` of a delay group: the residual's change at each delay of
    a 0.25 ms grid up to what the pipeline's margin allows, and the instrument column (the
    change along the reference's effort; None without a reference)."""
    p = g.params[0]
    dmax = (st.pipe.max_shift - 2) * st.pipe.dt
    grid = np.arange(0.25e-3, dmax + 1e-12, 0.25e-3)
    opts = []
    for d in grid:
        off = st.R({p: st.nominal[p] + d}) - R0
        opts.append(Option(g, None, off, {"params": {p: st.nominal[p] + d}}, 1))
    instrument = None
    if st.pipe.tau_ref_s is not None:
        h = 0.25e-3
        instrument = _delay_change(st, p, st.nominal[p] + h, {}, R0) / h
    return g.label, opts, instrument


def _level_options(st, key, gs, R0) -> dict:
    """{label: [Option per level]} of saturation or dead-zone groups: a profile over the level,
    the effort limit as a fraction of the largest command, the dead-zone width as a fraction of
    the typical effort (labels whose every level leaves the training part unchanged left out)."""
    m = R0.shape[0]
    if key == "saturation":
        base = np.abs(st.pipe.tau_c).max(axis=0)
        fracs = (0.5, 0.6, 0.7, 0.75, 0.8, 0.84, 0.88, 0.91, 0.94, 0.96, 0.98)
    else:
        base = np.asarray(st.sc.effort)
        fracs = tuple(0.004 * 1.12 ** np.arange(38))  # 0.4 % to 27 %, 12 % apart
    tmax = base
    opts = {g.label: [] for g in gs}
    for f in fracs:
        par = {g.params[0]: f * tmax[g.joint] for g in gs}
        D = st.R(par) - R0
        for g in gs:
            off = np.zeros((m, st.C))
            for c in st.channels(g):
                off[:, c] = D[:, c]
            if np.any(off[st.train] != 0):
                opts[g.label].append(Option(g, None, off, {"params": {g.params[0]: f * tmax[g.joint]},
                                                           "fraction": f}, 1))
    return {lab: o for lab, o in opts.items() if o}


def _one_sided(st, g, p, R0):
    """((R(p + h) - R0) / h, h), stepping down instead (h < 0) when the core refuses
    p + h (a principal moment of inertia beyond the sum of the other two...)."""
    h = st.step(g, p)
    try:
        return (st.R({p: st.nominal[p] + h}) - R0) / h, h
    except ParameterError:
        return (st.R({p: st.nominal[p] - h}) - R0) / -h, -h


def _reference_change(st, key, params):
    """Change of the effort residual along the reference motion when ``params`` are
    set (m, nd): the instrument of an effect in INSTRUMENTED; None for the others
    and without a reference."""
    if key not in INSTRUMENTED or not st.use_instruments:
        return None
    # the residual is effort minus inverse dynamics
    return st.pipe.reference_effort() - st.pipe.reference_effort(params)


def _relevant(st, cols, instr):
    """``instr`` if every instrument column is correlated with its regressor column
    by at least MIN_RELEVANCE (on the fitted samples), else None (least squares)."""
    if instr is None:
        return None
    X, Z = st.vec_cols(cols), st.vec_cols(instr)
    for j in range(X.shape[1]):
        nx, nz = np.linalg.norm(X[:, j]), np.linalg.norm(Z[:, j])
        if nx == 0 or nz == 0 or abs(X[:, j] @ Z[:, j]) < MIN_RELEVANCE * nx * nz:
            return None
    return instr


def _delay_change(st, name, value, theta, Rbase):
    """Change of the residual when the delay ``name`` goes from its value in theta
    to ``value``: the effort channels from the reference effort (an instrument free
    of the rate noise, when the recording has qref), the readings exactly."""
    R = st.R(dict(theta, **{name: value}))
    out = R - Rbase
    cur = theta.get(name, st.nominal[name])
    sig = st.pipe.delay_signature(name, value)
    if sig is not None:
        base = st.pipe.delay_signature(name, cur)
        out[:, :st.nd] = sig - base
    return out
