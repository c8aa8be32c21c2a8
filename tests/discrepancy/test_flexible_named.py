"""A folded fit whose level depends on the joint's own rate holds that rate twice in
``FlexibleFit.inputs`` (the direction, then the level's curve on it): its named inputs, the
report's table and the benches' lists name it once, first (the direction)."""
import sys
from pathlib import Path

from cosim.discrepancy.flexible import report
from cosim.discrepancy.flexible.stage import Dependence, FlexibleFit

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import unlisted_common as uc  # noqa: E402

RATE, POSITION = "rate of slider 5", "position of slider 5"


def _folded_eddy_brake():
    """An eddy-current brake over a zone, sigma c |qd| there, folded: the direction of motion, the
    zone's position and the level's rate (the inputs as the stage builds them for a folded fit)."""
    direction = Dependence(RATE, "direction of motion", 5, "rate", 1.8, "", (-1.0, 1.0), (-0.2, 0.2))
    zone = Dependence(POSITION, "q5", 5, "position", 0.6, "m", (0.1, 0.2), (0.0, 0.3))
    level = Dependence(RATE, "qd5", 5, "rate", 0.4, "m/s", (-0.1, 0.1), (0.1, 0.1))
    return FlexibleFit("tau5", 5, "N", 0.7, 120.0, True, 0.3, 0.01, inputs=(direction, zone, level), folded=True)


def test_the_own_rate_is_named_once_first_for_the_direction():
    fit = _folded_eddy_brake()
    assert [d.group for d in fit.inputs] == [RATE, POSITION, RATE]  # both curves kept
    assert fit.named == (RATE, POSITION)
    assert fit.to_dict()["named"] == [RATE, POSITION]


def test_the_report_table_names_it_once_with_both_importances():
    row = next(line for line in report.markdown([_folded_eddy_brake()], {}) if line.startswith("| tau5"))
    assert row.count(RATE) == 1
    assert f"{RATE} (direction 180 %, level 40 %), {POSITION} (60 %)" in row


def test_the_benches_judgement_lists_it_once():
    key = {"need": {RATE, POSITION}, "any": set(), "allowed": {RATE, POSITION, "history of slider 5"}}
    ok, _, named = uc.judge([_folded_eddy_brake()], key, 5)
    assert ok and named == {"tau5": [RATE, POSITION]}
    assert uc.judge_either([_folded_eddy_brake()], {}, key, 5) is True
