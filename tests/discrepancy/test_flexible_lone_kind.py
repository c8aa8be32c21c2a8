"""A kind of input on one channel alone (cosim.discrepancy.flexible.across.without_lone_kinds):
where three or more channels hold a force, a history, an acceleration, a model effort or time
named on one of them and on no other is left out of that channel's inputs, every group of its
kind, and the channel's fit without them is its answer.  Stubs stand for the channels' fits; the
refit records what it was asked."""
from types import SimpleNamespace

from cosim.discrepancy.flexible import across
from cosim.discrepancy.flexible.stage import FlexibleFit, statement

GROUPS = tuple(f"{q} of slider {k}" for q in ("position", "rate", "acceleration", "effort", "history")
               for k in range(1, 7)) + ("the platform pose", "time")


def _fit(channel, named, explained=True):
    return SimpleNamespace(channel=channel, named=tuple(named), explained=explained)


def _refit(asked):
    def refit(f, without, why):
        asked.append((f.channel, without, why))
        return _fit(f.channel, [g for g in f.named if g not in without])
    return refit


def test_an_acceleration_and_a_history_each_on_one_channel_of_four_are_left_out_there():
    fits = [_fit("tau1", ["the platform pose"]), _fit("tau2", ["rate of slider 2", "the platform pose"]),
            _fit("tau3", ["the platform pose", "acceleration of slider 6"]),
            _fit("tau4", ["the platform pose", "history of slider 4"]), _fit("tau5", ["time"], explained=False)]
    asked = []
    out = across.without_lone_kinds(fits, GROUPS, _refit(asked))
    assert [f.named for f in out] == [("the platform pose",), ("rate of slider 2", "the platform pose"),
                                      ("the platform pose",), ("the platform pose",), ("time",)]
    assert out[0] is fits[0] and out[1] is fits[1] and out[4] is fits[4]
    (c3, w3, why3), (c4, w4, why4) = asked
    assert c3 == "tau3" and w3 == tuple(f"acceleration of slider {k}" for k in range(1, 7))
    assert c4 == "tau4" and w4 == tuple(f"history of slider {k}" for k in range(1, 7))
    assert why3.startswith("accelerations left out of the inputs") and "no other of the 4 holding a force" in why3


def test_a_kind_two_channels_name_stays_and_so_does_everything_under_three_channels():
    shared = [_fit("tau1", ["the platform pose", "acceleration of slider 1"]),
              _fit("tau2", ["the platform pose", "acceleration of slider 2"]), _fit("tau3", ["the platform pose"])]
    asked = []
    assert across.without_lone_kinds(shared, GROUPS, _refit(asked)) == shared and not asked
    two = [_fit("tau1", ["the platform pose", "time"]), _fit("tau2", ["the platform pose"])]
    assert across.without_lone_kinds(two, GROUPS, _refit(asked)) == two and not asked
    # a channel whose refit cannot be made keeps its fit
    lone = shared[:1] + [_fit("tau2", ["the platform pose"]), _fit("tau3", ["rate of slider 3"])]
    assert across.without_lone_kinds(lone, GROUPS, lambda f, w, why: None) == lone


def test_time_and_an_effort_on_one_channel_are_left_out_together_and_positions_rates_and_the_pose_never():
    fits = [_fit("tau1", ["time", "effort of slider 4", "position of slider 1"]),
            _fit("tau2", ["rate of slider 2", "position of slider 3"]), _fit("tau3", ["the platform pose"])]
    asked = []
    out = across.without_lone_kinds(fits, GROUPS, _refit(asked))
    assert len(asked) == 1 and set(asked[0][1]) == {f"effort of slider {k}" for k in range(1, 7)} | {"time"}
    assert asked[0][2].startswith("model efforts, time left out of the inputs")
    assert out[0].named == ("position of slider 1",) and out[1:] == fits[1:]
    assert [across.kind(g) for g in ("time", "history of slider 2", "the platform pose", "rate of slider 1",
                                     "the platform's motion")] == ["time", "history of ", None, None, None]


def test_the_statement_ends_with_why_the_inputs_were_left_out_and_the_json_says_it():
    fit = FlexibleFit("tau3", 3, "N", 0.3, 40.0, True, 0.1, 0.01, without=("acceleration of slider 6",),
                      left_out="accelerations left out of the inputs: named on this channel and on no other")
    said = statement(fit, "slider")
    assert said.endswith("; accelerations left out of the inputs: named on this channel and on no other")
    assert fit.to_dict()["left_out"] == fit.left_out and "left out" not in statement(
        FlexibleFit("tau3", 3, "N", 0.3, 40.0, True, 0.1, 0.01), "slider")


def test_a_refit_naming_another_kind_on_that_channel_alone_is_fitted_again_without_both():
    fits = [_fit("tau1", ["the platform pose"]), _fit("tau2", ["rate of slider 2"]), _fit("tau3", ["time"])]
    asked = []

    def refit(f, without, why):
        asked.append((f.channel, set(without), why))
        return _fit(f.channel, ["acceleration of slider 3"] if "time" in without and len(asked) == 1 else
                    ["position of slider 3"])
    out = across.without_lone_kinds(fits, GROUPS, refit)
    assert out[2].named == ("position of slider 3",) and len(asked) == 2
    assert asked[1][1] == {f"acceleration of slider {k}" for k in range(1, 7)} | {"time"}
    assert asked[1][2].startswith("accelerations, time left out of the inputs")
