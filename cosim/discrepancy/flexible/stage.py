"""Where no family fits: a flexible model of what is left, then its dependence.

After the library, the discovery step and the platform force, an effort channel that still
keeps structure (:mod:`.structure`, or a residual holding more than its own noise by the bars of
a claim: :func:`beyond_noise`) is fitted with a flexible regression, scikit-learn's
:class:`~sklearn.ensemble.HistGradientBoostingRegressor` (boosted trees), on every input the
recording offers at the decimated samples (:mod:`.columns`): each joint's position, rate (the smoothed reading,
and the commanded rate where the recording has a reference: its sign is the direction of
motion where the smoothed reading lags at a reversal; with it the sign of the commanded rate
smoothed as the efforts are, the course a force switching with the direction takes in the
smoothed residual), acceleration and the fitted model's
effort (not the measured one: it holds the residual itself), the low-passed |rate| and effort
of each joint (time constants :data:`~.columns.TIME_CONSTANTS`), its low-passed dissipated power
|effort x rate| (:data:`~.columns.POWER_TIME_CONSTANTS`) and that power signed by the direction of motion
(a friction level a slow state sets: a product greedy trees do not find from its factors), the
time since its direction last changed (a friction state a reversal resets: its own channel's
input), the platform pose (from the joints, tracker or not), and time; per channel also the pose and
the rates projected on the direction of a linear fit of the residual, fitted per fold (:mod:`.oblique`),
and where the residual holds a line of its spectrum, the line's phase (:mod:`.periodic`).  A channel
whose structure left is a line is fitted against the own noise of the residual without its lines
(:func:`with_lines`).

It is judged out of fold, by cross-validation over blocks in time spread through the recording
(:mod:`.cv`): a slowly varying input takes in the held-out blocks the values the
fitted ones span, where a held-out end of the recording would lie beyond them.

* **explained share**: 1 - MSE(residual - out-of-fold prediction) / var(residual), claimed only
  when it is at least :data:`SHARE_MIN` and the variance it explains is significant against
  the residual's own noise: a chi-square in independent samples (the explained sum of squares
  over the noise variance, divided by the decimated samples per independent one) above
  :data:`CHI2_MIN`, as for structure left (:mod:`.structure`).  When nothing is claimed and even
  a model predicting all but the noise would fall short of these two bars (``beyond_noise``
  False: the residual holds nothing beyond its own noise), the sentence says that it cannot be
  judged, not that it is not explainable;
* **inputs**: grouped permutation importance out of fold, per fold (a group is one input of one
  joint: "position of slider 3", or the pose, or time; a signed power belongs to the joint's
  rate and history); a group passes when permuting it costs at least :data:`IMPORTANCE_MIN`
  of the residual's variance, :data:`RELATIVE_MIN` of the explained share and :data:`TOP_MIN`
  of the strongest group's importance (at most the share), above :data:`BLOCK_Z` standard
  errors over the folds; it is named when the trees cross-validated without it (on the other
  passing groups) lose :data:`DROP_MIN` of the variance, causes before consequences (the
  channel's own model effort and acceleration follow the force in closed loop: named
  only where the other inputs cannot explain the same share; an acceleration, effort or history
  only where its counterpart along the reference motion adds too: :mod:`.copies`) and a group
  sharing a named one's columns named where those add (:mod:`.select`), the channel's own rate and
  effort the screen passed over named where they add significantly (:mod:`.own_state`); the share claimed is then that of
  the trees on the named groups alone (where two share columns, on fewer of them when that
  explains more out of fold: :func:`.select.lean`), judged again by the same two bars: when it fails them,
  no input is named and the claim is the full model's, on no single input (``screened`` holds
  the groups and their share).  When the trees on every input claim nothing (a force on a few
  inputs drowned by the many, or a weak force spread over many), the groups their importance
  passes are checked and judged alone as above (:func:`.select.screened_first`); when those claim
  nothing either, the group whose strongest column alone explains the most out of fold as a step
  function (:func:`~.cv.binned_shares`) is cross-validated alone and named where it passes;
* **folded by the direction of motion** (:mod:`.folded`): where the best single input as a step
  function explains :data:`~.folded.MARGIN` more of the residual's variance once the residual is
  multiplied by its own joint's direction sigma = +-1, the channel is fitted with the trees on
  sigma y (the level g of a force sigma g: a friction whose level another input sets),
  predicting sigma g; its held-out error, hence its claim, is judged on y as the plain fit's;
  from :data:`~.folded.ALONE` more (not on the joint's own history) instead of the plain fit,
  else beside it, the fit explaining more kept; folded, the joint's rate is named for the
  direction, first, and the curves are those of the level; the level's efforts stay as beside a
  named rate (``directed`` of :func:`.select.made_of_efforts`);
* **the fitted model re-adjusted**: once inputs are named, the fitted model's parameters on the
  channel are refitted linearly beside the trees on them, in turn, per fold
  (:mod:`.backfit`), where that beats the trees alone as an added input must; the share
  claimed is then that of the trees plus the refit, out of fold (``readjusted`` names them);
* **where the trees extrapolate**: the share of samples whose named inputs lay outside the
  range fitted without their block (``outside``), stated when above :data:`OUTSIDE_WARN`;
* **how**: the partial dependence of the prediction on each named input's strongest feature
  (:func:`sklearn.inspection.partial_dependence`), in the input's and the effort's units;
* **whether a found family already says it**: a discovered term or a library effect of the
  same joint keyed on the same input.

The thresholds were set on the tuning seeds of ``bench/flexible_bench.py`` (docs/records/flexible_runs.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .columns import (POWER_TIME_CONSTANTS, SINCE, TIME_CONSTANTS, _lowpass, _since_reversal,  # noqa: F401
                      input_groups, inputs)
from .report import (OUTSIDE_WARN, _where, family_says, figure, markdown, reported, sentence,  # noqa: F401
                     statement)  # the stage's report, re-exported
from .across import across_channels
from .backfit import readjusted, stage_columns
from .beside import copy_alone, judged_last, rules
from .copies import on_channel
from .oblique import extend, extended
from .own_state import beside_named, recorded
from . import motion, periodic
from .cv import N_FOLDS, cross_validate, final_model, folds, gap_for, importance, outside
from .folded import (FoldedModel, direction_columns, direction_dependence, direction_importance, fitted_folded,
                     importance_on_y, kept, screen)
from .select import (DROP_MIN, POSE, causes_alone, consequences, gain, lean, partners, screened_first,  # noqa: F401
                     select, strongest_alone)

#: fewest decimated samples per cross-validation block for a fit
BLOCK = 25
#: smallest explained share claimed, and the chi-square (independent samples) it must explain
SHARE_MIN, CHI2_MIN = 0.05, 25.0
#: an input is named when permuting it costs this share of the residual's variance (out of fold)...
IMPORTANCE_MIN = 0.04
#: ... and this fraction of the explained share
RELATIVE_MIN = 0.1
#: ... and this fraction of the strongest group's importance
TOP_MIN = 0.1
#: ... and it exceeds this many standard errors over the folds
BLOCK_Z = 2.0
#: ... at most this many are checked by refitting without each ...
MAX_INPUTS = 4
#: ... and one is kept when the trees cross-validated without it lose this share of the variance
#: (DROP_MIN, :mod:`.select`: consequences of the force in closed loop last)
#: a channel with no structure flagged and a residual RMS under this factor times its own noise
#: (fitted because it holds more than its noise: :func:`beyond_noise`) carries at most a weak
#: force, which the trees on every input spread over inputs that follow it and do not claim
#: (the position-threshold cases of the tuning set report4: shares 0.03-0.10 out of fold against
#: truths 0.41-0.74): only the strongest input alone is cross-validated there, one small fit
#: instead of the full model's (library cases leave such channels on several joints)
RMS_OVER_NOISE = 2.0

_QUANTITIES = ("position", "rate", "acceleration", "effort", "history")


@dataclass(frozen=True)
class Dependence:
    """One input the flexible model depends on.

    ``group`` (e.g. ``"position of slider 3"``), ``feature`` (the column the curve is drawn
    over, e.g. ``"q3"``), ``joint`` (1-based; None for the pose and time), ``quantity``
    (position, rate, acceleration, effort, history, pose, time), ``importance`` (share of the
    residual variance lost out of fold when the group is permuted, 0-1), ``unit`` (of the
    feature), ``grid`` and ``curve`` (partial dependence of the force on the feature, in the
    channel's effort unit), ``where`` (in words: "above 0.42 m")."""

    group: str
    feature: str
    joint: int | None
    quantity: str
    importance: float
    unit: str
    grid: tuple = ()
    curve: tuple = ()
    where: str = ""


@dataclass(frozen=True)
class FlexibleFit:
    """The flexible model of one effort channel's residual and what it depends on.

    ``channel`` and ``joint`` (1-based), ``share`` (explained share out of fold, at most 1; below 0
    when the model predicts worse than the mean), ``z`` (the chi-square it explains, in
    independent samples against the residual's own noise), ``explained`` (whether it is claimed),
    ``rms_left`` (RMS of the residual) and ``noise`` (its own noise), in ``unit``;
    ``inputs`` (:class:`Dependence`, most important first), ``family`` (a found term or effect
    keyed on the same input, "" if none), ``statement`` (the report's sentence), ``black_box``
    (whether the replay used it as a force)."""

    channel: str
    joint: int
    unit: str
    share: float
    z: float
    explained: bool
    rms_left: float
    noise: float
    inputs: tuple = ()
    family: str = ""
    statement: str = ""
    black_box: bool = False
    #: share of the samples whose named inputs lay outside the range fitted without their block
    outside: float = 0.0
    #: whether the residual holds more than its own noise: a model predicting all but the noise
    #: would explain a share of at least SHARE_MIN and a chi-square above CHI2_MIN (False: whether
    #: it is explainable cannot be judged, there is nothing beyond the noise to explain)
    beyond_noise: bool = True
    #: fitted only because its residual holds more than its noise (no structure flagged, RMS
    #: under RMS_OVER_NOISE times the noise): the report shows it only when a force was found
    weak: bool = False
    #: when the inputs the screen passed do not carry the claim alone: (their groups, the share
    #: of the trees on them out of fold, not significant); the claim is then on no single input
    screened: tuple = ()
    model: object = field(default=None, repr=False, compare=False)
    columns: tuple = field(default=(), repr=False, compare=False)
    #: the columns (indices into ``columns``) ``model`` takes: the named inputs' when any
    use: tuple = field(default=(), repr=False, compare=False)
    #: the residual it was fitted on (decimated samples), in ``unit``
    target: object = field(default=None, repr=False, compare=False)
    #: the fitted model's parameters re-adjusted beside the trees (:mod:`.backfit`): the
    #: share is then that of the trees plus the re-adjusted fit, out of fold
    readjusted: tuple = ()
    #: the projected columns (:func:`.oblique.extend`: ``columns`` and ``use`` past the stage's inputs)
    projections: tuple = field(default=(), repr=False, compare=False)
    #: the line's column (:func:`.periodic.extend`: after the projected ones), fitted on every sample
    lines: tuple = field(default=(), repr=False, compare=False)
    #: the platform's acceleration through a resonance (:func:`.motion.extend`: after the line's),
    #: fitted on every sample: ``(frequency [Hz], mean, scale, weights)`` or ()
    resonance: tuple = field(default=(), repr=False, compare=False)
    #: fitted folded by the direction of motion (:mod:`.folded`): the force is sigma g, ``inputs``
    #: the direction (first) and the inputs of its level g, ``model`` predicts sigma g
    folded: bool = False
    #: the claimed model's out-of-fold prediction of the residual (decimated samples), in ``unit``
    pred: object = field(default=None, repr=False, compare=False)
    #: the groups whose columns the trees were not given (:mod:`.across`) and the clause saying why
    without: tuple = ()
    left_out: str = ""

    @property
    def named(self) -> tuple:
        """The groups of ``inputs``, each once, in their order: a folded fit whose level depends on
        the joint's own rate holds that rate twice in ``inputs`` (the direction first, then the
        level's curve on it), one input named."""
        return tuple(dict.fromkeys(d.group for d in self.inputs))

    def to_dict(self) -> dict:
        out = {k: getattr(self, k) for k in ("channel", "joint", "unit", "share", "z", "explained", "rms_left",
                                             "noise", "family", "statement", "black_box", "outside",
                                             "beyond_noise", "screened", "weak", "readjusted", "folded",
                                             "without", "left_out")}
        out["inputs"] = [vars(d) for d in self.inputs]
        out["named"] = list(self.named)
        return out


def beyond_noise(y, noise, spi) -> bool:
    """Whether residual ``y`` holds more than its own ``noise``: a model predicting all of it
    but the noise would explain a share of at least :data:`SHARE_MIN` and a chi-square (in
    independent samples, ``spi`` decimated samples each) above :data:`CHI2_MIN`, the bars of a
    claim.  Where it does not, no flexible model could make one."""
    var = float(np.var(y))
    room = len(y) * (var - noise ** 2) / max(noise, 1e-300) ** 2 / spi
    return bool(room > CHI2_MIN and var > 0 and noise ** 2 / var <= 1.0 - SHARE_MIN)


def candidates(pipe, R, left, noise) -> list:
    """Effort channels (0-based) worth a flexible fit: structure flagged there (``left``), or a
    residual that holds more than its own noise (``noise``, per channel) by the bars of a claim
    (:func:`beyond_noise`): a force keyed on another joint, which :mod:`.structure` does not
    test, or one too weak for its families."""
    from ..structure import samples_per_independent

    flagged = {e["joint"] - 1 for e in left if e["channel"] in pipe.channels[:pipe.nd]}
    spi = samples_per_independent(pipe)
    return sorted(flagged | {c for c in range(pipe.nd) if beyond_noise(R[:, c], noise[c], spi)})


def with_lines(pipe, left, lines, noise) -> tuple:
    """``(left, noise)`` with the effort channels whose structure left is a spectral line
    (``lines``: entries of :func:`..structure.unexplained` of signature ``periodic``) flagged, and
    their noise the entries' (the own noise of the residual without its lines, where it is the
    smaller): the own noise of a residual holding a fast line reads the line's amplitude, and
    such a channel would hold nothing beyond it (:func:`beyond_noise`)."""
    own = [e for e in lines if e["channel"] in pipe.channels[:pipe.nd]]
    noise = list(noise)
    for e in own:
        noise[e["joint"] - 1] = min(noise[e["joint"] - 1], float(e["noise"]))
    return list(left) + own, noise


def _screen(imp, share) -> list:
    """Groups whose permutation importance passes the thresholds and is significant over the
    folds, most important first (at most :data:`MAX_INPUTS`)."""
    top = min(max(m for m, _ in imp.values()), share)  # a permuted sign can cost more than all the variance
    ok = [g for g, (m, se) in imp.items() if m >= IMPORTANCE_MIN and m >= RELATIVE_MIN * share
          and m >= TOP_MIN * top and m > BLOCK_Z * se]
    return sorted(ok, key=lambda g: -imp[g][0])[:MAX_INPUTS]


def _select(X, y, fold_rows, groups, named, var, follow=(), known=None, after=None, directed=False, claims=None):
    """The check of the screened groups (:func:`.select.select`, causes before
    consequences; ``after``: :func:`.beside.rules`; ``claims``: whether a cross-validation passes the
    two bars, the replacing rules' guard, :func:`.select.claimed_or_checked`): ``(kept,
    cross-validation on the kept groups' columns, its columns)``."""
    return select(X, y, fold_rows, groups, named, var, follow=follow, cross_validate=cross_validate, known=known,
                  after=after, directed=directed, claims=claims)


def fit_channel(pipe, X, columns, y, noise, unit, weak=False, fitted=None, offered=(), without=()) -> FlexibleFit:
    """The flexible model of residual ``y`` (decimated samples, in time order) on inputs ``X``,
    cross-validated over blocks in time (:mod:`.cv`).  The inputs it names are screened
    by grouped permutation importance out of fold, significant over the blocks, then checked one
    by one by cross-validating without them; the share claimed is that of the trees on the named
    inputs alone (the model the statement describes), out of fold.  When the trees on every
    input claim nothing, the groups their importance passes are checked and judged alone
    (:func:`.select.screened_first`), and only when those claim nothing either, or at once for a
    ``weak`` channel (no structure flagged, RMS under :data:`RMS_OVER_NOISE` times the noise), the
    strongest input alone; on a weak channel whose strongest input is a consequence
    (:func:`.select.consequences`) the trees on every input first, causes before consequences.  The
    time since a joint's direction last changed is an input of that joint's channel only.
    ``fitted``: the fitted model's columns on the channel (:func:`.backfit.fitted_columns`),
    re-adjusted beside the trees on the named inputs where that adds (:func:`.backfit.readjusted`).
    Where :func:`.folded.prefer` says so, all of it is done on the residual folded by the joint's
    direction of motion (its columns too), judged against the variance of ``y`` itself: instead of
    the plain fit where the screen's gain is at least :data:`.folded.ALONE`, else beside it, the
    fit explaining more out of fold kept (:func:`.folded.kept`).  ``offered``: the lines [Hz] found
    elsewhere in the recording (:func:`.periodic.offered`), the line's phase where ``y`` holds none by
    its own rule (:func:`.periodic.extend`).  ``without``: groups whose columns the channel's trees
    are not given (:mod:`.across`: the rules reading the channels side by side)."""
    plain, sigma = _fit_channel(pipe, X, columns, y, noise, unit, weak, fitted, offered=offered, without=without)
    if sigma is None:
        return plain
    folded = _fit_channel(pipe, X, columns, y, noise, unit, weak, fitted, sigma=sigma, offered=offered,
                          without=without)[0]
    return kept(plain, folded)


def _fit_channel(pipe, X, columns, y, noise, unit, weak=False, fitted=None, sigma=None, offered=(), without=()):
    """:func:`fit_channel`'s fit, on ``y`` folded by ``sigma`` where given (:mod:`.folded`):
    ``(fit, sigma)``: where ``sigma`` is not given, the screen (:func:`.folded.prefer`) folds at once
    where the folded residual is far better explained, and where it may be, returns the direction
    ``sigma`` for a folded fit beside this plain one (else None)."""
    # loaded before the limit is set: threadpoolctl limits only the OpenMP runtimes already loaded, and
    # an unlimited first fit spins threads on a busy machine (98 s CPU instead of 1.8 s measured)
    import sklearn.ensemble  # noqa: F401
    from threadpoolctl import threadpool_limits

    from ..structure import samples_per_independent

    c = pipe.channels.index(unit[1]) if isinstance(unit, tuple) else None
    unit = unit[0] if isinstance(unit, tuple) else unit
    var = float(np.var(y))
    spi = samples_per_independent(pipe)
    fold_rows = folds(len(y), gap_for(spi))
    def judged(mse):  # (share, chi-square, whether claimed) of a held-out error (a claim stops the screen's trees)
        share = 1.0 - mse / var if var > 0 else 0.0
        z = len(y) * (var - mse) / max(noise, 1e-300) ** 2 / spi
        return share, z, share >= SHARE_MIN and z > CHI2_MIN

    given = (X, columns)
    X, columns, groups, every, keep, projections, lines, resonance = _channel_columns(
        X, columns, y, fold_rows, c, offered, motion.bank(pipe), without)
    reference = on_channel(pipe, *given, keep, X)  # the inputs built from the answer, along the reference
    follow = judged_last(consequences(columns, groups, (joint := c + 1 if c is not None else None)), groups, lines)
    how, direction_c = screen(X, y, columns, c + 1, fold_rows) if sigma is None and c is not None else ("", None)
    screened_fold, sigma = (direction_c if how == "both" else None), (direction_c if how == "folded" else sigma)
    folded, y_seen = sigma is not None, y
    if folded:  # the trees learn the level g of sigma g (:mod:`.folded`); judged on y: the same held-out error
        y, fitted = sigma * y, fitted_folded(fitted, sigma)
    after = rules(X, y, fold_rows, groups, follow, fitted, cross_validate, lines, reference, joint, judged, folded)
    (_screen_c, passed), rng = recorded(_screen), np.random.default_rng(0)  # passed: judged by the rules
    with threadpool_limits(limits=1):
        cv = None if weak else cross_validate(X, y, fold_rows, enough=lambda mse: judged(mse)[2])
        share, z, explained = (0.0, 0.0, False) if weak else judged(cv.mse)
        deps, use, beyond, named, screened = (), list(range(X.shape[1])), 0.0, [], ()
        strongest = strongest_alone(X, y, fold_rows, groups, cross_validate) if weak else None
        if weak and strongest[0] in follow:  # a consequence is no cause: the trees on every input, causes first
            cv = cross_validate(X, y, fold_rows, enough=lambda mse: judged(mse)[2])
            share, z, explained = judged(cv.mse)
        first = screened_first(X, y, fold_rows, groups, follow, judged, cv, share, _screen_c, cross_validate, after,
                               folded) if cv is not None and not explained else None
        if first is not None:  # the trees on the inputs that stood out claim what those on every input did not
            (named, cv, use, share, z), explained = first, True
        elif not explained:  # the trees on every input spread a weak force over many: the strongest input alone
            g, cv_g = strongest or strongest_alone(X, y, fold_rows, groups, cross_validate)
            share_g, z_g, ok = judged(cv_g.mse)
            if ok or weak:
                cv, use, share, z, explained = cv_g, list(groups[g]), share_g, z_g, ok
            named = [g] if ok else []  # with the group sharing its columns where they add (partners)
            kept, cv_k, use_k = _select(X, y, fold_rows, groups, named, var, follow, known={tuple(sorted(use)): cv_g},
                                        after=after, directed=folded) if ok else (named, cv, use)
            share_k, z_k, ok_k = judged(cv_k.mse)
            if kept != named and ok_k:
                named, cv, use, share, z = kept, cv_k, use_k, share_k, z_k
            elif copy_alone(named, kept, ok_k):  # a model effort whose constituents claim nothing: no input
                named = []
        else:
            named = _screen_c(importance(cv, X, y, groups, rng), share)
            if named:
                kept, cv_k, use_k = _select(X, y, fold_rows, groups, named, var, follow, after=after, directed=folded,
                                            claims=lambda v: judged(v.mse)[2])  # the replacing rules' guard
                if any(g in follow for g in kept):  # a consequence named: the causes alone, where they do as well
                    kept, cv_k, use_k = causes_alone(X, y, fold_rows, groups, follow, rng, judged, (kept, cv_k, use_k),
                                                     _screen_c, cross_validate, after, folded)
                share_k, z_k, ok = judged(cv_k.mse)
                if ok:  # the claim is the named inputs' refit's, judged again by the same criterion
                    named, cv, use, share, z = kept, cv_k, use_k, share_k, z_k
                else:  # they do not carry it alone: the claim stays the full model's, on no single input
                    named, screened = [], (tuple(kept), share_k)
        moved, y_t, cv_t = (), y, cv
        if explained and named:  # the own joint's rate and effort the screen's bars passed over
            named, cv, use = beside_named(named, use, cv, groups, joint, X, y, fold_rows, reference, passed, folded)
            cv, use = lean(X, y, fold_rows, groups, named, use, cv, cross_validate)
            share, z, _ = judged(cv.mse)
            cv_t = cv
            cv, moved = readjusted(X[:, use], y, fitted, cv)
            if moved:  # the share claimed is the trees' plus the fitted model re-adjusted beside them
                share, z, _ = judged(cv.mse)
                cv_t, y_t = cv.trees(y)
            sub = {g: [use.index(i) for i in groups[g] if i in use] for g in named}  # a partner: its shared columns
            imp_k = importance_on_y(importance(cv_t, X[:, use], y_t, sub, rng), y_t, sigma)
            beyond = outside(X[:, use], cv, list(range(len(use))))
        model = final_model(X[:, use], cv.less_refit(y, fitted[0]) if moved else y, cv)
        if explained and named:
            deps = tuple(_dependence(model, X[:, use], [columns[i] for i in use], sub[g], g, imp_k[g][0], unit)
                         for g in named)
            if folded:  # the direction of motion first: the curves above are of the level g
                deps = (Dependence(joint=c + 1, **direction_dependence(
                    next(col[1] for col in columns if col[2] == c + 1 and col[3] == "rate"), direction_importance(
                        cv_t, sigma * y_t, sigma, rng)[0], model.predict(X[:, use]))),) + deps
        if folded:  # sigma g from the stage's columns: the direction's columns last
            model, use = FoldedModel(model, len(use)), list(use) + direction_columns(columns, c + 1)
    return (FlexibleFit(pipe.channels[c] if c is not None else "", 0, unit, share, z, explained, float(np.std(y_seen)),
                       float(noise), deps, outside=beyond, beyond_noise=beyond_noise(y_seen, noise, spi),
                       screened=screened, model=model, readjusted=moved, folded=folded, resonance=resonance,
                       pred=sigma * cv.pred if folded else cv.pred, without=tuple(without),
                       **_on_stage_columns(every, keep, columns, use, projections, lines)), screened_fold)


def _channel_columns(X, columns, y, fold_rows, c, offered=(), responses=None, without=()) -> tuple:
    """The inputs of channel ``c`` (0-based; None: any): the stage's columns but another joint's time
    since a reversal (which acts here through the coupling's forces, already inputs), with the pose
    and rates projected (:mod:`.oblique`), the line's phase (:mod:`.periodic`; ``offered``: the lines
    found elsewhere) and, on a platform with a pose, its acceleration through a resonance
    (:mod:`.motion`; ``responses``: its :func:`.motion.bank`), fitted per fold; the columns of the
    groups ``without`` left out.
    Returns ``(X, columns, groups, every, keep, projections, lines, resonance)``: ``every`` the stage's
    columns, ``keep`` the indices into them of ``X``'s first columns."""
    every = tuple(columns)
    keep = [i for i, col in enumerate(every) if not (col[0].startswith(SINCE) and c is not None and col[2] != c + 1)
            and col[1] not in without]
    X, columns, groups, projections = extend(X[:, keep], [every[i] for i in keep],
                                             input_groups([every[i] for i in keep]), y, fold_rows)
    X, columns, groups, lines = periodic.extend(X, columns, groups, y, fold_rows, offered)
    X, columns, groups, resonance = motion.extend(X, columns, groups, y, fold_rows,
                                                  responses if groups.get(POSE) else None)
    return X, columns, groups, every, keep, projections, lines, resonance


def _on_stage_columns(every, keep, columns, use, projections, lines) -> dict:
    """A fit's ``columns``, ``use``, ``projections`` and ``lines`` with indices into the stage's
    columns ``every`` followed by the columns fitted for the channel (:func:`_channel_columns`)."""
    def at(i):
        return keep[i] if i < len(keep) else len(every) + i - len(keep)
    return dict(columns=tuple(every) + tuple(columns[len(keep):]), use=tuple(at(i) for i in use),
                projections=tuple((tuple(keep[i] for i in p[0]),) + p[1:] for p in projections),
                lines=tuple((keep[x[0]],) + x[1:] for x in lines))


def _dependence(model, X, columns, cols, group, importance, unit) -> Dependence:
    """The partial dependence of the trees (on the columns ``X``) on the group's strongest
    column (``cols`` of ``columns``)."""
    from sklearn.inspection import partial_dependence

    i = cols[0]
    if len(cols) > 1:  # the group's strongest column carries the curve: the widest partial dependence
        sub = X[:: max(1, len(X) // 150)]
        spans = [np.ptp(partial_dependence(model, sub, [k], grid_resolution=10, percentiles=(0.02, 0.98),
                                           kind="average")["average"][0]) for k in cols]
        i = cols[int(np.argmax(spans))]
    sub = X[:: max(1, len(X) // 300)]
    pd = partial_dependence(model, sub, [i], grid_resolution=25, percentiles=(0.02, 0.98), kind="average")
    grid, curve = np.asarray(pd["grid_values"][0], float), np.asarray(pd["average"][0], float)
    name, _, joint, quantity, xunit = columns[i]
    return Dependence(group, name, joint, quantity, float(importance), xunit, tuple(grid.tolist()),
                      tuple(curve.tolist()), _where(grid, curve, xunit))


def flexible_stage(eng, R, left, discovered=(), effects=(), theta=None, lines=(), outfit=()) -> list:
    """The flexible stage of a diagnosis: one :class:`FlexibleFit` per effort channel worth a
    fit (:func:`candidates`), on the residual ``R`` after the fitted model (decimated samples
    x channels), judged out of fold over blocks in time (:mod:`.cv`).

    A discovered term the diagnosis calls partial (``partial``: it may stand in for what is
    missing) is no equation found: on its channel the flexible model is fitted on the residual
    without it (the fitted parameters ``theta`` less the term's), and the statement says how
    much of that the term explained on the engine's held-out part beside the flexible model's share.

    ``lines``: the structure left whose signature is a spectral line (:mod:`..lines`): its channels
    are fitted too, judged against the own noise of the residual without the lines (the entries'
    ``noise``: the own noise of the residual with them reads a fast line's amplitude), and their
    trees are given the line's phase (:mod:`.periodic`); their lines that repeat, and those a
    channel holds by its own rule, are offered to every channel fitted (:func:`.periodic.offered`).

    ``outfit``: {channel (0-based): :class:`FlexibleFit`} where the trees outfit a discovered term
    (:mod:`.rival`): that fit of the residual without the term is the channel's, even where what
    the term leaves holds nothing.

    Example
    -------
    >>> fits = flexible_stage(eng, eng.R(theta), left)          # doctest: +SKIP
    >>> fits[0].statement                                      # doctest: +SKIP
    'a force on slider 3 that depends on the position of slider (q3, above 0.42 m; ...'
    """
    from ..structure import own_noise, samples_per_independent

    pipe = eng.pipe
    R = np.asarray(R, float)
    if len(R) < N_FOLDS * BLOCK:
        return []
    floor = eng.accuracy()
    left, noise = with_lines(pipe, left, lines, [own_noise(pipe, R[:, c], floor[c]) for c in range(pipe.nd)])
    chans = sorted(set(candidates(pipe, R, left, noise)) | {c for c in outfit if 0 <= c < pipe.nd})
    if not chans:
        return []
    flagged = {e["joint"] - 1 for e in left if e["channel"] in pipe.channels[:pipe.nd]}
    rms = np.std(R[:, :pipe.nd], axis=0)
    weak = {c for c in chans if c not in flagged and c not in outfit and rms[c] <= RMS_OVER_NOISE * noise[c]}
    stand_ins = {t.joint - 1: t for t in discovered if t.partial and t.joint - 1 in chans}
    R_fit = R
    if stand_ins and theta is not None:
        drop = {k for t in stand_ins.values() for k in t.params()}
        R_fit = R.copy()
        R_wo = eng.R({k: v for k, v in theta.items() if k not in drop})
        for c in stand_ins:
            R_fit[:, c] = R_wo[:, c]
    X, columns = inputs(pipe, R_fit, direction=True)
    noun = pipe.model.facts.joint_noun
    fitted = stage_columns(eng, theta, stand_ins, [c for c in chans if c not in outfit])
    t, pos = periodic.time_and_positions(X, columns)
    fold_rows = folds(len(R_fit), gap_for(samples_per_independent(pipe)))
    offered = periodic.offered(t, R_fit[:, :pipe.nd], pos, fold_rows,
                               [e for e in lines if e["channel"] in pipe.channels[:pipe.nd]])

    def fitted_on(c, without=(), why=""):
        fit = outfit[c] if c in outfit else fit_channel(
            pipe, X, columns, R_fit[:, c], noise[c], (pipe.model.facts.effort_unit, pipe.channels[c]),
            weak=c in weak, fitted=fitted.get(c), offered=offered, without=without)
        fit = _with(fit, joint=c + 1, target=R_fit[:, c].copy(), weak=c in weak, left_out=why)
        said = family_says(fit, discovered, effects) if fit.explained else ""
        if c in stand_ins and R_fit is not R:
            test = np.asarray(eng.test, bool)
            yt, at = R_fit[test, c], R[test, c]
            term_share = 1.0 - float(np.mean((at - at.mean()) ** 2) / np.var(yt))
            said = (f"the discovered term ({stand_ins[c].equation}), which may stand in for it, explains "
                    f"{100 * term_share:.0f} % of it held out; the flexible model is fitted without it")
        fit = _with(fit, family=said)
        return _with(fit, statement=statement(fit, noun))

    def refit(f, without, why):  # a rival's channel (outfit) is the rival's fit
        return None if f.joint - 1 in outfit else fitted_on(f.joint - 1, without, why)
    return across_channels([fitted_on(c) for c in chans], pipe.nd, columns, refit, fold_rows)


def _with(fit, **kw):
    from dataclasses import replace

    return replace(fit, **kw)


def black_box_force(eng, R, fits, rows: int) -> np.ndarray:
    """The explained channels' flexible models as a known external effort for the replay,
    (rows, joints) at every recording row: minus the predicted residual (the residual is the
    effort the drive spent beyond the model), evaluated along the recorded motion at the
    decimated samples and interpolated in time (zero elsewhere).  A black box: it follows the
    recorded motion, not the replayed one."""
    pipe = eng.pipe
    X, _ = inputs(pipe, R, direction=True)
    t = pipe.t[pipe.idx]
    out = np.zeros((rows, pipe.nd))
    for f in fits:
        if f.explained:
            given = motion.extended(periodic.extended(extended(X, f.projections), f.lines), pipe, f.resonance)
            predicted = f.model.predict(given[:, list(f.use)])
            out[:, f.joint - 1] = -np.interp(pipe.t[:rows], t, predicted, left=0.0,
                                             right=0.0)
    return out
