"""The MuJoCo benches' second judgement: the declared inputs against what either stage models
(bench/foreign/unlisted_common.py: ``term_groups``, ``platform_groups``, ``stage_reads``,
``judge_either``).  Stand-ins of the diagnosis's objects, the expected groups written by hand."""
import sys
from pathlib import Path
from types import SimpleNamespace as NS

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import unlisted_common as uc  # noqa: E402

from cosim.discrepancy.discovery.terms import TERMS  # noqa: E402


def term(joint, terms, shape=None, partial="", pair=0):
    return NS(joint=joint, terms=terms, shape=shape or {}, partial=partial, pair=pair)


def fit(joint, groups, explained=True):
    return NS(joint=joint, channel=f"tau{joint}", explained=explained, share=0.8,
              inputs=[NS(group=g) for g in groups], named=tuple(groups))


def diagnosis(discovered=(), platform=None, drifts=(), unexplained=()):
    return NS(discovered=list(discovered), platform_force=platform, drifts=list(drifts), unexplained=list(unexplained))


#: the damper between rails 4 and 5 (coupling_damper): both rates, nothing else
DAMPER = {"need": {"rate of slider 4", "rate of slider 5"}, "any": set(),
          "allowed": {"rate of slider 4", "rate of slider 5"}}


def test_a_term_reads_its_own_joint_and_a_cross_terms_other_joint():
    t = term(5, ["stroke_2", "cross_v"], {"rail[5].force_qc": 0.05, "rail[5].force_xj": 4.0})
    assert uc.term_groups(t) == {"position of slider 5", "rate of slider 5", "rate of slider 4"}
    assert uc.term_groups(term(2, ["load"])) == {"effort of slider 2", "rate of slider 2"}
    assert uc.term_groups(term(3, ["inertia"])) == {"acceleration of slider 3"}
    assert uc.term_groups(term(1, ["effortpos"])) == {"effort of slider 1", "position of slider 1"}
    assert uc.term_groups(term(6, ["cross_q"], {"rail[6].force_xj": 2.0})) == {"position of slider 2"}
    assert uc.term_groups(term(6, ["constant"])) == set()
    assert uc.term_groups(term(4, ["ripple", "coulomb_both"])) == {"position of slider 4", "rate of slider 4"}


def test_a_damper_found_as_a_pair_reads_both_rates():
    t = term(4, ["viscous_both", "cross_v"], {"rail[4].force_xj": 5.0}, pair=5)
    assert uc.term_groups(t) == {"rate of slider 4", "rate of slider 5"}


def test_a_term_outside_the_table_reads_a_group_no_declaration_allows():
    assert uc.term_groups(term(2, ["a_new_term"])) == {"an unknown term a_new_term"}
    # a cross term whose shape holds no other joint is not read as a rate of nothing
    assert uc.term_groups(term(2, ["cross_v"])) == {"an unknown term cross_v"}


def test_every_term_of_the_search_has_its_reads():
    assert set(TERMS) <= set(uc.OWN_READS)


def test_a_platform_force_reads_the_pose_and_a_drag_the_rates_too():
    assert uc.platform_groups("cable") == {"the platform pose"}
    assert uc.platform_groups("wrench+drag") == {"the platform pose", "rate of slider 1", "rate of slider 2",
                                                 "rate of slider 3", "rate of slider 4", "rate of slider 5",
                                                 "rate of slider 6"}
    assert "an unknown platform force spring" in uc.platform_groups("spring")


def test_the_discovery_equation_with_the_declared_inputs_passes_where_the_flexible_stage_alone_fails():
    fits = [fit(5, ["rate of slider 4"])]
    reads = {"4": ["rate of slider 4", "rate of slider 5"]}
    assert uc.judge(fits, DAMPER, [4, 5])[0] is False
    assert uc.judge_either(fits, reads, DAMPER, [4, 5]) is True


def test_either_stage_naming_an_input_outside_allowed_refuses():
    fits = [fit(5, ["rate of slider 4"])]
    assert uc.judge_either(fits, {"4": ["rate of slider 4", "rate of slider 5"], "5": ["position of slider 5"]},
                           DAMPER, [4, 5]) is False
    # the flexible stage's outside input refuses too, whatever the discovery reads
    assert uc.judge_either([fit(5, ["history of slider 1"])], {"4": ["rate of slider 4", "rate of slider 5"]},
                           DAMPER, [4, 5]) is False


def test_only_the_cases_channels_count():
    assert uc.judge_either([], {"1": ["rate of slider 4", "rate of slider 5"]}, DAMPER, [4, 5]) is False
    # an unexplained flexible channel names nothing
    assert uc.judge_either([fit(4, ["rate of slider 4", "rate of slider 5"], explained=False)], {}, DAMPER,
                           [4, 5]) is False


def test_a_platform_case_needs_one_of_its_any_groups_on_any_channel():
    key = {"need": set(), "any": {"the platform pose", "position of slider 1"},
           "allowed": {"the platform pose", "position of slider 1", "rate of slider 1"}}
    assert uc.judge_either([], {"3": ["the platform pose"]}, key, None) is True
    assert uc.judge_either([], {"3": ["rate of slider 1"]}, key, None) is False
    assert uc.judge_either([], {}, key, None) is False


