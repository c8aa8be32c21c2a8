"""A library effect of the platform's inertia fitted beside a force of the platform's motion through
a resonance is not named with confidence (cosim.discrepancy.keyed.carried; docs/discrepancy.md,
section 4, "Nor beside a body the platform carries on a spring").

The recording: bench/foreign/mujoco_unlisted.py's tuned mass damper (``platform_tmd``) at the seen
seed 62703: 57 g on a spring and damper along a guide in the platform (4.2 Hz, damping ratio 0.076),
its mass taken off the platform's, computed in MuJoCo's step.  Without the rule a platform inertia
error is named with confidence: its fit takes the body's force in phase with the platform's
acceleration and leaves no structure the structure test keys on, while the flexible stage explains
29-63 % of what is left on five channels, each on the platform's motion through a resonance."""
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402
import mujoco_unlisted_more as more  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.diagnosis import tied  # noqa: E402
from cosim.discrepancy.flexible.motion import MOTION  # noqa: E402
from cosim.discrepancy.keyed.carried import CARRIED, withheld_carried  # noqa: E402
from cosim.discrepancy.results import FoundEffect  # noqa: E402


def test_a_body_on_a_spring_in_the_platform_is_not_named_a_platform_inertia(tmp_path):
    m = Model("6pus")
    seed = 62700 + more.KINDS_MORE.index("platform_tmd")
    hook, edit, truth, _, _ = mu.draw("platform_tmd", np.random.default_rng(seed), m, mu.motion(m, seed))
    assert abs(truth["frequency"] - 4.2) < 0.05
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, mu.DURATION, blind.load_config()["noise"]["6pus"],
                         hook=hook, edit=edit)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    assert confident == [], d.conclusion
    inertia = [e for e in d.effects if e["key"] == "platform_inertia"]
    assert inertia and inertia[0]["lookalikes"][0]["group"] == CARRIED, d.conclusion
    assert "tied with a body the platform carries on a spring" in d.conclusion


def _effect(key, joint=None):
    return FoundEffect(key, key.replace("_", " "), key, key.replace("_", " "), joint, "effort", {f"{key}.p": {}},
                       50.0, 50.0, "", [])


def _fit(groups, explained=True, channel="tau2"):
    deps = tuple(SimpleNamespace(group=g, joint=None) for g in groups)
    return SimpleNamespace(channel=channel, joint=int(channel[-1]), explained=explained, share=0.4, inputs=deps)


def test_a_claim_on_the_platforms_motion_ties_the_platforms_inertial_effects_only():
    effects = [_effect("platform_inertia"), _effect("payload"), _effect("platform_mass"), _effect("coulomb", 3),
               _effect("gravity_tilt")]
    marked = withheld_carried(effects, [_fit(["the platform pose"], channel="tau1"), _fit([MOTION])])
    for e in marked[:3]:
        assert e["lookalikes"][0]["group"] == CARRIED and tied(e["lookalikes"][0])
        assert "tau2 40 %" in e["lookalikes"][0]["name"] and "tau1" not in e["lookalikes"][0]["name"]
    assert [e["lookalikes"] for e in marked[3:]] == [[], []]  # a rail's friction, a tilt: not forces of inertia
    assert [a["group"] for a in withheld_carried(marked, [_fit([MOTION])])[0]["lookalikes"]] == [CARRIED]  # once


def test_no_claim_on_the_platforms_motion_withholds_nothing():
    effects = [_effect("platform_inertia")]
    assert withheld_carried(effects, []) == effects
    assert withheld_carried(effects, [_fit([MOTION], explained=False)])[0]["lookalikes"] == []
    assert withheld_carried(effects, [_fit(["the platform pose", "acceleration of slider 2"])])[0]["lookalikes"] == []
