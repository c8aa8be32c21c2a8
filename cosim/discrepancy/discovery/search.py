"""The discovery's search: the candidate columns of every term on every effort channel
(:class:`Search`, made by :func:`make_search`, a frozen value), the ripple's period from the
residual's spectrum and the grids of the fading friction's velocity scale and of the smooth
step (:mod:`.discovery`).
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np

from ...errors import ParameterError
from .terms import RATE_TERMS, TERMS
from ..effects import joint_prefix
from ..families import acceptance, products
from ..structure import LOW_SPEEDS


def _frozen(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a``."""
    v = a.view()
    v.flags.writeable = False
    return v


@dataclass(frozen=True, eq=False)
class Search:
    """The candidate columns of the function library on one engine's recording (made by
    :func:`make_search`), a value: what changes it (a channel's noise weight, an option of a
    shape fitted off the grid, the families on or off) is a new Search (:meth:`with_weight`,
    :meth:`with_step`, :meth:`with_ripple`, :meth:`with_fade`, :meth:`with_family_option`,
    ``dataclasses.replace(search, fam_on=...)``), the old one unchanged.

    Columns are taken once, at the library's fitted parameters ``theta``: the force is
    additive in the inverse dynamics, so a column does not depend on what else is fitted."""

    eng: object
    theta: Mapping            # the library's fitted parameters
    channels: tuple           # the effort channels searched
    pre: str                  # the joints' parameter prefix
    q_centre: np.ndarray      # per joint: the fitted part's mean position,
    travel: np.ndarray        # its position spread,
    rate: np.ndarray          # RMS rate,
    accel: np.ndarray         # RMS acceleration,
    effort: np.ndarray        # RMS effort
    period: np.ndarray        # per joint: the ripple's period from the spectrum (0: none)
    v_floor: np.ndarray       # per joint: the slowest fading the rates resolve
    q_range: tuple            # (lowest, highest) position per joint
    base_residual: np.ndarray  # the residual at ``theta``
    ref0: np.ndarray | None   # the reference effort (instruments), None without them
    periods: Mapping          # ripple option -> period per joint: the spectrum's, then periods fitted
    fades: tuple              # fading option -> velocity scale per joint
    steps: tuple              # step option -> (positions, widths) per joint
    fam: Mapping              # the families' terms -> their options (families/products.py)
    cols: Mapping             # (term, option) -> columns (samples, joints, coefficients)
    instr: Mapping            # (term, option) -> instruments of a rate term's columns
    w: np.ndarray             # per channel: 1 / (own noise sqrt(samples per independent one))
    off_grid: frozenset = frozenset()  # (term, option) of shapes fitted off the grid: no candidates
    fam_extra: float = 0.0    # what a family term pays beyond a library one
    fam_on: bool = True       # the families' terms are searched (not in the library's trials)

    @property
    def pipe(self):
        return self.eng.pipe

    @property
    def nd(self) -> int:
        return self.eng.nd

    def name(self, j: int, key: str) -> str:
        return f"{self.pre}[{j + 1}].{key}"

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
        return (self.eng.R(p)[:, c] - self.base_residual[:, c]) / d

    def with_weight(self, c: int, w: float) -> Search:
        """This search with channel c's noise weight ``w``."""
        ws = self.w.copy()
        ws[c] = w
        return replace(self, w=_frozen(ws))

    def with_ripple(self, c: int, period: float) -> tuple:
        """``(search, option)``: a ripple on joint c of another period as a new option (no candidate)."""
        ps = self.periods[0].copy()
        ps[c] = period
        o = max(self.periods) + 1
        return self._with_option("ripple", c, o, periods=MappingProxyType({**self.periods, o: _frozen(ps)}))

    def with_fade(self, c: int, v: float) -> tuple:
        """``(search, option)``: fading Coulomb levels on joint c with velocity scale v as a new
        option (no candidate)."""
        vs = self.fades[0].copy()
        vs[c] = v
        return self._with_option("fading", c, len(self.fades), fades=self.fades + (_frozen(vs),))

    def with_step(self, c: int, q: float, w: float) -> tuple:
        """``(search, option)``: a step on joint c at position q, width w as a new option (no candidate)."""
        qs, ws = (a.copy() for a in self.steps[0])
        qs[c], ws[c] = q, w
        return self._with_option("step", c, len(self.steps), steps=self.steps + ((_frozen(qs), _frozen(ws)),))

    def with_family_option(self, term: str, c: int, option: dict) -> tuple:
        """``(search, option number)``: ``option`` ({core key: values per joint}, differing from
        the grid's first on joint c only) a new option of the families' ``term`` (no candidate)."""
        fam = MappingProxyType({**self.fam, term: self.fam[term] + (option,)})
        return self._with_option(term, c, len(self.fam[term]), fam=fam)

    def option_of(self, t, name: str) -> int:
        """The option of the shaped term ``name`` that the discovered term ``t`` holds (its
        fitted step, ripple period, fading rate or family shape; 0 for a term of one shape)."""
        if name in products.TERMS:
            return products.option_of(self, t, name)
        if name == "ripple":
            P = t.shape[self.name(t.joint - 1, "force_period")]
            return next((o for o, ps in self.periods.items() if ps[t.joint - 1] == P), 0)
        if name == "fading":
            v = t.shape[self.name(t.joint - 1, "force_cv")]
            return next((o for o, vs in enumerate(self.fades) if vs[t.joint - 1] == v), 0)
        if name != "step":
            return 0
        q = t.shape[self.name(t.joint - 1, "force_step_q")]
        return next((o for o, (qs, _) in enumerate(self.steps) if qs[t.joint - 1] == q), 0)

    def _with_option(self, term: str, c: int, o: int, **grown) -> tuple:
        """``(search, o)``: option ``o`` of ``term``, whose shape (in ``grown``: the new fields)
        differs from the grid's first option on joint c only, with that option's columns (and
        instruments, for a rate term) with joint c's taken again at the new shape.  Fitted
        shapes are no candidates."""
        s = replace(self, **grown)
        sh = s.shape(term, c, o)
        cols = s.cols[(term, 0)].copy()
        z = s.instr[(term, 0)].copy() if (term, 0) in s.instr else None
        for a, (k, sc) in enumerate(zip(TERMS[term][0], TERMS[term][1])):
            cols[:, c, a] = s.column(c, k, sc, sh)
            if z is not None:
                d = s._delta(sc, c)
                z[:, c, a] = (s.ref0 - s.pipe.reference_effort({**sh, s.name(c, k): d}))[:, c] / d
        instr = MappingProxyType({**s.instr, (term, o): _frozen(z)}) if z is not None else s.instr
        every = MappingProxyType({**s.cols, (term, o): _frozen(cols)})
        return replace(s, off_grid=s.off_grid | {(term, o)}, cols=every, instr=instr), o


