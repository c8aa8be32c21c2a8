"""Sweep specs: case expansion, stable ids, random draws, refused specs, overrides,
flattening, the results file and the FMU cache (no cluster here)."""
import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from cosim.sweep import SweepError, SweepSpecError, case_id, flatten, load_spec, materialise_fmu, read_records, \
    spec_from_dict
from cosim.sweep.store import _open_results
from cosim.sweep.kinds import apply_scenario_override

REPO = Path(__file__).resolve().parents[2]


def _spec(**kw):
    d = {"kind": "calibration", "base": {"n_poses": 20}}
    d.update(kw)
    return spec_from_dict(d, name="t")


def test_grid_is_the_cartesian_product_in_order():
    s = _spec(grid={"seed": [1, 2, 3], "tracker_noise": [1e-6, 2e-6]})
    cases = s.case_list()
    assert [c.params for c in cases] == [{"seed": a, "tracker_noise": b} for a in (1, 2, 3) for b in (1e-6, 2e-6)]
    assert [c.index for c in cases] == list(range(6))
    assert len({c.id for c in cases}) == 6


def test_grid_forms_and_explicit_cases():
    s = _spec(grid={"n_poses": {"range": [10, 40, 10]}, "max_length": {"linspace": [1e-4, 3e-4, 3]}},
              cases=[{"n_poses": 3}])
    ps = [c.params for c in s.case_list()]
    assert len(ps) == 3 * 3 + 1
    assert sorted({p["n_poses"] for p in ps[:-1]}) == [10, 20, 30]
    assert [p["max_length"] for p in ps[:3]] == pytest.approx([1e-4, 2e-4, 3e-4], rel=1e-15)
    assert ps[-1] == {"n_poses": 3}
    # explicit cases alone: only them (not an empty grid point besides)
    assert [c.params for c in _spec(cases=[{"seed": 4}, {"seed": 5}]).case_list()] == [{"seed": 4}, {"seed": 5}]


def test_case_id_is_a_hash_of_the_parameters_only():
    a = case_id({"x": 1.5, "y": [1, 2], "name": "a"})
    assert a == case_id({"name": "a", "y": [1, 2], "x": 1.5})  # key order does not matter
    assert a != case_id({"x": 1.5000000000000002, "y": [1, 2], "name": "a"})
    assert len(a) == 16 and int(a, 16) >= 0
    canon = json.dumps({"name": "a", "x": 1.5, "y": [1, 2]}, sort_keys=True, separators=(",", ":"))
    assert a == hashlib.sha256(canon.encode()).hexdigest()[:16]
    # growing a grid keeps the ids of the cases it had (resume runs only the new ones)
    small = {c.id: c.params for c in _spec(grid={"seed": [1, 2]}).case_list()}
    big = {c.id: c.params for c in _spec(grid={"seed": [1, 2, 3]}).case_list()}
    assert set(small) < set(big) and all(big[k] == v for k, v in small.items())


def test_duplicate_cases_run_once():
    s = _spec(grid={"seed": [1, 1, 2]}, cases=[{"seed": 2}])
    assert [c.params for c in s.case_list()] == [{"seed": 1}, {"seed": 2}]


def test_random_draws_are_reproducible_bounded_and_independent_per_parameter():
    r = {"n": 200, "seed": 7, "vary": {"max_length": {"uniform": [1e-4, 5e-4]},
                                         "tracker_noise": {"loguniform": [1e-6, 1e-4]},
                                         "seed": {"integers": [0, 1000]},
                                         "solver": {"choice": ["lm", "gauss-newton"]}}}
    s1, s2 = _spec(random=r).case_list(), _spec(random=r).case_list()
    assert [c.params for c in s1] == [c.params for c in s2]
    ml = np.array([c.params["max_length"] for c in s1])
    tn = np.array([c.params["tracker_noise"] for c in s1])
    sd = [c.params["seed"] for c in s1]
    assert ml.min() >= 1e-4 and ml.max() < 5e-4 and tn.min() >= 1e-6 and tn.max() < 1e-4
    assert all(isinstance(v, int) and 0 <= v < 1000 for v in sd)
    assert {c.params["solver"] for c in s1} == {"lm", "gauss-newton"}
    # log-uniform: about half the draws below the geometric mean 1e-5
    assert 0.35 < np.mean(tn < 1e-5) < 0.65
    # removing one parameter leaves the draws of the others unchanged
    r2 = {**r, "vary": {k: v for k, v in r["vary"].items() if k != "tracker_noise"}}
    assert [c.params["max_length"] for c in _spec(random=r2).case_list()] == list(ml)
    # another seed, other draws
    assert [c.params["max_length"] for c in _spec(random={**r, "seed": 8}).case_list()] != list(ml)


