"""Blocked cross-validation of the flexible stage's boosted trees (:mod:`.flexible`).

The folds are blocks in time (:mod:`cosim.discrepancy.blocked_folds`): the recording's decimated samples cut
into ``N_FOLDS x BLOCKS_PER_FOLD`` contiguous blocks dealt to the folds in turn, each fold held
out in turn and the trees fitted on the others, less a gap of ``GAP_INDEPENDENT`` independent
samples' worth on each side of each held-out block (:func:`folds`, :func:`gap_for`).
Every sample is predicted once by trees that never saw it, and a slowly varying input (a
drive's temperature, the duty of the excitation) takes over the held-out blocks the values the
fitted ones span, instead of lying beyond them as it does at the end of the recording.

The trees' number of iterations (at most ``max_iter``) is the one with the smallest summed
held-out loss over the folds; the explained share, the permutation importance (per fold: its
standard error is their spread) and the refits of the input selection are all out of fold.
"""
from __future__ import annotations

import copy
import hashlib
import math
import threading
from dataclasses import dataclass
from itertools import islice

import numpy as np

from ..blocked_folds import BLOCKS_PER_FOLD, GAP_INDEPENDENT, N_FOLDS, folds, gap_for  # noqa: F401  (the stage's folds)

#: fewest iterations the held-out loss may choose
MIN_ITER = 5
#: the folds' trees grow to these numbers of iterations in turn (the last: TREES["max_iter"]),
#: and stop when the summed held-out loss has not fallen for PATIENCE iterations (its minimum
#: is then the chosen number); each step bins the inputs again, hence two steps only
STEPS, PATIENCE = (50, 75), 25
#: the steps of a growth judged against a bar alone (``under`` of :func:`cross_validate`): the
#: held-out error is tested after 10 and 25 iterations too, where PATIENCE cannot end a growth
#: (10 - 5 and 25 - 5 < 25), and a growth under the bar there stops (the warm-started fits add
#: the same trees as :data:`STEPS`' do; a fit's bins are kept, :func:`_trees_keeping_bins`)
BAR_STEPS = (10, 25) + STEPS
#: the boosted trees' settings (small: a few hundred decimated samples; the number of
#: iterations, at most max_iter, is chosen on the held-out blocks).  A tree costs about 0.5 ms
#: whatever its inputs (scikit-learn's per-node work on some 800 rows): the stage's time is its
#: number of trees.  A cross-validation whose held-out minimum lies within the first max_iter
#: iterations is the same with any larger bound (the same trees, grown in the same order); a
#: faster learning rate over fewer iterations names other inputs (docs/records/speed_runs.md, Speed)
TREES = dict(max_iter=75, learning_rate=0.15, max_leaf_nodes=12, min_samples_leaf=20, l2_regularization=1.0,
             max_bins=64, early_stopping=False, random_state=0)
#: quantile bins of the single-input screen (:func:`binned_shares`)
BINS = 16
#: an input's held-out value is outside the fitted range when it lies beyond it by this share
#: of the fitted range
RANGE_TOL = 0.02


class FoldInputs(np.ndarray):
    """Inputs with columns fitted per fold (:mod:`.oblique`): the array holds the columns fitted
    on every sample (the final model's, the black box's); ``variants`` (folds, n, p) holds, per
    fold of the cross-validation, the columns fitted on that fold's fitted rows alone, which its
    trees are fitted and judged on (:func:`at`).  Selecting columns (``X[:, cols]``) and
    :meth:`copy` keep the variants (a copy's are copied too: a column assigned in the copy is
    to be assigned in each of them as well); selecting rows gives the columns fitted on every
    sample, a plain array, and so does any other computation on the array."""

    def __new__(cls, whole, variants):
        out = np.asarray(whole, float).view(cls)
        out.variants = variants
        return out

    def __array_finalize__(self, obj):
        self.variants = None  # an array computed from these holds the whole columns only

    def copy(self, order="C"):
        out = np.ndarray.copy(self, order)
        out.variants = None if self.variants is None else self.variants.copy()
        return out

    def __getitem__(self, key):
        whole = self.view(np.ndarray)
        if (self.variants is not None and isinstance(key, tuple) and len(key) == 2
                and isinstance(key[0], slice) and key[0] == slice(None)):
            got = whole[key]
            if got.ndim == 2:
                return FoldInputs(got, self.variants[:, :, key[1]])
        return whole[key]


