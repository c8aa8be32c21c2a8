"""Sweeps on a LocalCluster of 2 worker processes: the same numbers as the serial loop,
failing cases recorded with their parameters, the FMU shipped to the workers."""
import csv
import hashlib
import math
import shutil

import pytest

from cosim.sweep import SweepError, run_sweep, spec_from_dict

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

TIMING = ("seconds", "worker")


def _numbers_equal(a, b):
    """Rows of two runs: same cases, same status and the same value in every column but
    the timing ones (wall times differ from run to run)."""
    assert [r["case_id"] for r in a] == [r["case_id"] for r in b]
    n = 0
    for ra, rb in zip(a, b):
        keys = {k for k in ra if k not in TIMING and not k.endswith("wall_time") and not k.endswith("seconds")
                and k != "plant.fmu"}
        assert keys == {k for k in rb if k not in TIMING and not k.endswith("wall_time")
                        and not k.endswith("seconds") and k != "plant.fmu"}
        for k in keys:
            va, vb = ra[k], rb[k]
            if isinstance(va, float) and math.isnan(va):
                assert isinstance(vb, float) and math.isnan(vb), k
            else:
                assert va == vb, (ra["case_id"], k, va, vb)
            n += 1
    return n


def test_calibration_trials_on_two_workers_equal_the_serial_loop(client, tmp_path):
    spec = spec_from_dict({"kind": "calibration", "base": {"n_poses": 24, "validation_poses": 30},
                           "grid": {"seed": [1, 2, 3], "robot": ["6pus", "fourbar"]}}, name="cal")
    serial = run_sweep(spec, out=tmp_path / "serial", workers=0, progress=False)
    dask = run_sweep(spec, out=tmp_path / "dask", client=client, progress=False)
    assert serial.cluster == "serial" and "2 workers" in dask.cluster
    assert len(serial.ok) == len(dask.ok) == 6
    assert _numbers_equal(serial.rows, dask.rows) > 6 * 15
    # the cases really ran in the two worker processes, not here
    workers = {r["worker"] for r in dask.rows}
    assert len(workers) == 2 and serial.rows[0]["worker"] not in workers
    # and the figures are those of a calibration: large gain on the true robot
    assert all(r["truth.gain"] > 5 for r in dask.rows)


def test_scenario_runs_on_two_workers_equal_the_serial_loop(client, tmp_path):
    spec = spec_from_dict({"kind": "scenario",
                           "base": {"scenario": "scenarios/6pus_step_pdg.toml", "duration": 0.03, "plant": "core"},
                           "grid": {"controller.kp": [200.0, 400.0], "plant_scale.platform.m": [1.0, 1.3]},
                           "results": {"exclude": ["predicted_step_info*"]}}, name="scen")
    serial = run_sweep(spec, out=tmp_path / "serial", workers=0, progress=False)
    dask = run_sweep(spec, out=tmp_path / "dask", client=client, progress=False)
    assert len(dask.ok) == 4
    assert _numbers_equal(serial.rows, dask.rows) > 4 * 50
    # the varied parameters reached the runs
    assert [r["plant_parameters.platform.m"] for r in dask.rows] == pytest.approx([0.35, 0.455, 0.35, 0.455])
    assert [r["result.controller.kp"] for r in dask.rows] == [200.0, 200.0, 400.0, 400.0]
    assert not any(k.startswith("predicted_step_info") for k in dask.rows[0])