def test_grid_times_random():
    s = _spec(grid={"n_poses": [20, 30]}, random={"n": 3, "seed": 1, "vary": {"seed": {"integers": [0, 10**6]}}})
    cases = s.case_list()
    assert len(cases) == 6
    assert [c.params["seed"] for c in cases[:3]] == [c.params["seed"] for c in cases[3:]]


@pytest.mark.parametrize("d, key", [
    ({"kind": "calibration", "bogus": 1}, "bogus"),
    ({"kind": "nope"}, "kind"),
    ({"kind": "calibration", "grid": {"seed": 3}}, "grid.seed"),
    ({"kind": "calibration", "grid": {"seed": []}}, "grid.seed"),
    ({"kind": "calibration", "grid": {"seed": [1]},
      "random": {"n": 2, "seed": 1, "vary": {"seed": {"uniform": [0, 1]}}}},
     "random.vary.seed"),
    ({"kind": "calibration", "random": {"n": 2, "seed": 1, "vary": {"max_length": {"gauss": [0, 1]}}}},
     "random.vary.max_length"),
    ({"kind": "calibration", "random": {"n": 0, "seed": 1, "vary": {"seed": {"integers": [0, 9]}}}}, "random.n"),
    ({"kind": "calibration", "grid": {"n_pose": [1]}}, "n_pose"),
    ({"kind": "scenario", "base": {"scenario": "scenarios/6pus_step_pd.toml"}, "grid": {"controler.kp": [1.0]}},
     "controler.kp"),
    ({"kind": "scenario", "base": {"scenario": "scenarios/no_such_file.toml"}}, "base.scenario"),
    ({"kind": "scenario", "base": {"scenario": "scenarios/6pus_step_pd.toml"}, "grid": {"fmu.path": ["a.fmu"]}},
     "fmu.path"),
    ({"kind": "function", "base": {"function": "no_colon"}}, "base.function"),
    ({"kind": "calibration", "results": {"include": "steady*"}}, "results.include"),
])
def test_bad_specs_are_refused_naming_the_key(d, key):
    with pytest.raises(SweepSpecError) as e:
        spec_from_dict(d, name="bad")
    assert key in str(e.value) and "sweep bad" in str(e.value)