def at(X, b: int) -> np.ndarray:
    """The inputs fold ``b``'s trees see: ``X``'s variant fitted on that fold's fitted rows
    (:class:`FoldInputs`), or ``X`` itself."""
    variants = getattr(X, "variants", None)
    return np.asarray(X) if variants is None else variants[b]


@dataclass(frozen=True)
class CV:
    """One blocked cross-validation: ``folds`` ((held-out rows, fitted rows) per fold),
    ``models`` (per fold, fitted on its fitted rows), ``iterations`` (chosen), ``pred`` (the
    out-of-fold prediction at every sample) and ``mse`` (its mean squared error)."""

    folds: tuple
    models: tuple
    iterations: int
    pred: np.ndarray
    mse: float
    #: where ``enough`` stopped the trees after a step but the last (:func:`cross_validate`): True
    stopped: bool = False

    def predict(self, b: int, X) -> np.ndarray:
        """Fold ``b``'s trees at the chosen number of iterations on the rows ``X`` (the first
        ``iterations`` trees summed in their order, as ``staged_predict`` sums them)."""
        return first_trees(self.models[b], X, self.iterations)


def first_trees(model, X, k: int) -> np.ndarray:
    """The prediction of ``model``'s first ``k`` trees on the rows ``X``: ``staged_predict``'s
    ``k``-th value, the same trees summed in the same order (without the values before it where
    the model is :func:`grow`'s)."""
    if hasattr(model, "predict_first"):
        return model.predict_first(X, k)
    return next(islice(model.staged_predict(X), k - 1, None))


def cross_validate(X, y, fold_rows, enough=None, under=None) -> CV:
    """Boosted trees cross-validated over the blocks ``fold_rows`` (from :func:`folds`), grown
    as :func:`grow` grows them.

    ``enough``: a test of the held-out mean squared error at the number of iterations chosen so
    far, made after each step of :func:`grow` but the last; where it holds, the trees grow no
    further (their number, predictions and error are then the step's).  The error chosen over
    more iterations is at most the one chosen over fewer (the minimum of the same trees' summed
    losses over more iterations, to the rounding of the mean), so a test that every smaller error
    passes too (a share claimed: :func:`~.flexible.stage.fit_channel`) decides as the whole growth
    would, on fewer trees (``tests/discrepancy/test_flexible_cv.py``).

    ``under``: a bar on the held-out mean squared error where only whether the error falls under
    it matters (a leave-one-out fit, the fit without a partner's columns: :func:`.select.select`);
    the test ``enough`` is then ``mse < under``, made after each of :data:`BAR_STEPS` but the last,
    and a growth stopped under the bar after 10 or 25 iterations decides as one stopped after 50
    or grown whole (the error chosen over more iterations is at most that one).

    The trees are a function of the inputs' values, the target and the folds alone (their
    settings fixed, ``random_state`` 0): a cross-validation asked again on equal values (the same
    columns judged by two steps of the selection: a leave-one-out fit and a leaner refit, the
    screened groups checked twice) is the one made the first time (:func:`_remembered`), unless
    ``enough`` stopped that one early."""
    def held_out(held_pred):
        pred = np.empty(len(y))
        for (held, _), p in zip(fold_rows, held_pred):
            pred[held] = p
        return pred, float(np.mean((y - pred) ** 2))

    key = _inputs_key(X, y, fold_rows)
    done = _DONE.get(key)
    if under is not None:
        enough = lambda mse: mse < under  # noqa: E731
    if done is not None and (enough is None or under is not None or all(m.n_iter_ == STEPS[0] for m in done.models)):
        return done  # (with ``enough``: the growth ended at the first step, where the test is not made; with
        # ``under``: the whole growth's error is under the bar where any step's is)
    with _DONE_LOCK:
        start = _STOPPED.pop(key, None)
    stopped = []

    def stop(held_pred):
        stopped.append(bool(enough(held_out(held_pred)[1])))
        return stopped[-1]

    models, best, staged = _grow(X, y, fold_rows, None if enough is None else stop,
                                 None if start is None else (copy.deepcopy(start[0]), start[1]),
                                 STEPS if under is None else BAR_STEPS)
    pred, mse = held_out([p[best - 1] for p in staged])
    out = CV(tuple(fold_rows), tuple(models), best, pred, mse, stopped=any(stopped))
    if any(stopped):  # kept to be grown on where the whole growth is asked for
        _remembered("stopped", key, (models, staged), y)
    else:  # the whole growth: the same as a call without ``enough``
        _remembered("done", key, out, y)
    return out


