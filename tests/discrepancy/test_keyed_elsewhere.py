"""A library effect whose channel keeps a part keyed on another joint is not named with confidence
(cosim.discrepancy.keyed.elsewhere; docs/discrepancy.md, "Named with confidence only where nothing
is left").

The recording: bench/foreign/mujoco_unlisted.py's rate-coupled friction at its third set's seed
(32707), recorded for 7 s instead of 9 s: a Coulomb friction on rail 4 in proportion to the speed
of rail 2, c |qd2| / V2 tanh(qd4 / v), computed in MuJoCo's step.  Without the rule a friction
that fades at low speed on rail 4 takes the force's mean level and is named with confidence
(nothing is left by the structure test, whose yardstick the same force inflates); the level of
what it fits changes with rail 2's speed, which a friction of rail 4 does not use."""
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.diagnosis import tied  # noqa: E402
from cosim.discrepancy.keyed.elsewhere import KEYED_ELSEWHERE, withheld  # noqa: E402
from cosim.discrepancy.results import FoundEffect  # noqa: E402


def test_a_friction_in_proportion_to_another_rails_speed_is_not_named_a_library_friction(tmp_path):
    m = Model("6pus")
    seed = 32700 + mu.KINDS.index("rate_coupled_friction")
    hook, edit, truth, _, joint = mu.draw("rate_coupled_friction", np.random.default_rng(seed), m,
                                          mu.motion(m, seed))
    assert (joint, truth["other_rail"]) == (4, 2)
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, 7.0, blind.load_config()["noise"]["6pus"], hook=hook, edit=edit)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    assert confident == [], d.conclusion
    marks = [a for e in d.effects if e["joint"] == joint for a in e["lookalikes"] if a["group"] == KEYED_ELSEWHERE]
    assert marks and "qd2" in marks[0]["name"], d.conclusion  # keyed on rail 2's speed, the truth's


def _effect(joint):
    return FoundEffect("coulomb", "Coulomb friction", f"coulomb[{joint}]", f"Coulomb friction, joint {joint}", joint,
                       "friction", {f"rail[{joint}].coulomb": {}}, 50.0, 50.0, "", [])


def _fit(joint, *inputs, explained=True):
    deps = tuple(SimpleNamespace(group=f"{q} of slider {k}", joint=k) for q, k in inputs)
    return SimpleNamespace(joint=joint, channel=f"tau{joint}", explained=explained, share=0.2, inputs=deps)


def test_a_flexible_fit_keyed_on_another_joint_withholds_confidence_and_one_on_the_own_joint_does_not():
    own, other = withheld([_effect(4), _effect(3)], [_fit(4, ("history", 1)), _fit(3, ("rate", 3))], "slider")
    assert own["lookalikes"][0]["group"] == KEYED_ELSEWHERE and tied(own["lookalikes"][0])
    assert "history of slider 1" in own["lookalikes"][0]["name"]
    assert other["lookalikes"] == []  # its own rate: the effect's own shape, not another joint
    # a fit that claims nothing, or the pose / time (joint None), withholds nothing
    assert withheld([_effect(4)], [_fit(4, ("rate", 2), explained=False)])[0]["lookalikes"] == []
    assert withheld([_effect(4)], [_fit(4, ("the platform pose", None))])[0]["lookalikes"] == []