def make_search(eng, theta: dict, channels=None) -> Search:
    """The search of the function library on engine ``eng``'s recording at the library's fitted
    parameters ``theta`` over ``channels`` (default every effort channel): the grid's columns,
    one pipeline evaluation per coefficient key and option (:func:`_columns`)."""
    pipe, idx, train = eng.pipe, eng.pipe.idx, eng.train
    nd = eng.nd
    q = pipe.q_s[idx]
    travel = np.maximum(q[train].std(axis=0), 1e-12)
    rate = np.maximum(np.sqrt(np.mean(pipe.qd_s[idx][train] ** 2, axis=0)), 1e-12)
    Rb = eng.R(dict(theta))
    period = np.array([_period(q[train, j], Rb[train, j], travel[j]) for j in range(nd)])
    # the slowest fading the rates resolve: below a few times their noise a sharp friction read
    # at noisy rates looks the same (the pipeline leaves such samples out of the fit)
    v_floor = 3.0 * np.asarray(pipe.qd_noise, float)
    s = Search(eng=eng, theta=MappingProxyType(dict(theta)),
               channels=tuple(range(nd)) if channels is None else tuple(channels), pre=joint_prefix(eng.model),
               q_centre=q[train].mean(axis=0), travel=travel, rate=rate,
               accel=np.maximum(np.sqrt(np.mean(pipe.qdd_s[idx][train] ** 2, axis=0)), 1e-12),
               effort=eng.sc.effort, period=period, v_floor=v_floor,
               q_range=(q[train].min(axis=0), q[train].max(axis=0)), base_residual=Rb,
               ref0=pipe.reference_effort() if eng.use_instruments else None,
               periods=MappingProxyType({0: period}),
               fades=tuple(np.maximum(f * rate, v_floor) for f in FADE_GRID),  # per option: the scales
               steps=tuple(_step_grid(q[train], travel)), fam=MappingProxyType({}), cols=MappingProxyType({}),
               instr=MappingProxyType({}), w=_frozen(np.zeros(nd)))
    s = replace(s, fam=MappingProxyType({t: tuple(o) for t, o in products.grids(s).items()}))
    cols, instr = _columns(s)
    s = replace(s, cols=MappingProxyType(cols), instr=MappingProxyType(instr))
    return replace(s, fam_extra=acceptance.extra_cost(s))


def _columns(search) -> tuple:
    """``(cols, instr)`` of the grid: one pipeline evaluation per coefficient key (every joint at
    once: the drive layer's parameters act on their own joint only), per step position."""
    eng, Rb, theta = search.eng, search.base_residual, search.theta
    nd = search.nd
    use_iv = eng.use_instruments
    ref0 = search.ref0
    options = {t: {"step": len(search.steps), "fading": len(search.fades)}.get(t, 1)
               if t not in products.TERMS else products.n_options(search, t)
               for t in TERMS if not t.endswith("_both") and t not in products.excluded()}
    if not np.any(search.period > 0):
        options.pop("ripple")
    cols_of, instr_of = {}, {}
    for term, n_opt in options.items():
        keys, scales, _, _ = TERMS[term]
        for o in range(n_opt):
            shape = {}
            for j in range(nd):
                shape.update(search.shape(term, j, o))
            cols = np.zeros((Rb.shape[0], nd, len(keys)))
            zs = np.zeros_like(cols) if use_iv and term in RATE_TERMS else None
            for a, (k, s) in enumerate(zip(keys, scales)):
                deltas = [search._delta(s, j) for j in range(nd)]
                for attempt in range(4):
                    # a step from the value the model holds (the library's offset, if fitted)
                    p = dict(theta, **shape, **{search.name(j, k): theta.get(search.name(j, k), 0.0)
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
                    ref = search.pipe.reference_effort({**shape, **{search.name(j, k): deltas[j] for j in range(nd)}})
                    zs[:, :, a] = (ref0 - ref) / np.array(deltas)
            cols_of[(term, o)] = _frozen(cols)
            if zs is not None:
                instr_of[(term, o)] = _frozen(zs)
    for kind in ("viscous", "coulomb"):  # the two directions together: the single terms' columns
        parts = [(f"{kind}_pos", 0), (f"{kind}_neg", 0)]
        if not all(p in cols_of for p in parts):
            continue
        cols_of[(f"{kind}_both", 0)] = _frozen(np.concatenate([cols_of[p] for p in parts], axis=2))
        if all(p in instr_of for p in parts):
            instr_of[(f"{kind}_both", 0)] = _frozen(np.concatenate([instr_of[p] for p in parts], axis=2))
    return cols_of, instr_of


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