#: the last cross-validations made (:func:`cross_validate`), by :func:`_inputs_key`, and the
#: growths ``enough`` stopped (their trees and held-out predictions per step), of the last
#: TARGETS_KEPT targets (a channel's fits share one; the efforts' choice made again without the
#: fitted levels, :func:`.beside.passed_on`, fits a second between the channel's own): at most
#: DONE_MAX of each per target (a channel makes 5-40 cross-validations, some 0.2 s of trees and
#: 0.7-1 MB each); ``_TARGET``: per target kept, the (store, key) of its entries, the most recent
#: target last
_DONE: dict = {}
_STOPPED: dict = {}
_TARGET: dict = {}
DONE_MAX = 32
TARGETS_KEPT = 2
_DONE_LOCK = threading.Lock()


def _inputs_key(X, y, fold_rows) -> bytes:
    """A digest of what a cross-validation's trees are a function of: the inputs' values (with
    their per-fold variants, :class:`FoldInputs`), the target, the folds, and the trees' settings
    and steps."""
    h = hashlib.blake2b(digest_size=20)
    variants = getattr(X, "variants", None)
    for a in (np.asarray(X, float), variants, np.asarray(y, float)):
        if a is None:
            h.update(b"none")
            continue
        a = np.ascontiguousarray(a)
        h.update(f"{a.shape}{a.dtype.str}".encode())
        h.update(a.tobytes())
    for held, fit in fold_rows:
        h.update(np.asarray(held, np.int64).tobytes())
        h.update(b"|")
        h.update(np.asarray(fit, np.int64).tobytes())
        h.update(b";")
    h.update(repr((sorted(TREES.items()), STEPS, PATIENCE, MIN_ITER)).encode())
    return h.digest()


def _remembered(which: str, key, value, y) -> None:
    """Keeps ``value`` under ``key`` in the module's store ``which`` ("done": whole growths,
    "stopped": growths stopped early) among the last :data:`DONE_MAX` of the target ``y``; the
    entries of targets older than the last :data:`TARGETS_KEPT` are let go."""
    target = hashlib.blake2b(np.ascontiguousarray(np.asarray(y, float)).tobytes(), digest_size=16).digest()
    stores = {"done": _DONE, "stopped": _STOPPED}
    with _DONE_LOCK:
        entries = _TARGET.pop(target, None)  # put back last: the most recent target
        if entries is None:
            entries = []
            while len(_TARGET) >= TARGETS_KEPT:
                for w, k in _TARGET.pop(next(iter(_TARGET))):
                    stores[w].pop(k, None)
        entries = [(w, k) for w, k in entries if k in stores[w] and (w, k) != (which, key)]  # (a stopped growth
        # grown on is gone from its store)
        mine = [k for w, k in entries if w == which]
        while len(mine) >= DONE_MAX:
            old = mine.pop(0)
            stores[which].pop(old, None)
            entries.remove((which, old))
        stores[which][key] = value
        entries.append((which, key))
        _TARGET[target] = entries


def grow(X, Y, fold_rows, stop=None) -> tuple:
    """Boosted trees per fold of ``fold_rows`` on the target ``Y``: (n,), or (n, folds) with a
    target per fold (each fold's loss on its own).

    The folds' trees grow together to each of :data:`STEPS` iterations in turn (warm start: the
    same trees as one fit of as many iterations) and stop once the summed held-out loss has not
    fallen for :data:`PATIENCE` iterations, at the last, or where ``stop`` (a callable of the
    held-out predictions per fold at the number chosen so far) says so after a step but the
    last.  Returns ``(models, iterations, the held-out predictions per fold at that number)``."""
    models, best, staged = _grow(X, Y, fold_rows, stop)
    return models, best, [p[best - 1] for p in staged]


