"""The single-input screen of the flexible stage (cosim.discrepancy.flexible.cv.binned_shares):
its bins computed once for the inputs a stage's channels share, and kept, give every channel the
shares of the screen's definition.

The oracle is the definition written out column by column: per fold, the quantile bins of the
column on the fitted rows, the fitted rows' mean per bin (the fitted mean for an empty bin)
predicting the held-out rows.
"""
from itertools import islice

import numpy as np
import pytest

from cosim.discrepancy.flexible import cv as flexible_cv


@pytest.fixture(autouse=True)
def _one_thread():
    # the trees on one thread, as the stage grows them: OpenMP's default threads on a busy
    # machine turn seconds into minutes.  scikit-learn's ensembles are loaded first:
    # threadpoolctl limits only the runtimes already loaded.
    import sklearn.ensemble  # noqa: F401
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):
        yield


def _by_definition(X, y, fold_rows, bins=flexible_cv.BINS):
    sse = np.zeros(X.shape[1])
    for held, fit in fold_rows:
        for c in range(X.shape[1]):
            edges = np.unique(np.quantile(X[fit, c], np.linspace(0.0, 1.0, bins + 1)[1:-1]))
            kf, kh = np.searchsorted(edges, X[fit, c]), np.searchsorted(edges, X[held, c])
            count = np.bincount(kf, minlength=len(edges) + 1)
            total = np.bincount(kf, y[fit], minlength=len(edges) + 1)
            mean = np.where(count > 0, total / np.maximum(count, 1), y[fit].mean())
            sse[c] += float(np.sum((y[held] - mean[kh]) ** 2))
    return 1.0 - sse / len(y) / np.var(y)


