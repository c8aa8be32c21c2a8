"""The Quattro map tiles and the blind cases as sweep kinds."""
import numpy as np
import pytest

from cosim.sweep import run_sweep, spec_from_dict

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def test_quattro_tiles_join_into_the_map_of_one_core_call(client, tmp_path):
    from cosim.quattro import BETTER, index_map

    axes = {"x": {"min": -0.4, "max": 0.4, "n": 7}, "y": {"min": -0.3, "max": 0.3, "n": 5},
            "z": {"min": -1.2, "max": -0.8, "n": 9}}
    spec = spec_from_dict({"kind": "quattro_tile", "base": {"param_set": "appendix_a", "tiles": 3, **axes}},
                          name="qmap")
    assert [c.params for c in spec.case_list()] == [{"tile": 0}, {"tile": 1}, {"tile": 2}]
    res = run_sweep(spec, out=tmp_path, client=client, progress=False)
    # np.array_split: 3 + 2 + 2 x values
    assert len(res.ok) == 3 and [r["x_from"] for r in res.rows] == pytest.approx([-0.4, 0.0, 0.4 / 1.5], abs=1e-12)
    ref = index_map(np.linspace(-0.4, 0.4, 7), np.linspace(-0.3, 0.3, 5), np.linspace(-1.2, -0.8, 9),
                    param_set="appendix_a")
    joined = np.load(tmp_path / "quattro_map.npz")
    assert np.array_equal(joined["x"], ref.x) and np.array_equal(joined["status"], ref.status)
    for name in ref.names():
        assert np.array_equal(joined[name], ref[name], equal_nan=True), name
    # the summary's best pose of an index is the whole map's
    best = ref.argbest("mu_T")
    line = next(s for s in res.summary.splitlines() if s.strip().startswith("mu_T "))
    v = np.nanmax(ref["mu_T"]) if BETTER["mu_T"] == "max" else np.nanmin(ref["mu_T"])
    assert f"{v:.6g}" in line and f"{best[2]:.4g}" in line
    assert sum(r["reachable"] for r in res.rows) == int(np.sum(ref.status == 0))


def test_quattro_tile_errors_are_case_errors(tmp_path):
    spec = spec_from_dict({"kind": "quattro_tile", "base": {"tiles": 2, "x": [0.0, 0.1], "y": [0.0], "z": [-1.0],
                                                            "indices": ["mu_T", "no_such_index"]},
                           "cases": [{"tile": 0}, {"tile": 5}]}, name="qbad")
    res = run_sweep(spec, out=tmp_path, workers=0, progress=False)
    assert [r["status"] for r in res.rows] == ["error", "error"]
    assert "no_such_index" in res.rows[0]["error"] and "tile 5 out of range" in res.rows[1]["error"]


def test_a_blind_case_is_generated_diagnosed_and_scored(tmp_path):
    spec = spec_from_dict({"kind": "blind", "base": {"general.duration": 2.0},
                           "cases": [{"effects": ["coulomb"], "seed": 3, "controller": "pd_gravity"},
                                     {"effects": ["no_such_effect"], "seed": 3}]}, name="blind")
    res = run_sweep(spec, out=tmp_path, workers=0, progress=False)
    ok, bad = res.rows
    assert ok["status"] == "ok" and ok["hidden"] == "coulomb" and ok["result.controller"] == "pd_gravity"
    # the score compares the diagnosis with the hidden values (the answer key, kept in memory)
    true = np.array([ok[f"true.rail[{i}].coulomb"] for i in range(1, 7)])
    fitted = np.array([ok[f"fitted.rail[{i}].coulomb"] for i in range(1, 7)])
    assert np.all(true > 0)
    assert ok["param_error.coulomb"] == pytest.approx(np.linalg.norm(fitted - true) / np.linalg.norm(true), rel=1e-9)
    assert bad["status"] == "error" and "no_such_effect" in bad["error"]
    assert "effect cases: 1" in res.summary and (tmp_path / "summary.txt").exists()