def _grow(X, Y, fold_rows, stop=None, start=None, steps=STEPS) -> tuple:
    """:func:`grow`, returning the held-out predictions per fold at every iteration grown
    (``staged``) instead of the chosen one's, and grown on from ``start`` (``(models, staged)``
    of a growth ``stop`` ended after a step: its trees are the first of the whole growth's, and
    a warm-started fit adds the next ones as one fit of as many iterations would), ``stop`` tested
    after each of ``steps`` but the last (:data:`STEPS` or :data:`BAR_STEPS`: the same trees)."""
    Y = np.asarray(Y)
    target = (lambda b: Y) if Y.ndim == 1 else (lambda b: Y[:, b])
    if start is None:
        models = [_trees_keeping_bins()(**dict(TREES, warm_start=True)) for _ in fold_rows]
        staged = [np.empty((0, len(held))) for held, _ in fold_rows]
    else:
        models, staged = list(start[0]), list(start[1])
    for n in steps:
        for b, ((held, fit), m) in enumerate(zip(fold_rows, models)):
            if len(staged[b]) >= n:  # grown to this step already (``start``)
                continue
            m.set_params(max_iter=n).fit(at(X, b)[fit], target(b)[fit])
            new = list(_staged_after(m, at(X, b)[held], staged[b]))
            staged[b] = np.vstack([staged[b]] + new)
        total = sum(np.sum((target(b)[held][None, :] - p) ** 2, axis=1)
                    for b, ((held, _), p) in enumerate(zip(fold_rows, staged)))
        best = int(np.argmin(total[MIN_ITER - 1:])) + MIN_ITER
        if n - best >= PATIENCE or (stop is not None and n != steps[-1] and stop([p[best - 1] for p in staged])):
            break
    for m in models:  # the kept training rows are no part of the fitted trees
        m.__dict__.pop("_kept_bins", None)
    return models, best, staged


def _staged_after(m, X, done):
    """``m.staged_predict(X)`` after its first ``len(done)`` values ``done`` (the trees grown at
    the earlier steps): continued from the last of them (:meth:`_Trees.staged_predict_after`)
    instead of predicted again from the first tree, the same values."""
    if len(done) and hasattr(m, "staged_predict_after"):
        return m.staged_predict_after(X, len(done), done[-1])
    return islice(m.staged_predict(X), len(done), None)


_TREES_KEEPING_BINS: list = []


