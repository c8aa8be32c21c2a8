"""The fitted model re-adjusted beside the flexible stage's trees (cosim.discrepancy.flexible.backfit).

The synthetic case knows its truth in closed form: a force on one input, of which an earlier
least-squares fit of another column (a library effect's, say) took its projection; what is left
is then no function of the force's input alone, and all of it but the white noise is the
force plus the fitted column re-adjusted: share 1 - var(noise) / var(residual).
"""
import types

import numpy as np

from cosim.discrepancy.flexible import backfit as flexible_backfit
from cosim.discrepancy.flexible import stage as flexible


def _taken_in_part(seed=0, n=1200, sigma=0.05):
    rng = np.random.default_rng(seed)
    X = rng.uniform(0.0, 1.0, (n, 6))
    force = 0.3 * np.exp(-(((X[:, 2] - 0.5) / 0.1) ** 2))
    column = (force - force.mean()) + rng.normal(0.0, 0.1, n)  # moves with the force and with what no input holds
    noise = rng.normal(0.0, sigma, n)
    y0 = force + noise
    taken = column * float(column @ (y0 - y0.mean()) / (column @ column))  # the earlier fit's share of it
    y = y0 - taken
    cols = [(f"x{i}", f"input {i}", None, "position", "m") for i in range(6)]
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=5)
    return pipe, X, cols, y, column[:, None], sigma, 1.0 - float(np.var(noise) / np.var(y))


def test_a_force_the_earlier_fit_took_in_part_is_claimed_at_its_share_with_the_fit_readjusted():
    pipe, X, cols, y, J, sigma, truth = _taken_in_part()
    assert 0.5 < truth < 0.8  # the earlier fit took part of the force: the trees alone cannot reach this
    alone = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert [d.group for d in alone.inputs] == ["input 2"]
    assert truth - alone.share > 0.15  # measured 0.31 under the truth without the re-adjustment
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"), fitted=(J, ["rail[1].coulomb"]))
    assert [d.group for d in fit.inputs] == ["input 2"]
    assert fit.readjusted == ("rail[1].coulomb",)
    assert abs(fit.share - truth) < 0.1
    assert "with the fitted rail[1].coulomb re-adjusted beside it" in flexible.statement(fit, "slider")


def test_a_column_the_residual_does_not_follow_is_not_readjusted():
    # the same force, nothing taken: a column of noise adds nothing out of fold (no trees fitted for it)
    pipe, X, cols, _, J, sigma, _ = _taken_in_part()
    rng = np.random.default_rng(1)
    y = 0.3 * np.exp(-(((X[:, 2] - 0.5) / 0.1) ** 2)) + rng.normal(0.0, sigma, len(X))
    from cosim.discrepancy.flexible.cv import cross_validate, folds

    cv = cross_validate(X[:, [2]], y, folds(len(y), 1))
    assert flexible_backfit.linear_gain(rng.normal(size=(len(y), 1)), y, cv) < flexible_backfit.LINEAR_MIN
    assert flexible_backfit.readjusted(X[:, [2]], y, (rng.normal(size=(len(y), 1)), ["p"]), cv)[1] == ()


def test_a_parameter_the_core_refuses_to_take_out_is_left_out_not_raised():
    # a residual linear in "a" (its column the line t) and a parameter "b" whose removal the core
    # refuses (a drive's effort terms that self-lock): "a" gives its column, "b" none
    from cosim.errors import ArgumentError

    t = np.linspace(0.0, 1.0, 50)

    def R(theta):
        if "b" not in theta:
            raise ArgumentError("the drive self-locks", "PKM_ERR_ARGUMENT")
        return np.column_stack([1.0 + t - theta.get("a", 0.0) * t, np.zeros_like(t)])

    eng = types.SimpleNamespace(R=R)
    cols = flexible_backfit.fitted_columns(eng, {"a": 0.5, "b": 1.0}, [0, 1])
    assert cols[0][1] == ["a"]
    assert np.allclose(cols[0][0][:, 0], 0.5 * t)  # taken out: the residual rises by what it took
    assert cols[1][1] == []


def test_a_fitted_column_zero_on_a_folds_fitted_rows_gives_a_gain_not_a_singular_matrix():
    # a fitted effect's column that is zero wherever a fold is fitted (an effect active only in one
    # block of the recording): the relative ridge is zero too, and the refit takes no part of it
    rng = np.random.default_rng(3)
    n = 400
    y = rng.normal(size=n)
    cv = types.SimpleNamespace(pred=np.zeros(n), folds=[(np.arange(0, 200), np.arange(200, n)),
                                                        (np.arange(200, n), np.arange(0, 200))])
    J = np.zeros((n, 2))
    J[:200, 0] = rng.normal(size=200)  # zero on the first fold's fitted rows
    gain = flexible_backfit.linear_gain(J, y, cv)
    assert np.isfinite(gain)
    assert np.array_equal(flexible_backfit._refit(J[200:], y[200:]), np.zeros(2))


def test_no_channel_asks_the_core_for_no_residual():
    # every channel fitted without its stand-in (stage_columns) leaves none for the fit at theta
    def refuse(theta):
        raise AssertionError("a residual evaluated for no channel")
    eng = types.SimpleNamespace(R=refuse)
    assert flexible_backfit.fitted_columns(eng, {"a": 1.0, "b": 2.0}, []) == {}
