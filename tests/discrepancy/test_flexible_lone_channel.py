"""A force on one channel alone is no force on the platform (cosim.discrepancy.flexible.across.
without_lone_pose): where one channel of several names anything and it names the platform pose,
that channel is fitted again without the pose's columns, and the new fit is the answer where the
pose does not explain significantly more.

With trees, truth in closed form (tests/discrepancy/test_flexible_platform_inputs.py's case): a
force 0.5 tanh(3 s) on an oblique direction s of six pose columns, beside rail 2's model effort,
which moves with s (s plus its own motion at 0.6 of s's RMS), and three other rails' positions.
With stubs: fits whose out-of-fold predictions miss the target by a chosen share.
"""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from cosim.discrepancy.flexible import across
from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.cv import folds
from test_flexible_platform_inputs import _oblique

N = 400
ROWS = folds(N, 2)


def _trees(without=()):
    pipe, X, cols, y, sigma = _oblique()
    return flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"), without=without)


def test_the_fit_without_the_pose_is_given_no_pose_column_and_the_pose_stays_where_it_explains_more():
    posed, again = _trees(), _trees(without=(flexible.POSE,))
    assert posed.named == (flexible.POSE,) and posed.share > 0.9
    assert again.explained and flexible.POSE not in again.named and "effort of slider 2" in again.named
    # no pose column among the trees' inputs, and their columns index the stage's (the black box's)
    assert all(again.columns[i][1] != flexible.POSE for i in again.use)
    assert again.without == (flexible.POSE,) and posed.without == ()
    said = flexible.statement(replace(again, left_out="the platform pose left out of the inputs: ..."), "slider")
    assert "the platform pose left out of the inputs" in said and "the platform pose left out" not in \
        flexible.statement(posed, "slider")
    y = _oblique()[3]
    posed = replace(posed, target=y)
    # the pose explains 0.95, the rail's effort 0.56: the pose stays
    assert across.without_lone_pose([posed], 6, lambda f, w, why: again, folds(len(y), 5))[0] is posed


def _stub(named, missed, seed, explained=True):
    """A fit naming ``named`` whose out-of-fold prediction misses the target by ``missed`` of its variance."""
    y = np.sin(np.linspace(0.0, 40.0, N))
    e = np.random.default_rng(seed).normal(size=N)
    pred = y + e * np.sqrt(missed * np.var(y) / np.mean(e ** 2))
    return SimpleNamespace(explained=explained, named=tuple(named), target=y, pred=pred)


def test_the_fit_without_the_pose_is_the_answer_where_it_explains_about_as_much():
    posed, again = _stub([flexible.POSE], 0.20, 0), _stub(["position of slider 4"], 0.21, 1)
    asked = []
    assert across.without_lone_pose([posed], 6, lambda f, w, why: asked.append((w, why)) or again, ROWS) == [again]
    assert asked[0][0] == (flexible.POSE,) and asked[0][1].startswith("the platform pose left out of the inputs")
    worse = _stub(["position of slider 4"], 0.50, 1)
    assert across.without_lone_pose([posed], 6, lambda f, w, why: worse, ROWS) == [posed]


def test_the_pose_stays_beside_another_channel_on_a_one_channel_robot_and_where_the_refit_claims_nothing():
    posed, other = _stub([flexible.POSE], 0.20, 0), _stub(["rate of slider 2"], 0.3, 2)
    asked = []

    def refit(f, without, why):
        asked.append(f)
        return _stub(["position of slider 4"], 0.2, 1, explained=False)
    assert across.without_lone_pose([posed, other], 6, refit, ROWS) == [posed, other]
    assert across.without_lone_pose([posed], 1, refit, ROWS) == [posed]
    assert not asked
    assert across.without_lone_pose([posed], 6, refit, ROWS) == [posed] and len(asked) == 1
    assert across.without_lone_pose([posed], 6, lambda f, w, why: None, ROWS) == [posed]
