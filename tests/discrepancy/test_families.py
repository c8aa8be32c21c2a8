"""The discovery step's term families (cosim/discrepancy/families/products.py): a force built
from one family, hidden in a blind case by the families' generator (families/generator.py), is
found on its joint with its structure (for a coupling, read from the right other joint) and its
coefficient within 15 %, with no library effect named with confidence; a library effect and a
family's force in one recording are both found.  The truth is read from the answer key after
the diagnosis.  Each case fails without its family (leave-one-family-out: the same recording
diagnosed with its family out of the search): no other term of the search holds its coefficient
(``generator.structure_ok``), and no library effect is named with confidence in its place."""
import json
from pathlib import Path

import pytest

from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.diagnosis import tied
from cosim.discrepancy.families import generator, without

#: one case per family: (kind of the generator, seed)
CASES = [
    ("load_friction", 5),    # Coulomb friction mu |tau| sign(qd) on a rail whose effort keeps one sign
    ("friction_zone", 7),    # a Coulomb level over one side of the stroke, its edge and width fitted
    ("cable_link", 7),       # a force on rail 4 in rail 3's position
    ("effort_position", 11),  # (force_eq z + force_eg) tau: the truth's centre shifts the gain
    ("position_damper", 8),  # z qd: the truth's centre shifts a viscous pair beside it
]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory, short_cfg):
    """The cases' recordings and answer keys, simulated once for the module."""
    tmp = tmp_path_factory.mktemp("families")
    return {(kind, seed): _case(tmp, short_cfg, [kind], seed) for kind, seed in CASES}


def _case(tmp_path, cfg, hidden, seed):
    rec, key = blind.make_case(blind.CaseSpec(f"{'+'.join(hidden)}{seed}", "6pus", hidden, seed), tmp_path / "c",
                               tmp_path / "k", cfg=cfg)
    return rec, json.loads(Path(key).read_text())["effects"]


def _confident(d):
    return [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])]


@pytest.mark.parametrize("kind, seed", CASES)
def test_a_force_of_a_family_is_found_with_its_structure_and_coefficient(recordings, kind, seed):
    rec, (truth,) = recordings[(kind, seed)]
    d = diagnose(rec, figures=False, replay=False)  # the families are searched by default
    found = {t.joint: t for t in d.discovered}
    (j,) = truth["joints"]
    assert j in found, (d.conclusion, truth)
    term = found[j]
    assert generator.structure_ok(kind, term, truth), (term.equation, truth)
    assert generator.coefficient_error(kind, term, truth) < 0.15, (term.equation, truth)
    assert term.heldout_before >= 3 * term.heldout_after, term
    assert set(found) == {j}, d.conclusion
    assert _confident(d) == [], d.conclusion
    # the plant handed on carries the family's core parameters (its coefficient and shape)
    need = generator.NEEDS[kind]
    assert any(k.endswith("." + need) for k in d.plant_parameters()), d.plant_parameters()


@pytest.mark.parametrize("kind, seed", CASES)
def test_without_its_family_a_case_fails_its_structure_check_and_names_no_library_effect(recordings, kind, seed):
    # leave-one-family-out: the case above with its family out of the search.  No other term
    # holds the family's coefficient, so the case's own test fails without the family's rule;
    # and what stands in for the force is no library effect named with confidence
    rec, (truth,) = recordings[(kind, seed)]
    with without(generator.KINDS[kind][0]):
        d = diagnose(rec, figures=False, replay=False)
    term = {t.joint: t for t in d.discovered}.get(truth["joints"][0])
    assert term is None or not generator.structure_ok(kind, term, truth), term.equation
    assert _confident(d) == [], d.conclusion


def test_a_library_friction_and_a_load_dependent_one_on_one_joint_are_both_found(tmp_path, short_cfg):
    # viscous friction (the library's) and mu |tau| sign(qd) (the load family's) on rail 2: the
    # load term's coefficient is right, and the plant's viscous friction (the library's level and
    # a direction pair the discovery step adds to it, ADDS_TO) is the hidden one
    rec, hidden = _case(tmp_path, short_cfg, ["viscous", "load_friction"], 12)
    d = diagnose(rec, figures=False, replay=False)
    visc, load = hidden
    assert visc["joints"] == load["joints"] == [2], hidden
    assert "viscous" in d.named(), d.conclusion
    (term,) = [t for t in d.discovered if t.joint == 2]
    assert generator.structure_ok("load_friction", term, load), term.equation
    assert generator.coefficient_error("load_friction", term, load) < 0.15, (term.equation, load)
    p = d.plant_parameters()
    total = p["rail[2].viscous"] + 0.5 * (p.get("rail[2].force_vpos", 0.0) + p.get("rail[2].force_vneg", 0.0))
    want = visc["params"]["rail[2].viscous"]
    assert abs(total / want - 1) < 0.15, (total, want, d.conclusion)
    assert set(_confident(d)) <= {"viscous"}, d.conclusion


def test_the_command_line_searches_the_families_unless_told_not_to(tmp_path, recordings):
    # `cosim diagnose` searches the families by default: the load-dependent friction of the first
    # case above is found as its family without a flag, and no term of the family with --no-families
    import subprocess
    import sys

    rec, _ = recordings[("load_friction", 5)]
    found = {}
    for flag in ((), ("--no-families",)):
        r = subprocess.run([sys.executable, "-m", "cosim", "diagnose", str(rec), "--no-replay", "--no-figures",
                            "--json", "--out", str(tmp_path / f"out{len(flag)}"), *flag], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
        d = json.loads(r.stdout)
        found[not flag] = {t for term in d["discovered"] for t in term["terms"]}
    assert "load" in found[True], found
    assert "load" not in found[False], found
