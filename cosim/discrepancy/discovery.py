"""Discovery: the joint force no effect of the library names, as an equation.

After the library's selection, every effort channel is searched for a per-joint force built
from a function library of the joint's position, rate and acceleration (the core's generic joint force,
``<j>[i].force_*``, ``pkm.h``): a constant (the drive's ``<j>[i].offset``, the library's
offset effect: one parameter, so the library and the search can never fit the same column
twice with opposite signs, and a coefficient the library has fitted on a channel is not
searched again there), a spring and its quadratic and cubic terms about
the recording's mean position, quadratic drag qd|qd|, viscous and Coulomb terms split by the
direction of motion, Coulomb levels that fade below a velocity scale v, tanh(qd / v) (from a grid of
scales), a ripple sin/cos(2 pi q / P) with the period P found from the residual's
spectrum over position, a smooth step in position, and an added inertia force_inertia qdd, the
rotor inertia's physics, not searched where the library fits that (a selected step's position and
width, a selected ripple's period and a fading friction's velocity scale are then fitted, with
intervals from the fit linearised in them; the library's offset on the joint is refitted with the
terms).  Each candidate column is a finite
difference of the residual pipeline over its core parameter (the core evaluates the force;
nothing here restates it), the columns of the rate terms and the inertia get instruments (the
same column along the reference motion, free of the rate and acceleration noise), as the
library's masses and viscous frictions do.

Selection per channel is stepwise (forward with BIC, then backward), with the threshold of the
library plus the look-elsewhere cost of the search: ``2 ln M`` for M candidate terms tried
over all channels (a Bonferroni bound: the chance that the best of M noise-only terms passes
is at most M times that of one).  A selected set is kept only if its terms come back in most
block-bootstrap resamples of the fitted part (stability) and it lowers the chi-square of the
held-out part by more than the threshold.  Intervals are the larger of the instrumental
sandwich and the block-bootstrap spread (the residual is autocorrelated and the model may be
wrong: the bootstrap covers both).

A library effect acting on the same channels is then put on trial (:func:`judge_library`):
the discovered terms in its place replace it only when they fit the held-out part
significantly better (:func:`significant`: the held-out chi-square lower by more than the
threshold a term pays to enter, look-elsewhere cost included, and by more than Z_ONE_SIDED
standard errors of that difference over blocks of the held-out part); otherwise the library
effect is named, because it carries a physics name, and the discovered terms are listed as
a tie when they fit about as well.  Two effects on a common channel then go on trial together
(Coulomb friction and an offset are, while the joint moves, friction that differs by
direction; a friction restated alone in place of two effects makes the other a stand-in).
"""
from __future__ import annotations

import copy
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError
from ._linalg import small_lstsq
from .effects import joint_prefix
from .families import acceptance, products
from .intervals import hac_covariance
from .regressors import MIN_RELEVANCE, fit
from .structure import LOW_SPEEDS, own_noise, samples_per_independent

#: term -> (core keys of its coefficients, scale of its basis function: "1", "T", "T2", "T3",
#: "V", "V2", "A" (the acceleration)), shape parameters it needs, what it is in words
TERMS = {
    "constant": (("offset",), ("1",), (), "a constant force (the drive's offset)"),
    "spring": (("force_k1",), ("T",), ("force_qc",), "a force proportional to the position (a spring)"),
    "quadratic": (("force_k2",), ("T2",), ("force_qc",), "a force quadratic in the position"),
    "cubic": (("force_k3",), ("T3",), ("force_qc",), "a force cubic in the position (a hardening spring)"),
    "drag": (("force_v2",), ("V2",), (), "quadratic drag, qd |qd|"),
    "viscous_pos": (("force_vpos",), ("V",), (), "viscous friction moving in the positive direction"),
    "viscous_neg": (("force_vneg",), ("V",), (), "viscous friction moving in the negative direction"),
    "coulomb_pos": (("force_cpos",), ("1",), (), "Coulomb friction moving in the positive direction"),
    "coulomb_neg": (("force_cneg",), ("1",), (), "Coulomb friction moving in the negative direction"),
    # both directions in one step: a greedy search of single terms would take a look-alike of
    # a friction acting both ways (quadratic drag for half of a viscous one) before either half
    "viscous_both": (("force_vpos", "force_vneg"), ("V", "V"), (), "viscous friction with a level for each direction"),
    "coulomb_both": (("force_cpos", "force_cneg"), ("1", "1"), (),
                     "Coulomb friction with a level for each direction"),
    # the same levels through tanh(qd / force_cv): a friction that builds up over a velocity
    # scale instead of at the smallest speed (one scale per joint in the core: the sharp and the
    # fading levels are one pair of coefficients, entered once)
    "fading": (("force_cpos", "force_cneg"), ("1", "1"), ("force_cv",),
               "Coulomb friction that fades below a velocity scale, a level for each direction"),
    "ripple": (("force_sin", "force_cos"), ("1", "1"), ("force_period",), "a ripple periodic in the position"),
    "step": (("force_step",), ("1",), ("force_step_q", "force_step_w"), "a smooth step in the position"),
    "inertia": (("force_inertia",), ("A",), (), "a force proportional to the acceleration (an inertia on the joint)"),
    # products of the velocity's sign with the load or the position, couplings between joints
    # (families/products.py)
    **products.TERMS,
}
#: coefficients of dissipative terms (friction, drag): the friction they make never negative
DISSIPATIVE = ("force_v2", "force_vpos", "force_vneg", "force_cpos", "force_cneg")
#: coefficients with a sign of their physics: friction and drag dissipate, and the joint's
#: inertia (the rotor's the model holds plus the added one) is no less than zero
SIGNED = DISSIPATIVE + ("force_inertia",) + products.SIGNED
#: the library's parameter whose column on its joint is the coefficient's own (the same physics):
#: where the model fits it, the coefficient is not searched
SAME_COLUMN = {"force_inertia": "rotor_inertia"}
#: the library's symmetric friction a direction-split coefficient adds to on its joint: on top
#: of it the split term is the friction's asymmetry, and the total (library level plus the
#: coefficient), not the coefficient, must not be negative
ADDS_TO = {"force_vpos": "viscous", "force_vneg": "viscous", "force_cpos": "coulomb", "force_cneg": "coulomb"}
#: terms whose columns carry the noise of the measured rates or accelerations: estimated with
#: instruments (an acceleration from the smoother is noisier than a rate: the library's rotor
#: inertia is instrumented for the same reason)
RATE_TERMS = ("drag", "viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg", "viscous_both", "coulomb_both",
              "fading", "inertia") + products.RATE_TERMS

#: physical mechanisms that produce each kind of term (for the report's sentence)
MECHANISMS = {
    "constant": "a cable carrier or hose pulling one way, a counterweight or spring preloaded far from its rest, "
                "an offset in the drive's current or torque measurement",
    "spring": "a return spring, a cable carrier or hose bending with the stroke, a bellows or way cover, a gas spring",
    "quadratic": "a cable carrier whose bend changes with the stroke, a spring of changing rate, a stop approached",
    "cubic": "a hardening spring: a cable carrier or bellows stretched towards its ends, an elastic stop",
    "drag": "aerodynamic or fluid drag (a part moving through air, oil or coolant), turbulent flow in a seal or damper",
    "viscous": "a damper or seal that damps one direction more than the other (a check valve, asymmetric lubrication)",
    "coulomb": "friction that differs by direction: asymmetric wear of a guide, screw or nut, a preload on one flank, "
               "a seal lip that drags one way",
    "fading": "friction that builds up over a speed range instead of at once: a contact that deflects before it "
              "slides (pre-sliding, bristles of a seal or brush), a lubricated guide or screw, a belt or elastomer "
              "coupling that creeps, a drive whose friction compensation is smoothed",
    "ripple": "cogging of a motor (magnet pitch), ripple of a ball screw or gear (lead, tooth mesh), a bearing race "
              "or rack with a periodic defect",
    **products.MECHANISMS,
    "step": "a detent, a cable carrier reaching its bend, a seal, cover or limit spring engaging at one position",
    "inertia": "a mass or inertia the drive moves that the model leaves out: a motor rotor, coupling, pulley, belt or "
               "screw, a tool, clamp or cable carrier riding on the carriage",
}

#: standard errors a held-out chi-square gain must exceed to be significant (one-sided 95 %)
Z_ONE_SIDED = 1.645
#: a term is kept when the bootstrap selects it in at least this share of the resamples
STABILITY = 0.6
#: forward steps of the stepwise selection (a term may leave again in the backward pass)
MAX_STEPS = 8
#: bootstrap resamples, and the block length in decimated samples
N_BOOT, BLOCK = 30, 25


@dataclass
class Coefficient:
    """One fitted coefficient of a discovered term: core ``param``, ``value`` and ``ci95``
    (half width of the 95 % interval) in ``unit``, ``base`` the value the model held."""

    param: str
    value: float
    ci95: float
    unit: str
    #: the value the model held before (the library's offset refitted with the term): the
    #: term's force is ``value - base`` times the column on top of the model
    base: float = 0.0