def _trees_keeping_bins():
    """scikit-learn's ``HistGradientBoostingRegressor`` that bins its training rows once when a
    warm-started fit is given the same rows again (:func:`grow`'s second step): a fit bins them
    again (its private ``_bin_data``: some 30 ms on 800 rows of 97 columns, a third of such a
    fold's two fits), into the same bins, since the bins are the quantiles of those rows alone.
    The bins and the bin mapper of the last training rows are kept and given back when the rows
    are equal, element for element; any other call is scikit-learn's own.  Its
    ``staged_predict_after`` continues the staged predictions from a given iteration (the next
    step's new trees only).  Both read scikit-learn's private ``_bin_data``, ``_predictors`` and
    ``_predict_iterations`` (written against scikit-learn 1.9.1); ``tests/discrepancy/test_flexible_cv.py``
    compares the trees and predictions with scikit-learn's own, bit for bit."""
    if not _TREES_KEEPING_BINS:
        from sklearn.ensemble import HistGradientBoostingRegressor

        class Trees(HistGradientBoostingRegressor):
            def _bin_data(self, X, *args, is_training_data, **kw):
                weights = [a for a in args + tuple(kw.values()) if a is not None]
                kept = self.__dict__.get("_kept_bins")
                if (is_training_data and not weights and kept is not None and kept[0].shape == X.shape
                        and kept[0].dtype == X.dtype and np.array_equal(kept[0], X)):
                    self._bin_mapper = kept[1]
                    return kept[2]
                got = _binned_with_kept_thresholds(self._bin_mapper, X) if is_training_data and not weights else None
                if got is not None:
                    self._bin_mapper, out = got
                else:
                    out = super()._bin_data(X, *args, is_training_data=is_training_data, **kw)
                if is_training_data and weights:
                    self.__dict__.pop("_kept_bins", None)
                elif is_training_data:
                    self.__dict__["_kept_bins"] = (np.array(X), self._bin_mapper, out)
                return out

            def predict_first(self, X, k):
                """The prediction of the first ``k`` trees on ``X``: the baseline and their raw
                predictions added in their order, as ``staged_predict`` adds them (its ``k``-th
                value, without the values before it)."""
                from sklearn.utils._openmp_helpers import _openmp_effective_n_threads

                if self.loss != "squared_error" or not hasattr(self, "_preprocess_X"):
                    return next(islice(self.staged_predict(X), k - 1, None))
                X = self._preprocess_X(X, reset=False)
                raw = np.zeros((X.shape[0], 1), dtype=self._baseline_prediction.dtype, order="F")
                raw += self._baseline_prediction
                self._predict_iterations(X, self._predictors[:k], raw, is_binned=False,
                                         n_threads=_openmp_effective_n_threads())
                return raw.ravel().copy()

            def predict_first_replaced(self, X, Xr, col_groups, k):
                """Per group of columns ``col_groups``, the prediction of the first ``k`` trees on
                the rows ``X`` with that group's columns taken from ``Xr`` (as many rows): row for
                row :meth:`predict_first` of those rows, stacked group after group.  A tree reads
                only the columns it splits on, so it is predicted again only on the groups that
                hold one of them; its prediction on ``X`` serves the others, added in the same
                order (the same values)."""
                from sklearn.utils._openmp_helpers import _openmp_effective_n_threads

                if self.loss != "squared_error" or not hasattr(self, "_preprocess_X"):
                    return None
                X, Xr = self._preprocess_X(X, reset=False), self._preprocess_X(Xr, reset=False)
                known, f_idx = self._bin_mapper.make_known_categories_bitsets()
                threads = _openmp_effective_n_threads()
                replaced = {}
                for i, cols in enumerate(col_groups):
                    replaced[i] = np.array(X)
                    replaced[i][:, cols] = Xr[:, cols]
                raw = np.zeros((len(col_groups), X.shape[0]), dtype=self._baseline_prediction.dtype)
                raw += self._baseline_prediction.ravel()[0]
                col_sets = [set(np.asarray(cols, int).tolist()) for cols in col_groups]
                for (tree,) in self._predictors[:k]:
                    nodes = tree.nodes
                    used = set(nodes["feature_idx"][nodes["is_leaf"] == 0].tolist())
                    hit = np.array([bool(c & used) for c in col_sets])
                    if not hit.all():
                        raw[~hit] += tree.predict(X, known, f_idx, threads)
                    for i in np.flatnonzero(hit):
                        raw[i] += tree.predict(replaced[i], known, f_idx, threads)
                return raw

            def staged_predict_after(self, X, start, at_start):
                """``staged_predict(X)``'s values after iteration ``start``, given its value there
                (``at_start``): the trees' raw predictions added from it as ``staged_predict``
                adds them, the same values (squared error: the raw prediction is the value)."""
                from sklearn.utils._openmp_helpers import _openmp_effective_n_threads

                if self.loss != "squared_error" or not hasattr(self, "_preprocess_X"):
                    yield from islice(self.staged_predict(X), start, None)
                    return
                X = self._preprocess_X(X, reset=False)
                raw = np.array(np.asarray(at_start, self._baseline_prediction.dtype).reshape(-1, 1), order="F")
                threads = _openmp_effective_n_threads()
                for i in range(start, len(self._predictors)):
                    self._predict_iterations(X, self._predictors[i:i + 1], raw, is_binned=False, n_threads=threads)
                    yield raw.ravel().copy()
        Trees.__module__, Trees.__name__, Trees.__qualname__ = __name__, "_Trees", "_Trees"
        _TREES_KEEPING_BINS.append(Trees)
    return _TREES_KEEPING_BINS[0]


#: per (bins less one, a training column's bytes): the bin thresholds scikit-learn finds on that
#: column (:func:`_binned_with_kept_thresholds`); emptied when it holds THRESHOLDS_MAX (about 6 kB each on
#: 700 rows: a stage keeps some 700)
_THRESHOLDS: dict = {}
THRESHOLDS_MAX = 4000


