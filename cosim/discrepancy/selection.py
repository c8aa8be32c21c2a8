"""Attribution: which effects of the library the residual supports, with what parameters.

The engine in four parts a reader can hold: :mod:`.regressors` (1), :mod:`.noise` (2), this
module (3: forward selection) and :mod:`.inference` (4); the diagnosis (:mod:`cosim.discrepancy`)
puts them together.

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
   grid value, no free amplitude).  The columns built from the measured motion (masses,
   inertias, viscous friction) get instruments, the same columns along the reference
   motion, and are estimated by instrumental variables (:func:`.regressors.fit`): the
   noise of the measured accelerations would bias least squares low.
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

from .effects import Group
from .inference import Inference
from .noise import NoiseModel, _inflation  # noqa: F401  (re-exported)
from .regressors import (LINEAR, LINEARISED, LOCAL, TYPICAL_RATE, VELOCITY_SCALED, _NONNEGATIVE, Option,  # noqa: F401
                         Regressors, Scales, _joint_mass, fit, reference_size)
from .residuals import DiagnosisError


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


#: a delay's instrumental root must be this many standard errors from zero
DELAY_T = 3.0


class Engine(Regressors, NoiseModel, Inference):
    """Holds the candidate columns of one recording and runs the selection."""

    def __init__(self, pipe, groups, *, train_fraction: float = 0.7, threshold: float = 10.0,
                 lookalike_margin: float = 10.0, max_groups: int = 8, instruments: bool = True,
                 verbose: bool = False):
        self.pipe, self.groups = pipe, groups
        self.train, self.test = pipe.split(train_fraction)
        if self.train.sum() < 20:
            raise DiagnosisError(f"{pipe.where}: the fitted part of the recording has {int(self.train.sum())} "
                                 f"decimated samples; at least 20 are needed")
        self.threshold, self.lookalike_margin, self.max_groups = threshold, lookalike_margin, max_groups
        self.verbose = verbose
        self.use_instruments = instruments and pipe.has_reference
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

    def _select(self):
        logn = math.log(self.n_eff)
        selected, theta, steps = [], {}, []
        self.refused = {}
        # A group backward elimination took out does not come back in this selection: with
        # instruments the entry's gain and the removal's cost are two different fits, and
        # a group between them would go in and out until the entries run out.
        removed = set()
        y = self.vec(self.R0)
        chi2_nom = chi2 = float(y @ y)
        if self.verbose:
            print(f"  noise {self.sig}, phi {self.phi}, N_eff {self.n_eff:.0f}, chi2 {chi2:.1f}")
        last_best = {}
        while len(steps) < self.max_groups:  # entries (an all-joints entry adds several groups)
            # Delays already in the model are held (their instrumental estimate is
            # refreshed by refine); least squares would pull them to the noise-biased value.
            J, names, Z = self.jacobian(self._fitted_jointly(selected), theta, instruments=True)
            y = self.vec(self.R(theta))
            Q = np.linalg.qr(J)[0] if J.shape[1] else np.zeros((len(y), 0))
            y_perp = y - Q @ (Q.T @ y)
            # The candidates are fitted with the current parameters projected out by least
            # squares; with instruments the current chi-square is above that projection's,
            # so the baseline is the projection's, or every candidate would be credited
            # with the difference.
            chi2 = float(y_perp @ y_perp) if Z is not None else float(y @ y)
            best = None
            last_best = {}
            taken = {a.group.label for a in selected} | removed
            # A group that shares a parameter with a selected one (a fading and a step
            # Coulomb friction of one joint) would fight over it: the first one in stays.
            held = {p for a in selected for p in a.group.params}
            for lab, opts in list(self.options.items()) + list(self._joint_sets(taken).items()):
                if lab in taken or held & set(opts[0].group.params):
                    continue
                c2, o2 = self._best_option(opts, Q, y_perp, J, y)
                if c2 is None:
                    continue
                gbest = (c2 - chi2 + o2.k * logn, o2, c2)
                last_best[lab] = gbest[0]
                # Two candidates that are the same physics here (a dead zone under a command
                # of one sign and an offset of that sign) fit equally to rounding: the first
                # in the library's order stays, not the one rounding favours.
                if best is None or gbest[0] < best[0] - 1e-9 * abs(chi2):
                    best = gbest
            if best is None or best[0] > -self.threshold:
                break
            dbic, opt, c2 = best
            coef_all = self._coef(opt, J, y, Z)
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
            before = {a.group.label for a in selected}
            selected, theta = self._prune(selected, theta, logn)
            removed |= before - {a.group.label for a in selected}
            # Statistically supported but physically negligible (a tenth of a 'small'
            # effect, e.g. a 5 us delay): model misfit leaking into a candidate, not physics.
            for a in list(selected):
                size = self._magnitude(a.group, theta)
                ref = reference_size(a.group, self.sc, self.model)
                why = None
                if a.group.key not in ("saturation", "dead_zone") and ref > 0 and size < 0.1 * ref:
                    why = f"fitted size {size:.3g} is below a tenth of a small one ({ref:.3g}): negligible"
                elif a.group.key in VELOCITY_SCALED:
                    # A velocity scale that left the grid upwards is not resolved by this recording:
                    # a fading friction never reaches its full value (friction proportional to
                    # speed), a Stribeck peak never fades (a constant friction: Coulomb).
                    v, top = theta.get(a.group.params[1], 0.0), float(self.velocity_grid()[-1])
                    if v > 1.5 * top:
                        what = ("a friction proportional to speed" if a.group.key == "smooth_coulomb" else
                                "a friction that never fades, Coulomb friction")
                        why = (f"its velocity scale {v:.3g} is above the joint speeds of the recording "
                               f"({top:.3g}): on this recording it is {what}")
                if why:
                    selected.remove(a)
                    for p in a.group.params:
                        theta.pop(p, None)
                    self.options.pop(a.group.label, None)
                    self.refused[a.group.label] = why
                    theta = self.refine(selected, theta)
        return selected, theta, steps, last_best, chi2_nom

    def _fitted_jointly(self, selected):
        """The selected groups a linearised joint fit may move: all but the delays estimated
        by their instrumental root (held, refreshed by refine)."""
        return [a for a in selected if not (a.group.key.endswith("_delay") and a.group.label in self.instruments)]

    def _magnitude(self, g, theta):
        """Size of a group's fitted change, in the unit of its reference size."""
        p = g.params
        if g.key == "payload" or g.key in VELOCITY_SCALED:
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
            # a joint whose instrument is too weak keeps its own column (least squares there)
            instr = None if all(o.instr is None for o in opts) else np.concatenate(
                [o.cols if o.instr is None else o.instr for o in opts], axis=2)
            groups = [o.group for o in opts]
            pseudo = Group(groups[0].effect, None, tuple(g.params[0] for g in groups))
            out[f"{key}[all]"] = [Option(pseudo, cols, None, {}, len(opts), expand=groups, instr=instr)]
        # A dead zone on every drive: the same width (as a fraction of each joint's typical
        # effort) enters on all at once, then refine sets each width; one joint at a time, a
        # payload's moments would take the common part first.  A drive's dead zone acts on
        # its own effort channel only, so the all-joints offset is the sum of the joints' own.
        by_frac = {}
        for lab, opts in self.options.items():
            g = opts[0].group
            if g.key != "dead_zone" or g.joint is None or lab in taken:
                continue
            for o in opts:
                by_frac.setdefault(o.hyper["fraction"], []).append(o)
        dz = []
        for f, opts in sorted(by_frac.items()):
            if len(opts) < 2:
                continue
            groups = [o.group for o in opts]
            pseudo = Group(groups[0].effect, None, tuple(g.params[0] for g in groups))
            params = {k: v for o in opts for k, v in o.hyper["params"].items()}
            dz.append(Option(pseudo, None, sum(o.offset for o in opts), {"params": params, "fraction": f},
                             len(opts), expand=groups))
        if dz:
            out["dead_zone[all]"] = dz
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
        # as in the selection: delays estimated by instruments are held (least squares
        # would pull them to the noise-biased value and credit the removal with that fit)
        Jr, names, Zr = self.jacobian(self._fitted_jointly(rest), th, instruments=True)
        if Jr.shape[1]:
            d = fit(Jr, y, Zr)
            y = y + Jr @ d
            th2 = self._clip({**th, **{n: th.get(n, self.nominal[n]) + dv for n, dv in zip(names, d)}})
            th = th2 if self._try_R(th2) is not None else th
        return float(y @ y) - self._chi2(theta), th

    def _best_option(self, opts, Q, y_perp, J, y):
        """(chi-square, option) of the best way the group can enter, or (None, None)."""
        g = opts[0].group
        if g.key in ("actuator_delay", "sensor_delay") and g.label in self.instruments:
            return self._try_delay(opts, Q, y_perp)
        if g.key == "dead_zone":
            return self._try_width(opts, Q, y_perp)
        best = (None, None)
        for o in opts:
            c2, _, o2 = self._try(o, Q, y_perp, J, y)
            if c2 is not None and (best[0] is None or c2 < best[0]):
                best = (c2, o2)
        return best

    def _try_width(self, opts, Q, y_perp):
        """A dead zone's width between its profile grid's values: the residual change is
        interpolated linearly between neighbouring widths (from no dead zone to the
        smallest, then grid value to grid value) and the chi-square minimised on each
        segment.  Where the joint's command keeps one sign the change is exactly linear in
        the width (a constant u0 on the command's side), so the dead zone then fits exactly
        as well as a constant effort offset of that sign, its look-alike, instead of losing
        to it by the grid's spacing."""
        g = opts[0].group
        ts = [y_perp] + [y_perp + (self.vec(o.offset) - Q @ (Q.T @ self.vec(o.offset))) for o in opts]
        best, where = None, None
        for i in range(len(opts)):
            d = ts[i + 1] - ts[i]
            dd = float(d @ d)
            a = min(max(-float(ts[i] @ d) / dd, 0.0), 1.0) if dd > 0 else 1.0
            if i == 0 and a == 0.0:
                continue  # no dead zone at all is not an option
            r = ts[i] + a * d
            c2 = float(r @ r)
            if best is None or c2 < best:
                best, where = c2, (i, a)
        if best is None:
            return None, None
        i, a = where
        hi = opts[i]
        lo_off = np.zeros_like(hi.offset) if i == 0 else opts[i - 1].offset
        lo_par = {k: self.nominal[k] for k in hi.hyper["params"]} if i == 0 else opts[i - 1].hyper["params"]
        lo_f = 0.0 if i == 0 else opts[i - 1].hyper["fraction"]
        params = {k: (1 - a) * lo_par[k] + a * v for k, v in hi.hyper["params"].items()}
        off = (1 - a) * lo_off + a * hi.offset
        return best, Option(g, None, off, {"params": params, "fraction": (1 - a) * lo_f + a * hi.hyper["fraction"]},
                            hi.k, expand=hi.expand)

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
            # The root's standard error, sqrt(z'z s2) / |d(z't)/dd|: a root within
            # DELAY_T of them of zero is the noise's (the root drifts off zero as the rate
            # noise grows: 14 us, 85 us, 212 us at 0.2, 1, 3 mm/s on a clean MuJoCo run).
            slope = abs(f[i + 1] - f[i]) / (ds[i + 1] - ds[i])
            se = math.sqrt(float(z @ z) * max(chi / self.n_eff, 1.0)) / slope if slope > 0 else float("inf")
            if d < DELAY_T * se:
                continue
            if best[0] is None or chi < best[0]:
                best = (chi, Option(opts[0].group, None, off, {"params": {p: self.nominal[p] + d}}, 1))
        return best

    def _try(self, o, Q, y_perp, J, y):
        """chi-square of the current model plus option o, its coefficients (parameter
        changes) and the option actually fitted; (None, None, o) if the fit has a
        non-physical sign.  An all-joints option of a non-negative effect keeps the
        joints whose coefficient is positive (active set).

        The residual after a change is ``y + offset + X c`` (+ ``J d`` for the current
        parameters, projected out through Q: least squares for them, also where they have
        instruments, so that every option is measured against the same baseline, the
        chi-square of ``y_perp``).  An option with instruments gets its coefficients by
        instrumental variables, the current parameters partialled out of both."""
        t = y_perp
        if o.offset is not None:
            off = self.vec(o.offset)
            t = t + (off - Q @ (Q.T @ off))
        if o.cols is None:
            return float(t @ t), np.zeros(0), o
        X = self.vec_cols(o.cols)
        Xp = X - Q @ (Q.T @ X)
        Zp = None
        if o.instr is not None:
            # instrumental variables, the current parameters partialled out of both
            Z = self.vec_cols(o.instr)
            Zp = Z - Q @ (Q.T @ Z)
        keep = np.arange(X.shape[1])
        while True:
            coef = fit(Xp[:, keep], t, None if Zp is None else Zp[:, keep])
            if o.expand is None or o.group.effect.sign != ">=0" or np.all(coef >= 0):
                break
            keep = keep[coef >= 0]
            if len(keep) == 0:
                return None, None, o
        if o.expand is not None and len(keep) < X.shape[1]:
            if len(keep) < 2:
                return None, None, o
            o = Option(o.group, o.cols[:, :, keep], None, o.hyper, len(keep), [o.expand[i] for i in keep],
                       None if o.instr is None else o.instr[:, :, keep])
        if not o.sign_ok(coef):
            return None, None, o
        r = t + Xp[:, keep] @ coef
        return float(r @ r), coef, o

    def _coef(self, o, J, y, Z=None):
        """Joint fit: changes of the current parameters, then the option's coefficients
        (instrumental variables where the current parameters ``Z`` or the option have
        instruments, least squares otherwise)."""
        t = y.copy()
        if o.offset is not None:
            t += self.vec(o.offset)
        X = J if o.cols is None else np.hstack([J, self.vec_cols(o.cols)])
        if X.shape[1] == 0:
            return np.zeros(0)
        W = None
        if Z is not None or o.instr is not None:
            W = J if Z is None else Z
            if o.cols is not None:
                W = np.hstack([W, self.vec_cols(o.cols if o.instr is None else o.instr)])
        rank = o.hyper.get("rank")
        if rank is not None and o.cols is not None and rank < o.cols.shape[2]:
            return fit(X, t, W, rcond=1e-6)
        return fit(X, t, W)

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
                out[k] = max(v, 1e-9 if k.endswith((".stribeck_v", ".coulomb_v")) else 0.0)
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
