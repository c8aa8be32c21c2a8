"""The fourth set of bench/foreign/mujoco_unlisted.py's mechanisms (``--kinds-set 4``,
bench/foreign/mujoco_unlisted_fourth.py), drawn at seeds TEST_SEED + the kind's index (57800 +,
outside the bench's draws 57700 + and the size check's 57750-57769): each kind builds and runs in
MuJoCo and changes the recording; a rail force computed in MuJoCo's step, run along its case's
reference, has the RMS it was drawn to (at most, where a cap on its coefficient binds); the
cushion's air follows the polytropic law; the cord built as a MuJoCo tendon has the length and
tension the draw computed from the reference's geometry; every declaration is well-formed in the
flexible stage's vocabulary and names no kind of the other sets, generators or the library."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import mujoco_blind as mb  # noqa: E402
import mujoco_unlisted as mu  # noqa: E402
import mujoco_unlisted_fourth as fourth  # noqa: E402

from cosim.core import Model  # noqa: E402
from disc_helpers import stage_groups, check_mechanism_acts  # noqa: E402

#: the tests' seeds: TEST_SEED + the kind's index (the bench draws 57700 +; sizes were checked at 57750-57769)
TEST_SEED = 57800
#: the rail forces computed in MuJoCo's step
HOOKED_RAIL = ("end_cushion", "misaligned_nut", "coil_crosstalk", "magnet_heating", "neighbour_heat")


def _case(kind):
    m = Model("6pus")
    seed = TEST_SEED + fourth.KINDS_FOURTH.index(kind)
    mo = mu.motion(m, seed)
    return m, seed, mo, mu.draw(kind, np.random.default_rng(seed), m, mo)


def _other_kinds() -> set:
    from discovery_mujoco_bench import KINDS as DISCOVERY_BENCH
    from mujoco_unnamed import KINDS as UNNAMED

    from cosim.discrepancy.blind.sampling import UNLISTED
    from cosim.discrepancy.effects import LIBRARY
    from cosim.discrepancy.families.generator import KINDS as FAMILY_KINDS
    from cosim.discrepancy.families.products import TERMS
    from cosim.discrepancy.flexible.cases import KINDS as FLEXIBLE

    library = {e.key for e in LIBRARY}
    return (set(mu.KINDS) | set(mu.KINDS_MORE) | set(mu.KINDS_THIRD) | set(UNLISTED) | set(FAMILY_KINDS)
            | set(FLEXIBLE) | set(DISCOVERY_BENCH) | set(UNNAMED) | set(TERMS) | library)


def test_the_fourth_set_is_new_and_every_declaration_names_the_stage_s_inputs():
    assert len(fourth.KINDS_FOURTH) == 10
    assert not set(fourth.KINDS_FOURTH) & _other_kinds()
    assert mu.KIND_SETS[4] == fourth.KINDS_FOURTH
    vocabulary = stage_groups()
    for kind in fourth.KINDS_FOURTH:
        _, _, _, (_, _, truth, key, joint) = _case(kind)
        assert key == mu.keyed(kind, truth.get("rail"), truth.get("other_rail")), kind  # what --replay re-reads
        assert set(key) == {"need", "any", "allowed"}, kind
        assert key["need"] or key["any"], kind  # a declaration that nothing meets judges nothing
        assert key["need"] <= key["allowed"] and key["any"] <= key["allowed"], kind
        assert key["allowed"] <= vocabulary, (kind, key["allowed"] - vocabulary)
        if kind in fourth.PLATFORM_FOURTH:
            assert joint is None and "rail" not in truth, kind
        else:  # a rail's force: its own inputs are named after the rail it acts on
            assert truth["rail"] in (joint if isinstance(joint, tuple) else (joint,)), kind
            assert any(g.endswith(f"slider {truth['rail']}") for g in key["need"] | key["any"]), kind


@pytest.mark.parametrize("kind", HOOKED_RAIL)
def test_a_rail_force_along_its_reference_has_the_rms_it_was_drawn_to(kind):
    """The hook run along the case's reference (the commanded efforts, positions and rates, at the
    recording's 1 ms from its start) gives a force on the drawn rail alone (and, for the coils'
    crosstalk, its reaction on the other) whose RMS is the drawn target, or below it by the cap
    on its coefficient (the crosstalk's 0.5, the magnets' loss 0.25, the nut's mu 0.5); the RMS is
    recomputed here from the hook's output, not read from the draw's own figures.  The nut's
    friction f = -mu w |u| s at the reference's command is made up by the loop, whose command's
    magnitude becomes |u| / (1 - mu w s sign(u)): its target is f / (1 + f / u).  The magnets'
    loss x = -f / u of the command is made up by u x / (1 - x), its target."""
    _, _, mo, (hook, edit, truth, _, joint) = _case(kind)
    assert edit is None
    q = np.asarray(mo["qref"])
    qd = np.gradient(q, mb.DT, axis=0)
    u = np.asarray(mo["u"])
    f = np.array([hook(None, None, 0.5 + i * mb.DT, q[i], qd[i], u[i]) for i in range(len(q))])
    j = truth["rail"] - 1
    if kind == "coil_crosstalk":
        k = truth["other_rail"] - 1
        assert joint == (j + 1, k + 1)
        assert np.array_equal(f[:, k], -f[:, j])  # the reaction on the other coil
        assert np.all(np.delete(f, [j, k], axis=1) == 0.0)
    else:
        assert np.all(np.delete(f, j, axis=1) == 0.0)
    got = float(np.sqrt(np.mean(f[:, j] ** 2)))
    if kind == "misaligned_nut":
        uj = u[:, j]
        made = np.divide(f[:, j], 1 + np.divide(f[:, j], uj, out=np.zeros_like(uj), where=uj != 0))
        got = float(np.sqrt(np.mean(made ** 2)))
    if kind == "magnet_heating":
        x = np.divide(-f[:, j], u[:, j], out=np.zeros(len(u)), where=u[:, j] != 0)
        got = float(np.sqrt(np.mean((u[:, j] * x / (1 - x)) ** 2)))
    capped = {"coil_crosstalk": truth.get("coupling") == 0.5,
              "magnet_heating": truth.get("loss") == pytest.approx(fourth.LOSS),
              "misaligned_nut": truth.get("mu") == pytest.approx(0.5)}.get(kind)
    assert 0.2 * truth["rms_target"] < got < 1.05 * truth["rms_target"], (kind, got, truth)
    if not capped:
        assert got == pytest.approx(truth["rms_target"], rel=0.05), (kind, got, truth)


def test_the_cushion_s_air_is_compressed_polytropically_leaks_and_vents():
    """Pushed in slowly to a depth x of an air column L with no leak, the trapped air's force is
    Fa ((L / (L - x))^1.4 - 1) (p V^1.4 constant); held there it leaks over its time constant,
    and moving out it vents over VENT."""
    Fa, L, x_end, v, dt = 10.0, 0.02, 0.008, 0.01, 1e-5
    F, x = 0.0, 0.0
    while x < x_end - 1e-12:
        x += v * dt
        F = fourth.cushion(F, x, v, dt, Fa, L, 1e12)
    assert F == pytest.approx(Fa * ((L / (L - x)) ** 1.4 - 1), rel=1e-3)
    held = fourth.cushion(F, x, 1e-12, 0.1, Fa, L, 0.1)  # (next to) still: the leak alone
    assert held == pytest.approx(F * math.exp(-1), rel=1e-6)
    assert fourth.cushion(F, x, -v, fourth.VENT, Fa, L, 0.1) == pytest.approx(F * math.exp(-1))
    assert fourth.cushion(F, -1e-3, v, fourth.VENT, Fa, L, 0.1) == pytest.approx(F * math.exp(-1))


def test_the_bundle_s_friction_builds_over_its_twist_and_saturates():
    """The Dahl state's exact step equals many small steps of dg/dpsi = (1 - g sign) / psi_c, and
    a long turn brings it to the turn's sign."""
    g, psi_c = -0.3, 0.002
    for _ in range(10000):
        g += 1e-7 / psi_c * (1 - g)
    assert fourth.dahl(-0.3, 1e-3, psi_c) == pytest.approx(g, rel=1e-4)
    assert fourth.dahl(0.5, -1.0, psi_c) == pytest.approx(-1.0)
    assert fourth.dahl(0.5, 0.0, psi_c) == 0.5


def test_the_coiled_cord_is_a_mujoco_tendon_of_the_draw_s_geometry():
    """MuJoCo's own tendon length at the reference's configurations (the rails' positions and the
    platform's pose of the reference): its spring's tension k (L - rest), with MuJoCo's stiffness
    and rest length, is zero on average and has the drawn RMS."""
    import mujoco

    m, seed, mo, (hook, edit, truth, _, joint) = _case("coiled_cord")
    assert hook is None and joint is None
    xml, _ = mb.case_xml(m, [], np.random.default_rng(seed))
    model = mujoco.MjModel.from_xml_string(edit(xml))
    data = mujoco.MjData(model)
    q0 = np.asarray(m.ik(m.home()))
    free = model.jnt_qposadr[model.body_jntadr[model.body("platform").id]]
    lengths = []
    for i in range(0, len(mo["qref"]), 5):
        for r in range(6):
            data.qpos[model.joint(f"rail{r}").qposadr[0]] = mo["qref"][i][r] - q0[r]
        x = mo["xr"][i]
        data.qpos[free:free + 3] = x[:3]
        quat = np.zeros(4)
        R = (np.asarray(fourth._rotation(np.asarray(x)[None]))[0]).reshape(9)
        mujoco.mju_mat2Quat(quat, R)
        data.qpos[free + 3:free + 7] = quat
        mujoco.mj_forward(model, data)
        lengths.append(float(data.ten_length[model.tendon("cord").id]))
    lengths = np.asarray(lengths)
    cord = model.tendon("cord").id
    k, rest = float(model.tendon_stiffness[cord]), float(np.ravel(model.tendon_lengthspring[cord])[0])
    assert k == pytest.approx(truth["stiffness"], rel=1e-7)
    tension = k * (lengths - rest)  # MuJoCo's spring: its stiffness and rest length as built
    assert abs(tension.mean()) < 0.05 * truth["tension_rms"]
    assert np.sqrt(np.mean(tension ** 2)) == pytest.approx(truth["tension_rms"], rel=0.03)


@pytest.mark.parametrize("kind", fourth.KINDS_FOURTH)
def test_every_kind_builds_runs_in_mujoco_and_changes_the_recording(kind):
    m, seed, _, (hook, edit, _, _, _) = _case(kind)
    duration = 9.0 if kind == "end_cushion" else 2.0  # the cushion is reached over the stroke's last 8-15 %
    check_mechanism_acts(mb, m, seed, hook, edit, duration, kind)