@dataclass
class DiscoveredTerm:
    """The force found on one joint's effort channel.

    ``joint`` (1-based), ``channel``, ``terms`` (keys of :data:`TERMS`), ``equation`` (with
    units and intervals), ``coefficients`` ({core parameter: :class:`Coefficient`}),
    ``shape`` (core shape parameters: the polynomial's centre, the ripple's period, the step's
    position and width, the fading friction's velocity scale), ``mechanisms`` (a sentence),
    ``stability`` (share of bootstrap resamples that select each term), ``heldout_before`` /
    ``heldout_after`` (RMS of the channel's held-out residual without and with the term, in its
    unit), ``delta_chi2_heldout``, ``instead_of`` (library effects it replaced: look-alikes that
    fit worse, offsets it refitted to zero), ``partial`` (why it is not named as the physics:
    structure the recording keeps with it, a partial fit where its own joint keeps it, a tied
    library effect beside it; or "")."""

    joint: int
    channel: str
    terms: list
    equation: str
    coefficients: dict
    shape: dict
    mechanisms: str
    stability: dict
    heldout_before: float
    heldout_after: float
    delta_chi2_heldout: float
    key_variable: str
    instead_of: list = field(default_factory=list)
    #: "" when the recording keeps no structure with the term added; else the sentence saying so
    #: (a partial fit that may stand in for what is missing, not the physics)
    partial: str = ""
    #: 95 % half widths of the shape parameters the fit moves (a step's position and width, a
    #: ripple's period, a fading friction's velocity scale), {core parameter: half width}
    shape_ci95: dict = field(default_factory=dict)
    #: for the report's figure, on the decimated samples: ``key`` (the joint's position or
    #: rate), ``before`` / ``after`` (the channel's residual without / with the term)
    curve: dict = field(default_factory=dict, repr=False)

    def __getitem__(self, k):
        return getattr(self, k)

    def params(self) -> dict:
        """Core parameters that put the term into the plant (shape and coefficients)."""
        return {**self.shape, **{p: c.value for p, c in self.coefficients.items()}}


class Search:
    """The candidate columns of the function library on one engine's recording.

    Columns are taken once, at the library's fitted parameters ``theta``: the force is
    additive in the inverse dynamics, so a column does not depend on what else is fitted."""

    def __init__(self, eng, theta: dict, channels=None):
        self.eng, self.pipe = eng, eng.pipe
        self.theta = dict(theta)
        self.nd = eng.nd
        self.channels = list(range(self.nd)) if channels is None else list(channels)
        self.pre = joint_prefix(eng.model)
        pipe, idx, train = self.pipe, self.pipe.idx, eng.train
        q = pipe.q_s[idx]
        self.q_centre = q[train].mean(axis=0)
        self.travel = np.maximum(q[train].std(axis=0), 1e-12)
        self.rate = np.maximum(np.sqrt(np.mean(pipe.qd_s[idx][train] ** 2, axis=0)), 1e-12)
        self.accel = np.maximum(np.sqrt(np.mean(pipe.qdd_s[idx][train] ** 2, axis=0)), 1e-12)
        self.effort = eng.sc.effort
        self.period = np.array([_period(q[train, j], self._base_residual()[train, j], self.travel[j])
                                for j in range(self.nd)])
        self.periods = {0: self.period}  # per ripple option: the spectrum's, then periods fitted
        self.steps = _step_grid(q[train], self.travel)
        # the slowest fading the rates resolve: below a few times their noise a sharp friction read
        # at noisy rates looks the same (the pipeline leaves such samples out of the fit)
        self.v_floor = 3.0 * np.asarray(pipe.qd_noise, float)
        self.fades = [np.maximum(f * self.rate, self.v_floor) for f in FADE_GRID]  # per option: the scales
        #: (term, option) of shapes fitted off the grid: no candidates
        self.off_grid = set()
        self.q_range = (q[train].min(axis=0), q[train].max(axis=0))
        self.fam = products.grids(self)  # the options of the families' terms
        self.cols, self.instr = {}, {}
        self.w = np.zeros(self.nd)  # per channel: 1 / (own noise sqrt(samples per independent one))
        self._columns()
        self.fam_extra = acceptance.extra_cost(self)  # what a family term pays beyond a library one
        self.fam_on = True  # the families' terms are searched (not in the library's trials)

    def name(self, j: int, key: str) -> str:
        return f"{self.pre}[{j + 1}].{key}"

    def _base_residual(self):
        if not hasattr(self, "_Rb"):
            self._Rb = self.eng.R(self.theta)
        return self._Rb

    def shape(self, term: str, j: int, option: int = 0) -> dict:
        if term in products.TERMS:
            return products.shape(self, term, j, option)
        keys = TERMS[term][2]
        out = {}
        for k in keys:
            if k == "force_qc":
                out[self.name(j, k)] = float(self.q_centre[j])
            elif k == "force_period":
                out[self.name(j, k)] = float(self.periods[option][j])
            elif k == "force_step_q":
                out[self.name(j, k)] = float(self.steps[option][0][j])
            elif k == "force_step_w":
                out[self.name(j, k)] = float(self.steps[option][1][j])
            elif k == "force_cv":
                out[self.name(j, k)] = float(self.fades[option][j])
        return out

    def _delta(self, scale: str, j: int) -> float:
        # a coefficient whose force is 5 % of the joint's RMS effort at the typical position, rate
        # or acceleration
        if scale in ("E", "TE", "TV"):
            return 0.05 * float(self.effort[j]) / products.scale(self, scale, j)
        s = {"1": 1.0, "T": self.travel[j], "T2": self.travel[j] ** 2, "T3": self.travel[j] ** 3,
             "V": self.rate[j], "V2": self.rate[j] ** 2, "A": self.accel[j]}[scale]
        return 0.05 * float(self.effort[j]) / s

    def _columns(self):
        """One pipeline evaluation per coefficient key (every joint at once: the drive layer's
        parameters act on their own joint only), per step position."""
        eng, Rb = self.eng, self._base_residual()
        nd = self.nd
        use_iv = eng.use_instruments
        ref0 = self._ref0 = self.pipe.reference_effort() if use_iv else None
        options = {t: {"step": len(self.steps), "fading": len(self.fades)}.get(t, 1)
                   if t not in products.TERMS else products.n_options(self, t)
                   for t in TERMS if not t.endswith("_both") and t not in products.excluded()}
        if not np.any(self.period > 0):
            options.pop("ripple")
        for term, n_opt in options.items():
            keys, scales, _, _ = TERMS[term]
            for o in range(n_opt):
                shape = {}
                for j in range(nd):
                    shape.update(self.shape(term, j, o))
                cols = np.zeros((Rb.shape[0], nd, len(keys)))
                zs = np.zeros_like(cols) if use_iv and term in RATE_TERMS else None
                for a, (k, s) in enumerate(zip(keys, scales)):
                    deltas = [self._delta(s, j) for j in range(nd)]
                    for attempt in range(4):
                        # a step from the value the model holds (the library's offset, if fitted)
                        p = dict(self.theta, **shape, **{self.name(j, k): self.theta.get(self.name(j, k), 0.0)
                                                         + deltas[j] for j in range(nd)})
                        try:
                            R = eng.R(p)
                            break
                        except ParameterError:
                            # a joint that hardly moves (a step response): the step of a cubic per
                            # its tiny spread leaves the core's range; the column is linear in the
                            # coefficient, and a smaller step gives the same column
                            if attempt == 3:
                                raise
                            deltas = [1e-3 * d for d in deltas]
                    cols[:, :, a] = (R[:, :nd] - Rb[:, :nd]) / np.array(deltas)
                    if zs is not None:
                        ref = self.pipe.reference_effort({**shape, **{self.name(j, k): deltas[j] for j in range(nd)}})
                        zs[:, :, a] = (ref0 - ref) / np.array(deltas)
                self.cols[(term, o)] = cols
                if zs is not None:
                    self.instr[(term, o)] = zs
        for kind in ("viscous", "coulomb"):  # the two directions together: the single terms' columns
            parts = [(f"{kind}_pos", 0), (f"{kind}_neg", 0)]
            if not all(p in self.cols for p in parts):
                continue
            self.cols[(f"{kind}_both", 0)] = np.concatenate([self.cols[p] for p in parts], axis=2)
            if all(p in self.instr for p in parts):
                self.instr[(f"{kind}_both", 0)] = np.concatenate([self.instr[p] for p in parts], axis=2)

    def candidates(self):
        """The grid's candidate terms (a step fitted off the grid is no candidate)."""
        return [k for k in self.cols if k not in self.off_grid]

    def n_tried(self) -> int:
        """Candidate terms tried over all channels (the look-elsewhere count)."""
        return max(1, len(self.candidates()) * len(self.channels))

    def column(self, c: int, key: str, scale: str, shape: dict) -> np.ndarray:
        """The column (samples,) of coefficient ``key`` on joint c with the shape parameters
        ``shape`` ({core name: value}): one pipeline evaluation."""
        d = self._delta(scale, c)
        p = dict(self.theta, **shape, **{self.name(c, key): self.theta.get(self.name(c, key), 0.0) + d})
        return (self.eng.R(p)[:, c] - self._base_residual()[:, c]) / d

    def add_ripple(self, c: int, period: float) -> int:
        """A ripple on joint c of another period: its option number (no candidate)."""
        ps = self.periods[0].copy()
        ps[c] = period
        o = max(self.periods) + 1
        self.periods[o] = ps
        return self._off_grid("ripple", c, o)

    def add_fade(self, c: int, v: float) -> int:
        """Fading Coulomb levels on joint c with velocity scale v: their option number (no candidate)."""
        vs = self.fades[0].copy()
        vs[c] = v
        self.fades.append(vs)
        return self._off_grid("fading", c, len(self.fades) - 1)

    def add_step(self, c: int, q: float, w: float) -> int:
        """A step on joint c at position q, width w: its option number (no candidate)."""
        qs, ws = (a.copy() for a in self.steps[0])
        qs[c], ws[c] = q, w
        self.steps.append((qs, ws))
        return self._off_grid("step", c, len(self.steps) - 1)

    def _off_grid(self, term: str, c: int, o: int) -> int:
        """Option ``o`` of ``term``, whose shape differs from the grid's first option on joint c
        only: that option's columns (and instruments, for a rate term) with joint c's taken
        again at the new shape.  Fitted shapes are no candidates."""
        self.off_grid.add((term, o))
        sh = self.shape(term, c, o)
        cols = self.cols[(term, 0)].copy()
        z = self.instr[(term, 0)].copy() if (term, 0) in self.instr else None
        for a, (k, sc) in enumerate(zip(TERMS[term][0], TERMS[term][1])):
            cols[:, c, a] = self.column(c, k, sc, sh)
            if z is not None:
                d = self._delta(sc, c)
                z[:, c, a] = (self._ref0 - self.pipe.reference_effort({**sh, self.name(c, k): d}))[:, c] / d
        self.cols[(term, o)] = cols
        if z is not None:
            self.instr[(term, o)] = z
        return o


