"""A mechanism no library effect, term family or platform force names, hidden in MuJoCo's 6-PUS.

One case of bench/foreign/mujoco_unlisted.py (which runs eleven such mechanisms and clean
recordings; docs/records/discovery_unnamed_runs.md has its table), at the bench's seed for the kind, recorded for
6 s instead of 9 s: a seal on one rail whose friction grows with the time since the rail last
reversed, c (1 - exp(-s / tau)) tanh(qd / v), computed in MuJoCo's step from MuJoCo's state.
The truth is outside the library, so the diagnosis must see the force (structure left on the
seal's rail, or a flexible model of it) and name no library effect with confidence (every
library effect it fits has a declared tie, "may stand in"), nor a discovered term as the
physics (every term flagged partial)."""
import sys
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.discrepancy.diagnosis import tied  # noqa: E402


def test_a_seal_whose_friction_grows_after_each_reversal_is_seen_and_not_named_a_library_effect(tmp_path):
    m = Model("6pus")
    seed = mu.SEED + mu.KINDS.index("reversal_seal")
    hook, edit, truth, _, joint = mu.draw("reversal_seal", np.random.default_rng(seed), m, mu.motion(m, seed))
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, 6.0, blind.load_config()["noise"]["6pus"], hook=hook, edit=edit)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    seen = {e["joint"] for e in d.unexplained} | {f.joint for f in d.flexible if f.explained}
    assert joint in seen, (truth, d.conclusion)
    confident = [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]
    assert confident == [], d.conclusion
    assert all(t.partial for t in d.discovered), [t.equation for t in d.discovered]
