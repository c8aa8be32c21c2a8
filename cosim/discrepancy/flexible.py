"""Where no family fits: a flexible model of what is left, then its dependence.

After the library, the discovery step and the platform force, an effort channel that still
keeps structure (:mod:`.structure`, or a residual well above its own noise) is fitted with a
flexible regression, scikit-learn's :class:`~sklearn.ensemble.HistGradientBoostingRegressor`
(boosted trees), on every input the recording offers at the decimated samples: each joint's
position, rate, acceleration and the fitted model's effort (not the measured one: it holds the
residual itself), the low-passed |rate| and effort of each joint (time constants
:data:`TIME_CONSTANTS`) and its low-passed dissipated power |effort x rate|
(:data:`POWER_TIME_CONSTANTS`), the platform pose where the recording gives one, and time.

It is fitted on the engine's fitted part and judged on its held-out part (the last
``1 - train_fraction`` of the recording):

* **explained share**: 1 - MSE(residual - prediction) / var(residual) on the held-out samples,
  claimed only when it is at least :data:`SHARE_MIN` and the variance it explains is
  significant against the residual's own noise: a chi-square in independent samples (the
  held-out samples' explained sum of squares over the noise variance, divided by the decimated
  samples per independent one) above :data:`CHI2_MIN`, as for structure left (:mod:`.structure`);
* **inputs**: grouped permutation importance on the held-out samples, per held-out block (a
  group is one input of one joint: "position of slider 3", or the pose, or time); a group
  passes when permuting it costs at least :data:`IMPORTANCE_MIN` of the held-out variance,
  :data:`RELATIVE_MIN` of the explained share and :data:`TOP_MIN` of the strongest group's
  importance, above :data:`BLOCK_Z` standard errors over the blocks; it is named when the trees
  refitted without it (on the other passing groups) lose :data:`DROP_MIN` of the held-out
  variance; the share claimed is then that of the trees on the named groups alone;
* **how**: the partial dependence of the prediction on each named input's strongest feature
  (:func:`sklearn.inspection.partial_dependence`), in the input's and the effort's units;
* **whether a found family already says it**: a discovered term or a library effect of the
  same joint keyed on the same input.

The thresholds were set on the tuning seeds of ``bench/flexible_bench.py`` (docs/flexible.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: time constants of the low-passed histories [s]: |rate| and effort (duty), and the dissipated
#: power |effort x rate| (a first-order thermal model's temperature rise)
TIME_CONSTANTS = (1.0, 4.0)
POWER_TIME_CONSTANTS = (0.5, 2.0, 8.0)
#: fewest held-out decimated samples for a fit, and per held-out block of the importance
BLOCK = 25
#: held-out blocks the importance is measured on (its standard error is their spread)
N_BLOCKS = 5
#: the last share of the fitted samples that chooses the trees' number of iterations
EARLY_BLOCK = 0.2
#: smallest explained share claimed, and the chi-square (independent samples) it must explain
SHARE_MIN, CHI2_MIN = 0.05, 25.0
#: an input is named when permuting it costs this share of the held-out variance...
IMPORTANCE_MIN = 0.04
#: ... and this fraction of the explained share
RELATIVE_MIN = 0.15
#: ... and this fraction of the strongest group's importance
TOP_MIN = 0.1
#: ... and it exceeds this many standard errors over the held-out blocks
BLOCK_Z = 2.0
#: ... at most this many are checked by refitting without each ...
MAX_INPUTS = 4
#: ... and one is kept when the trees refitted without it lose this share of the held-out variance
DROP_MIN = 0.03
#: a channel with no structure flagged is still fitted when its residual's RMS exceeds its own
#: noise by this factor (a force keyed on another joint, which :mod:`.structure` does not test)
RMS_OVER_NOISE = 2.0
#: the boosted trees' settings (small: a few hundred decimated samples; the number of
#: iterations, at most max_iter, is chosen on the last fitted block)
TREES = dict(max_iter=300, learning_rate=0.08, max_leaf_nodes=12, min_samples_leaf=20, l2_regularization=1.0,
             early_stopping=False, random_state=0)

_QUANTITIES = ("position", "rate", "acceleration", "effort", "history")


@dataclass(frozen=True)
class Dependence:
    """One input the flexible model depends on.

    ``group`` (e.g. ``"position of slider 3"``), ``feature`` (the column the curve is drawn
    over, e.g. ``"q3"``), ``joint`` (1-based; None for the pose and time), ``quantity``
    (position, rate, acceleration, effort, history, pose, time), ``importance`` (share of the
    held-out residual variance lost when the group is permuted, 0-1), ``unit`` (of the
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

    ``channel`` and ``joint`` (1-based), ``share`` (held-out explained share, at most 1; below 0
    when the model predicts worse than the mean), ``z`` (the chi-square it explains, in
    independent samples against the residual's own noise), ``explained`` (whether it is claimed),
    ``rms_left`` (held-out RMS of the residual) and ``noise`` (its own noise), in ``unit``;
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
    model: object = field(default=None, repr=False, compare=False)
    columns: tuple = field(default=(), repr=False, compare=False)
    #: the columns (indices into ``columns``) ``model`` takes: the named inputs' when any
    use: tuple = field(default=(), repr=False, compare=False)
    #: the residual it was fitted on (decimated samples), in ``unit``
    target: object = field(default=None, repr=False, compare=False)

    def to_dict(self) -> dict:
        out = {k: getattr(self, k) for k in ("channel", "joint", "unit", "share", "z", "explained", "rms_left",
                                             "noise", "family", "statement", "black_box")}
        out["inputs"] = [vars(d) for d in self.inputs]
        return out


def _lowpass(x, dt, tau, starts):
    """First-order low-pass of the columns of x (sample step dt) with time constant tau,
    restarted at each block start."""
    a = math.exp(-dt / tau)
    y = np.empty_like(x)
    for i in range(len(x)):
        y[i] = x[i] if i in starts else a * y[i - 1] + (1 - a) * x[i]
    return y


def inputs(pipe, R) -> tuple:
    """The flexible model's inputs at the decimated samples.

    ``R`` is the residual after the fitted model (decimated samples x channels); the effort
    input is the model's, measured minus ``R``.  Returns ``(X, columns)``: X (n, p) and per
    column ``(feature, group, joint or None, quantity, unit)``."""
    idx, nd = pipe.idx, pipe.nd
    facts = pipe.model.facts
    noun, qu, eu = facts.joint_noun, facts.joint_unit, facts.effort_unit
    rate_u = f"{qu}/s"
    t = pipe.t[idx]
    starts = {0} | {int(np.searchsorted(idx, a)) for a, _ in pipe.segments[1:]}
    dt = float(np.median(np.diff(t))) if len(t) > 1 else pipe.dt
    effort = pipe.tau_s[idx, :nd] - np.asarray(R, float)[:, :nd]
    cols, X = [], []
    for k in range(nd):
        q, qd, qdd = pipe.q_s[idx, k], pipe.qd_s[idx, k], pipe.qdd_s[idx, k]
        for name, v, quantity, unit in ((f"q{k + 1}", q, "position", qu), (f"qd{k + 1}", qd, "rate", rate_u),
                                        (f"qdd{k + 1}", qdd, "acceleration", f"{qu}/s^2"),
                                        (f"effort{k + 1}", effort[:, k], "effort", eu)):
            X.append(v)
            cols.append((name, f"{quantity} of {noun} {k + 1}", k + 1, quantity, unit))
        group = f"history of {noun} {k + 1}"
        for tc in TIME_CONSTANTS:
            hist = _lowpass(np.column_stack([np.abs(qd), effort[:, k]]), dt, tc, starts)
            X += [hist[:, 0], hist[:, 1]]
            cols += [(f"|qd{k + 1}| low-passed {tc:g} s", group, k + 1, "history", rate_u),
                     (f"effort{k + 1} low-passed {tc:g} s", group, k + 1, "history", eu)]
        for tc in POWER_TIME_CONSTANTS:
            X.append(_lowpass(np.abs(effort[:, k] * qd)[:, None], dt, tc, starts)[:, 0])
            cols.append((f"|effort{k + 1} qd{k + 1}| low-passed {tc:g} s", group, k + 1, "history", f"{eu} {rate_u}"))
    if pipe.has_pose:
        x = pipe.x_s[idx]
        for i in range(x.shape[1]):
            if np.std(x[:, i]) > 0:
                X.append(x[:, i])
                cols.append((f"pose[{i}]", "the platform pose", None, "pose", ""))
    X.append(t)
    cols.append(("t", "time", None, "time", "s"))
    return np.column_stack(X), cols


def candidates(pipe, R, left, noise) -> list:
    """Effort channels (0-based) worth a flexible fit: structure flagged there (``left``), or a
    residual RMS above :data:`RMS_OVER_NOISE` times its own noise (``noise``, per channel)."""
    flagged = {e["joint"] - 1 for e in left if e["channel"] in pipe.channels[:pipe.nd]}
    rms = np.sqrt(np.mean((R[:, :pipe.nd] - R[:, :pipe.nd].mean(axis=0)) ** 2, axis=0))
    return sorted(flagged | {c for c in range(pipe.nd) if rms[c] > RMS_OVER_NOISE * noise[c]})


def _where(grid, curve, unit) -> str:
    """Where the partial dependence acts, in words: "above x" / "below x" when it is flat
    (within a tenth of its span) over at least a quarter of the range at one end only, "from
    x0 to x1" when at both (a step), else "over x0 to x1"."""
    span = float(np.max(curve) - np.min(curve))
    n = len(grid)
    if not span > 0 or n < 4:
        return ""
    tol = 0.1 * span
    near_lo = np.abs(np.asarray(curve) - curve[0]) <= tol
    near_hi = np.abs(np.asarray(curve) - curve[-1]) <= tol
    a = int(np.argmin(near_lo))            # first point off the low end's level
    b = n - 1 - int(np.argmin(near_hi[::-1]))  # last point off the high end's level
    lo, hi = a >= 0.25 * n, (n - 1 - b) >= 0.25 * n

    def x(i):
        return f"{grid[i]:.3g}"
    if lo and hi:
        return f"a change from {x(a - 1)} to {x(b + 1)} {unit}".rstrip()
    if lo:
        return f"above {x(a - 1)} {unit}".rstrip()
    if hi:
        return f"below {x(b + 1)} {unit}".rstrip()
    return f"over {x(0)} to {x(n - 1)} {unit}".rstrip()


def _trees(X, y, train, test=None):
    """Boosted trees on the ``train`` rows of (X, y); the number of iterations is chosen on a
    held-out block, the last :data:`EARLY_BLOCK` of the fitted rows (the rows are in time order:
    a random split would judge on neighbours of the fitted samples), then the trees are refitted
    on all the fitted rows with it."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    rows = np.flatnonzero(train)
    cut = int(len(rows) * (1.0 - EARLY_BLOCK))
    a, b = rows[:cut], rows[cut:]
    probe = HistGradientBoostingRegressor(**TREES).fit(X[a], y[a])
    loss = [float(np.mean((y[b] - p) ** 2)) for p in probe.staged_predict(X[b])]
    best = int(np.argmin(loss)) + 1
    return HistGradientBoostingRegressor(**dict(TREES, max_iter=max(best, 5))).fit(X[rows], y[rows])


def _block_losses(model, X, y, blocks, cols=None, rng=None) -> np.ndarray:
    """Mean squared error of ``model`` on each held-out block (index arrays), with the columns
    ``cols`` permuted together (within the held-out samples) when given."""
    Xp = X
    if cols is not None:
        Xp = X.copy()
        Xp[:, cols] = X[rng.permutation(len(X))][:, cols]
    e = (y - model.predict(Xp)) ** 2
    return np.array([float(np.mean(e[b])) for b in blocks])


def _importance(model, X, y, groups, blocks, rng, repeats=2) -> dict:
    """Grouped permutation importance on the held-out samples, per held-out block: the loss of
    MSE when the group's columns are permuted, over the held-out variance.  Returns, per group,
    ``(mean, standard error over the blocks)``."""
    var = float(np.var(y))
    base = _block_losses(model, X, y, blocks)
    out = {}
    for g, cols in groups.items():
        d = np.mean([_block_losses(model, X, y, blocks, cols, rng) for _ in range(repeats)], axis=0) - base
        d = d / var
        out[g] = (float(np.mean(d)), float(np.std(d, ddof=1) / math.sqrt(len(d))))
    return out


def _screen(imp, share) -> list:
    """Groups whose permutation importance passes the thresholds and is significant over the
    held-out blocks, most important first (at most :data:`MAX_INPUTS`)."""
    top = max(m for m, _ in imp.values())
    ok = [g for g, (m, se) in imp.items() if m >= IMPORTANCE_MIN and m >= RELATIVE_MIN * share
          and m >= TOP_MIN * top and m > BLOCK_Z * se]
    return sorted(ok, key=lambda g: -imp[g][0])[:MAX_INPUTS]


def _select(X, y, train, test, groups, named, var):
    """Conditional check of the screened groups: refit the trees without each one, on the
    others of ``named``; a group is kept when leaving it out costs at least :data:`DROP_MIN`
    of the held-out variance (an input that only moves with a kept one costs nothing).
    When none is kept (interchangeable inputs), all are kept.  Returns ``(kept, model on the
    kept groups' columns, its columns)``."""
    def fit_on(gs):
        cols = sorted(i for g in gs for i in groups[g])
        m = _trees(X[:, cols], y, train)
        return m, cols, float(np.mean((y[test] - m.predict(X[test][:, cols])) ** 2))

    full, cols, mse = fit_on(named)
    if len(named) == 1:
        return named, full, cols
    kept = [g for g in named if (fit_on([h for h in named if h != g])[2] - mse) / var >= DROP_MIN]
    if not kept or kept == named:
        return named, full, cols
    model, cols, _ = fit_on(kept)
    return kept, model, cols


def fit_channel(pipe, X, columns, y, train, test, noise, unit) -> FlexibleFit:
    """The flexible model of residual ``y`` (decimated samples) on inputs ``X``: fitted on
    ``train``, judged on ``test`` (boolean masks).  The inputs it names are screened by grouped
    permutation importance, significant over the held-out blocks, then checked one by one by
    refitting without them; the share claimed is that of the trees refitted on the named inputs
    alone (the model the statement describes)."""
    # loaded before the limit is set: threadpoolctl limits only the OpenMP runtimes already loaded, and
    # an unlimited first fit spins threads on a busy machine (98 s CPU instead of 1.8 s measured)
    import sklearn.ensemble  # noqa: F401
    from threadpoolctl import threadpool_limits

    from .structure import samples_per_independent

    c = pipe.channels.index(unit[1]) if isinstance(unit, tuple) else None
    unit = unit[0] if isinstance(unit, tuple) else unit
    yt = y[test]
    var = float(np.var(yt))
    with threadpool_limits(limits=1):
        model = _trees(X, y, train)
        pred = model.predict(X[test])
        mse = float(np.mean((yt - pred) ** 2))
        share = 1.0 - mse / var if var > 0 else 0.0
        z = len(yt) * (var - mse) / max(noise, 1e-300) ** 2 / samples_per_independent(pipe)
        explained = share >= SHARE_MIN and z > CHI2_MIN
        deps, use = (), tuple(range(X.shape[1]))
        if explained:
            groups = {}
            for i, col in enumerate(columns):
                groups.setdefault(col[1], []).append(i)
            rng = np.random.default_rng(0)
            n_t = int(test.sum())
            blocks = np.array_split(np.arange(n_t), max(2, min(N_BLOCKS, n_t // BLOCK)))
            imp = _importance(model, X[test], yt, groups, blocks, rng)
            named = _screen(imp, share)
            if named:
                named, model, cols = _select(X, y, train, test, groups, named, var)
                use = tuple(cols)
                share = 1.0 - float(np.mean((yt - model.predict(X[test][:, cols])) ** 2)) / var
                sub = {g: [cols.index(i) for i in groups[g]] for g in named}
                imp_k = _importance(model, X[test][:, cols], yt, sub, blocks, rng)
                deps = tuple(_dependence(model, X[:, cols], [columns[i] for i in cols], sub[g], g, imp_k[g][0],
                                         unit) for g in named)
    return FlexibleFit(pipe.channels[c] if c is not None else "", 0, unit, share,
                       z, explained, float(np.sqrt(np.mean((yt - yt.mean()) ** 2))), float(noise), deps,
                       model=model, columns=tuple(columns), use=use)


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


def family_says(fit: FlexibleFit, discovered, effects) -> str:
    """A found discovered term or library effect of the channel's joint keyed on an input the
    flexible model depends on, in words; "" if none."""
    key_of = {"position": "position", "velocity": "rate", "acceleration": "acceleration"}
    own = {d.quantity for d in fit.inputs if d.joint == fit.joint}
    for t in discovered:
        if t.joint == fit.joint and key_of.get(t.key_variable) in own:
            return f"the discovered term ({t.equation}) is keyed on the same input and leaves this part"
    for e in effects:
        if e["joint"] == fit.joint:
            return f"{e['name']} on this joint was fitted and leaves this part"
    return ""


def statement(fit: FlexibleFit, noun: str) -> str:
    """The report's sentence for one channel."""
    if not fit.explained:
        return (f"{fit.channel}: the structure left is not explainable from the recorded inputs "
                f"(held-out share {100 * max(fit.share, 0):.0f} %, not significant)")
    if not fit.inputs:
        return (f"{fit.channel}: {100 * fit.share:.0f} % of what is left is explainable, on no single input "
                f"(held out)")
    parts = []
    for d in fit.inputs:
        size = max(abs(min(d.curve)), abs(max(d.curve)))
        k = int(np.argmax(np.abs(np.asarray(d.curve))))
        at = f"{d.feature} = {d.grid[k]:.3g} {d.unit}".rstrip()
        parts.append(f"the {d.group.replace(f'{noun} {fit.joint}', f'{noun}')} ({d.feature}"
                     f"{', ' + d.where if d.where else ''}; up to {size:.3g} {fit.unit} at {at}; "
                     f"importance {100 * d.importance:.0f} %)")
    only = " and on nothing else" if len(parts) == 1 else ""
    s = (f"a force on {noun} {fit.joint} that depends on " + " and on ".join(parts) + only
         + f": {100 * fit.share:.0f} % of what is left (held out, flexible model)")
    return s + (f"; {fit.family}" if fit.family else "; no found family is keyed on these inputs")


def flexible_stage(eng, R, left, discovered=(), effects=(), theta=None) -> list:
    """The flexible stage of a diagnosis: one :class:`FlexibleFit` per effort channel worth a
    fit (:func:`candidates`), on the residual ``R`` after the fitted model (decimated samples
    x channels); fitted on the engine's fitted part, judged on its held-out part.

    A discovered term the diagnosis calls partial (``partial``: it may stand in for what is
    missing) is no equation found: on its channel the flexible model is fitted on the residual
    without it (the fitted parameters ``theta`` less the term's), and the statement says how
    much of that the term explained on the held-out part beside the flexible model's share.

    Example
    -------
    >>> fits = flexible_stage(eng, eng.R(theta), left)          # doctest: +SKIP
    >>> fits[0].statement                                      # doctest: +SKIP
    'a force on slider 3 that depends on the position of slider (q3, above 0.42 m; ...'
    """
    from .structure import own_noise

    pipe = eng.pipe
    R = np.asarray(R, float)
    train, test = ~np.asarray(eng.test, bool), np.asarray(eng.test, bool)
    if test.sum() < 3 * BLOCK or train.sum() < 4 * BLOCK:
        return []
    floor = eng.accuracy()
    noise = [own_noise(pipe, R[:, c], floor[c]) for c in range(pipe.nd)]
    chans = candidates(pipe, R, left, noise)
    if not chans:
        return []
    stand_ins = {t.joint - 1: t for t in discovered if t.partial and t.joint - 1 in chans}
    R_fit = R
    if stand_ins and theta is not None:
        drop = {k for t in stand_ins.values() for k in t.params()}
        R_fit = R.copy()
        R_wo = eng.R({k: v for k, v in theta.items() if k not in drop})
        for c in stand_ins:
            R_fit[:, c] = R_wo[:, c]
    X, columns = inputs(pipe, R_fit)
    noun = pipe.model.facts.joint_noun
    out = []
    for c in chans:
        fit = fit_channel(pipe, X, columns, R_fit[:, c], train, test, noise[c], (pipe.model.facts.effort_unit,
                                                                                 pipe.channels[c]))
        fit = _with(fit, joint=c + 1, target=R_fit[:, c].copy())
        said = family_says(fit, discovered, effects) if fit.explained else ""
        if c in stand_ins and R_fit is not R:
            yt, at = R_fit[test, c], R[test, c]
            term_share = 1.0 - float(np.mean((at - at.mean()) ** 2) / np.var(yt))
            said = (f"the discovered term ({stand_ins[c].equation}), which may stand in for it, explains "
                    f"{100 * term_share:.0f} % of it held out; the flexible model is fitted without it")
        fit = _with(fit, family=said)
        out.append(_with(fit, statement=statement(fit, noun)))
    return out


def _with(fit, **kw):
    from dataclasses import replace

    return replace(fit, **kw)


def sentence(fits: list) -> str:
    """The conclusion's clause: the explained channels' statements."""
    told = [f.statement for f in fits if f.explained]
    return "where no equation was found: " + "; ".join(told) if told else ""


def figure(fits: list, path):
    """Partial-dependence figure of the explained channels (one panel per named input): the
    flexible model's force against the input, in their units.  Returns the path, or None when
    no channel is explained."""
    panels = [(f, d) for f in fits if f.explained for d in f.inputs]
    if not panels:
        return None
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    for ax, (f, d) in zip(axes[0], panels):
        ax.plot(d.grid, d.curve, color="#d62728")
        ax.set_xlabel(f"{d.feature} [{d.unit}]" if d.unit else d.feature)
        ax.set_ylabel(f"{f.channel}: partial dependence [{f.unit}]")
        ax.set_title(f"{d.group}\n{100 * d.importance:.0f} % importance, {100 * f.share:.0f} % explained", fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def markdown(fits: list, files: dict) -> list:
    """The report's section (Markdown lines)."""
    if not fits:
        return []
    L = ["## Where no equation was found: a flexible model and its dependence", "",
         "Boosted trees (scikit-learn HistGradientBoostingRegressor) fitted on the fitted part of each channel "
         "that keeps structure, on every joint's position, rate, acceleration and model effort, their low-passed "
         "|rate| and effort, the pose and time; judged on the held-out part.  The inputs are those whose "
         "permutation on the held-out part costs the most; the curves are partial dependences.  A black box: "
         "it says what the force depends on, not its equation.", "",
         "| channel | explained (held out) | chi-square | RMS left | own noise | inputs (importance) |",
         "| --- | --- | --- | --- | --- | --- |"]
    for f in fits:
        ins = ", ".join(f"{d.group} ({100 * d.importance:.0f} %)" for d in f.inputs) or "-"
        L.append(f"| {f.channel} | {100 * f.share:.0f} %{'' if f.explained else ' (not claimed)'} | {f.z:.0f} | "
                 f"{f.rms_left:.3g} {f.unit} | {f.noise:.3g} {f.unit} | {ins} |")
    L += [""] + [f"- {f.statement}" for f in fits] + [""]
    if files.get("flexible"):
        L += ["![Partial dependence of the flexible model](flexible.png)", ""]
    return L


def black_box_force(eng, R, fits, rows: int) -> np.ndarray:
    """The explained channels' flexible models as a known external effort for the replay,
    (rows, joints) at every recording row: minus the predicted residual (the residual is the
    effort the drive spent beyond the model), evaluated along the recorded motion at the
    decimated samples and interpolated in time (zero elsewhere).  A black box: it follows the
    recorded motion, not the replayed one."""
    pipe = eng.pipe
    X, _ = inputs(pipe, R)
    t = pipe.t[pipe.idx]
    out = np.zeros((rows, pipe.nd))
    for f in fits:
        if f.explained:
            out[:, f.joint - 1] = -np.interp(pipe.t[:rows], t, f.model.predict(X[:, list(f.use)]), left=0.0,
                                             right=0.0)
    return out
