"""A discovered equation against the flexible stage's trees (cosim.discrepancy.flexible.rival).

The synthetic checks know their truth in closed form: a damping c qd acting only while q is
inside a zone (no global term), the equation either of the wrong form (a global viscous pair
and Coulomb friction, what discovery wrote on a MuJoCo recording of such a band) or of the
right one (the zone's column itself).
"""
import numpy as np

from cosim.discrepancy.flexible import rival
from cosim.discrepancy.flexible.cv import cross_validate, folds


def _band(n=1500, sigma=0.02, seed=3):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, n)
    q = 0.5 * np.sin(2 * np.pi * 0.31 * t) + 0.3 * np.sin(2 * np.pi * 0.73 * t + 1.0)
    qd = np.gradient(q, t)
    zone = ((q > 0.1) & (q < 0.3)).astype(float)
    y = 2.0 * zone * qd + rng.normal(0.0, sigma, n)
    X = np.column_stack([q, qd, np.sign(qd), t])
    return X, y, q, qd, zone


def test_the_trees_outfit_an_equation_of_the_wrong_form_not_the_right_one():
    X, y, q, qd, zone = _band()
    rows = folds(len(y), gap=5)
    trees = cross_validate(X, y, rows).pred
    wrong = rival.equation_out_of_fold(np.column_stack([np.maximum(qd, 0), np.minimum(qd, 0), np.sign(qd)]), y, rows)
    right = rival.equation_out_of_fold((zone * qd)[:, None], y, rows)
    w, r = rival.compare(y, wrong, trees, rows), rival.compare(y, right, trees, rows)
    assert w.outfit and w.excess > rival.MARGIN and w.equation < w.trees
    assert not r.outfit and r.equation > 0.9
    assert rival.PARTIAL in w.sentence()


def test_the_equation_is_refitted_out_of_fold():
    # a column that fits pure noise in-sample predicts nothing held out: its share is not above zero
    rng = np.random.default_rng(0)
    y = rng.normal(size=600)
    rows = folds(len(y), gap=2)
    pred = rival.equation_out_of_fold(rng.normal(size=(600, 40)), y, rows)
    assert 1.0 - np.mean((y - pred) ** 2) / np.var(y) < 0.0


def test_no_variance_is_no_claim():
    y = np.zeros(400)
    rows = folds(len(y), gap=2)
    assert not rival.compare(y, y, y, rows).outfit
