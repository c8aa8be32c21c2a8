"""A partner stays named only where its shared columns add to the kept groups' model
(cosim.discrepancy.flexible.select.still_added).

Synthetic, truth in closed form: rail 2's rate named (its reading, a column ``c`` it shares with
rail 1's rate, as the rates' projected column, and its signed history ``s``, shared with rail 2's
history); rail 1's rate holds ``c`` and its own reading ``r``; each column Gaussian noise smoothed
over 8 samples, scaled to unit RMS.  The force is tanh(3 c) plus, with ``product``,
tanh(3 r) tanh(3 s): beside ``r`` (rail 1's reading, a column the named model never holds: a
partner is named for its shared columns only) ``s`` adds; on the kept group's columns it adds
nothing (r is independent of s, its tanh of mean zero; measured, seeds 1-2: s beside r adds 0.35-0.40 of the
variance out of fold, on the kept group's columns -0.06 to -0.07).  Rail 1's rate is judged first (the groups'
order), so without the rule rail 2's history is judged against the trees holding ``r``.  With
``signed``, the force adds 0.5 s: the history's shared column adds on the kept model too.
"""
import numpy as np
import sklearn.ensemble  # noqa: F401  (loaded before the thread limit: threadpoolctl limits the loaded runtimes)
from scipy.ndimage import gaussian_filter1d
from threadpoolctl import threadpool_limits

from cosim.discrepancy.flexible import select as sel
from cosim.discrepancy.flexible.cv import folds


def _case(seed, product=True, signed=False, n=800, sigma=0.05):
    rng = np.random.default_rng(seed)
    qd2, c, r, s, h2 = (x / np.std(x) for x in gaussian_filter1d(rng.normal(size=(5, n)), 8, axis=1))
    y = np.tanh(3.0 * c) + rng.normal(0.0, sigma, n)
    if product:
        y += np.tanh(3.0 * r) * np.tanh(3.0 * s)
    if signed:
        y += 0.5 * s
    X = np.column_stack([qd2, c, s, r, h2])
    groups = {"rate of slider 2": [0, 1, 2], "rate of slider 1": [3, 1], "history of slider 2": [4, 2]}
    return X, y, groups


def _named(X, y, groups):
    with threadpool_limits(limits=1):
        return sel.select(X, y, folds(len(y), 10), groups, ["rate of slider 2"], float(np.var(y)))[0]


def test_a_partner_judged_beside_another_partners_columns_is_not_named(monkeypatch):
    for seed in (1, 2):
        X, y, groups = _case(seed)
        assert _named(X, y, groups) == ["rate of slider 2", "rate of slider 1"]
        monkeypatch.setattr(sel, "still_added", lambda out, *a: out)  # the rule taken out
        assert _named(X, y, groups) == ["rate of slider 2", "rate of slider 1", "history of slider 2"]
        monkeypatch.undo()


def test_a_partner_whose_shared_columns_add_to_the_kept_model_stays_named():
    for seed in (1, 2):
        X, y, groups = _case(seed, product=False, signed=True)
        assert _named(X, y, groups) == ["rate of slider 2", "rate of slider 1", "history of slider 2"]
