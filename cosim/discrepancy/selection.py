"""Attribution: which effects of the library the residual supports, with what parameters.

Method (docs/discrepancy.md gives the reasoning):

1. Regressors.  Every candidate group (an effect on a joint, or a global effect) gets
   its columns from the residual pipeline by finite differences over its core
   parameters at the nominal model: one-sided for the parameters the core's residual
   is linear in (friction amplitudes, masses, inertias, gravity, encoder offset, gap,
   compliance), central for the others (payload offset, geometry).  Drive-layer and
   sensor parameters act on their own joint only (pkm.h), so one evaluation with the
   parameter moved on every joint gives the columns of all joints.  Non-linear
   hyper-parameters are profiled on a grid: the Stribeck velocity (linear amplitude
   per grid value), the delays and the saturation level (the exact residual change per
   grid value, no free amplitude).
2. Weights.  Each channel is divided by its noise level and the square root of its
   variance inflation ``phi = 1 + 2 sum rho_L`` (autocorrelation of the residual of
   the fit with every linear candidate), so that the chi-square counts effectively
   independent samples: ``N_eff = sum_c n / phi_c``.
3. Forward selection over groups with BIC: a group enters if it lowers
   ``chi2 + k log N_eff`` by more than ``threshold``; a physical magnitude fitted with
   the wrong sign does not enter.  After each entry the selected parameters are
   refined by Gauss-Newton on the exact residual (columns of the native parameters by
   finite differences through the core).
4. Confidence intervals from the final Jacobian (95 %, chi-square rescaled), the
   importance of each group (chi-square increase when it is removed), look-alikes
   (the best alternative group in its place: if its BIC is within ``lookalike_margin``
   the two cannot be told apart with this data) and the detectability of every
   candidate (the smallest amplitude that would have entered).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._native import ParameterError
from .effects import Group
from .residuals import DiagnosisError

#: effects whose core parameter acts on its own joint's channels only
LOCAL = {"coulomb", "viscous", "stribeck", "rotor_inertia", "saturation", "dead_zone", "encoder_offset", "backlash",
         "compliance"}
#: effects whose Jacobian is taken as the regressor columns at the nominal model: the
#: residual is linear in them, or nearly (geometry: errors of 1e-3 of a length change the
#: inverse kinematics at second order, 1e-6)
LINEARISED = {"coulomb", "viscous", "rotor_inertia", "platform_mass", "platform_inertia", "gravity_tilt",
              "encoder_offset", "backlash", "compliance", "geometry"}
#: core parameters that cannot be negative
_NONNEGATIVE = (".coulomb", ".viscous", ".stribeck", ".stribeck_v", ".rotor_inertia", ".backlash", ".compliance",
                ".effort_max", "payload.m", ".delay")
#: effects whose residual is linear in the core parameter
LINEAR = {"coulomb", "viscous", "rotor_inertia", "platform_mass", "platform_inertia", "gravity_tilt",
          "encoder_offset", "backlash", "compliance"}


@dataclass
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
    if k in ("coulomb", "stribeck"):
        return 0.02 * sc.effort[i]
    if k == "viscous":
        return 0.02 * sc.effort[i] / TYPICAL_RATE[model.joint_unit]
    if k == "rotor_inertia":
        return 0.05 * float(_joint_mass(model)[i])
    if k in ("payload", "platform_mass"):
        return 0.1 * max(model.param("platform.m"), 0.05)
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


@dataclass
class Option:
    """One way a group can enter: linear columns (m, C, k) and/or a fixed offset (m, C)
    of the residual, with the native parameters a coefficient vector maps to."""

    group: Group
    cols: np.ndarray | None
    offset: np.ndarray | None
    hyper: dict
    k: int
    expand: list | None = None   # the per-joint groups of an all-joints option

    def native(self, coef, nominal):
        g, e = self.group, self.group.key
        if self.expand is not None:
            return {gg.params[0]: nominal[gg.params[0]] + c for gg, c in zip(self.expand, coef)}
        p = g.params
        if e == "payload" and len(p) == 4:
            m = nominal[p[0]] + coef[0]
            c = coef[1:4] / coef[0] if coef[0] > 1e-9 else np.zeros(3)
            return {p[0]: m, p[1]: nominal[p[1]] + c[0], p[2]: nominal[p[2]] + c[1], p[3]: nominal[p[3]] + c[2]}
        if e == "stribeck":
            return {p[0]: nominal[p[0]] + coef[0], p[1]: self.hyper["v"]}
        if self.cols is None:
            return dict(self.hyper["params"])
        return {name: nominal[name] + c for name, c in zip(self.hyper.get("names", p), coef)}

    def sign_ok(self, coef) -> bool:
        if self.group.effect.sign != ">=0" or coef is None or len(coef) == 0:
            return True
        return bool(coef[0] >= 0)


@dataclass
class Attribution:
    """One selected group with its fitted core parameters."""

    group: Group
    values: dict            # core parameter -> fitted value
    ci: dict                # core parameter -> half width of the 95 % interval
    delta_bic: float        # BIC change when it entered (negative)
    importance: float = 0.0  # chi-square increase when removed from the final model
    lookalikes: list = field(default_factory=list)


@dataclass
class Selection:
    """The result of :func:`select`."""

    selected: list
    theta: dict               # all fitted core parameters (nominal values omitted)
    chi2_nominal: float
    chi2_final: float
    n_eff: float
    sigma: np.ndarray         # noise level per channel (final fit)
    phi: np.ndarray           # variance inflation per channel
    steps: list               # log of the forward steps
    candidates: dict          # group label -> best delta BIC at the last step (evidence against)
    detectability: dict       # group label -> (min detectable size, reference size)
    threshold: float
    refused: dict = field(default_factory=dict)  # group label -> why it was refused


class Engine:
    """Holds the candidate columns of one recording and runs the selection."""

    def __init__(self, pipe, groups, *, train_fraction: float = 0.7, threshold: float = 10.0,
                 lookalike_margin: float = 10.0, max_groups: int = 8, verbose: bool = False):
        self.pipe, self.groups = pipe, groups
        self.train, self.test = pipe.split(train_fraction)
        if self.train.sum() < 20:
            raise DiagnosisError(f"{pipe.where}: the fitted part of the recording has {int(self.train.sum())} "
                                 f"decimated samples; at least 20 are needed")
        self.threshold, self.lookalike_margin, self.max_groups = threshold, lookalike_margin, max_groups
        self.verbose = verbose
        self.model = pipe.model
        self.nominal = pipe.nominal
        self.nd = pipe.nd
        self.sc = Scales.of(pipe)
        self.R0 = self.R({})
        self.C = self.R0.shape[1]
        # Samples used per channel: a joint's channels leave out its rest phases.
        self.use = np.tile(pipe.usable, (1, self.C // self.nd)).astype(float)
        self.W = self.use.copy()
        self.options = {}
        self._instrument_cols = {}
        self.instruments = {}
        self._build_options()

    # ---------------------------------------------------------------- plumbing
    def R(self, theta):
        return self.pipe.evaluate(theta).stack()

    def vec(self, Rm, mask=None, w=None):
        """Weighted residual channels of the rows in ``mask``, one channel after the other."""
        mask = self.train if mask is None else mask
        W = (self.W if w is None else w * self.use)[mask]
        return (Rm[mask] * W).T.reshape(-1)

    def vec_cols(self, cols, mask=None, w=None):
        mask = self.train if mask is None else mask
        W = (self.W if w is None else w * self.use)[mask]
        c = cols[mask] * W[:, :, None]
        return c.transpose(1, 0, 2).reshape(-1, cols.shape[2])

    def _channels(self, group):
        i, fam = group.joint, group.effect.family
        ch = []
        if fam in ("effort", "both"):
            ch.append(i)
        if fam in ("kinematic", "both") and self.C > self.nd:
            ch.append(self.nd + i)
        return ch

    def _step(self, group, name):
        sc, k, i = self.sc, group.key, group.joint
        val = self.nominal[name]
        if k in ("coulomb", "stribeck"):
            return 0.05 * sc.effort[i]
        if k == "viscous":
            return 0.05 * sc.effort[i] / sc.rate[i]
        if k == "rotor_inertia":
            return 0.05 * sc.effort[i] / sc.accel[i]
        if k in ("encoder_offset", "backlash"):
            return 1e-3 * sc.travel[i]
        if k == "compliance":
            return 1e-3 * sc.travel[i] / sc.effort[i]
        if name.startswith("gravity."):
            return 0.1
        if k == "geometry":
            return 1e-4 * max(abs(val), 1e-3)
        if k in ("saturation", "dead_zone"):
            return 0.01 * sc.effort[i]
        return 0.05 * abs(val) if val != 0 else 1e-3

    def _one_sided(self, g, p, R0):
        """(R(p + h) - R0) / h, stepping down instead when the core refuses p + h (a
        principal moment of inertia beyond the sum of the other two...)."""
        h = self._step(g, p)
        try:
            return (self.R({p: self.nominal[p] + h}) - R0) / h
        except ParameterError:
            return (self.R({p: self.nominal[p] - h}) - R0) / -h

    def _delay_change(self, name, value, theta, Rbase):
        """Change of the residual when the delay ``name`` goes from its value in theta
        to ``value``: the effort channels from the reference effort (an instrument free
        of the rate noise, when the recording has qref), the readings exactly."""
        R = self.R(dict(theta, **{name: value}))
        out = R - Rbase
        cur = theta.get(name, self.nominal[name])
        sig = self.pipe.delay_signature(name, value)
        if sig is not None:
            base = self.pipe.delay_signature(name, cur)
            out[:, :self.nd] = sig - base
        return out

    def _try_R(self, theta):
        """R(theta), or None when theta is not a valid parameter set of the core."""
        try:
            return self.R(theta)
        except ParameterError:
            return None

    # ------------------------------------------------------------- candidates
    def _build_options(self):
        R0, nd = self.R0, self.nd
        m = R0.shape[0]
        by_key = {}
        for g in self.groups:
            by_key.setdefault(g.key, []).append(g)
        for key, gs in by_key.items():
            if key in LINEAR and key in LOCAL:
                steps = {g.params[0]: self._step(g, g.params[0]) for g in gs}
                D = self.R({p: self.nominal[p] + h for p, h in steps.items()}) - R0
                for g in gs:
                    col = np.zeros((m, self.C, 1))
                    h = steps[g.params[0]]
                    for c in self._channels(g):
                        col[:, c, 0] = D[:, c] / h
                    if g.effect.family == "kinematic":
                        # A sensor error also moves the pose the dynamics is evaluated at:
                        # that part reaches every effort channel, so it is taken per joint.
                        col[:, :self.nd, 0] = self.pipe.pose_term({g.params[0]: self.nominal[g.params[0]] + h}) / h
                    self.options[g.label] = [Option(g, col, None, {}, 1)]
            elif key in LINEAR or (key == "payload" and len(gs[0].params) == 1):
                for g in gs:
                    cols = np.zeros((m, self.C, len(g.params)))
                    for j, p in enumerate(g.params):
                        cols[:, :, j] = self._one_sided(g, p, R0)
                    self.options[g.label] = [Option(g, cols, None, {}, len(g.params))]
            elif key == "payload":
                g = gs[0]
                pm = g.params[0]
                mref = max(0.1 * self.nominal.get("platform.m", 0.1), 1e-3)
                cols = np.zeros((m, self.C, 4))
                Rm = self.R({pm: self.nominal[pm] + mref})
                cols[:, :, 0] = (Rm - R0) / mref
                hc = 0.01
                for j, p in enumerate(g.params[1:]):
                    Rp = self.R({pm: self.nominal[pm] + mref, p: self.nominal[p] + hc})
                    Rn = self.R({pm: self.nominal[pm] + mref, p: self.nominal[p] - hc})
                    cols[:, :, j + 1] = (Rp - Rn) / (2 * hc * mref)
                self.options[g.label] = [Option(g, cols, None, {}, 4)]
            elif key == "geometry":
                for g in gs:
                    cols = np.zeros((m, self.C, len(g.params)))
                    for j, p in enumerate(g.params):
                        h = self._step(g, p)
                        cols[:, :, j] = (self.R({p: self.nominal[p] + h}) - self.R({p: self.nominal[p] - h})) / (2 * h)
                    vw = self.vec_cols(cols, w=np.ones(self.C) / np.maximum(np.std(R0[self.train], axis=0), 1e-15))
                    s = np.linalg.svd(vw, compute_uv=False)
                    rank = int(np.sum(s > 1e-6 * s[0])) if s[0] > 0 else 0
                    if rank == 0:
                        continue
                    self.options[g.label] = [Option(g, cols, None, {"rank": rank}, rank)]
            elif key == "stribeck":
                v = float(np.median(self.sc.rate))
                # A Stribeck velocity below a few times the rate noise is not resolvable.
                vmin = max(0.02 * v, 5.0 * float(np.median(self.pipe.qd_noise)))
                grid = np.geomspace(vmin, max(0.5 * v, 2 * vmin), 9)
                opts = {g.label: [] for g in gs}
                for vs in grid:
                    steps = {g: self._step(g, g.params[0]) for g in gs}
                    par = {}
                    for g, h in steps.items():
                        par[g.params[0]] = self.nominal[g.params[0]] + h
                        par[g.params[1]] = vs
                    D = self.R(par) - R0
                    for g in gs:
                        col = np.zeros((m, self.C, 1))
                        for c in self._channels(g):
                            col[:, c, 0] = D[:, c] / steps[g]
                        opts[g.label].append(Option(g, col, None, {"v": float(vs)}, 2))
                self.options.update(opts)
            elif key in ("actuator_delay", "sensor_delay"):
                g = gs[0]
                p = g.params[0]
                dmax = (self.pipe.max_shift - 2) * self.pipe.dt
                grid = np.arange(0.25e-3, dmax + 1e-12, 0.25e-3)
                opts = []
                for d in grid:
                    off = self.R({p: self.nominal[p] + d}) - R0
                    opts.append(Option(g, None, off, {"params": {p: self.nominal[p] + d}}, 1))
                self.options[g.label] = opts
                if self.pipe.tau_ref_s is not None:
                    h = 0.25e-3
                    self._instrument_cols[g.label] = self._delay_change(p, self.nominal[p] + h, {}, R0) / h
            elif key in ("saturation", "dead_zone"):
                # a profile over the level: the effort limit as a fraction of the largest
                # command, the dead-zone width as a fraction of the typical effort
                if key == "saturation":
                    base = np.abs(self.pipe.tau_c).max(axis=0)
                    fracs = (0.5, 0.6, 0.7, 0.75, 0.8, 0.84, 0.88, 0.91, 0.94, 0.96, 0.98)
                else:
                    base = np.asarray(self.sc.effort)
                    fracs = tuple(0.004 * 1.12 ** np.arange(38))  # 0.4 % to 27 %, 12 % apart
                tmax = base
                opts = {g.label: [] for g in gs}
                for f in fracs:
                    par = {g.params[0]: f * tmax[g.joint] for g in gs}
                    D = self.R(par) - R0
                    for g in gs:
                        off = np.zeros((m, self.C))
                        for c in self._channels(g):
                            off[:, c] = D[:, c]
                        if np.any(off[self.train] != 0):
                            opts[g.label].append(Option(g, None, off, {"params": {g.params[0]: f * tmax[g.joint]}}, 1))
                for lab, o in opts.items():
                    if o:
                        self.options[lab] = o
            if self.verbose:
                print(f"  columns of {key}: done")

    # ------------------------------------------------------------ noise model
    def noise_model(self):
        """Per-channel noise level and variance inflation from the fit with every
        linear candidate column (first option of each group)."""
        cols = [o[0].cols for o in self.options.values() if o[0].cols is not None]
        # Profile effects enter linearised: a delay by its smallest-step change, a
        # saturation by its change at a middle level (an unmodelled 5 ms delay would
        # otherwise pass for noise ten times the real one and hide a second effect).
        for opts in self.options.values():
            o = opts[0]
            if o.cols is None and o.group.key in ("actuator_delay", "sensor_delay"):
                d = list(o.hyper["params"].values())[0] - self.nominal[o.group.params[0]]
                cols.append((o.offset / d)[:, :, None])
            elif o.cols is None:
                cols.append(opts[len(opts) // 2].offset[:, :, None])
        r = self.R0[self.train]
        sig = np.maximum(1.4826 * np.median(np.abs(r - np.median(r, axis=0)), axis=0), 1e-15)
        res = r
        used = self.use[self.train] > 0
        if cols:
            A = np.concatenate(cols, axis=2)
            for _ in range(3):
                w = 1.0 / sig
                X = self.vec_cols(A, w=w)
                y = self.vec(self.R0, w=w)
                beta, *_ = np.linalg.lstsq(X, y, rcond=None)
                res = (y - X @ beta).reshape(self.C, -1).T / w
                sig = np.maximum(np.sqrt(np.sum(res**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
        phi = np.array([_inflation(res[used[:, c], c], self.pipe.window, self.pipe.step) for c in range(self.C)])
        return np.maximum(sig, self.floor()), phi

    def floor(self):
        """Smallest noise level a channel is given: the accuracy of the pipeline itself
        (integration tolerance, smoothing round-off: 2e-5 of the effort on noiseless
        closed-loop runs), so a noiseless recording does not turn round-off into physics."""
        eff = 1e-4 * self.sc.effort
        return np.concatenate([eff, np.full(self.C - self.nd, 1e-8)])

    # ---------------------------------------------------------------- select
    def run(self) -> Selection:
        """Forward selection with backward elimination; one more pass with the noise of
        the selected model when it differs from the first estimate by more than 25 %."""
        sig, phi = self.noise_model()
        options = dict(self.options)
        for _ in range(2):
            self._weights(sig, phi)
            selected, theta, steps, last_best, chi2_nom = self._select()
            r = self.R(theta)[self.train]
            used = self.use[self.train] > 0
            sig_f = np.maximum(np.sqrt(np.sum(r**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)),
                               self.floor())
            if np.all(np.abs(np.log(sig_f / sig)) < math.log(1.25)):
                break
            phi = np.array([_inflation(r[used[:, c], c], self.pipe.window, self.pipe.step)
                            for c in range(self.C)])
            sig = sig_f
            self.options = dict(options)
        chi2_final = self._chi2(theta)
        sel = Selection(selected, theta, chi2_nom, chi2_final, self.n_eff, self.sig, self.phi, steps, last_best,
                        {}, self.threshold, dict(self.refused))
        self.finish(sel)
        return sel

    def _weights(self, sig, phi):
        self.sig, self.phi = sig, phi
        self.w = 1.0 / (sig * np.sqrt(phi))
        self.W = self.w[None, :] * self.use
        n = (self.use[self.train] > 0).sum(axis=0)
        self.n_eff = float(np.sum(n / phi))
        self.instruments = {lab: self.vec(c) for lab, c in self._instrument_cols.items()}

    def _select(self):
        logn = math.log(self.n_eff)
        selected, theta, steps = [], {}, []
        self.refused = {}
        y = self.vec(self.R0)
        chi2_nom = chi2 = float(y @ y)
        if self.verbose:
            print(f"  noise {self.sig}, phi {self.phi}, N_eff {self.n_eff:.0f}, chi2 {chi2:.1f}")
        last_best = {}
        while len(steps) < self.max_groups:  # entries (an all-joints entry adds several groups)
            # Delays already in the model are held (their instrumental estimate is
            # refreshed by refine); least squares would pull them to the noise-biased value.
            J, names = self.jacobian([a for a in selected if not (a.group.key.endswith("_delay")
                                                                  and a.group.label in self.instruments)], theta)
            y = self.vec(self.R(theta))
            chi2 = float(y @ y)
            Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
            y_perp = y - Q @ (Q.T @ y)
            best = None
            last_best = {}
            taken = {a.group.label for a in selected}
            for lab, opts in list(self.options.items()) + list(self._joint_sets(taken).items()):
                if lab in taken:
                    continue
                c2, o2 = self._best_option(opts, Q, y_perp, J, y)
                if c2 is None:
                    continue
                gbest = (c2 - chi2 + o2.k * logn, o2, c2)
                last_best[lab] = gbest[0]
                if best is None or gbest[0] < best[0]:
                    best = gbest
            if best is None or best[0] > -self.threshold:
                break
            dbic, opt, c2 = best
            coef_all = self._coef(opt, J, y)
            new = self._apply(theta, names, coef_all, opt)
            if self._try_R(new) is None:
                # The fit is not a valid parameter set of the core: refuse the group.
                self.refused[opt.group.label] = "its fitted parameters are not a valid parameter set of the core"
                self.options.pop(opt.group.label, None)
                for g in opt.expand or []:
                    self.options.pop(g.label, None)
                continue
            theta = new
            for g in opt.expand or [opt.group]:
                selected.append(Attribution(g, {}, {}, float(dbic)))
            theta = self.refine(selected, theta)
            if self.verbose:
                print(f"  + {opt.group.label}: dBIC {dbic:.1f} -> {theta}")
            steps.append({"group": opt.group.label, "delta_bic": float(dbic),
                          "chi2": float(self._chi2(theta))})
            selected, theta = self._prune(selected, theta, logn)
            # Statistically supported but physically negligible (a tenth of a 'small'
            # effect, e.g. a 5 us delay): model misfit leaking into a candidate, not physics.
            for a in list(selected):
                size = self._magnitude(a.group, theta)
                ref = reference_size(a.group, self.sc, self.model)
                if a.group.key not in ("saturation", "dead_zone") and ref > 0 and size < 0.1 * ref:
                    selected.remove(a)
                    for p in a.group.params:
                        theta.pop(p, None)
                    self.options.pop(a.group.label, None)
                    self.refused[a.group.label] = (f"fitted size {size:.3g} is below a tenth of a small one "
                                                   f"({ref:.3g}): negligible")
                    theta = self.refine(selected, theta)
        return selected, theta, steps, last_best, chi2_nom

    def _magnitude(self, g, theta):
        """Size of a group's fitted change, in the unit of its reference size."""
        p = g.params
        if g.key in ("payload", "stribeck"):
            p = p[:1]
        d = np.array([theta.get(n, self.nominal[n]) - self.nominal[n] for n in p])
        return float(np.linalg.norm(d))

    def _joint_sets(self, taken):
        """All-joints candidates: a per-joint effect on every joint not yet selected (a
        friction or an offset on every rail enters in one step instead of a greedy chain
        that another multi-parameter group could cut short)."""
        out = {}
        by_key = {}
        for lab, opts in self.options.items():
            g = opts[0].group
            if g.joint is None or lab in taken or len(opts) != 1 or g.key not in LINEARISED:
                continue
            by_key.setdefault(g.key, []).append(opts[0])
        for key, opts in by_key.items():
            if len(opts) < 2:
                continue
            cols = np.concatenate([o.cols for o in opts], axis=2)
            groups = [o.group for o in opts]
            pseudo = Group(groups[0].effect, None, tuple(g.params[0] for g in groups))
            out[f"{key}[all]"] = [Option(pseudo, cols, None, {}, len(opts), expand=groups)]
        return out

    def _prune(self, selected, theta, logn):
        """Backward elimination: drop groups at the edge of their physical range, then,
        one at a time, the group whose removal costs less BIC than the threshold."""
        for a in list(selected):
            if a.group.effect.sign == ">=0" and all(theta.get(p, self.nominal[p]) <= 0 for p in a.group.params[:1]):
                selected.remove(a)
                for p in a.group.params:
                    theta.pop(p, None)
        while len(selected) > 1:
            chi2 = self._chi2(theta)
            worst = None
            for a in selected:
                imp, th = self._without(selected, theta, a)
                cost = imp - self._k(a.group) * logn
                if worst is None or cost < worst[0]:
                    worst = (cost, a, th)
            if worst[0] >= self.threshold:
                break
            selected = [b for b in selected if b is not worst[1]]
            theta = self.refine(selected, worst[2])
            if self.verbose:
                print(f"  - {worst[1].group.label}: removal costs {worst[0]:.1f} in BIC")
        return selected, theta

    def _without(self, selected, theta, a):
        """chi-square increase when group a is removed (the others refitted, linearised)
        and the parameters of that refit."""
        rest = [b for b in selected if b is not a]
        th = {k: v for k, v in theta.items() if k not in a.group.params}
        Rt = self._try_R(th)
        if Rt is None:
            return float("inf"), theta
        y = self.vec(Rt)
        Jr, names = self.jacobian(rest, th)
        if Jr.shape[1]:
            d = -np.linalg.lstsq(Jr, y, rcond=None)[0]
            y = y + Jr @ d
            th2 = self._clip({**th, **{n: th.get(n, self.nominal[n]) + dv for n, dv in zip(names, d)}})
            th = th2 if self._try_R(th2) is not None else th
        return float(y @ y) - self._chi2(theta), th

    def _best_option(self, opts, Q, y_perp, J, y):
        """(chi-square, option) of the best way the group can enter, or (None, None)."""
        g = opts[0].group
        if g.key in ("actuator_delay", "sensor_delay") and g.label in self.instruments:
            return self._try_delay(opts, Q, y_perp)
        best = (None, None)
        for o in opts:
            c2, _, o2 = self._try(o, Q, y_perp, J, y)
            if c2 is not None and (best[0] is None or c2 < best[0]):
                best = (c2, o2)
        return best

    def _try_delay(self, opts, Q, y_perp):
        """A delay by instrumental variables: the delay d where the instrument (the
        reference effort's signature, free of rate noise) is orthogonal to the exact
        residual, then the exact chi-square there.  Least squares on the recorded
        command would instead fit the closed loop's reaction to the rate noise (a
        spurious delay of about M/kd times the noise share of the effort changes)."""
        z = self.instruments[opts[0].group.label]
        z = z - Q @ (Q.T @ z)
        ds, f, c2 = [0.0], [float(z @ y_perp)], [float(y_perp @ y_perp)]
        for o in opts:
            off = self.vec(o.offset)
            t = y_perp + (off - Q @ (Q.T @ off))
            ds.append(list(o.hyper["params"].values())[0] - self.nominal[o.group.params[0]])
            f.append(float(z @ t))
            c2.append(float(t @ t))
        best = (None, None)
        p = opts[0].group.params[0]
        for i in range(len(ds) - 1):
            if f[i] == 0 or np.sign(f[i]) == np.sign(f[i + 1]):
                continue
            a = f[i] / (f[i] - f[i + 1])  # linear interpolation of the root
            d = ds[i] + a * (ds[i + 1] - ds[i])
            if d <= 0:
                continue
            lo = opts[i - 1].offset if i > 0 else np.zeros_like(opts[0].offset)
            off = (1 - a) * lo + a * opts[i].offset
            t = y_perp + (self.vec(off) - Q @ (Q.T @ self.vec(off)))
            chi = float(t @ t)
            if best[0] is None or chi < best[0]:
                best = (chi, Option(opts[0].group, None, off, {"params": {p: self.nominal[p] + d}}, 1))
        return best

    def _try(self, o, Q, y_perp, J, y):
        """chi-square of the current model plus option o, its coefficients (parameter
        changes) and the option actually fitted; (None, None, o) if the fit has a
        non-physical sign.  An all-joints option of a non-negative effect keeps the
        joints whose coefficient is positive (active set).

        The residual after a change is ``y + offset + X c`` (+ ``J d`` for the current
        parameters, projected out through Q)."""
        t = y_perp
        if o.offset is not None:
            off = self.vec(o.offset)
            t = t + (off - Q @ (Q.T @ off))
        if o.cols is None:
            return float(t @ t), np.zeros(0), o
        X = self.vec_cols(o.cols)
        Xp = X - Q @ (Q.T @ X)
        keep = np.arange(X.shape[1])
        while True:
            coef = -np.linalg.lstsq(Xp[:, keep], t, rcond=None)[0]
            if o.expand is None or o.group.effect.sign != ">=0" or np.all(coef >= 0):
                break
            keep = keep[coef >= 0]
            if len(keep) == 0:
                return None, None, o
        if o.expand is not None and len(keep) < X.shape[1]:
            if len(keep) < 2:
                return None, None, o
            o = Option(o.group, o.cols[:, :, keep], None, o.hyper, len(keep), [o.expand[i] for i in keep])
        if not o.sign_ok(coef):
            return None, None, o
        r = t + Xp[:, keep] @ coef
        return float(r @ r), coef, o

    def _coef(self, o, J, y):
        """Joint fit: changes of the current parameters, then the option's coefficients."""
        t = y.copy()
        if o.offset is not None:
            t += self.vec(o.offset)
        X = J if o.cols is None else np.hstack([J, self.vec_cols(o.cols)])
        if X.shape[1] == 0:
            return np.zeros(0)
        rank = o.hyper.get("rank")
        if rank is not None and o.cols is not None and rank < o.cols.shape[2]:
            return -(np.linalg.pinv(X, rcond=1e-6) @ t)
        return -np.linalg.lstsq(X, t, rcond=None)[0]

    def _apply(self, theta, names, coef_all, opt):
        theta = dict(theta)
        for nme, c in zip(names, coef_all[: len(names)]):
            theta[nme] = theta.get(nme, self.nominal[nme]) + c
        theta.update(opt.native(coef_all[len(names):], self.nominal))
        return self._clip(theta)

    def _clip(self, theta):
        out = dict(theta)
        for k, v in theta.items():
            if k.endswith(_NONNEGATIVE):
                out[k] = max(v, 1e-9 if k.endswith(".stribeck_v") else 0.0)
        if "actuator.delay" in out or "sensor.delay" in out:
            dmax = (self.pipe.max_shift - 2) * self.pipe.dt
            for k in ("actuator.delay", "sensor.delay"):
                if k in out:
                    out[k] = min(out[k], dmax)
        return out

    def _chi2(self, theta):
        y = self.vec(self.R(theta))
        return float(y @ y)

    # --------------------------------------------------------- linearisation
    def jacobian(self, selected, theta, mask=None):
        """Weighted Jacobian (N, p) of the residual with respect to the selected native
        parameters at theta: the precomputed columns for linear parameters, central
        differences through the core for the others."""
        names, cols = [], []
        for a in selected:
            g = a.group
            if g.key in LINEARISED or (g.key == "payload" and len(g.params) == 1):
                o = self.options[g.label][0]
                for j, p in enumerate(g.params):
                    names.append(p)
                    cols.append(self.vec_cols(o.cols[:, :, j:j + 1], mask=mask)[:, 0])
                continue
            for p in g.params:
                if g.key == "payload" and p != g.params[0] and theta.get(g.params[0], 0.0) <= 1e-9:
                    continue  # no payload yet: its offset does nothing
                v = theta.get(p, self.nominal[p])
                h = self._fd_step(g, p, v)
                if p.endswith(".delay"):
                    lo, hi = max(v - h, 0.0), min(v + h, (self.pipe.max_shift - 2) * self.pipe.dt)
                    col = (self.R(dict(theta, **{p: hi})) - self.R(dict(theta, **{p: lo}))) / (hi - lo)
                    names.append(p)
                    cols.append(self.vec(col, mask=mask))
                    continue
                Rhi = self._try_R(dict(theta, **{p: v + h}))
                Rlo = None if p.endswith(_NONNEGATIVE) and v - h < 0 else self._try_R(dict(theta, **{p: v - h}))
                if Rhi is not None and Rlo is not None:
                    col = (Rhi - Rlo) / (2 * h)
                elif Rhi is not None:
                    col = (Rhi - self.R(theta)) / h  # at a bound: one-sided
                elif Rlo is not None:
                    col = (self.R(theta) - Rlo) / h
                else:
                    col = np.zeros_like(self.R0)
                names.append(p)
                cols.append(self.vec(col, mask=mask))
        if not cols:
            n = int((self.train if mask is None else mask).sum()) * self.C
            return np.zeros((n, 0)), []
        return np.column_stack(cols), names

    def _fd_step(self, g, p, v):
        if p.endswith(".delay"):
            return 0.2e-3
        if p.endswith(".stribeck_v"):
            return 0.05 * max(v, 1e-9)
        if p.endswith(".effort_max"):
            return 0.005 * max(v, 1e-9)
        if p.endswith(".stribeck"):
            return 0.05 * self.sc.effort[g.joint]
        if p == "payload.m":
            return max(0.05 * v, 1e-3)
        if p.startswith("payload."):
            return 2e-3
        return self._step(g, p)

    def refine(self, selected, theta, iterations: int = 3):
        """Refine the selected parameters on the exact residual: Gauss-Newton (least
        squares) over all but the delays, then each delay again by its instrumental root
        with the others fixed; a few rounds."""
        delays = [a for a in selected if a.group.key in ("actuator_delay", "sensor_delay")
                  and a.group.label in self.instruments]
        others = [a for a in selected if a not in delays]
        linear = all(a.group.key in LINEARISED or (a.group.key == "payload" and len(a.group.params) == 1)
                     for a in others)
        if linear and not delays:
            return theta
        for _ in range(iterations if delays else 1):
            before = dict(theta)
            theta = self._gauss_newton(others, theta, 1 if linear else 4)
            for a in delays:
                p = a.group.params[0]
                rest = {k: v for k, v in theta.items() if k != p}
                y = self.vec(self.R(rest))
                _, opt = self._try_delay(self.options[a.group.label], np.zeros((len(y), 0)), y)
                if opt is not None:
                    theta = dict(rest, **opt.hyper["params"])
            if all(abs(theta.get(k, 0.0) - before.get(k, 0.0)) <= 1e-9 * max(abs(before.get(k, 0.0)), 1e-12)
                   for k in set(theta) | set(before)):
                break
        return theta

    def _gauss_newton(self, selected, theta, iterations):
        """Gauss-Newton on the exact residual over the native parameters of ``selected``
        (the others held), with step halving."""
        if not selected:
            return theta
        chi2 = self._chi2(theta)
        for _ in range(iterations):
            J, names = self.jacobian(selected, theta)
            y = self.vec(self.R(theta))
            if J.shape[1] == 0:
                break
            d = -np.linalg.lstsq(J, y, rcond=1e-10)[0]
            improved = False
            for scale in (1.0, 0.5, 0.25):
                cand = self._clip({**theta, **{n: theta.get(n, self.nominal[n]) + scale * dv
                                              for n, dv in zip(names, d)}})
                Rc = self._try_R(cand)
                if Rc is None:
                    continue
                yc = self.vec(Rc)
                c2 = float(yc @ yc)
                if c2 < chi2:
                    improved = chi2 - c2 > 1e-6 * chi2
                    theta, chi2 = cand, c2
                    break
            if not improved:
                break
        return theta

    # ------------------------------------------------------------- reporting
    def finish(self, sel: Selection):
        theta = sel.theta
        # Noise of the final fit (all channels): for intervals and localisation bands.
        r = self.R(theta)[self.train]
        used = self.use[self.train] > 0
        sig = np.maximum(np.sqrt(np.sum(r**2 * used, axis=0) / np.maximum(used.sum(axis=0), 1)), 1e-15)
        sel.sigma = np.maximum(np.minimum(sig, self.sig * 10), self.floor())
        # Intervals from the final Jacobian.
        if sel.selected:
            J, names = self.jacobian(sel.selected, theta)
            dof = max(self.n_eff - J.shape[1], 1.0)
            s2 = max(sel.chi2_final / dof, 1.0)
            cov = np.linalg.pinv(J.T @ J, rcond=1e-10) * s2
            half = 1.96 * np.sqrt(np.maximum(np.diag(cov), 0.0))
            ci = dict(zip(names, half))
            for a in sel.selected:
                a.values = {p: theta.get(p, self.nominal[p]) for p in a.group.params}
                a.ci = {p: float(ci.get(p, float("nan"))) for p in a.group.params}
            # Importance: chi-square increase when the group is removed (others refitted).
            for a in sel.selected:
                a.importance = self._without(sel.selected, theta, a)[0]
            sel.selected.sort(key=lambda a: -a.importance)
            self.lookalikes(sel)
        sel.detectability = self.detectability(sel)

    def lookalikes(self, sel: Selection):
        """For each selected group, the best group that could take its place."""
        logn = math.log(self.n_eff)
        theta = sel.theta
        bic_final = sel.chi2_final + sum(self._k(a.group) for a in sel.selected) * logn
        for a in sel.selected:
            rest = [b for b in sel.selected if b is not a]
            th = {k: v for k, v in theta.items() if k not in a.group.params}
            J, _ = self.jacobian(rest, th)
            y = self.vec(self.R(th))
            Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
            y_perp = y - Q @ (Q.T @ y)
            k_rest = sum(self._k(b.group) for b in rest)
            cands = []
            for lab, opts in self.options.items():
                g = opts[0].group
                if lab == a.group.label or any(b.group.label == lab for b in rest):
                    continue
                related = g.key in a.group.effect.lookalikes or a.group.key in g.effect.lookalikes
                same_place = g.joint is None or a.group.joint is None or g.joint == a.group.joint
                if not same_place:
                    continue
                best = self._best_option(opts, Q, y_perp, J, y)
                if best[0] is None:
                    continue
                bic_alt = best[0] + (k_rest + best[1].k) * logn
                dbic = bic_alt - bic_final
                if related or dbic < self.lookalike_margin:
                    corr = self._correlation(a.group, g, Q)
                    # The fit apart from the parameter penalty: an alternative with more
                    # parameters that fits exactly as well is the same physics here, not worse.
                    cands.append({"group": g.label, "effect": g.key, "name": g.title, "delta_bic": float(dbic),
                                  "delta_chi2": float(best[0] - sel.chi2_final),
                                  "extra_params": int(best[1].k - self._k(a.group)),
                                  "correlation": corr, "related": related})
            cands.sort(key=lambda c: c["delta_bic"])
            a.lookalikes = [c for c in cands if c["related"] or c["delta_bic"] < self.lookalike_margin][:4]

    def _k(self, g):
        o = self.options.get(g.label)
        return o[0].k if o else len(g.params)

    def _correlation(self, g1, g2, Q):
        """Largest canonical correlation between the two groups' column spaces (first
        option of each), after removing the other selected groups."""
        def space(g):
            o = self.options[g.label][0]
            if o.cols is not None:
                X = self.vec_cols(o.cols)
            else:
                X = self.vec(o.offset)[:, None]
            X = X - Q @ (Q.T @ X)
            u, s, _ = np.linalg.svd(X, full_matrices=False)
            keep = s > 1e-9 * (s[0] if len(s) else 1)
            return u[:, keep]
        try:
            U1, U2 = space(g1), space(g2)
            if U1.shape[1] == 0 or U2.shape[1] == 0:
                return 0.0
            return float(np.clip(np.linalg.svd(U1.T @ U2, compute_uv=False)[0], 0.0, 1.0))
        except (np.linalg.LinAlgError, KeyError):
            return float("nan")

    def detectability(self, sel: Selection):
        """Smallest amplitude of each candidate that would have entered, against the
        effect's reference size: a group is 'not excited' if it is larger."""
        logn = math.log(self.n_eff)
        J, _ = self.jacobian(sel.selected, sel.theta)
        Q = np.linalg.qr(J)[0] if J.shape[1] else None
        out = {}
        for lab, opts in self.options.items():
            o = opts[len(opts) // 2]
            g = o.group
            need = math.sqrt(self.threshold + o.k * logn)
            if o.cols is not None:
                X = self.vec_cols(o.cols)
                if Q is not None:
                    X = X - Q @ (Q.T @ X)
                s = np.linalg.svd(X, compute_uv=False)
                s_min = s[min(o.hyper.get("rank", len(s)), len(s)) - 1] if len(s) else 0.0
                # the amplitude column (first) for scalar summaries
                size = need / s_min if s_min > 0 else float("inf")
                if g.key == "payload" and len(g.params) == 4:
                    size = need / max(np.linalg.norm(X[:, 0]), 1e-300)
            else:
                # a profile option: its offset scales roughly with the hyper-parameter
                off = self.vec(o.offset)
                if Q is not None:
                    off = off - Q @ (Q.T @ off)
                val = list(o.hyper["params"].values())[0] - self.nominal[g.params[0]]
                nrm = np.linalg.norm(off)
                size = need * abs(val) / nrm if nrm > 0 else float("inf")
                if g.key in ("saturation", "dead_zone"):
                    size = float("nan")
            out[lab] = (float(size), float(reference_size(g, self.sc, self.model)))
        return out


def _inflation(r, window, step):
    """Variance inflation 1 + 2 sum_L rho_L of a decimated smoothed residual (sum to the
    first negative autocorrelation, at most two smoothing windows)."""
    r = r - r.mean()
    v = float(r @ r)
    if v <= 0:
        return 1.0
    lmax = max(1, int(math.ceil(2 * window / step)))
    s = 0.0
    for L in range(1, min(lmax, len(r) // 4) + 1):
        rho = float(r[:-L] @ r[L:]) / v
        if rho <= 0:
            break
        s += rho
    return max(1.0, 1.0 + 2.0 * s)
