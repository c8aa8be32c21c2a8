"""The fit state of the attribution: everything the engine's steps read, as plain data.

A :class:`FitState` holds one recording's residual pipeline and candidate groups, the
split into fitted and held-out samples, the samples each channel uses, the recording's
scales, the nominal residual, the candidate options (:func:`.regressors.candidates`), the
channel weights (:func:`.noise.weighted`) and the instruments.  It is frozen: a step that
changes any of it (the weights, a refused candidate) returns a new state
(:func:`dataclasses.replace`), so no result depends on the order other code ran in.

Its methods are queries of that data: the residual at a parameter set (:meth:`FitState.R`),
the weighted channel vector (:meth:`FitState.vec`), the finite-difference step of a
parameter, the noise floor.  The steps of the engine are free functions over it
(docs/architecture.md, "The discrepancy engine").
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from types import MappingProxyType

import numpy as np

from .._native import JointLimitError, ParameterError, UnreachableError
from .regressors import _NONNEGATIVE, Scales
from .residuals import DiagnosisError


def _empty():
    return MappingProxyType({})


@dataclass(frozen=True)
class Settings:
    """The choices of one attribution.

    Attributes
    ----------
    threshold : float
        BIC decrease a group must bring to enter (and its removal must cost to stay).
    lookalike_margin : float
        Delta BIC under which an alternative group is reported as a look-alike.
    max_groups : int
        Largest number of forward entries.
    verbose : bool
        Print the steps.
    """

    threshold: float = 10.0
    lookalike_margin: float = 10.0
    max_groups: int = 8
    verbose: bool = False


@dataclass(frozen=True, eq=False)
class FitState:
    """One recording's attribution data (see the module docstring).

    Build it with :func:`fit_state`, add the candidates with :meth:`with_candidates` and the
    weights with :func:`.noise.weighted`.

    Attributes
    ----------
    pipe : Pipeline
        The residual pipeline of the recording (:class:`.residuals.Pipeline`).
    groups : tuple of Group
        The candidate groups.
    settings : Settings
        Threshold, look-alike margin, entries, verbosity.
    train, test : numpy.ndarray of bool, shape (m,)
        Decimated samples fitted / held out.
    use : numpy.ndarray, shape (m, C)
        1 where a channel uses a sample (a joint's rest phases are left out), else 0.
    use_instruments : bool
        Estimate the errors-in-variables effects by instrumental variables.
    sc : Scales
        Typical magnitudes of the recording per joint.
    R0 : numpy.ndarray, shape (m, C)
        Residual of the nominal model.
    options : Mapping
        Group label -> tuple of :class:`.regressors.Option`, the ways it can enter.
    instrument_cols : Mapping
        Delay group label -> instrument residual change (m, C), unweighted.
    sig, phi : numpy.ndarray, shape (C,), or None
        Noise level and variance inflation per channel (None before :func:`.noise.weighted`).
    W : numpy.ndarray, shape (m, C)
        Weight of every sample of every channel (``use`` before the weights are set).
    n_eff : float or None
        Effectively independent samples of the fitted part.
    instruments : Mapping
        Delay group label -> weighted instrument vector.

    Examples
    --------
    >>> from cosim.discrepancy.engine import prepare          # doctest: +SKIP
    >>> st = prepare(pipe, groups)                            # doctest: +SKIP
    >>> st.R({"rail[1].coulomb": 0.05}).shape == st.R0.shape  # doctest: +SKIP
    True
    """

    pipe: object
    groups: tuple
    settings: Settings
    train: np.ndarray
    test: np.ndarray
    use: np.ndarray
    use_instruments: bool
    sc: Scales
    R0: np.ndarray
    W: np.ndarray
    options: MappingProxyType = field(default_factory=_empty)
    instrument_cols: MappingProxyType = field(default_factory=_empty)
    sig: np.ndarray | None = None
    phi: np.ndarray | None = None
    n_eff: float | None = None
    instruments: MappingProxyType = field(default_factory=_empty)

    def __post_init__(self):
        # frozen means the arrays too: a step that wrote into R0 or the weights would change
        # every other step's input behind its back
        for a in (self.train, self.test, self.use, self.R0, self.W, self.sig, self.phi):
            if isinstance(a, np.ndarray):
                a.setflags(write=False)

    # ------------------------------------------------------------ the recording

    @property
    def model(self):
        return self.pipe.model

    @property
    def nominal(self) -> dict:
        return self.pipe.nominal

    @property
    def nd(self) -> int:
        return self.pipe.nd

    @property
    def C(self) -> int:
        return self.R0.shape[1]

    def R(self, theta: dict) -> np.ndarray:
        """Residual (m, C) with the core parameters ``theta`` changed from the nominal model."""
        return self.pipe.evaluate(theta).stack()

    def try_R(self, theta: dict):
        """:meth:`R`, or None when theta is not a valid parameter set of the core, or one
        the recording cannot be evaluated with (sensor errors that put a joint reading
        outside its stroke: the forward kinematics refuses it)."""
        try:
            return self.R(theta)
        except (ParameterError, JointLimitError, UnreachableError):
            return None

    def chi2(self, theta: dict) -> float:
        """Weighted chi-square of the fitted samples at ``theta``."""
        y = self.vec(self.R(theta))
        return float(y @ y)

    def vec(self, Rm, mask=None, w=None) -> np.ndarray:
        """Weighted residual channels of the rows in ``mask`` (default: the fitted ones), one
        channel after the other; ``w`` (C,) weights instead of :attr:`W`."""
        if mask is None and w is None:  # the fitted rows and their weights, taken once
            rows, W = self._fitted
            return (Rm[rows] * W).T.reshape(-1)
        mask = self.train if mask is None else mask
        W = (self.W if w is None else w * self.use)[mask]
        return (Rm[mask] * W).T.reshape(-1)

    def vec_cols(self, cols, mask=None, w=None) -> np.ndarray:
        """Columns (m, C, k) weighted and stacked as :meth:`vec` does each one: (n C, k)."""
        if mask is None and w is None:
            rows, W = self._fitted
            c = cols[rows] * W[:, :, None]
        else:
            mask = self.train if mask is None else mask
            W = (self.W if w is None else w * self.use)[mask]
            c = cols[mask] * W[:, :, None]
        return c.transpose(1, 0, 2).reshape(-1, cols.shape[2])

    @functools.cached_property
    def _fitted(self) -> tuple:
        """``(rows, weights)``: the fitted rows' indices and their weights :attr:`W`, what
        :meth:`vec` and :meth:`vec_cols` read by default (thousands of times a selection), the
        same rows and values as the mask ``train`` selects."""
        rows = np.flatnonzero(self.train) if self.train.dtype == bool else np.asarray(self.train)
        W = self.W[rows]
        W.setflags(write=False)
        return rows, W

    # ------------------------------------------------------------ the candidates

    def with_candidates(self, options, instrument_cols) -> FitState:
        """A copy with the candidate options and the delays' instrument columns."""
        return replace(self, options=MappingProxyType(dict(options)),
                       instrument_cols=MappingProxyType(dict(instrument_cols)))

    def without_options(self, labels) -> FitState:
        """A copy without the options of the groups ``labels`` (refused candidates)."""
        labels = set(labels)
        return replace(self, options=MappingProxyType({k: v for k, v in self.options.items() if k not in labels}))

    def k(self, group) -> int:
        """Free parameters of a group's options (its parameter count without options)."""
        o = self.options.get(group.label)
        return o[0].k if o else len(group.params)

    def channels(self, group) -> list:
        """The residual channels a per-joint group acts on."""
        i, fam = group.joint, group.effect.family
        ch = []
        if fam in ("effort", "both"):
            ch.append(i)
        if fam in ("kinematic", "both") and self.C > self.nd:
            ch.append(self.nd + i)
        return ch

    def step(self, group, name: str) -> float:
        """Finite-difference step of the core parameter ``name`` of ``group``, from the
        recording's scales."""
        sc, k, i = self.sc, group.key, group.joint
        val = self.nominal[name]
        if k in ("coulomb", "stribeck", "smooth_coulomb", "offset"):
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

    def velocity_grid(self) -> np.ndarray:
        """The velocity scales tried for a Stribeck or fading friction [m/s or rad/s]: 9
        points from a few times the rate noise (a smaller scale is not resolvable) to half
        the median RMS joint speed (a larger one is friction proportional to speed over the
        recording: viscous friction)."""
        v = float(np.median(self.sc.rate))
        vmin = max(0.02 * v, 5.0 * float(np.median(self.pipe.qd_noise)))
        return np.geomspace(vmin, max(0.5 * v, 2 * vmin), 9)

    def clip(self, theta: dict) -> dict:
        """``theta`` with the non-negative parameters at least 0 (velocity scales at least
        1e-9) and the delays at most the pipeline's largest shift."""
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

    # ------------------------------------------------------------ noise floors

    def floor(self) -> np.ndarray:
        """Smallest noise level a channel is given: the accuracy of the pipeline itself
        (integration tolerance, smoothing round-off: 2e-5 of the effort on noiseless
        closed-loop runs), so a noiseless recording does not turn round-off into physics."""
        eff = 1e-4 * self.sc.effort
        return np.concatenate([eff, np.full(self.C - self.nd, 1e-8)])

    def accuracy(self) -> np.ndarray:
        """The smallest residual structure that counts as physics, per channel: 1e-3 of the
        largest smoothed effort of the channel, at least :meth:`floor`.  A noiseless
        recording of the nominal plant still has a residual of 1e-4 of that peak (the
        smoother and the central difference of the rates err at the jerk peaks: 7.9e-5 N
        on the 70 mm step of scenarios/6pus_step_pd.toml, whose interior efforts peak at
        0.7 N), and no force of 0.1 % of the peak effort matters to a model.  The structure
        test and the discovery step use it; the selection keeps :meth:`floor`."""
        peak = np.max(np.abs(self.pipe.tau_s[self.pipe.idx]), axis=0)
        return np.maximum(self.floor(), np.concatenate([1e-3 * peak, np.full(self.C - self.nd, 1e-8)]))


def fit_state(pipe, groups, *, train_fraction: float = 0.7, threshold: float = 10.0,
              lookalike_margin: float = 10.0, max_groups: int = 8, instruments: bool = True,
              verbose: bool = False) -> FitState:
    """The fit state of a recording before its candidates and weights.

    Parameters
    ----------
    pipe : Pipeline
        The recording's residual pipeline.
    groups : sequence of Group
        The candidate groups (:func:`.effects.groups_for`).
    train_fraction : float
        Share of the decimated samples fitted (the first ones); the rest is held out.
    threshold, lookalike_margin, max_groups, verbose
        See :class:`Settings`.
    instruments : bool
        Use instrumental variables where the recording has a reference motion.

    Returns
    -------
    FitState
        Without options and weights (``W`` is the samples each channel uses).

    Raises
    ------
    DiagnosisError
        Fewer than 20 fitted decimated samples.

    Examples
    --------
    >>> st = fit_state(pipe, groups, train_fraction=0.6)   # doctest: +SKIP
    >>> int(st.train.sum()) >= 20                          # doctest: +SKIP
    True
    """
    train, test = pipe.split(train_fraction)
    if train.sum() < 20:
        raise DiagnosisError(f"{pipe.where}: the fitted part of the recording has {int(train.sum())} "
                             f"decimated samples; at least 20 are needed")
    sc = Scales.of(pipe)
    R0 = pipe.evaluate({}).stack()
    nd = pipe.nd
    # Samples used per channel: a joint's channels leave out its rest phases.
    use = np.tile(pipe.usable, (1, R0.shape[1] // nd)).astype(float)
    return FitState(pipe=pipe, groups=tuple(groups),
                    settings=Settings(threshold, lookalike_margin, max_groups, verbose),
                    train=train, test=test, use=use, use_instruments=instruments and pipe.has_reference,
                    sc=sc, R0=R0, W=use.copy())
