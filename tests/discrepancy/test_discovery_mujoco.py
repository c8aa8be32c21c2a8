"""The discovery step on recordings MuJoCo made with a force no library lists: of the 6-PUS, and
of the linear delta built from its description file.

Four cases of bench/discovery_mujoco_bench.py (which runs eight kinds of hidden force, two
seeds each, and clean runs, per robot): the force is computed at every MuJoCo step from the rail's true
position and rate and applied to the rail's joint, so neither the core nor its joint force
makes it.  The recording is diagnosed blind with the default settings; the truth is compared
afterwards.  Nothing of the engine was tuned on these cases."""
import math
import sys
from pathlib import Path

import numpy as np
import pytest

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import discovery_mujoco_bench as dmb  # noqa: E402
import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402


@pytest.mark.parametrize("kind, seed, coefficient", [
    ("spring", 41, "force_k1"),             # a spring towards the home stroke on one rail
    # friction of another level in each direction: while the rail moves it is the library's Coulomb
    # friction (the mean level) plus a constant offset (half the difference); the two go on trial
    # together against the one discovered force
    ("direction_coulomb", 42, None),
    ("detent", 43, "force_step"),           # a smooth step at a place and width off the search's grid
])
def test_a_force_hidden_in_mujoco_is_named_as_its_equation(tmp_path, kind, seed, coefficient):
    m = Model("6pus")
    duration = 6.0
    force, truth, joints = dmb.draw(kind, np.random.default_rng(seed), dmb.motion(m, seed, duration),
                                    m.ik(m.home()))
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, duration, blind.load_config()["noise"]["6pus"], force=force)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    j = joints[0]
    found = {t.joint: t for t in d.discovered}
    assert set(found) == {j}, (d.conclusion, truth)
    term = found[j]
    got = {p.rsplit(".", 1)[1]: c for p, c in term.coefficients.items()}
    if coefficient is None:  # the larger of the two directions' levels
        cp, cn = truth[f"rail[{j}].force_cpos"], truth[f"rail[{j}].force_cneg"]
        coefficient = "force_cpos" if cp > cn else "force_cneg"
    want = truth[f"rail[{j}].{coefficient}"]
    assert coefficient in got, (term.equation, truth)
    assert abs(got[coefficient].value / want - 1) < 0.15, (term.equation, truth)
    assert abs(got[coefficient].value - want) <= got[coefficient].ci95, (term.equation, truth)  # the stated 95 %
    assert term.heldout_before >= 3 * term.heldout_after, term.equation
    # no library effect named with confidence: any one left is tied with the discovered term
    for e in d.effects:
        assert d.ties(e["key"]), (e["title"], d.conclusion)
    assert "missing physics no library effect names" in d.details
    if kind == "detent":  # the step's place and width are fitted: the truth inside their stated intervals
        for k in ("force_step_q", "force_step_w"):
            name = f"rail[{j}].{k}"
            assert abs(term.shape[name] - truth[name]) <= term.shape_ci95[name], (k, term.equation, truth)
        assert abs(term.shape[f"rail[{j}].force_step_w"] / truth[f"rail[{j}].force_step_w"] - 1) < 0.15, term.equation
    if kind == "spring":  # the rest position is home
        c0 = got["offset"].value if "offset" in got else 0.0
        q0 = term.shape[f"rail[{j}].force_qc"] - c0 / got["force_k1"].value
        assert math.isclose(q0, m.ik(m.home())[j - 1], abs_tol=1e-3), (q0, term.equation)


@pytest.mark.parametrize("kind, seed", [
    ("detent", 307),  # a smooth step of force at a place and width off the search's grid
    # a cubic hardening spring about home on a rail whose effort keeps one sign (it carries
    # gravity): the library's offset and dead zone enter first, nearly cancelling; they are one
    # force there and go on trial together against the term discovered in their place
    ("hardening_spring", 306),
    # quadratic drag: viscous friction and a saturation enter first; the drag alone in their place
    # beats the pair on the held-out part with fewer coefficients, and the pair is withdrawn
    ("drag", 334),
])
def test_a_force_hidden_in_mujoco_built_from_a_description_is_named(tmp_path, kind, seed):
    """Another family: the linear delta (3-P(SS)2), MuJoCo built from its description file by
    bench/foreign/mujoco_described.py (bench/foreign/mujoco_described_blind.py records it as
    the 6-PUS's runs are recorded), a force hidden on one rail: cases of
    ``bench/discovery_mujoco_bench.py --robot linear_delta``."""
    import mujoco_described_blind as mdb

    from cosim.recording import write_recording

    duration = 9.0
    m = Model("linear_delta")
    mo = dmb.motion(m, seed, duration)
    force, truth, joints = dmb.draw(kind, np.random.default_rng(seed), mo, m.ik(m.home()))
    csv, _ = write_recording(tmp_path / "run.csv", mdb.simulate("linear_delta", seed, duration, force=force))
    d = diagnose(csv, figures=False, replay=False)
    s = dmb.score(kind, truth, joints, d, mo)
    assert s["right"], (d.conclusion, truth)
    assert s["errors"] and max(s["errors"]) < 0.15, (s, [t.equation for t in d.discovered], truth)
    assert s["ratio"] >= 3, s
    assert all(s["hits"]), (s, [t.equation for t in d.discovered], truth)  # the stated 95 % intervals
    for e in d.effects:
        assert d.ties(e["key"]), (e["title"], d.conclusion)