def test_kept_bins_give_each_channel_and_each_input_set_its_own_shares():
    rng = np.random.default_rng(3)
    n = 600
    X = np.column_stack([rng.uniform(size=n), rng.normal(size=n), np.repeat([0.0, 1.0, 2.0], n // 3),
                         np.full(n, 0.5)])  # a continuous, a normal, a three-level and a constant column
    rows = flexible_cv.folds(n, gap=3)
    X2 = X.copy()
    X2[:, 0] = X[::-1, 0]  # the same shape, other values: the kept bins must not serve it
    for inputs in (X, X, X2, X):
        for k in range(3):  # three channels on the same inputs
            y = np.sin(6.0 * inputs[:, 0] + k) + 0.3 * inputs[:, 2] + rng.normal(0.0, 0.2, n)
            assert np.array_equal(flexible_cv.binned_shares(inputs, y, rows), _by_definition(inputs, y, rows))
    other = flexible_cv.folds(n, gap=8)  # other folds on the same inputs
    y = np.cos(4.0 * X[:, 0]) + rng.normal(0.0, 0.1, n)
    assert np.array_equal(flexible_cv.binned_shares(X, y, other), _by_definition(X, y, other))


def test_grow_bins_equal_training_rows_once_and_fits_the_same_trees(monkeypatch):
    """The folds' trees with the training rows binned once per fold are scikit-learn's trees
    bit for bit (a per-fold target included), and the second step does not bin again; rows
    that differ are binned again.  The held-out predictions of the second step, continued from
    the first step's last, are scikit-learn's staged predictions."""
    import pickle

    from sklearn.ensemble import HistGradientBoostingRegressor
    from sklearn.ensemble._hist_gradient_boosting import binning

    rng = np.random.default_rng(3)
    X = rng.normal(size=(600, 7))
    Y = np.column_stack([np.sin(3 * X[:, 0]) + 0.3 * X[:, 1] * X[:, 2] + 0.2 * rng.normal(size=600)
                         for _ in range(flexible_cv.N_FOLDS)]) + 0.1 * rng.normal(size=(600, flexible_cv.N_FOLDS))
    rows = flexible_cv.folds(600, gap=3)
    calls = []  # the thresholds of one column found (scikit-learn's fit finds them column by column)
    find = binning._find_binning_thresholds
    monkeypatch.setattr(binning, "_find_binning_thresholds", lambda *a, **k: calls.append(1) or find(*a, **k))
    monkeypatch.setattr(flexible_cv, "_THRESHOLDS", {})
    for y, found in ((Y[:, 0], flexible_cv.N_FOLDS * X.shape[1]), (Y, 0)):
        calls.clear()
        kept = flexible_cv.grow(X, y, rows)
        assert len(calls) == found  # once per fold and column; none for the same rows with another target
        with monkeypatch.context() as m:
            m.setattr(flexible_cv, "_trees_keeping_bins", lambda: HistGradientBoostingRegressor)
            calls.clear()
            plain = flexible_cv.grow(X, y, rows)
            assert len(calls) == 2 * flexible_cv.N_FOLDS * X.shape[1]  # at each of the two steps
        assert kept[1] == plain[1] and kept[1] + flexible_cv.PATIENCE > flexible_cv.STEPS[0]  # the second step ran
        for a, b in zip(kept[2], plain[2]):
            assert np.array_equal(a, b)
        for a, b in zip(kept[0], plain[0]):
            assert np.array_equal(a.predict(X), b.predict(X)) and a.n_iter_ == b.n_iter_
            assert "_kept_bins" not in a.__dict__
    pickle.loads(pickle.dumps(kept[0][0]))
    # the held-out predictions continued from an iteration are staged_predict's own
    m, (held, _) = kept[0][0], rows[0]
    every = list(m.staged_predict(X[held]))
    for start in (1, 20, len(every) - 1):
        after = list(m.staged_predict_after(X[held], start, every[start - 1]))
        assert len(after) == len(every) - start and all(np.array_equal(a, b) for a, b in zip(after, every[start:]))
    # other rows at the second fit: binned again
    m = flexible_cv._trees_keeping_bins()(**dict(flexible_cv.TREES, warm_start=True, max_iter=5)).fit(X, Y[:, 0])
    calls.clear()
    m.set_params(max_iter=8).fit(X + 1e-3, Y[:, 0])
    ref = HistGradientBoostingRegressor(**dict(flexible_cv.TREES, warm_start=True, max_iter=5)).fit(X, Y[:, 0])
    ref.set_params(max_iter=8).fit(X + 1e-3, Y[:, 0])
    assert len(calls) == 3 * X.shape[1] and np.array_equal(m.predict(X), ref.predict(X))  # m binned again, ref twice
    # a column met again in other training rows takes the thresholds found the first time: the same
    # mapper and bins as scikit-learn's fit finds
    calls.clear()
    mapper = binning._BinMapper(n_bins=flexible_cv.TREES["max_bins"] + 1, random_state=0, n_threads=1)
    Z = np.column_stack([X[:, 4], np.round(X[:, 0]), np.where(X[:, 1] > 1.0, np.nan, X[:, 1])])
    fitted, binned = flexible_cv._binned_with_kept_thresholds(mapper, Z)
    assert not hasattr(mapper, "bin_thresholds_")  # the mapper given is left as it was
    assert len(calls) == 2  # X's column 4 known, the other two new
    ref = binning._BinMapper(n_bins=flexible_cv.TREES["max_bins"] + 1, random_state=0, n_threads=1)
    assert np.array_equal(binned, ref.fit_transform(Z)) and sorted(vars(ref)) == sorted(vars(fitted))
    assert all(np.array_equal(a, b) for a, b in zip(fitted.bin_thresholds_, ref.bin_thresholds_))
    assert np.array_equal(fitted.n_bins_non_missing_, ref.n_bins_non_missing_)
    assert fitted.missing_values_bin_idx_ == ref.missing_values_bin_idx_



def test_a_claim_stops_the_trees_early_and_decides_as_the_whole_growth():
    """A cross-validation whose ``enough`` holds after the first step stops there; every test
    of the kind the stage makes (the held-out error at most a bar: a share claimed) decides on
    it as on the whole growth, for bars on both sides of the two errors; the stopped trees are
    the first step's of the whole growth, and a test that never holds changes nothing."""
    rng = np.random.default_rng(3)
    X = rng.normal(size=(600, 7))
    y = np.sin(3 * X[:, 0]) + 0.3 * X[:, 1] * X[:, 2] + 0.2 * rng.normal(size=600)
    rows = flexible_cv.folds(600, gap=3)
    whole = flexible_cv.cross_validate(X, y, rows)
    assert whole.iterations > flexible_cv.STEPS[0] - flexible_cv.PATIENCE  # the whole growth takes the second step
    never = flexible_cv.cross_validate(X, y, rows, enough=lambda mse: False)
    assert never.iterations == whole.iterations and never.mse == whole.mse and np.array_equal(never.pred, whole.pred)
    first = flexible_cv.cross_validate(X, y, rows, enough=lambda mse: True)
    assert all(m.n_iter_ == flexible_cv.STEPS[0] for m in first.models)  # stopped after the first step
    assert first.mse > whole.mse  # the second step's trees lower the held-out error here
    for (held, _), m, w in zip(rows, first.models, whole.models):  # the same trees, fewer of them
        assert np.array_equal(next(islice(m.staged_predict(X[held]), first.iterations - 1, None)),
                              next(islice(w.staged_predict(X[held]), first.iterations - 1, None)))
    var = float(np.var(y))
    decided = 0
    for bar in np.linspace(whole.mse - 0.2 * var, first.mse + 0.2 * var, 41):
        early = flexible_cv.cross_validate(X, y, rows, enough=lambda mse: mse <= bar)
        assert (early.mse <= bar) == (whole.mse <= bar)
        decided += early.iterations <= flexible_cv.STEPS[0] < whole.iterations
    assert decided >= 10  # the bars at or above the first step's error: decided on its trees


def test_a_bar_stops_the_trees_after_10_or_25_iterations_and_decides_as_the_whole_growth(monkeypatch):
    """A cross-validation judged against a bar alone (``under``) is tested after 10 and 25
    iterations too: under the bar there it stops, and for bars on both sides of the errors it
    decides as the whole growth does; asked for again whole it grows on from there, the whole
    growth's trees, predictions and error bit for bit."""
    X, y, rows = _case()
    _forgotten()
    whole = flexible_cv.cross_validate(X, y, rows)
    _forgotten()
    lowest = flexible_cv.cross_validate(X, y, rows, under=float("inf"))
    assert lowest.stopped and all(m.n_iter_ == flexible_cv.BAR_STEPS[0] == 10 for m in lowest.models)
    calls = _fits_counted(monkeypatch)
    grown_on = flexible_cv.cross_validate(X, y, rows)
    assert calls == [n for n in flexible_cv.STEPS if n <= max(m.n_iter_ for m in whole.models)
                     for _ in rows]  # the steps of 50 and 75 iterations only
    assert grown_on.iterations == whole.iterations and grown_on.mse == whole.mse
    assert np.array_equal(grown_on.pred, whole.pred)
    var = float(np.var(y))
    steps = set()
    for bar in np.linspace(whole.mse - 0.2 * var, lowest.mse + 0.2 * var, 41):
        _forgotten()
        early = flexible_cv.cross_validate(X, y, rows, under=bar)
        assert (early.mse < bar) == (whole.mse < bar)
        steps.add(max(m.n_iter_ for m in early.models))
    assert {10, 25} <= steps  # bars decided on the trees of 10 and of 25 iterations


def _forgotten():
    flexible_cv._DONE.clear()
    flexible_cv._STOPPED.clear()
    flexible_cv._TARGET.clear()


def _fits_counted(monkeypatch):
    """The warm-started fits of the folds' trees, by the number of iterations each was asked for."""
    trees, calls = flexible_cv._trees_keeping_bins(), []
    fit = trees.fit

    def counted(self, *args, **kw):
        calls.append(self.max_iter)
        return fit(self, *args, **kw)
    monkeypatch.setattr(trees, "fit", counted)
    return calls


def _case():
    rng = np.random.default_rng(5)
    X = rng.normal(size=(600, 6))
    y = np.sin(3 * X[:, 0]) + 0.3 * X[:, 1] * X[:, 2] + 0.2 * rng.normal(size=600)
    return X, y, flexible_cv.folds(600, gap=3)


def test_a_cross_validation_asked_again_on_equal_inputs_is_the_first_one(monkeypatch):
    """Equal values (other arrays) give the cross-validation made the first time, no tree grown;
    another target grows its own."""
    X, y, rows = _case()
    _forgotten()
    first = flexible_cv.cross_validate(X, y, rows)
    calls = _fits_counted(monkeypatch)
    again = flexible_cv.cross_validate(X.copy(), y.copy(), rows)
    assert again is first and calls == []
    other = flexible_cv.cross_validate(X, y + 0.5 * X[:, 3], rows)
    assert len(calls) >= len(rows) and other.mse != first.mse


def test_a_growth_stopped_early_grows_on_as_the_whole_growth_bit_for_bit(monkeypatch):
    """Trees stopped after the first step (``enough``) and asked for again whole are grown on from
    there: the second step's fits only, and the whole growth's trees, predictions and error bit for
    bit; the stopped cross-validation keeps its own trees."""
    X, y, rows = _case()
    _forgotten()
    whole = flexible_cv.cross_validate(X, y, rows)
    assert whole.iterations > flexible_cv.STEPS[0] - flexible_cv.PATIENCE  # the whole growth takes the second step
    _forgotten()
    early = flexible_cv.cross_validate(X, y, rows, enough=lambda mse: True)
    assert early.stopped and all(m.n_iter_ == flexible_cv.STEPS[0] for m in early.models)
    calls = _fits_counted(monkeypatch)
    grown_on = flexible_cv.cross_validate(X, y, rows)
    assert calls == [flexible_cv.STEPS[1]] * len(rows)  # the second step alone
    assert not grown_on.stopped and grown_on.iterations == whole.iterations and grown_on.mse == whole.mse
    assert np.array_equal(grown_on.pred, whole.pred)
    for (held, _), g, w in zip(rows, grown_on.models, whole.models):
        assert g.n_iter_ == w.n_iter_
        assert np.array_equal(g.predict(X[held]), w.predict(X[held]))
    assert all(m.n_iter_ == flexible_cv.STEPS[0] for m in early.models)


def test_the_first_trees_predict_as_the_staged_prediction_bit_for_bit():
    X, y, rows = _case()
    models, _, _ = flexible_cv.grow(X, y, rows)
    held = rows[0][0]
    for k in (1, 7, models[0].n_iter_):
        staged = next(islice(models[0].staged_predict(X[held]), k - 1, None))
        assert np.array_equal(flexible_cv.first_trees(models[0], X[held], k), staged)


def test_a_cross_validation_made_before_another_targets_is_still_the_first_one(monkeypatch):
    """A channel's fits on another target in between (the efforts' choice made again without the
    fitted levels) do not let its own go: asked again, the first one, no tree grown."""
    X, y, rows = _case()
    _forgotten()
    first = flexible_cv.cross_validate(X, y, rows)
    flexible_cv.cross_validate(X, y + 0.5 * X[:, 3], rows)
    calls = _fits_counted(monkeypatch)
    again = flexible_cv.cross_validate(X.copy(), y.copy(), rows)
    assert again is first and calls == []
    for shift in (1.0, 2.0):  # older than the last TARGETS_KEPT targets: let go, grown again
        flexible_cv.cross_validate(X, y + shift * X[:, 4], rows)
    assert flexible_cv.cross_validate(X, y, rows) is not first and len(calls) >= len(rows)


class _Stacked:
    """A fold's trees seen through ``predict_first`` alone: the permutation importance then
    predicts every group's permuted block in one stacked prediction."""

    def __init__(self, model):
        self.model = model

    def predict_first(self, X, k):
        return self.model.predict_first(X, k)


def test_the_importance_predicts_again_only_the_trees_a_permuted_group_reaches_bit_for_bit():
    X, y, rows = _case()
    X = np.column_stack([X, np.random.default_rng(2).normal(size=(len(X), 4))])
    _forgotten()
    cv = flexible_cv.cross_validate(X, y, rows)
    groups = {"a": [0], "b": [1, 2], "c": [3, 4], "d": [5, 6, 7], "e": [8, 9], "none": []}
    stacked = flexible_cv.CV(cv.folds, tuple(_Stacked(m) for m in cv.models), cv.iterations, cv.pred, cv.mse)
    got = flexible_cv.importance(cv, X, y, groups, np.random.default_rng(4))
    assert got == flexible_cv.importance(stacked, X, y, groups, np.random.default_rng(4))
    assert got["a"][0] > 0.1 and got["none"] == (0.0, 0.0)


def test_each_columns_bins_are_kept_and_serve_inputs_that_share_it():
    """Channels' inputs share all but their own few columns: a column's bins on a fold are made
    once and serve every input set holding it, with its per-fold variants; the shares stay the
    definition's."""
    rng = np.random.default_rng(5)
    n = 500
    rows = flexible_cv.folds(n, gap=3)
    common = np.column_stack([rng.uniform(size=n), rng.normal(size=n), np.repeat([0.0, 1.0], n // 2)])
    flexible_cv._COLUMN_BINS.clear()
    for k in range(3):  # three channels: the common columns and one of their own, fitted per fold
        own = rng.normal(size=n)
        variants = np.stack([np.column_stack([common, own + 0.1 * b]) for b in range(len(rows))])
        X = flexible_cv.FoldInputs(np.column_stack([common, own]), variants)
        before = len(flexible_cv._COLUMN_BINS)
        y = np.sin(5.0 * common[:, 0] + k) + 0.5 * own + rng.normal(0.0, 0.2, n)
        shares = flexible_cv.binned_shares(X, y, rows)
        # per fold, only the channel's own column is binned after the first channel
        assert len(flexible_cv._COLUMN_BINS) - before == (4 if k == 0 else 1) * len(rows)
        for b, ((held, fit), (kf, kh, total)) in enumerate(zip(rows, flexible_cv._bins(X, rows, flexible_cv.BINS))):
            Xb, start = variants[b], 0  # the definition on each fold's own inputs
            for c in range(X.shape[1]):
                edges = np.unique(np.quantile(Xb[fit, c], np.linspace(0.0, 1.0, flexible_cv.BINS + 1)[1:-1]))
                assert np.array_equal(kf[c], np.searchsorted(edges, Xb[fit, c]) + start)
                assert np.array_equal(kh[c], np.searchsorted(edges, Xb[held, c]) + start)
                start += len(edges) + 1
            assert total == start
        assert np.all(np.isfinite(shares))
