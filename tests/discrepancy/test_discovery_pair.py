"""A damper or a spring between two joints (cosim/discrepancy/discovery/pair.py): hidden by the
families' generator (``pair_damper``: c (qd_j - qd_k) against joint j, c (qd_k - qd_j) against
joint k; ``pair_spring``: k (q_j - q_k - L) against joint j, its opposite against joint k), it is
found as one pair term on both joints with c or k within 5 % (and the spring's rest difference L),
stated once, and the plant handed on holds it on both joints; a library offset the spring pair
refits to zero is withdrawn.  The truth is read from the answer key after the diagnosis.  Without
the pair rule the per-channel search reports no pair term, and without the withdrawal the offset
stays named (each checked by reverting the rule)."""
import json
from pathlib import Path

from cosim.discrepancy import blind, diagnose


def test_a_damper_between_two_joints_is_found_once_as_a_pair(tmp_path, short_cfg):
    rec, key = blind.make_case(blind.CaseSpec("pair_damper3", "6pus", ["pair_damper"], 3), tmp_path / "c",
                               tmp_path / "k", cfg=short_cfg)
    (truth,) = json.loads(Path(key).read_text())["effects"]
    j, k = truth["joints"]
    c_true = truth["params"][f"rail[{j}].force_vpos"]
    d = diagnose(rec, figures=False, replay=False)
    pairs = [t for t in d.discovered if t.pair]
    assert {(t.joint, t.pair) for t in pairs} == {(j, k), (k, j)}, d.conclusion
    for t in pairs:
        xv = t.coefficients[f"rail[{t.joint}].force_xv"].value
        assert abs(-xv / c_true - 1.0) < 0.05, (t.equation, c_true)
    assert (d.conclusion + d.details).count(pairs[0].equation) == 1, d.details  # stated once
    p = d.plant_parameters()
    for a, b in ((j, k), (k, j)):
        assert p[f"rail[{a}].force_xj"] == b
        assert abs(p[f"rail[{a}].force_vpos"] + p[f"rail[{a}].force_xv"]) < 1e-9 * c_true


def test_a_spring_between_two_joints_is_found_once_as_a_pair(tmp_path, short_cfg):
    # the families' generator's pair_spring: k (q_j - q_k - L) against joint j, its opposite on
    # k; the pair states k and the rest difference L (lower joint first) once, and the plant
    # handed on holds it on both joints (k1 = k, xk1 = -k, xqc = qc -+ L)
    rec, key = blind.make_case(blind.CaseSpec("pair_spring3", "6pus", ["pair_spring"], 3), tmp_path / "c",
                               tmp_path / "k", cfg=short_cfg)
    (truth,) = json.loads(Path(key).read_text())["effects"]
    j, k = truth["joints"]
    p_true = truth["params"]
    k_true = p_true[f"rail[{j}].force_k1"]
    rest_true = p_true[f"rail[{j}].force_qc"] - p_true[f"rail[{j}].force_xqc"]  # q_j - q_k at rest
    if j > k:
        j, k, rest_true = k, j, -rest_true
    d = diagnose(rec, figures=False, replay=False)
    pairs = [t for t in d.discovered if t.pair]
    assert {(t.joint, t.pair) for t in pairs} == {(j, k), (k, j)}, d.conclusion
    assert all(t.terms == ["spring", "cross_q"] for t in pairs), [t.terms for t in pairs]
    for t in pairs:
        assert abs(t.coefficients[f"rail[{t.joint}].force_k1"].value / k_true - 1.0) < 0.05, (t.equation, k_true)
    assert (d.conclusion + d.details).count(pairs[0].equation) == 1, d.details  # stated once
    p = d.plant_parameters()
    stiff = p[f"rail[{j}].force_k1"]
    rest = p[f"rail[{j}].force_qc"] - p[f"rail[{j}].force_xqc"]
    assert abs(rest - rest_true) < 0.05 * abs(rest_true) + 1e-5, (rest, rest_true)
    assert abs(p[f"rail[{k}].force_xqc"] - p[f"rail[{k}].force_qc"] - rest) < 1e-12
    for a, b in ((j, k), (k, j)):
        assert p[f"rail[{a}].force_xj"] == b
        assert p[f"rail[{a}].force_k1"] == stiff and p[f"rail[{a}].force_xk1"] == -stiff


def test_a_library_offset_the_spring_pair_refits_to_zero_is_withdrawn(tmp_path, short_cfg):
    # seed 5: the library names an offset on one of the two joints (the spring's constant, before
    # the pair); refitted with the pair it is zero within its interval, and is withdrawn
    rec, key = blind.make_case(blind.CaseSpec("pair_spring5", "6pus", ["pair_spring"], 5), tmp_path / "c",
                               tmp_path / "k", cfg=short_cfg)
    (truth,) = json.loads(Path(key).read_text())["effects"]
    d = diagnose(rec, figures=False, replay=False)
    assert {t.joint for t in d.discovered if t.pair} == set(truth["joints"]), d.conclusion
    zeroed = [w for w in d.withdrawn if "refitted" in w and w["group"].startswith("offset")]
    assert zeroed and all(abs(w["refitted"]["value"]) <= w["refitted"]["ci95"] for w in zeroed), d.withdrawn
    assert not any(e["key"] == "offset" for e in d.effects), d.conclusion