def test_stage_reads_keeps_partial_terms_and_stand_ins_apart():
    pair = term(4, ["viscous_both", "cross_v"], {"rail[4].force_xj": 5.0}, pair=5)
    partial = term(5, ["stroke_2"], {"rail[5].force_qc": 0.05}, partial="structure left")
    drift = NS(param="rail[1].viscous", kind="trend")
    d = diagnosis([pair, partial], drifts=[drift], unexplained=[{"channel": "tau5"}])
    got = uc.stage_reads(d)
    assert got["confident"] == {"4": ["rate of slider 4", "rate of slider 5"]}
    assert got["with_partial"] == {"1": ["time"], "4": ["rate of slider 4", "rate of slider 5"],
                                   "5": ["position of slider 5", "rate of slider 5"]}


def test_a_platform_force_and_a_platform_drift_reach_every_channel_where_nothing_is_left():
    d = diagnosis(platform=NS(family="cable"), drifts=[NS(param="platform.m", kind="step")])
    got = uc.stage_reads(d, n=3)
    want = {"1": ["the platform pose", "time"], "2": ["the platform pose", "time"], "3": ["the platform pose", "time"]}
    assert got["confident"] == want and got["with_partial"] == want


def test_the_table_counts_both_judgements_and_keeps_the_flexible_line():
    row = {"case": "coupling_damper_54704", "kind": "coupling_damper", "seed": 54704, "joint": [4, 5],
           "library_confident": [], "discovered": [], "unexplained": [], "platform": "", "drifts": [],
           "size_over_noise": 27.3, "size_channel": 4, "named": {"tau5": ["rate of slider 4"]}, "inputs_right": False,
           "share": 0.87, "gain": 46.5, "cpu": 4.4,
           "stage_reads": {"confident": {}, "with_partial": {"4": ["rate of slider 4", "rate of slider 5"]}},
           "either_right": {"confident": False, "with_partial": True}}
    lines = uc.table([row], ("coupling_damper",))
    assert any(line.startswith("library effect named with confidence: 0/1; flexible stage names the keyed-on "
                               "inputs: 0/1;") for line in lines)
    assert ("modelled as declared by either stage: 0/1 with the discovery's confident terms, 1/1 with its partial "
            "ones too") in lines
    assert "no / yes (reads rate of slider 4, rate of slider 5) |" in lines[2]


def test_the_flexible_mujoco_bench_judges_its_truth_on_the_rails_channel_by_either_stage():
    import flexible_mujoco_bench as fmb

    # a cross-joint position (rail 2's position on rail 4): the flexible stage names nothing on tau4,
    # the discovery's cross term on slider 4 reads slider 2's position
    cross = term(4, ["cross_q"], {"rail[4].force_xj": 2.0})
    row = {"kind": "cross_position", "joint": 4, "truth_inputs": ["position of slider 2"],
           "stage_reads": uc.stage_reads(diagnosis([cross]))}
    got = fmb.either(dict(row), [fit(4, [], explained=False), fit(2, ["position of slider 2"])])["either_right"]
    assert got == {"confident": True, "with_partial": True}
    # the declaration is the truth exactly: a partial drift on slider 4 reads time, outside it
    drift = NS(param="rail[4].viscous", kind="trend")
    row["stage_reads"] = uc.stage_reads(diagnosis([cross], drifts=[drift], unexplained=[{"channel": "tau4"}]))
    got = fmb.either(dict(row), [fit(4, ["position of slider 2"])])["either_right"]
    assert got == {"confident": True, "with_partial": False}
    # the flexible stage's heating named on its rate alone: its history is needed
    heat = {"kind": "heating", "joint": 3, "truth_inputs": ["rate of slider 3", "history of slider 3"],
            "stage_reads": {"confident": {}, "with_partial": {}}}
    assert fmb.either(heat, [fit(3, ["rate of slider 3"])])["either_right"]["confident"] is False


def test_the_flexible_mujoco_bench_prints_the_either_line_where_the_rows_kept_the_diagnosis():
    import flexible_mujoco_bench as fmb

    rows = [{"kind": "heating", "inputs_ok": False, "share_ok": True, "cpu": 4.0,
             "either_right": {"confident": True, "with_partial": False}},
            {"kind": "cross_position", "inputs_ok": True, "share_ok": True, "cpu": 5.0},
            {"kind": "clean", "claims": [], "cpu": 3.0}]
    lines = fmb.summary(rows, 12000, 1)
    assert lines[0].startswith("MuJoCo, base 12000: inputs right 1 of 2, shares within 10 points 2 of 2")
    assert lines[1] == ("modelled as declared by either stage: 1/1 with the discovery's confident terms, 0/1 with "
                        "its partial ones too (1 of 2 rows without the whole diagnosis)")
    assert fmb.summary([rows[1], rows[2]], 12000, 1)[1:] == []  # a replay of a capture without stage_reads