def test_spec_file_errors_name_the_file(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('kind = "calibration"\n[grid]\nseed = "1"\n')
    with pytest.raises(SweepSpecError, match=f"{p}: grid.seed"):
        load_spec(p)
    p.write_text("kind = \n")
    with pytest.raises(SweepSpecError, match="not valid TOML"):
        load_spec(p)
    with pytest.raises(SweepSpecError, match="not found"):
        load_spec(tmp_path / "missing.toml")


def test_toml_dotted_keys_become_parameter_names(tmp_path):
    p = tmp_path / "s.toml"
    p.write_text('kind = "scenario"\n[base]\nscenario = "%s"\n[grid]\ncontroller.kp = [1.0, 2.0]\n'
                 'plant_scale."platform.m" = [1.1]\n"reference.to[2]" = [0.09]\n'
                 % (REPO / "scenarios" / "6pus_step_pd.toml"))
    s = load_spec(p)
    assert s.param_names() == ["controller.kp", "plant_scale.platform.m", "reference.to[2]"]


def test_scenario_overrides():
    sc = {"duration": 1.0, "controller": {"kp": 1.0}, "reference": {"to": [0, 0, 0.1, 0, 0, 0]}}
    apply_scenario_override(sc, "duration", 0.5)
    apply_scenario_override(sc, "controller.kp", 300.0)
    apply_scenario_override(sc, "plant_scale.platform.m", 1.2)
    apply_scenario_override(sc, "plant_offset.leg[1].L", 3e-4)
    apply_scenario_override(sc, "reference.to[2]", 0.09)
    assert sc["duration"] == 0.5 and sc["controller"]["kp"] == 300.0
    assert sc["plant_scale"] == {"platform.m": 1.2} and sc["plant_offset"] == {"leg[1].L": 3e-4}
    assert sc["reference"]["to"] == [0, 0, 0.09, 0, 0, 0]
    with pytest.raises(KeyError, match="top-level"):
        apply_scenario_override(sc, "kp", 1.0)
    with pytest.raises(KeyError, match="has 6 elements"):
        apply_scenario_override(sc, "reference.to[6]", 1.0)


def test_flatten():
    f = flatten({"a": {"b": np.float64(1.5), "c": [1, 2]}, "d": [{"e": 1}, {"e": 2}], "n": None,
                 "long": list(range(40)), "arr": np.array([[1.0, 2.0]]), "flag": np.bool_(True)})
    assert f == {"a.b": 1.5, "a.c[0]": 1, "a.c[1]": 2, "d[0].e": 1, "d[1].e": 2, "n": None,
                 "long": json.dumps(list(range(40))), "arr[0][0]": 1.0, "arr[0][1]": 2.0, "flag": True}
    assert type(f["a.b"]) is float and type(f["flag"]) is bool


def test_results_file_survives_a_line_cut_short(tmp_path):
    p = tmp_path / "results.jsonl"
    p.write_text('{"case_id": "a", "status": "ok"}\n{"case_id": "b", "status": "ok"}\n{"case_id": "c", "sta')
    assert [r["case_id"] for r in read_records(tmp_path)] == ["a", "b"]
    with _open_results(tmp_path) as f:
        f.write('{"case_id": "c", "status": "ok"}\n')
    assert [r["case_id"] for r in read_records(tmp_path)] == ["a", "b", "c"]
    p.write_text('{"case_id": "a", "status": "ok"}\n{"case_id": \n{"case_id": "c", "status": "ok"}\n')
    with pytest.raises(SweepError, match="line 2"):
        read_records(tmp_path)


def test_fmu_cache_writes_checks_and_repairs(tmp_path, monkeypatch):
    import cosim.sweep.shipping as sw

    monkeypatch.setenv("PKM_SWEEP_FMU_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr(sw, "_FMU_CACHE", {})
    data = b"PK\x03\x04 not really an FMU " * 100
    sha = hashlib.sha256(data).hexdigest()
    p = materialise_fmu(sha, "X.fmu", data)
    assert p == tmp_path / "cache" / sha[:16] / "X.fmu" and p.read_bytes() == data
    assert materialise_fmu(sha, "X.fmu", None) == p  # cached in this process: no bytes needed
    monkeypatch.setattr(sw, "_FMU_CACHE", {})
    p.write_bytes(data[:50])  # a damaged copy (a killed writer) is rewritten
    assert materialise_fmu(sha, "X.fmu", data).read_bytes() == data
    monkeypatch.setattr(sw, "_FMU_CACHE", {})
    with pytest.raises(SweepError, match="do not match"):
        materialise_fmu("0" * 64, "Y.fmu", data)
    with pytest.raises(SweepError, match="not on this worker"):
        materialise_fmu("1" * 64, "Z.fmu", None)
    assert not list((tmp_path / "cache").rglob("*.part"))


def test_shipped_sweep_specs_load():
    files = sorted((REPO / "scenarios" / "sweeps").glob("*.toml"))
    assert len(files) >= 4
    kinds = set()
    for f in files:
        s = load_spec(f)
        kinds.add(s.kind)
        assert s.case_list(), f
    assert {"scenario", "calibration", "blind", "quattro_tile"} <= kinds