def _period(q, r, travel):
    """The period in position of the strongest ripple of residual r over position q (a
    Lomb-Scargle periodogram over wavelengths from 4 sample spacings of the binned
    position to half the stroke), or 0 when none stands out."""
    from scipy.signal import lombscargle

    lo, hi = float(q.min()), float(q.max())
    span = hi - lo
    if not span > 0 or len(q) < 50:
        return 0.0
    # bin the residual over position: a mean per bin removes the time structure
    nb = min(400, len(q) // 3)
    edges = np.linspace(lo, hi, nb + 1)
    which = np.clip(np.digitize(q, edges) - 1, 0, nb - 1)
    cnt = np.bincount(which, minlength=nb)
    ok = cnt > 0
    ys = np.bincount(which, weights=r, minlength=nb)[ok] / cnt[ok]
    xs = 0.5 * (edges[:-1] + edges[1:])[ok]
    if len(xs) < 20:
        return 0.0
    ys = ys - np.polyval(np.polyfit(xs - xs.mean(), ys, 3), xs - xs.mean())  # the slow part is a polynomial
    wl = np.geomspace(4 * span / nb, span / 2, 400)
    power = lombscargle(xs, ys, 2 * np.pi / wl, normalize=True)
    k = int(np.argmax(power))
    if not power[k] > 0.2:
        return 0.0
    # a finer grid around the peak: a period 1 % off drifts the phase by a third of a
    # radian over ten periods
    fine = np.linspace(0.97 * wl[k], 1.03 * wl[k], 241)
    return float(fine[int(np.argmax(lombscargle(xs, ys, 2 * np.pi / fine, normalize=True)))])


#: velocity scales of the fading Coulomb levels tried, per RMS joint rate of the recording (a
#: factor 3 apart, none below three times the rate readings' noise: the fit then moves the
#: selected one, within FADE_RANGE)
FADE_GRID = LOW_SPEEDS  # the structure test's low-speed family: what it keys on, the search tries
FADE_RANGE = (0.005, 1.0)


def _step_grid(q, travel):
    """Positions (the 20-80 % quantiles of each joint's stroke, 7 points) and a width (a
    tenth of the joint's travel) of the smooth steps tried."""
    qs = np.quantile(q, np.linspace(0.2, 0.8, 7), axis=0)
    return [(qs[i], 0.1 * travel) for i in range(len(qs))]


# ------------------------------------------------------------------------- fitting

@dataclass
class _Fit:
    terms: list          # [(term, option)]
    coef: np.ndarray     # in units of the columns' deltas (= the core parameter values)
    chi2: float
    cov: np.ndarray
    z95: float = 1.96    # multiplier of the HAC standard errors for 95 % intervals
    cov_classical: np.ndarray | None = None  # (Z'X)^-1 Z'Z (X'Z)^-1, in the weights' units


def _design(search, c, terms, rows):
    eng = search.eng
    w = search.w[c] * eng.use[rows, c]
    X = np.concatenate([search.cols[t][rows, c, :] for t in terms], axis=1) * w[:, None] if terms else None
    Zs = []
    for t in terms:
        z = search.instr.get(t)
        Zs.append(search.cols[t][rows, c, :] if z is None else z[rows, c, :])
    Z = np.concatenate(Zs, axis=1) * w[:, None] if terms else None
    return X, Z, w


def _relevant_z(X, Z):
    for j in range(X.shape[1]):
        nx, nz = np.linalg.norm(X[:, j]), np.linalg.norm(Z[:, j])
        if nx == 0 or nz == 0 or abs(X[:, j] @ Z[:, j]) < MIN_RELEVANCE * nx * nz:
            Z[:, j] = X[:, j]  # a column the reference does not image: least squares for it
    return Z


def fit_terms(search, c, y, terms, rows, instruments=True) -> _Fit:
    """Fit ``terms`` to channel c's residual y on ``rows`` (boolean mask of samples)."""
    X, Z, w = _design(search, c, terms, rows)
    t = y[rows] * w
    if not terms:
        return _Fit([], np.zeros(0), float(t @ t), np.zeros((0, 0)))
    Zr = _relevant_z(X, Z) if instruments else None
    coef = fit(X, t, Zr)
    e = t + X @ coef
    chi2 = float(e @ e)
    # two covariances for the intervals: HAC (the scores' correlation in time: the residual
    # drifts where the model is not quite right) and the classical one (scaled by the caller)
    cov, z95 = hac_covariance(X, e, Zr)
    Zc = X if Zr is None else Zr
    A = np.linalg.pinv(Zc.T @ X)
    return _Fit(list(terms), coef, chi2, cov, z95, A @ (Zc.T @ Zc) @ A.T)


#: terms that span a constant while the joint moves: the library's offset is not refitted beside them
SPAN_CONSTANT = ("constant", "coulomb_pos", "coulomb_neg", "coulomb_both", "fading")


def offset_refit(search, c, held, terms) -> list:
    """``[("constant", 0)]`` when the library's offset held on joint c (in ``held``) is
    refitted beside ``terms`` (none of them spans a constant while the joint moves), else []."""
    if search.name(c, "offset") in held and not any(t in SPAN_CONSTANT for t, _ in terms):
        return [("constant", 0)]
    return []


def stepwise(search, c, y, rows, threshold, phi, n_eff, fixed=frozenset(), floor=None, held=None,
             library_only=False):
    """Forward selection (then backward elimination) of terms for channel c by BIC in
    effective samples: a term enters when it lowers chi2 + k log N_eff by more than
    ``threshold`` (chi2 in effective samples: the weights carry 1 / sqrt(phi)).  ``rows`` is a
    boolean mask or an index array (a bootstrap resample); ``fixed``: coefficient keys the
    model already fits on this channel (the library's offset), not searched; ``floor``: the
    smallest value of each dissipative coefficient (default 0; minus the library's level of the
    friction it adds to, :data:`ADDS_TO`); ``held``: the model's parameters, whose offset on
    this joint is refitted beside the terms (:func:`offset_refit`), so that no term enters as
    a stand-in for the offset's share of them.  A term of the families pays more to enter
    (``families/acceptance.py``); ``library_only``: the library's candidates only.  Returns
    the terms."""
    floor = floor or {}
    logn = math.log(max(n_eff, 2.0))
    gram = _Gram(search, c, y, rows)

    def chi2_of(terms):
        c2, coef = gram.fit(terms + offset_refit(search, c, held or {}, terms))
        keys = [k for t, _ in terms for k in TERMS[t][0]]
        # friction and drag dissipate: a negative level is no such term (a Coulomb pair of
        # opposite signs is a constant force while moving), refused as the library refuses
        # a negative friction
        if any(k in SIGNED and v < floor.get(k, 0.0) for k, v in zip(keys, coef)):
            return math.inf
        return c2

    def part_of(terms, cand, cols):  # chi-square with only the columns ``cols`` of cand
        ts = terms + offset_refit(search, c, model or {}, terms + [cand])
        return gram.fit_idx(np.concatenate([gram.at[u] for u in ts] + [np.asarray(cols, int)]))[0]

    chosen = []
    chi2 = chi2_of(chosen)
    model = held  # the model's parameters (the loop's "held" is the coefficients entered)
    cost = lambda t: acceptance.cost(search, t, threshold)  # noqa: E731
    # the library's terms first, then every candidate on top of them (families/acceptance.py)
    candidates, refused = acceptance.searched(search, library_only), set()
    for _ in range(MAX_STEPS):
        best = None
        held = {k for t, _ in chosen for k in TERMS[t][0]} | set(fixed)
        for cand in candidates:
            if cand in refused or held & set(TERMS[cand[0]][0]):  # a coefficient is entered once
                continue
            if products.clash(search, c, chosen, cand, model):  # the core holds one shape per joint
                continue
            c2 = chi2_of(chosen + [cand])
            gain = (chi2 - c2) - len(TERMS[cand[0]][0]) * logn - cost(cand)  # a family term pays more
            if best is None or gain > best[0]:
                best = (gain, cand, c2)
        if best is None or best[0] <= 0.0:
            break
        if not acceptance.own_part(lambda cols: part_of(chosen, best[1], cols), best[2], best[1], gram.at,
                                   logn, cost(best[1])):  # a whole-effort gain is no effort x position
            refused.add(best[1])
            continue
        chosen.append(best[1])
        chi2 = best[2]
        # backward: a term the newer ones made redundant leaves
        for t in list(chosen[:-1]):
            rest = [u for u in chosen if u != t]
            c2 = chi2_of(rest)
            if (c2 - chi2) - len(TERMS[t[0]][0]) * logn <= cost(t):
                chosen, chi2 = rest, c2
    return chosen


class _Gram:
    """The least-squares fits of any set of candidate terms on channel c and ``rows``, from the
    cross products of all candidate columns taken once (a selection fits hundreds of subsets of
    the same columns: a solve of a few unknowns each instead of a least-squares problem over
    the samples)."""

    def __init__(self, search, c, y, rows):
        w = search.w[c] * search.eng.use[rows, c]
        t = y[rows] * w
        self.at, n = {}, 0
        blocks = []
        for cand in search.candidates():
            col = search.cols[cand][rows, c, :] * w[:, None]
            self.at[cand] = np.arange(n, n + col.shape[1])
            n += col.shape[1]
            blocks.append(col)
        X = np.concatenate(blocks, axis=1)
        self.G, self.b, self.tt = X.T @ X, X.T @ t, float(t @ t)

    def fit(self, terms):
        """(chi-square, coefficients) of the least-squares fit of ``terms``, as :func:`_ls_fit`."""
        if not terms:
            return self.tt, np.zeros(0)
        return self.fit_idx(np.concatenate([self.at[u] for u in terms]))

    def fit_idx(self, i):
        """(chi-square, coefficients) of the fit of the candidates' columns ``i`` (indices)."""
        if len(i) == 0:
            return self.tt, np.zeros(0)
        G, b = self.G[i][:, i], self.b[i]
        coef = -small_lstsq(G, b)
        # |t + X c|^2 = t't + 2 c'X't + c'X'X c
        return max(self.tt + 2.0 * float(coef @ b) + float(coef @ G @ coef), 0.0), coef


def _blocks(rows, rng):
    """A moving-block bootstrap resample of the True rows (indices, with repetition)."""
    where = np.flatnonzero(rows)
    n = len(where)
    nb = max(1, n // BLOCK)
    starts = rng.integers(0, max(1, n - BLOCK), nb)
    return where[(starts[:, None] + np.arange(BLOCK)[None, :]).ravel() % n]


def _ls_fit(search, c, y, terms, rows):
    """(chi-square, coefficients) of the least-squares fit of ``terms`` to channel c on
    ``rows`` (mask or index array): the comparison baseline, as in the library's selection."""
    w = search.w[c] * search.eng.use[rows, c]
    t = y[rows] * w
    if not terms:
        return float(t @ t), np.zeros(0)
    X = np.concatenate([search.cols[u][rows, c, :] for u in terms], axis=1) * w[:, None]
    coef = fit(X, t)
    e = t + X @ coef
    return float(e @ e), coef


def bootstrap(search, c, y, rows, terms, threshold, phi, n_eff, seed=0, fixed=frozenset(), floor=None, refit=(),
              held=None):
    """Share of block-bootstrap resamples whose stepwise selection picks each of ``terms``,
    and the spread (standard deviation) of the coefficients of ``terms`` and ``refit`` (terms
    fitted with them, not selected) over them."""
    rng = np.random.default_rng(seed + 7 * c)
    hits = {t: 0 for t in terms}
    coefs = []
    for _ in range(N_BOOT):
        pick = _blocks(rows, rng)
        chosen = stepwise(search, c, y, pick, threshold, phi, n_eff, fixed, floor, held)
        for t in terms:
            hits[t] += any(set(TERMS[u[0]][0]) & set(TERMS[t[0]][0]) for u in chosen)
        coefs.append(_ls_fit(search, c, y, list(terms) + list(refit), pick)[1])
    spread = np.std(np.array(coefs), axis=0) if terms else np.zeros(0)
    return {t: hits[t] / N_BOOT for t in terms}, spread


# ------------------------------------------------------------------------- the step

def discover_channel(search, c, y, threshold, seed=0, theta=None, asymmetry=(), library_result=None):
    """The discovered term on effort channel c (joint c) for the residual y (samples,) of the
    model with parameters ``theta`` (default the search's), or None.  A coefficient ``theta``
    holds on this joint (the library's offset) is not searched: it is fitted already.  For the
    library frictions in ``asymmetry`` ("viscous", "coulomb") a direction-split friction may be
    the asymmetry of the library's symmetric one on this joint (:data:`ADDS_TO`: the total, not
    the coefficient, must not be negative); otherwise each split level is a friction of its
    own.  ``library_result``: a function giving this search's result without the families' terms
    (made already), returned when the selection holds none of them."""
    eng = search.eng
    train, test = eng.train, eng.test
    # The yardstick is the residual's own high-frequency noise (as the structure test's):
    # the engine's noise model is inflated by the very force searched for.
    phi = samples_per_independent(eng.pipe)
    n_eff = float((eng.use[train, c] > 0).sum()) / phi
    lee = 2.0 * math.log(acceptance.n_library(search))  # a family term pays more (search.fam_extra)
    thr = threshold + lee
    held = search.theta if theta is None else theta
    fixed = frozenset(k for t in TERMS.values() for k in t[0]
                      if search.name(c, k) in held or search.name(c, SAME_COLUMN.get(k, k)) in held)
    floor = {k: -float(held.get(search.name(c, lib), 0.0)) if lib in asymmetry else 0.0 for k, lib in ADDS_TO.items()}
    # an added inertia may lower the rotor's the model holds, never below zero
    rotor = search.name(c, "rotor_inertia")
    floor["force_inertia"] = -float(held.get(rotor, eng.model.param(rotor)))

    def heldout(terms):
        # the channel's held-out chi-square without and with the terms, coefficients held
        f = fit_terms(search, c, y, terms, train)
        if not terms:
            return f, 0.0
        Xt, _, wt = _design(search, c, terms, test)
        tt = y[test] * wt
        return f, float(tt @ tt) - float(np.sum((tt + Xt @ f.coef) ** 2))

    r, terms = y, []
    search.w[c] = 0.0
    for _ in range(3):
        # the force searched for also shows in the differences one window apart when it varies
        # fast (a spring on a quick arm): the noise is measured again on the residual of the
        # terms found, and the search repeated with it
        sigma = own_noise(eng.pipe, r[train], eng.accuracy()[c])
        if search.w[c] > 0 and abs(math.log(search.w[c] * sigma * math.sqrt(phi))) < math.log(1.25):
            break
        search.w[c] = 1.0 / (sigma * math.sqrt(phi))
        terms = stepwise(search, c, y, train, thr, phi, n_eff, fixed, floor, held)
        if any(acceptance.is_family(t) for t in terms):
            lib = stepwise(search, c, y, train, thr, phi, n_eff, fixed, floor, held, library_only=True)
            if not acceptance.held_out_keeps(heldout(terms)[1], heldout(lib)[1], threshold, search):
                terms = lib  # the families' terms do not earn their place on the held-out part
        if not terms:
            break
        f0 = fit_terms(search, c, y, terms, np.ones_like(train))
        r = y + np.concatenate([search.cols[t][:, c, :] for t in terms], axis=1) @ f0.coef

    if library_result is not None and not any(acceptance.is_family(t) for t in terms):
        return library_result()  # the same selection as without the families: its result
    # the cheap held-out check first, then the bootstrap's stability
    if not terms or not heldout(terms)[1] > threshold:
        return None
    # The library's offset on this joint is refitted with the terms: fitted before them, it
    # took the part of their force the recording's mean leaves (a spring's force at the mean
    # position: its rest position would be missed).  Not beside Coulomb friction split by
    # direction: while the joint moves the two levels span the constant already.
    refit = lambda kept: offset_refit(search, c, held, kept)  # noqa: E731
    fitted = _resolved_fade(search, c, y, _fit_fade(search, c, y, _fit_period(
        search, c, y, _fit_step(search, c, y, terms, train), train), train), train)
    fitted = products.fit_zone(search, c, y, fitted, train, lambda ts: _ls_fit(search, c, y, ts, train)[0],
                               lambda ts: heldout(ts)[1])
    if fitted != terms:
        # the terms that stood in for the step's misplaced edge go again (the backward pass
        # of the selection, on the fitted step)
        terms = _backward(search, c, y, fitted, train, thr, n_eff)
    stab, spread = bootstrap(search, c, y, train, terms, thr, phi, n_eff, seed=seed, fixed=fixed, floor=floor,
                             refit=refit(terms), held=held)
    # An unstable term goes unless the held-out part needs it: near-equivalent candidates (a
    # constant and a step at the end of the stroke) split the resamples' votes between them.
    full = heldout(terms)[1]
    kept = [t for t in terms if stab[t] >= STABILITY or full - heldout([u for u in terms if u != t])[1] > threshold]
    if not kept:
        return None
    if kept != terms:
        terms = kept
        _, spread = bootstrap(search, c, y, train, terms, thr, phi, n_eff, seed=seed, fixed=fixed, floor=floor,
                              refit=refit(terms), held=held)
    extra = refit(terms)
    if extra:
        # terms that stood in for the offset's part (a step at the end of the stroke) leave
        pruned = _backward(search, c, y, terms, train, thr, n_eff, keep=extra)
        if pruned != terms:
            terms = pruned
            _, spread = bootstrap(search, c, y, train, terms, thr, phi, n_eff, seed=seed, fixed=fixed, floor=floor,
                                  refit=extra, held=held)
    terms = terms + extra
    f, d_held = heldout(terms)
    # an effort term's column bends with its coefficient (the core solves for the applied effort)
    f.coef = products.refine_effort(search, c, terms, f.coef, held, train,
                                    lambda t: list(zip(TERMS[t][0], TERMS[t][1])))
    if not d_held > threshold:
        return None
    # the fit with instruments may leave the selection's least squares: a joint inertia below
    # zero is no body (and no plant of the core)
    keys = [k for t, _ in terms for k in TERMS[t][0]]
    if any(k == "force_inertia" and v < floor[k] for k, v in zip(keys, f.coef)):
        return None
    # the widest of: the HAC interval, the classical one of the residual's own noise in effective
    # samples (s^2 >= 1: never narrower than that noise allows), and the bootstrap's spread of
    # the coefficients (which also sees the selection of the terms)
    s2 = max(f.chi2 / max(n_eff - len(f.coef), 1.0), 1.0)
    half = np.maximum(np.maximum(f.z95 * np.sqrt(np.maximum(np.diag(f.cov), 0.0)),
                                 1.96 * np.sqrt(np.maximum(np.diag(f.cov_classical), 0.0) * s2)), 1.96 * spread)
    use_t = eng.use[test, c] > 0
    rms = lambda a: float(np.sqrt(np.mean(a[use_t] ** 2))) if use_t.any() else float("nan")  # noqa: E731
    yt = y[test]
    Xraw = np.concatenate([search.cols[t][test, c, :] for t in terms], axis=1)
    base = {search.name(c, "offset"): float(held[search.name(c, "offset")])} if extra else {}
    term = _term(search, c, terms, f.coef, half, stab, rms(yt), rms(yt + Xraw @ f.coef), d_held, base=base,
                 shape_ci95=_shape_intervals(search, c, y, terms, f.coef, train, s2))
    return term


def _fit_step(search, c, y, terms, rows):
    """The step of ``terms`` (if any) with its position and width fitted (Nelder-Mead on the
    fitted part's chi-square, every other term refitted with it, from the grid's step; the
    width kept within 2-100 % of the joint's position spread, the position within its range):
    ``terms`` with the step's option replaced by the fitted one."""
    from scipy.optimize import minimize

    k = next((i for i, (t, _) in enumerate(terms) if t == "step"), None)
    if k is None:
        return terms
    qs, ws = search.steps[terms[k][1]]
    q0, w0 = float(qs[c]), float(ws[c])
    lo, hi = float(search.q_range[0][c]), float(search.q_range[1][c])
    T = float(search.travel[c])
    tried = {}

    def at(x):
        q, w = q0 + x[0] * w0, w0 * math.exp(x[1])
        if not (lo <= q <= hi and 0.02 * T <= w <= T):
            return math.inf, None
        o = search.add_step(c, q, w)
        chi2 = _ls_fit(search, c, y, terms[:k] + [("step", o)] + terms[k + 1:], rows)[0]
        tried[o] = chi2
        return chi2, o

    r = minimize(lambda x: at(x)[0], np.zeros(2), method="Nelder-Mead",
                 options={"initial_simplex": [[0, 0], [0.5, 0], [0, 0.5]], "xatol": 0.01, "fatol": 0.1,
                          "maxfev": 40})
    best = min(tried, key=tried.get, default=None)
    start = _ls_fit(search, c, y, terms, rows)[0]
    if best is None or not tried[best] < start or not np.isfinite(r.fun):
        return terms
    return terms[:k] + [("step", best)] + terms[k + 1:]


def _fit_period(search, c, y, terms, rows):
    """The ripple of ``terms`` (if any) with its period fitted (:func:`_fit_shape`), from the
    spectrum's period P0 as P0 (1 + x), x from 0.5 % either side, within +-3 %."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "ripple"), None)
    if k is None:
        return terms
    P0 = float(search.periods[terms[k][1]][c])
    if not P0 > 0:
        return terms
    return _fit_shape(search, c, y, terms, rows, k, lambda x: search.add_ripple(c, P0 * (1.0 + x)), 0.005,
                      (-0.03, 0.03))


def _fit_fade(search, c, y, terms, rows):
    """The fading friction of ``terms`` (if any) with its velocity scale fitted (:func:`_fit_shape`),
    from the grid's v0 as v0 exp(x), x from 0.3 either side, within :data:`FADE_RANGE` of the
    joint's RMS rate and no slower than three times the rate readings' noise."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "fading"), None)
    if k is None:
        return terms
    v0 = float(search.fades[terms[k][1]][c])
    lo, hi = (math.log(max(f * search.rate[c], search.v_floor[c]) / v0) for f in FADE_RANGE)
    return _fit_shape(search, c, y, terms, rows, k, lambda x: search.add_fade(c, v0 * math.exp(x)), 0.3, (lo, hi))


def _resolved_fade(search, c, y, terms, rows):
    """``terms`` with a fading friction whose velocity scale the recording does not resolve
    (its 95 % interval reaches down to :attr:`Search.v_floor`, the slowest scale the rate
    readings tell from a sharp friction) taken as the sharp pair, the simpler account."""
    k = next((i for i, (t, _) in enumerate(terms) if t == "fading"), None)
    if k is None:
        return terms
    f = fit_terms(search, c, y, terms, rows)
    n_eff = float((search.eng.use[rows, c] > 0).sum()) / samples_per_independent(search.eng.pipe)
    s2 = max(f.chi2 / max(n_eff - len(f.coef), 1.0), 1.0)
    name = search.name(c, "force_cv")
    v = search.shape("fading", c, terms[k][1])[name]
    half = _shape_intervals(search, c, y, terms, f.coef, rows, s2).get(name, math.inf)
    if v - half > search.v_floor[c]:
        return terms
    return terms[:k] + [("coulomb_both", 0)] + terms[k + 1:]


def _fit_shape(search, c, y, terms, rows, k, option_at, h, bounds):
    """Term k of ``terms`` with one shape parameter fitted: Newton steps on the fitted part's
    chi-square (the other terms refitted with it) from the parabola through the three best
    values of x tried (``option_at(x)``: the search's option of the term at x; x = 0 is the
    term's own), starting at 0 and +-h, within ``bounds``; done when the step is below a tenth
    of x's standard error the parabola's curvature gives (a chi-square rise of 1), or after
    four steps.  ``terms`` with the term's option replaced by the best one tried."""
    name = terms[k][0]
    start = _ls_fit(search, c, y, terms, rows)[0]
    tried = {0.0: (start, None)}  # x -> (chi-square, option)
    lo, hi = bounds

    def at(x):
        if x not in tried:
            o = option_at(x)
            tried[x] = (_ls_fit(search, c, y, terms[:k] + [(name, o)] + terms[k + 1:], rows)[0], o)
        return tried[x][0]

    for x in (-h, h):
        if lo <= x <= hi:
            at(x)
    for _ in range(4):
        xs = sorted(tried, key=lambda x: tried[x][0])[:3]
        if len(xs) < 3:
            break
        a2, a1, _ = np.polyfit(xs, [tried[x][0] for x in xs], 2)
        best = xs[0]
        if a2 > 0:
            x = float(np.clip(-a1 / (2 * a2), lo, hi))
            if abs(x - best) < 0.1 / math.sqrt(a2):
                break
        else:  # no minimum between them: on towards the lower side
            x = float(np.clip(best + (2 * h if best >= max(xs) else -2 * h), lo, hi))
        if x in tried:
            break
        at(x)
    best = min(tried, key=lambda x: tried[x][0])
    if tried[best][1] is None or not tried[best][0] < start:
        return terms
    return terms[:k] + [(name, tried[best][1])] + terms[k + 1:]


def _backward(search, c, y, terms, rows, threshold, n_eff, keep=()):
    """The backward pass of :func:`stepwise` on ``terms`` (least squares, with the terms
    ``keep`` fitted beside them): a term leaves when the others without it lose no more than
    ``threshold`` plus its BIC price."""
    logn = math.log(max(n_eff, 2.0))
    keep = list(keep)
    chi2 = _ls_fit(search, c, y, terms + keep, rows)[0]
    for t in list(terms):
        rest = [u for u in terms if u != t]
        if not rest:
            break
        c2 = _ls_fit(search, c, y, rest + keep, rows)[0]
        if (c2 - chi2) - len(TERMS[t[0]][0]) * logn <= acceptance.cost(search, t, threshold):
            terms, chi2 = rest, c2
    return terms


def _shape_intervals(search, c, y, terms, coef, rows, s2):
    """95 % half widths of the shape parameters a fit moves (a step's position and width, a
    ripple's period, a fading friction's velocity scale), from the fit linearised in them: the
    derivative of the term's force over each shape parameter (central differences of the
    pipeline's columns) as one more column beside the terms' own; the wider of the classical
    (s^2 >= 1) and the HAC interval."""
    out, extra = {}, []
    i = 0
    for t, o in terms:
        n = len(TERMS[t][0])
        a = coef[i:i + n]
        i += n
        shape = search.shape(t, c, o)
        if t == "step":
            keys = ("force_step_q", "force_step_w")
        elif t == "ripple":
            keys = ("force_period",)
        elif t == "fading":
            keys = ("force_cv",)
        elif t == "zone":
            keys = ("force_czone_q", "force_czone_w")
        else:
            continue
        for key in keys:
            name = search.name(c, key)
            v = shape[name]
            h = 1e-3 * (v if key in ("force_period", "force_cv") else search.travel[c])
            force = []
            for sgn in (1, -1):
                sh = dict(shape, **{name: v + sgn * h})
                force.append(sum(a[b] * search.column(c, k2, sc, sh)
                                 for b, (k2, sc) in enumerate(zip(TERMS[t][0], TERMS[t][1]))))
            extra.append((name, (force[0] - force[1]) / (2 * h)))
    if not extra:
        return out
    w = search.w[c] * search.eng.use[rows, c]
    X = np.concatenate([search.cols[u][rows, c, :] for u in terms] + [d[rows, None] for _, d in extra], axis=1)
    X = X * w[:, None]
    e = y[rows] * w + X[:, :len(coef)] @ coef
    cov_c = np.linalg.pinv(X.T @ X) * s2
    cov_h, z95 = hac_covariance(X, e)
    for j, (name, _) in enumerate(extra):
        jj = len(coef) + j
        out[name] = float(max(1.96 * math.sqrt(max(cov_c[jj, jj], 0.0)), z95 * math.sqrt(max(cov_h[jj, jj], 0.0))))
    return out


def _units(search):
    facts = search.eng.model.facts
    return facts.effort_unit, facts.joint_unit


def _term(search, c, terms, coef, half, stab, before, after, d_held, base=None, shape_ci95=None) -> DiscoveredTerm:
    """The :class:`DiscoveredTerm` of ``terms`` fitted on channel c; ``base``: {core parameter:
    the value the model held} of coefficients refitted with the terms (their coefficient is
    the held value plus the fitted step)."""
    base = base or {}
    F, Q = _units(search)
    units = {p.name: p.unit for p in search.eng.model.param_info()}
    coefs, shape = {}, {}
    i = 0
    for t, o in terms:
        shape.update(search.shape(t, c, o))
        for k in TERMS[t][0]:
            p = search.name(c, k)
            b = base.get(p, 0.0)
            coefs[p] = Coefficient(p, b + float(coef[i]), float(half[i]), units.get(p, ""), b)
            i += 1
    names = [t for t, _ in terms]
    eq = equation(names, coefs, shape, search, c, shape_ci95 or {})
    kinds = []
    # a constant beside a spring is the spring's rest position, no force of its own; a
    # refitted offset is the library's
    refitted = {search.name(c, "offset")} & set(base)
    for t in [n for n in names if not (n == "constant" and ("spring" in names or refitted))]:
        kind = t.split("_")[0]
        if kind not in kinds:
            kinds.append(kind)
    mech = "; ".join(" and ".join(TERMS[n][3] for n in names if n.split("_")[0] == k) + f": {MECHANISMS[k]}"
                     for k in kinds)
    key = _key_variable(names)
    noun = search.eng.model.facts.joint_noun
    return DiscoveredTerm(c + 1, search.pipe.channels[c], names, f"{noun} {c + 1}: {eq}", coefs, shape,
                          mech, {t: stab[(t, o)] for t, o in terms if (t, o) in stab}, before, after, d_held, key,
                          shape_ci95=dict(shape_ci95 or {}))


def _key_variable(names):
    fam = products.key_variable(names)
    if fam:
        return fam
    pos = {"spring", "quadratic", "cubic", "ripple", "step"}
    if any(n in pos for n in names):
        return "position"
    if "inertia" in names:
        return "acceleration"
    if names and all(n == "constant" for n in names):
        return "position"
    return "velocity"


def _pm(v, ci, unit, digits=3):
    u = f" {unit}" if unit else ""
    return f"({v:.{digits}g} +- {ci:.2g}){u}"


def equation(names, coefs, shape, search, c, shape_ci95=None) -> str:
    """F = ... with units and intervals; a spring with a constant as k (q - q0)."""
    F, Q = _units(search)
    shape_ci95 = shape_ci95 or {}

    def sh(key, digits, unit=Q):  # a shape parameter, with its interval when the fit moved it
        v, ci = shape[search.name(c, key)], shape_ci95.get(search.name(c, key))
        return f"{v:.{digits}g} {unit}" if ci is None else f"({v:.{digits}g} +- {ci:.2g}) {unit}"
    get = lambda k: coefs.get(search.name(c, k))  # noqa: E731
    parts = []
    qc = shape.get(search.name(c, "force_qc"))
    k1, c0 = get("force_k1"), get("offset")
    if k1 is not None and c0 is not None and k1.value != 0:
        q0 = qc - c0.value / k1.value
        # delta method, the two taken as independent (an upper bound when they are correlated)
        dq0 = math.hypot(c0.ci95 / abs(k1.value), abs(c0.value) * k1.ci95 / k1.value ** 2)
        parts.append(f"{_pm(k1.value, k1.ci95, k1.unit)} (q - ({q0:.5g} +- {dq0:.2g}) {Q})")
    else:
        if c0 is not None:
            parts.append(_pm(c0.value, c0.ci95, c0.unit))
        if k1 is not None:
            parts.append(f"{_pm(k1.value, k1.ci95, k1.unit)} (q - {qc:.5g} {Q})")
    signs = ("[qd > 0]", "(-[qd < 0])")
    if "fading" in names:  # the levels through tanh(qd / v)
        v = sh("force_cv", 3, f"{Q}/s")
        signs = (f"max(tanh(qd / {v}), 0)", f"min(tanh(qd / {v}), 0)")
    for key, fmt in (("force_k2", "(q - {qc:.5g} {Q})^2"), ("force_k3", "(q - {qc:.5g} {Q})^3"),
                     ("force_v2", "qd |qd|"), ("force_vpos", "max(qd, 0)"), ("force_vneg", "min(qd, 0)"),
                     ("force_cpos", signs[0]), ("force_cneg", signs[1]), ("force_inertia", "qdd")):
        e = get(key)
        if e is not None:
            parts.append(f"{_pm(e.value, e.ci95, e.unit)} " + fmt.format(qc=qc or 0.0, Q=Q))
    s, co = get("force_sin"), get("force_cos")
    if s is not None:
        amp = math.hypot(s.value, co.value)
        damp = math.hypot(s.ci95, co.ci95)
        phase = math.atan2(co.value, s.value)
        parts.append(f"({amp:.3g} +- {damp:.2g}) {F} sin(2 pi q / {sh('force_period', 4)} + {phase:.2f})")
    st = get("force_step")
    if st is not None:
        parts.append(f"{_pm(st.value, st.ci95, st.unit)} tanh((q - {sh('force_step_q', 5)}) / {sh('force_step_w', 3)})")
    parts += products.equation_parts(search, c, names, get, lambda k: shape.get(search.name(c, k)), _pm)
    return "F = " + " + ".join(parts)


def heldout_chi2(search, R, channels):
    """Weighted chi-square of the held-out samples of ``channels`` (in effective samples)."""
    return float(heldout_samples(search, R, channels).sum())


def heldout_samples(search, R, channels):
    """Each held-out sample's weighted chi-square over ``channels`` (held-out samples,)."""
    eng = search.eng
    test = eng.test
    total = np.zeros(int(np.count_nonzero(test)))
    for c in channels:
        r = R[test, c] * search.w[c] * eng.use[test, c]
        total += r * r
    return total


def significant(search, R_a, R_b, channels, bar: float) -> tuple:
    """Does model B fit the held-out part of ``channels`` significantly better than model A?

    ``(better, gain, se)``: the held-out chi-square of A minus B's (``gain``, in effective
    samples) and its standard error ``se`` (the per-sample differences summed over blocks of
    :data:`BLOCK` consecutive held-out samples, the blocks taken as independent: the
    residuals are autocorrelated and, on a real recording, carry structure neither model
    explains, which white-noise chi-square statistics would not count).  B is better when
    ``gain`` exceeds both ``bar`` (the threshold a term pays to enter, look-elsewhere cost
    included) and :data:`Z_ONE_SIDED` ``se`` (B better than A at 95 %, one-sided)."""
    d = heldout_samples(search, R_a, channels) - heldout_samples(search, R_b, channels)
    gain = float(d.sum())
    nb = len(d) // BLOCK
    if nb >= 2:
        sums = d[:nb * BLOCK].reshape(nb, BLOCK).sum(axis=1)
        se = float(np.std(sums, ddof=1) * math.sqrt(nb) * len(d) / (nb * BLOCK))
    else:
        se = float("inf")
    return gain > bar and gain > Z_ONE_SIDED * se, gain, se


def _with_terms(R, search, terms, rows=slice(None)):
    """R with the discovered terms' forces added (their columns times their coefficients)."""
    R = R.copy()
    for t in terms:
        c = t.joint - 1
        i = 0
        for name in t.terms:
            opt = _option(search, t, name)
            cols = search.cols[(name, opt)]
            for a in range(cols.shape[2]):
                p = list(t.coefficients.values())[i]
                R[:, c] += cols[:, c, a] * (p.value - p.base)
                i += 1
    return R


def _option(search, t, name):
    if name in products.TERMS:
        return products.option_of(search, t, name)
    if name == "ripple":
        P = t.shape[search.name(t.joint - 1, "force_period")]
        return next((o for o, ps in search.periods.items() if ps[t.joint - 1] == P), 0)
    if name == "fading":
        v = t.shape[search.name(t.joint - 1, "force_cv")]
        return next((o for o, vs in enumerate(search.fades) if vs[t.joint - 1] == v), 0)
    if name != "step":
        return 0
    q = t.shape[search.name(t.joint - 1, "force_step_q")]
    for o, (qs, _) in enumerate(search.steps):
        if qs[t.joint - 1] == q:
            return o
    return 0


def judge_library(eng, sel, threshold: float):
    """The tie rule between the library's named effects and discovered terms.

    Every effort-family group G of the library's selection is put on trial on the channels it
    acts on, discovery allowed on both sides: (A) the library model with G and the terms
    discovered on top of it, against (B) the model without G and the terms discovered in its
    place, compared on the held-out part (:func:`significant`; the bar is the threshold a
    term pays to enter the search, ``threshold + 2 ln M`` for M candidate terms tried).

    * B significantly better (:func:`significant`), or B with fewer free coefficients (the
      rank of the columns) and a held-out gain above the bar: G is withdrawn (the discovered
      terms explain what it explains, and more or more simply) and listed as a look-alike
      that fits worse;
    * B not significantly worse: G is named, because it carries a physics name, but tied with
      the discovered terms (not with confidence), unless they restate it (:func:`restates`:
      Coulomb or viscous friction split by direction with both levels positive is the library's
      friction with an asymmetry);
    * else G is named: it beats the best discovered term.

    Two effects acting on a common channel then go on trial together against the terms in
    their joint place: withdrawn as a single effect would be, or as one force (see the code's
    comments), and tied when those terms fit as well with no more free coefficients (Coulomb and
    viscous friction standing in together for a friction that fades at low speed).

    Terms in G's place that the library names itself (a constant alone: the drive's offset,
    the library's offset effect) are no discovered alternative: the library's own selection
    has weighed G against its look-alikes.

    Returns ``(theta, withdrawn, ties, search, base)``: the library's parameters less the
    withdrawn groups', the withdrawn and the tied groups with their held-out figures, the search,
    and the terms discovered per channel on the final library model."""
    theta = dict(sel.theta)
    search = Search(eng, theta)
    bar = threshold + 2.0 * math.log(acceptance.n_library(search))
    withdrawn, ties = [], []
    acting = []  # (selected group, the channels it acts on), in the order put on trial
    confirmed = {}  # channel -> library frictions that the terms in their place restated

    # The trials search the same channel with the same residual and the same parameters of its
    # joint again and again (two thirds of the calls on a 6-PUS with six frictions on trial): a
    # search is a function of those, of the search's columns and of the joint's noise weight,
    # which it sets and which the held-out comparisons read, so both are kept
    memo = {}

    def discover_all(R, chans, th, asymmetry=None):
        out = {}
        for c in chans:
            asym = tuple((asymmetry or {}).get(c, ()))
            own = search.name(c, "")
            key = (c, hashlib.sha1(np.ascontiguousarray(R[:, c]).tobytes()).hexdigest(),
                   tuple(sorted((k, v) for k, v in th.items() if k.startswith(own))), tuple(sorted(asym)),
                   search.fam_on)
            if key not in memo:
                lib = key[:-1] + (False,)  # the same search without the families, if made
                done = (lambda: memo[lib][0]) if search.fam_on and lib in memo else None  # noqa: E731
                memo[key] = (discover_channel(search, c, R[:, c], threshold, theta=th, asymmetry=asym,
                                              library_result=done), search.w[c])
            term, search.w[c] = memo[key]
            out[c] = copy.deepcopy(term)
        return out

    R_lib = eng.R(theta)
    # the trials weigh the library's effects against the library's own terms; the families' terms
    # are searched on the model that stays, on top of it (families/acceptance.py)
    search.fam_on = False
    base = discover_all(R_lib, range(eng.nd), theta)
    # the yardstick of "acts on a channel": the residual's own noise (the engine's noise model
    # is inflated by a missing force and would hide a small stand-in such as a gravity tilt)
    noise = np.array([own_noise(eng.pipe, R_lib[eng.train, c], eng.accuracy()[c]) for c in range(eng.nd)])
    for a in sorted(sel.selected, key=lambda a: a.importance):
        g = a.group
        if g.effect.family not in ("effort", "both"):
            continue
        th_minus = {k: v for k, v in theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        chans = [c for c in range(eng.nd)
                 if np.sqrt(np.mean((R_lib[:, c] - R_minus[:, c]) ** 2)) > 0.3 * noise[c]]
        if not chans:
            continue
        acting.append((a, chans))
        in_place = [t for t in discover_all(R_minus, chans, th_minus).values() if t is not None]
        if not in_place or all(library_named(t) for t in in_place):
            continue
        on_top = [base[c] for c in chans if base.get(c) is not None]
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, in_place)
        A, B = heldout_chi2(search, R_A, chans), heldout_chi2(search, R_B, chans)
        # free coefficients: a direction-split pair on top of the library's symmetric friction
        # adds one (its asymmetry), not two
        k_A = len(g.params) - 1 + _rank(search, [R_lib - R_minus], on_top, chans)
        k_B = _rank(search, [], in_place, chans)
        better, gain, se = significant(search, R_A, R_B, chans, bar)
        restated = any(restates(t, g.key) for t in in_place)
        if restated:
            for c in chans:
                confirmed.setdefault(c, set()).add(g.key)
        figures = {"heldout_chi2_library": A, "heldout_chi2_discovered": B, "gain": gain, "se": se, "bar": bar,
                   "coefficients": [k_A, k_B]}
        # fewer free coefficients and a held-out gain above the bar, or a gain beyond its
        # uncertainty as well
        if (better or (k_B < k_A and gain > bar)) and not restated:
            theta = th_minus
            withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                              "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                              "replaced_by": [t.channel for t in in_place], **figures})
            R_lib = R_minus
            base.update(discover_all(R_lib, chans, theta))
        elif not restated and -gain <= max(bar, Z_ONE_SIDED * se):
            # not told apart on the held-out part: the library effect is named, not with confidence
            _tie(ties, (g,), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
    # Two library effects on one channel may be one force the search names: Coulomb friction and
    # an offset are, while the joint moves, friction that differs by direction.  Alone on trial,
    # each lost to nothing (with the offset kept, the pair in Coulomb's place restated Coulomb);
    # they go on trial together against the terms discovered in their joint place.
    for (a1, ch1), (a2, ch2) in _pairs(acting):
        g1, g2 = a1.group, a2.group
        if not all(p in theta for p in (*g1.params, *g2.params)):
            continue  # one of them was withdrawn already
        th_minus = {k: v for k, v in theta.items() if k not in g1.params and k not in g2.params}
        chans = sorted(set(ch1) | set(ch2))
        R_minus = eng.R(th_minus)
        in_place = [t for t in discover_all(R_minus, chans, th_minus).values() if t is not None]
        if not in_place or any(library_named(t) for t in in_place):
            continue
        # both frictions restated (split by direction, every level positive): they are named,
        # their asymmetry searched on top, as alone on trial
        if all(any(restates(t, g.key) for t in in_place) for g in (g1, g2)):
            continue
        # one of them restated alone (equal levels): the terms in place of both need only it,
        # and the other one stands on trial against them
        alone = [g for g in (g1, g2) if any(restates(t, g.key, distinct=True) for t in in_place)]
        other = [g for g in (g1, g2) if g not in alone]
        # the library's side as it would stay: with the asymmetry of the frictions the terms
        # in their place restated (searched on top of them)
        on_top = [t for t in discover_all(R_lib, chans, theta, asymmetry=confirmed).values() if t is not None]
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, in_place)
        A, B = heldout_chi2(search, R_A, chans), heldout_chi2(search, R_B, chans)
        k_A = (len(g1.params) + len(g2.params) - 2
               + _rank(search, [R_lib - eng.R({k: v for k, v in theta.items() if k not in g.params})
                                for g in (g1, g2)], on_top, chans))
        k_B = _rank(search, [], in_place, chans)
        better, gain, se = significant(search, R_A, R_B, chans, bar)
        figures = {"heldout_chi2_library": A, "heldout_chi2_discovered": B, "gain": gain, "se": se,
                   "bar": bar, "coefficients": [k_A, k_B]}
        as_well = -gain <= max(bar, Z_ONE_SIDED * se)
        if alone:
            # the other effect may be a stand-in the discovered terms do without: when they fit
            # as well with no more free coefficients, it is tied (not named with confidence), and
            # so is the restated one, whose level was fitted with the stand-in's share
            if k_B <= k_A and as_well:
                _tie(ties, (g1, g2), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
            continue
        # the pair is withdrawn by the rule of a single effect's trial (the terms in place of
        # both significantly better, or fewer free coefficients and a held-out gain above the
        # bar: a saturation and viscous friction that stand in for quadratic drag), or, for two
        # effects whose sum is, while the joint moves, a term of the search (:data:`ONE_FORCE`)
        # or that are one column on this recording (the inference's ``collinear`` look-alikes),
        # with no more free coefficients and a held-out fit not worse beyond the bar or its
        # uncertainty: the simpler account is the one force (the two effects are listed as
        # look-alikes that fit as well, not named)
        one = {g1.key, g2.key} in ONE_FORCE or any(c.get("collinear") and c["group"] == g2.label
                                                   for c in a1.lookalikes)
        if better or (k_B < k_A and gain > bar) or (one and k_B <= k_A and as_well):
            figures.update(together=[g1.title, g2.title], as_well=not better)
            for g in (g1, g2):
                withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                                  "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                                  "replaced_by": [t.channel for t in in_place], **figures})
            ties[:] = [t for t in ties if t["group"] not in (g1.label, g2.label)]
            theta, R_lib = th_minus, R_minus
            base.update(discover_all(R_lib, chans, theta))
        elif k_B <= k_A and as_well:
            # one force in place of both fits as well with no more free coefficients (Coulomb and
            # viscous friction for a friction that fades at low speed): neither is named with
            # confidence, the two may stand in for it together
            _tie(ties, (g1, g2), in_place, k_B - k_A, figures, [eng.pipe.channels[c] for c in chans])
    # On the library model that stays, a direction-split friction may now be the asymmetry of a
    # library friction that the terms in its place restated (on trial each level had to be a
    # friction of its own, so that the library effect stood against the discovered terms alone;
    # a friction kept only as a tie may be a stand-in, whose asymmetry would be no physics)
    again = [c for c in confirmed if any(search.name(c, lib) in theta for lib in confirmed[c])]
    base.update(discover_all(R_lib, again, theta, asymmetry=confirmed))
    search.fam_on = True
    if acceptance.split(search.candidates())[1]:
        base = discover_all(R_lib, range(eng.nd), theta, asymmetry=confirmed)
        theta, R_lib = _trials_again(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all)
    return theta, withdrawn, ties, search, base


def _trials_again(eng, sel, search, theta, R_lib, base, bar, withdrawn, discover_all):
    """The library's effects of one joint that stay, on trial once more with the families searched
    on both sides where the terms in their place hold a family term that may withdraw one
    (:data:`.families.acceptance.WITHDRAWING`): an effect whose place such terms take is
    withdrawn by the tie rule's test (significantly better on the held-out part, or fewer free
    coefficients and a gain above the bar), and ``base`` (channel -> term) takes the terms in its
    place.  Returns ``(theta, R_lib)``."""
    for a in sel.selected:
        g = a.group
        c = g.joint
        if g.effect.family not in ("effort", "both") or c is None or not all(p in theta for p in g.params):
            continue
        th_minus = {k: v for k, v in theta.items() if k not in g.params}
        R_minus = eng.R(th_minus)
        # as in the trial (no asymmetry): the trial's search without the families is then made already
        in_place = discover_all(R_minus, [c], th_minus).get(c)
        if in_place is None or not acceptance.withdrawing(in_place):
            continue
        on_top = [base[c]] if base.get(c) is not None else []
        R_A, R_B = _with_terms(R_lib, search, on_top), _with_terms(R_minus, search, [in_place])
        k_A = len(g.params) - 1 + _rank(search, [R_lib - R_minus], on_top, [c])
        k_B = _rank(search, [], [in_place], [c])
        better, gain, se = significant(search, R_A, R_B, [c], bar)
        if better or (k_B < k_A and gain > bar):
            withdrawn.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                              "params": {p: float(sel.theta.get(p, float('nan'))) for p in g.params},
                              "replaced_by": [in_place.channel], "heldout_chi2_library": heldout_chi2(search, R_A, [c]),
                              "heldout_chi2_discovered": heldout_chi2(search, R_B, [c]), "gain": gain, "se": se,
                              "bar": bar, "coefficients": [k_A, k_B]})
            theta, R_lib, base[c] = th_minus, R_minus, in_place
    return theta, R_lib


def _tie(ties, groups, in_place, extra, figures, channels):
    """Each of ``groups`` tied with the terms ``in_place`` (once): named, not with confidence; the
    record says on which ``channels`` and with which parameters (a discovered term fitted
    beside it there is no physics of its own either, diagnosis._beside_tie_sentence)."""
    for g in groups:
        if not any(t["group"] == g.label for t in ties):
            ties.append({"group": g.label, "title": g.title, "params": list(g.params), "channels": list(channels),
                         "terms": [t.equation for t in in_place], "extra_params": extra, **figures})


def _pairs(acting):
    """Pairs of library effects on trial that act on a common channel, in trial order."""
    return [(x, y) for i, x in enumerate(acting) for y in acting[i + 1:] if set(x[1]) & set(y[1])]


def _rank(search, extra, terms, chans) -> int:
    """Number of independent columns among ``extra`` (residual differences, (samples, channels))
    and the columns of ``terms``, over the samples of ``chans`` stacked."""
    cols = [np.concatenate([e[:, c] for c in chans]) for e in extra]
    n = search.eng.test.shape[0]
    for t in terms:
        c = t.joint - 1
        if c not in chans:
            continue
        for name in t.terms:
            block = search.cols[(name, _option(search, t, name))][:, c, :]
            for a in range(block.shape[1]):
                v = np.zeros(n * len(chans))
                k = chans.index(c)
                v[k * n:(k + 1) * n] = block[:, a]
                cols.append(v)
    if not cols:
        return 0
    M = np.array(cols).T
    M = M / np.maximum(np.linalg.norm(M, axis=0), 1e-300)
    sv = np.linalg.svd(M, compute_uv=False)
    return int(np.sum(sv > 1e-6 * sv[0]))


def library_named(term: DiscoveredTerm) -> bool:
    """The term is one the effect library names itself: a constant alone (the drive's offset)."""
    return list(term.terms) == ["constant"]




#: pairs of library effects that are, while the joint moves, one term of the search: Coulomb
#: friction (or one fading at low speed) and a constant offset are friction that differs by
#: direction (the levels' mean and half their difference); so is a dead zone in the offset's
#: place, a constant force where the joint's command keeps one sign.  For the same reason a dead
#: zone and an offset are one force there: a constant outside the zone and whatever the few
#: samples inside it (the efforts nearest zero) hold; alone on trial each is taken over by the other
ONE_FORCE = (tuple({f, c} for f in ("coulomb", "smooth_coulomb") for c in ("offset", "dead_zone"))
             + ({"offset", "dead_zone"},))

#: the coefficient keys of the direction-split pair of a library friction (a friction that fades
#: below a velocity scale: the Coulomb pair through tanh(qd / force_cv), the term "fading")
_PAIR_KEYS = {"coulomb": ("force_cpos", "force_cneg"), "viscous": ("force_vpos", "force_vneg"),
              "smooth_coulomb": ("force_cpos", "force_cneg")}


def restates(term: DiscoveredTerm, key: str, distinct: bool = False) -> bool:
    """The discovered term holds the library effect ``key``: an added inertia positive beyond its
    interval holds the rotor inertia (the same column); Coulomb (viscous) friction split
    by direction with both levels positive beyond their intervals, i.e. the library's friction
    (the levels' mean) and an asymmetry (their difference; none when they are equal within
    their intervals).  A level for one direction only (a one-way damper) is no such friction.
    ``distinct``: the term restates the effect alone, with nothing besides: the two levels
    equal within their intervals (then the pair is the library's friction, not friction that
    differs by direction).  Coulomb levels that fade below a velocity scale (the term "fading")
    restate the library's friction that fades (``smooth_coulomb``), not its sharp Coulomb friction,
    and a sharp pair not the fading one."""
    if key == "rotor_inertia":
        # an added inertia on the joint is the rotor's physics (one column): a positive one restates it
        inertia = [c for name, c in term.coefficients.items() if name.endswith(".force_inertia")]
        return (bool(inertia) and inertia[0].value > inertia[0].ci95
                and (not distinct or list(term.terms) == ["inertia"]))
    if key not in _PAIR_KEYS:
        return False
    if key in ("coulomb", "smooth_coulomb") and ("fading" in term.terms) != (key == "smooth_coulomb"):
        return False  # a sharp pair is no friction that fades, nor a fading one a sharp friction
    pos = neg = None
    for name, c in term.coefficients.items():
        k = name.rsplit(".", 1)[1]
        if k == _PAIR_KEYS[key][0]:
            pos = c
        elif k == _PAIR_KEYS[key][1]:
            neg = c
    both = pos is not None and neg is not None and pos.value > pos.ci95 and neg.value > neg.ci95
    if distinct:
        return both and abs(pos.value - neg.value) <= math.hypot(pos.ci95, neg.ci95)
    return both
