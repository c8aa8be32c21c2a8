"""A force on one channel alone is no force on the platform (cosim.discrepancy.flexible.stage.
without_lone_pose): where one channel of several names anything and it names the platform pose,
that channel is fitted again without the pose's columns.

Synthetic, truth in closed form (tests/discrepancy/test_flexible_platform_inputs.py's case): a
force 0.5 tanh(3 s) on an oblique direction s of six pose columns, beside rail 2's model effort,
which moves with s (s plus its own motion at 0.6 of s's RMS), and three other rails' positions.
"""
from dataclasses import replace

from cosim.discrepancy.flexible import stage as flexible
from test_flexible_platform_inputs import _oblique


def _fit(without=()):
    pipe, X, cols, y, sigma = _oblique()
    return flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"), without=without)


def test_the_pose_named_on_one_channel_alone_gives_way_to_what_the_channel_names_without_it():
    fit = _fit()
    assert fit.named == (flexible.POSE,)
    out = flexible.without_lone_pose([fit], 6, lambda f: _fit(without=(flexible.POSE,)))
    assert out[0].explained and flexible.POSE not in out[0].named
    assert "effort of slider 2" in out[0].named
    # the trees were given no pose column, and their columns index the stage's (the black box's)
    assert all(out[0].columns[i][1] != flexible.POSE for i in out[0].use)
    assert out[0].share < fit.share  # the pose explains more: the rule is a prior, not a better fit


def test_the_pose_stays_beside_another_channel_on_a_one_channel_robot_and_where_the_refit_claims_nothing():
    fit = _fit()
    never = []

    def refit(f):
        never.append(f)
        return replace(f, explained=False)
    assert flexible.without_lone_pose([fit, replace(fit, joint=2, channel="tau2")], 6, refit)[0] is fit
    assert flexible.without_lone_pose([fit], 1, refit)[0] is fit
    assert not never
    assert flexible.without_lone_pose([fit], 6, refit)[0] is fit and len(never) == 1
    assert flexible.without_lone_pose([fit], 6, lambda f: None)[0] is fit
