"""The flexible stage's cross-validation (cosim.discrepancy.flexible.cv).

The single-input screen (binned_shares): its bins computed once for the inputs a stage's channels
share, and kept, give every channel the shares of the screen's definition.  The oracle is the
definition written out column by column: per fold, the quantile bins of the column on the fitted
rows, the fitted rows' mean per bin (the fitted mean for an empty bin) predicting the held-out rows.

The boosted trees (grow, final_model): the oracle is LightGBM's own single fit with the same
settings, and the held-out error of its own predictions.
"""
import numpy as np
import pytest

from cosim.discrepancy.flexible import cv as flexible_cv


@pytest.fixture(autouse=True)
def _one_thread():
    # the trees on one thread, as the stage grows them: OpenMP's default threads on a busy
    # machine turn seconds into minutes.  LightGBM is loaded first: threadpoolctl limits only
    # the runtimes already loaded.
    import lightgbm  # noqa: F401
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


def _one_fit(X, y, iterations):
    """LightGBM's own fit of ``iterations`` iterations with the stage's settings (its booster as
    trained, not reloaded from its text: the text rounds the nodes' internal values)."""
    import lightgbm

    return lightgbm.train(flexible_cv.TREES, lightgbm.Dataset(X, y, params=flexible_cv.TREES),
                          num_boost_round=iterations, keep_training_booster=True)


def test_grow_in_steps_is_one_fit_and_chooses_the_held_out_minimum():
    """The folds' trees grown in two steps are LightGBM's trees of one fit of as many iterations
    (a per-fold target included); the chosen number of iterations is the minimum of the summed
    held-out squared error of those trees' own predictions (from MIN_ITER on), and the held-out
    predictions are theirs at that number."""
    rng = np.random.default_rng(3)
    X = rng.normal(size=(600, 7))
    Y = np.column_stack([np.sin(3 * X[:, 0]) + 0.3 * X[:, 1] * X[:, 2] + 0.2 * rng.normal(size=600)
                         for _ in range(flexible_cv.N_FOLDS)]) + 0.1 * rng.normal(size=(600, flexible_cv.N_FOLDS))
    rows = flexible_cv.folds(600, gap=3)
    for y in (Y[:, 0], Y):
        models, best, held_pred = flexible_cv.grow(X, y, rows)
        assert best + flexible_cv.PATIENCE > flexible_cv.STEPS[0]  # the second step ran
        total = np.zeros(flexible_cv.STEPS[-1])
        for b, ((held, fit), m) in enumerate(zip(rows, models)):
            t = y if y.ndim == 1 else y[:, b]
            assert m.current_iteration() == flexible_cv.STEPS[-1]
            ref = _one_fit(X[fit], t[fit], flexible_cv.STEPS[-1])
            assert m.dump_model()["tree_info"] == ref.dump_model()["tree_info"]
            assert np.array_equal(m.predict(X), ref.predict(X))
            assert np.array_equal(held_pred[b], ref.predict(X[held], num_iteration=best))
            total += [np.sum((t[held] - ref.predict(X[held], num_iteration=k)) ** 2)
                      for k in range(1, flexible_cv.STEPS[-1] + 1)]
        assert best == int(np.argmin(total[flexible_cv.MIN_ITER - 1:])) + flexible_cv.MIN_ITER


def test_grow_stops_after_the_first_step_when_the_minimum_is_early_and_survives_pickling():
    """A target the inputs do not explain: the held-out loss is lowest early, and the trees stop
    at the first step (PATIENCE iterations past the minimum); the fitted trees pickle."""
    import pickle

    rng = np.random.default_rng(5)
    X, y = rng.normal(size=(500, 4)), rng.normal(size=500)
    rows = flexible_cv.folds(500, gap=2)
    models, best, _ = flexible_cv.grow(X, y, rows)
    assert best <= flexible_cv.STEPS[0] - flexible_cv.PATIENCE
    assert all(m.current_iteration() == flexible_cv.STEPS[0] for m in models)
    again = pickle.loads(pickle.dumps(models[0]))
    assert np.array_equal(again.predict(X), models[0].predict(X))


def test_grow_on_a_constant_target_and_the_final_model_is_lightgbms_own_fit():
    """A constant target (no split anywhere) gives a constant held-out prediction, no NaN; the
    final model (LightGBM's scikit-learn regressor, the settings renamed) is LightGBM's own fit
    of the chosen number of iterations on every sample, bit for bit."""
    rng = np.random.default_rng(7)
    X = rng.normal(size=(400, 5))
    rows = flexible_cv.folds(400, gap=2)
    cv = flexible_cv.cross_validate(X, np.full(400, 2.5), rows)
    assert np.allclose(cv.pred, 2.5) and np.isfinite(cv.mse)
    y = np.tanh(2 * X[:, 0]) + 0.5 * X[:, 1] ** 2 + 0.1 * rng.normal(size=400)
    cv = flexible_cv.cross_validate(X, y, rows)
    model = flexible_cv.final_model(X, y, cv)
    assert np.array_equal(model.predict(X), _one_fit(X, y, cv.iterations).predict(X))
