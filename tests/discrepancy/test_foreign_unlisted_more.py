"""The second set of bench/foreign/mujoco_unlisted.py's mechanisms (``--kinds-set 2``,
bench/foreign/mujoco_unlisted_more.py): each kind builds and runs in MuJoCo, its force changes
the recording, and its declaration of the inputs it is keyed on is well-formed in the flexible
stage's own vocabulary; a force on two rails is judged over both rails' channels."""
import sys
import types
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402
import mujoco_unlisted_more as more  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind  # noqa: E402
from disc_helpers import check_declaration, stage_groups  # noqa: E402




def _case(kind):
    m = Model("6pus")
    seed = more.SEED_MORE + more.KINDS_MORE.index(kind)
    return m, seed, mu.draw(kind, np.random.default_rng(seed), m, mu.motion(m, seed))


def test_every_declaration_names_the_stage_s_inputs_and_can_be_met():
    vocabulary = stage_groups()
    assert "the platform pose" in vocabulary and "time" in vocabulary
    for kind in more.KINDS_MORE:
        _, _, (_, _, truth, key, joint) = _case(kind)
        # the pump runs on its own clock: time, not the rail, is what it is keyed on
        check_declaration(kind, key, truth, joint, more.PLATFORM_MORE, vocabulary, own_inputs=kind != "pulse_pump")


@pytest.mark.parametrize("kind", more.KINDS_MORE)
def test_every_kind_builds_runs_in_mujoco_and_changes_the_recording(kind):
    m, seed, (hook, edit, _, _, _) = _case(kind)
    noise = dict(blind.load_config()["noise"]["6pus"])
    noise = {k: (0.0 if np.isscalar(v) else [0.0] * len(v)) for k, v in noise.items()}  # the force alone differs
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, 2.0, noise, hook=hook, edit=edit)
    clean, _ = mb.simulate(m, None, 0.0, 0, seed, 2.0, noise)
    tau, tau0 = np.asarray(rec.tau), np.asarray(clean.tau)
    assert np.isfinite(tau).all() and np.isfinite(np.asarray(rec.q)).all()
    assert tau.shape == tau0.shape
    # [N]: the mechanism acts (a run is deterministic at its seed: a no-op differs by round-off);
    # the snubber's rail passes its threshold within 2 s (not within 1.5 s), and the platform's mass
    # on a spring, driven far below its 4-9 Hz, moves the efforts by 2e-4 N RMS in 1.5 s
    assert np.sqrt(np.mean((tau - tau0) ** 2)) > 1e-5


def test_a_force_on_two_rails_is_judged_over_both_rails_channels():
    key = more.keyed_more("cable_carrier", 2, 1)
    fit = lambda joint, groups: types.SimpleNamespace(  # noqa: E731
        explained=True, joint=joint, channel=f"tau{joint}", share=0.5,
        inputs=[types.SimpleNamespace(group=g) for g in groups], named=tuple(groups))
    fits = [fit(2, ["position of slider 2"]), fit(1, ["position of slider 1"]), fit(4, ["time"])]
    ok, _, named = mu.judge(fits, key, (2, 1))
    assert ok and set(named) == {"tau2", "tau1"}  # rail 4's channel is not the carrier's
    assert not mu.judge(fits[:1], key, (2, 1))[0]  # one position alone is not the difference
    assert not mu.judge(fits, key, None)[0]  # over every channel, time is named where it may not be