def _binned_with_kept_thresholds(mapper, X):
    """The training rows ``X`` binned as scikit-learn's ``_BinMapper.fit_transform`` bins them,
    each column's thresholds found once: its ``fit`` finds each column's thresholds from that
    column alone (``_find_binning_thresholds``, with no weights and no subsample under
    ``mapper.subsample`` rows), so a column met again (the same fold's rows of an input every
    channel and most input subsets share: a stage bins about 200 folds' rows) takes the
    thresholds found the first time, the same values.  Returns ``(fitted, binned)``: a copy of
    ``mapper`` with the attributes its ``fit`` sets, and the bins; None where that ``fit`` would do
    more (categories, subsampling)."""
    from sklearn.ensemble._hist_gradient_boosting import binning

    if (mapper.is_categorical is not None or mapper.known_categories is not None or X.ndim != 2
            or X.dtype != binning.X_DTYPE or not 3 <= mapper.n_bins <= 256
            or (mapper.subsample is not None and X.shape[0] > mapper.subsample)):
        return None
    max_bins, found = mapper.n_bins - 1, []
    for f in range(X.shape[1]):
        key = (max_bins, X[:, f].tobytes())
        t = _THRESHOLDS.get(key)
        if t is None:
            if len(_THRESHOLDS) >= THRESHOLDS_MAX:
                _THRESHOLDS.clear()
            t = _THRESHOLDS[key] = binning._find_binning_thresholds(X[:, f], max_bins, sample_weight=None)
        found.append(t.copy())
    fitted = copy.copy(mapper)
    fitted.is_categorical_ = np.zeros(X.shape[1], dtype=np.uint8)
    fitted.missing_values_bin_idx_ = mapper.n_bins - 1
    fitted.bin_thresholds_ = found
    fitted.n_bins_non_missing_ = np.array([t.shape[0] + 1 for t in found], dtype=np.uint32)
    return fitted, fitted.transform(X)


