"""The third set of bench/foreign/mujoco_unlisted.py's mechanisms (``--kinds-set 3``,
bench/foreign/mujoco_unlisted_third.py): each kind builds and runs in MuJoCo and changes the
recording; a rail force computed in MuJoCo's step, run along its case's reference, has the RMS it
was drawn to (at most, where a cap on its coefficient binds); the damper built as a MuJoCo tendon
pushes the two carriages equally and oppositely; every declaration is well-formed in the flexible
stage's vocabulary."""
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402
import mujoco_unlisted_third as third  # noqa: E402

from cosim.core import Model  # noqa: E402
from disc_helpers import check_declaration, stage_groups, check_mechanism_acts  # noqa: E402

#: the rail forces computed in MuJoCo's step (the others edit MuJoCo's model)
HOOKED_RAIL = ("thrust_ripple", "wiper_debris", "backemf_limit", "brake_window", "shared_bus_sag", "grease_warming")




def _case(kind):
    m = Model("6pus")
    seed = third.SEED_THIRD + third.KINDS_THIRD.index(kind)
    mo = mu.motion(m, seed)
    return m, seed, mo, mu.draw(kind, np.random.default_rng(seed), m, mo)


def test_the_third_set_is_new_and_every_declaration_names_the_stage_s_inputs():
    assert len(third.KINDS_THIRD) == 10
    assert not set(third.KINDS_THIRD) & (set(mu.KINDS) | set(mu.KINDS_MORE))
    assert mu.KIND_SETS[3] == third.KINDS_THIRD
    vocabulary = stage_groups()
    for kind in third.KINDS_THIRD:
        _, _, _, (_, _, truth, key, joint) = _case(kind)
        assert key == mu.keyed(kind, truth.get("rail"), truth.get("other_rail")), kind  # what --replay re-reads
        check_declaration(kind, key, truth, joint, third.PLATFORM_THIRD, vocabulary)


@pytest.mark.parametrize("kind", HOOKED_RAIL)
def test_a_rail_force_along_its_reference_has_the_rms_it_was_drawn_to(kind):
    """The hook run along the case's reference (the commanded efforts, positions and rates, at the
    recording's 1 ms from its start) gives a force on the drawn rail alone whose RMS is the drawn
    target, or below it by the cap on its coefficient (the ripple's 0.3, the sag's 0.5, the
    back-EMF limiter's gain 0.8); the RMS is recomputed here from the hook's output, not read
    from the draw's own figures.  The back-EMF limiter's shortfall at the reference's command,
    s short, is made up by the loop asking e = s (short + e) more: its target is e = s / (1 - s)
    short.  The bus's sag x of the command is made up by u x / (1 - x), its target the RMS of
    that about its mean (an offset)."""
    _, _, mo, (hook, edit, truth, _, joint) = _case(kind)
    assert edit is None
    q = np.asarray(mo["qref"])
    qd = np.gradient(q, mb.DT, axis=0)
    u = np.asarray(mo["u"])
    f = np.array([hook(None, None, third.LEAD + i * mb.DT, q[i], qd[i], u[i]) for i in range(len(q))])
    j = truth["rail"] - 1
    assert np.all(np.delete(f, j, axis=1) == 0.0)
    got = float(np.sqrt(np.mean(f[:, j] ** 2)))
    if kind == "backemf_limit":
        got /= 1.0 - truth["gain"]
    if kind == "shared_bus_sag":
        x = -f[:, j] / u[:, j]
        e = u[:, j] * x / (1 - x)
        got = float(np.sqrt(np.mean((e - e.mean()) ** 2)))
    capped = {"thrust_ripple": truth.get("ripple") == 0.3, "shared_bus_sag": truth.get("sag") == 0.5,
              "backemf_limit": truth.get("gain") == pytest.approx(0.8)}.get(kind, False)
    assert got > 0.2 * truth["rms_target"], (kind, got, truth)
    assert got < 1.1 * truth["rms_target"], (kind, got, truth)
    if not capped:  # the coefficient set for the target: the target to within the step's discretisation
        assert got == pytest.approx(truth["rms_target"], rel=0.05), (kind, got, truth)


def test_the_coupling_damper_is_a_mujoco_tendon_that_pushes_the_two_carriages_oppositely():
    import mujoco

    m, seed, _, (hook, edit, truth, _, joint) = _case("coupling_damper")
    assert hook is None and joint == (truth["rail"], truth["other_rail"])
    xml, _ = mb.case_xml(m, [], np.random.default_rng(seed))
    model = mujoco.MjModel.from_xml_string(edit(xml))
    data = mujoco.MjData(model)
    j, k = (model.joint(f"rail{r - 1}").dofadr[0] for r in joint)
    data.qvel[j], data.qvel[k] = 0.03, -0.01  # [m/s]
    mujoco.mj_forward(model, data)
    c = truth["damping"]
    assert data.qfrc_passive[j] == pytest.approx(-c * 0.04, rel=1e-7)  # c written to 9 digits
    assert data.qfrc_passive[k] == pytest.approx(c * 0.04, rel=1e-7)  # c written to 9 digits


@pytest.mark.parametrize("kind", third.KINDS_THIRD)
def test_every_kind_builds_runs_in_mujoco_and_changes_the_recording(kind):
    m, seed, _, (hook, edit, _, _, _) = _case(kind)
    duration = 6.0 if kind == "brake_window" else 2.0  # the brake's window opens 1.5-5.5 s into the run
    check_mechanism_acts(mb, m, seed, hook, edit, duration, kind)