def test_a_failing_case_is_reported_with_its_parameters_and_the_others_kept(client, tmp_path):
    spec = spec_from_dict({
        "kind": "scenario",
        "base": {"scenario": "scenarios/6pus_step_pdg.toml", "duration": 0.02},
        "grid": {"controller.kp": [300.0, 600.0]},
        "cases": [{"reference.to": [0.0, 0.0, 0.30, 0.0, 0.0, 0.0]}],   # out of every leg's reach
        "results": {"include": ["steady_state.*"]}}, name="fail")
    res = run_sweep(spec, out=tmp_path / "out", client=client, progress=False)
    assert res.pending == 0 and len(res.rows) == 3
    assert [r["status"] for r in res.rows] == ["ok", "ok", "error"]
    bad = res.failed[0]
    assert bad["reference.to"] == [0.0, 0.0, 0.30, 0.0, 0.0, 0.0] and bad["index"] == 2
    assert bad["error_type"] == "MasterError"
    assert "leg 1 cannot reach pose" in bad["error"] and "0.3" in bad["error"]
    assert "FAILED case 2" in res.text() and "leg 1 cannot reach" in res.text()
    # the table on disk has the failed case with its parameters and message
    rows = list(csv.DictReader(open(res.files["table"])))
    assert [r["status"] for r in rows] == ["ok", "ok", "error"]
    assert rows[2]["reference.to"] == "[0.0, 0.0, 0.3, 0.0, 0.0, 0.0]" and "cannot reach" in rows[2]["error"]
    assert rows[0]["steady_state.joint_error_max"] != "" and rows[2]["steady_state.joint_error_max"] == ""


def test_the_fmu_is_shipped_to_the_workers_and_instantiated_there(client, tmp_path, fmu_cache):
    from cosim.fmu import fmu_path

    # a copy the workers are never told about: they get its bytes, keyed by checksum
    src = tmp_path / "driver_only" / "PKM_6PUS.fmu"
    src.parent.mkdir()
    shutil.copy(fmu_path("6pus"), src)
    sha = hashlib.sha256(src.read_bytes()).hexdigest()
    spec = spec_from_dict({"kind": "scenario",
                           "base": {"scenario": "scenarios/6pus_step_pdg.toml", "duration": 0.02, "plant": "fmu",
                                    "fmu.path": str(src)},
                           "grid": {"controller.kp": [250.0, 500.0]},
                           "results": {"include": ["steady_state.*", "plant.*"]}}, name="fmu")
    serial = run_sweep(spec, out=tmp_path / "serial", workers=0, progress=False)
    dask = run_sweep(spec, out=tmp_path / "dask", client=client, progress=False)
    assert len(dask.ok) == 2, dask.text()
    shipped = fmu_cache / sha[:16] / "PKM_6PUS.fmu"
    assert shipped.exists() and hashlib.sha256(shipped.read_bytes()).hexdigest() == sha
    assert {r["plant.fmu"] for r in dask.rows} == {str(shipped)}
    assert {r["plant.fmu"] for r in serial.rows} == {str(src.resolve())}
    assert all(r["plant.kind"] == "fmu" for r in dask.rows)
    assert _numbers_equal(serial.rows, dask.rows) > 2 * 20


def test_an_existing_scheduler_by_address(cluster, tmp_path):
    _, local = cluster
    spec = spec_from_dict({"kind": "function", "base": {"function": "sweep_testfns:product", "b": 3},
                           "grid": {"a": [1, 2, 5]}}, name="addr")
    res = run_sweep(spec, out=tmp_path / "out", scheduler=local.scheduler_address, progress=False)
    assert res.cluster.startswith(f"scheduler {local.scheduler_address}")
    assert [r["y"] for r in res.rows] == [3, 6, 15]
    assert [r["nested.list[0]"] for r in res.rows] == [1, 2, 5]


def test_results_of_another_spec_are_not_mixed(client, tmp_path):
    d = {"kind": "function", "base": {"function": "sweep_testfns:product", "b": 3}, "grid": {"a": [1, 2]}}
    run_sweep(spec_from_dict(d, name="x"), out=tmp_path, workers=0, progress=False)
    with pytest.raises(SweepError, match="already holds results"):
        run_sweep(spec_from_dict(d, name="x"), out=tmp_path, workers=0, progress=False)
    d2 = {**d, "base": {**d["base"], "b": 4}}
    with pytest.raises(SweepError, match="another kind or base"):
        run_sweep(spec_from_dict(d2, name="x"), out=tmp_path, workers=0, resume=True, progress=False)
    res = run_sweep(spec_from_dict(d2, name="x"), out=tmp_path, client=client, overwrite=True, progress=False)
    assert [r["y"] for r in res.rows] == [4, 8] and res.ran == 2