def __getattr__(name):
    if name == "_Trees":  # the class by its name, for pickle (made when first asked for)
        return _trees_keeping_bins()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def final_model(X, y, cv: CV):
    """The trees on every sample with the cross-validation's number of iterations (the model
    the partial dependence and the black box use)."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    return HistGradientBoostingRegressor(**dict(TREES, max_iter=cv.iterations)).fit(X, y)


def importance(cv: CV, X, y, groups, rng, repeats=2) -> dict:
    """Grouped permutation importance out of fold: per fold, the rise of its trees' mean
    squared error on its held-out rows when the group's columns are replaced by those of rows
    drawn at random from the whole recording (the inputs' marginal distribution), over the
    residual's variance.  Returns, per group, ``(mean over the folds, standard error)``."""
    var = float(np.var(y))
    names = list(groups)
    rise = np.zeros((len(names), len(cv.folds)))
    for _ in range(repeats):
        perm = rng.permutation(len(X))
        for b, (h, _) in enumerate(cv.folds):  # every group's permuted copy of the block
            Xb = at(X, b)
            replaced = getattr(cv.models[b], "predict_first_replaced", None)
            got = None if replaced is None else replaced(Xb[h], Xb[perm[h]], [groups[g] for g in names],
                                                         cv.iterations)
            if got is None:  # in one prediction
                stack = np.tile(Xb[h], (len(names), 1))
                for i, g in enumerate(names):
                    stack[i * len(h):(i + 1) * len(h), groups[g]] = Xb[perm[h]][:, groups[g]]
                got = cv.predict(b, stack)
            e = (np.tile(y[h], len(names)) - got.ravel()) ** 2
            rise[:, b] += e.reshape(len(names), len(h)).mean(axis=1)
    base = np.array([np.mean((y[h] - cv.pred[h]) ** 2) for h, _ in cv.folds])
    d = (rise / repeats - base[None, :]) / var
    return {g: (float(np.mean(d[i])), float(np.std(d[i], ddof=1) / math.sqrt(len(cv.folds))))
            for i, g in enumerate(names)}


def outside(X, cv: CV, cols) -> float:
    """The share of samples whose columns ``cols`` lie, in their held-out fold, outside the
    range the fold's fitted rows span (beyond :data:`RANGE_TOL` of it): where the trees
    extrapolate flat."""
    if not cols:
        return 0.0
    out = 0
    for b, (held, fit) in enumerate(cv.folds):
        Xb = at(X, b)
        lo, hi = Xb[fit][:, cols].min(axis=0), Xb[fit][:, cols].max(axis=0)
        tol = RANGE_TOL * (hi - lo)
        v = Xb[held][:, cols]
        out += int(np.sum(np.any((v < lo - tol) | (v > hi + tol), axis=1)))
    return out / len(X)


def _bins(X, fold_rows, bins):
    """Per fold, the quantile bins of every column of ``X`` on the fitted rows: ``(bin of each
    fitted row, bin of each held-out row, bins per column)``, the bins of column ``c`` numbered
    from the sum of the earlier columns' bins (one ``bincount`` serves every column).  They
    depend on the inputs and the folds only, which a stage's channels share: the last inputs'
    bins are kept (:data:`_BINS_KEPT`), and each column's per fold (:data:`_COLUMN_BINS`: the
    channels' inputs differ in their own few columns)."""
    import hashlib

    variants = getattr(X, "variants", None)
    h = hashlib.blake2b(np.ascontiguousarray(X if variants is None else variants).tobytes(), digest_size=16)
    for held, fit in fold_rows:
        h.update(np.asarray(held).tobytes())
        h.update(b"|")
        h.update(np.asarray(fit).tobytes())
    key = (X.shape, bins, h.digest())
    kept = _BINS_KEPT.get("last")
    if kept is None or kept[0] != key:
        q = np.linspace(0.0, 1.0, bins + 1)[1:-1]
        out = []
        for b, (held, fit) in enumerate(fold_rows):
            Xb = at(X, b)
            Xf, Xh = Xb[fit], Xb[held]
            rows = (bins, hashlib.blake2b(np.asarray(held).tobytes() + b"|" + np.asarray(fit).tobytes()).digest())
            keys = [rows + (Xb[:, c].tobytes(),) for c in range(X.shape[1])]
            got = [_COLUMN_BINS.get(k) for k in keys]
            new = [c for c, g in enumerate(got) if g is None]
            cuts = np.quantile(Xf[:, new], q, axis=0) if new else None  # column by column, as of each column
            if len(_COLUMN_BINS) + len(new) > COLUMN_BINS_MAX:
                _COLUMN_BINS.clear()
            for i, c in enumerate(new):
                edges = np.unique(cuts[:, i])
                got[c] = _COLUMN_BINS[keys[c]] = (np.searchsorted(edges, Xf[:, c]), np.searchsorted(edges, Xh[:, c]),
                                                  len(edges) + 1)
            kf, kh = np.empty(Xf.shape[::-1], np.intp), np.empty(Xh.shape[::-1], np.intp)
            for c, g in enumerate(got):
                kf[c], kh[c] = g[0], g[1]
            nb = [g[2] for g in got]
            start = np.concatenate([[0], np.cumsum(nb)[:-1]]).astype(np.intp)
            out.append((kf + start[:, None], kh + start[:, None], int(sum(nb))))
        # one assignment: a diagnosis in another thread reads the old pair or the new one, whole
        kept = _BINS_KEPT["last"] = (key, out)
    return kept[1]


#: per (bins, a fold's rows, a column's values in that fold's inputs): the column's bins on the
#: fold (:func:`_bins`); emptied when it would hold more than COLUMN_BINS_MAX (some 16 kB each on
#: 1,000 rows: a stage of seven channels keeps some 600)
_COLUMN_BINS: dict = {}
COLUMN_BINS_MAX = 1500


#: the quantile bins of the last inputs (:func:`_bins`): ``"last"`` holds their key and bins
_BINS_KEPT: dict = {}


def binned_shares(X, y, fold_rows, bins: int = BINS) -> np.ndarray:
    """Per column of ``X``, the share of ``y``'s variance a step function of that column
    alone explains out of fold: per fold, the means of ``y`` over ``bins`` quantile bins of
    the column on the fitted rows predict the held-out rows (an empty bin predicts the fitted
    mean).  A cheap screen of single inputs, judged like the trees (out of fold, the same
    blocks); 1 - MSE / var(y) per column, below 0 where it predicts worse than the mean.

    Example
    -------
    >>> x = np.linspace(0.0, 1.0, 400)
    >>> X = np.column_stack([x, np.random.default_rng(0).normal(size=400)])
    >>> s = binned_shares(X, np.where(x > 0.6, 1.0, 0.0), folds(400, gap=2))
    >>> bool(s[0] > 0.9 and s[1] < 0.1)
    True
    """
    X, y = (X if isinstance(X, FoldInputs) else np.asarray(X, float)), np.asarray(y, float)
    var = float(np.var(y))
    sse = np.zeros(X.shape[1])
    for (held, fit), (kf, kh, total) in zip(fold_rows, _bins(X, fold_rows, bins)):
        yf = y[fit]
        count = np.bincount(kf.ravel(), minlength=total)
        sums = np.bincount(kf.ravel(), np.tile(yf, X.shape[1]), minlength=total)  # each bin's rows in order
        mean = np.where(count > 0, sums / np.maximum(count, 1), yf.mean())
        d = (y[held][None, :] - mean[kh]) ** 2
        for c in range(X.shape[1]):
            sse[c] += float(np.sum(d[c]))
    return 1.0 - sse / len(y) / var if var > 0 else np.zeros(X.shape[1])
