"""The discovery's search: the candidate columns of every term on every effort channel
(:class:`Search`), the ripple's period from the residual's spectrum and the grids of the
fading friction's velocity scale and of the smooth step (:mod:`.discovery`).
"""
from __future__ import annotations

import numpy as np

from ...errors import ParameterError
from .terms import RATE_TERMS, TERMS
from ..effects import joint_prefix
from ..families import acceptance, products
from ..structure import LOW_SPEEDS


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
