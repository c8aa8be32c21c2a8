"""modelDescription.xml: valid, generated from the same table as the C value references,
and carrying the core's parameter table (names, units, descriptions, defaults) unchanged."""
import ctypes
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from cosim import fmu
from cosim._native import lib, pkm_sim_options

REPO = Path(__file__).resolve().parents[2]


def test_fmpy_validation_reports_no_problem(fmu_file):
    assert fmu.validate(fmu_file) == []


def test_core_parameters_are_fmu_parameters(fmu_file, model):
    md = read_model_description(str(fmu_file))
    by_name = {v.name: v for v in md.modelVariables}
    info = model.param_info()
    assert len(info) > 50
    for p in info:
        v = by_name[p.name]
        assert v.causality == "parameter" and v.variability == "fixed", p.name
        assert float(v.start) == p.value, p.name
        assert (v.unit or "") == ("" if p.unit in ("", "1", "-") else p.unit), p.name
        assert v.description == p.description, p.name


def test_initial_state_and_solver_starts_come_from_the_core(fmu_file, model):
    md = read_model_description(str(fmu_file))
    start = {v.name: v.start for v in md.modelVariables}
    names = fmu.variable_names(md)
    np.testing.assert_array_equal([float(start[n]) for n in names["x0"]], model.home())
    assert [float(start[n]) for n in names["xd0"]] == [0.0] * 6
    d = pkm_sim_options()
    lib.pkm_sim_default_options(ctypes.byref(d))
    assert float(start["solver.rtol"]) == d.rtol and float(start["solver.atol"]) == d.atol
    assert int(start["solver.method"]) == d.method and int(start["solver.maxSteps"]) == d.max_steps
    assert float(start["solver.singMin"]) == d.sing_min


def test_states_and_derivatives(fmu_file):
    md = read_model_description(str(fmu_file))
    names = fmu.variable_names(md)
    assert names["x"] == ["x", "y", "z", "rx", "ry", "rz"]
    assert names["xd"] == ["xd", "yd", "zd", "rxd", "ryd", "rzd"]
    assert names["xdd"] == ["xdd", "ydd", "zdd", "rxdd", "rydd", "rzdd"]
    assert md.numberOfEventIndicators == 13  # singularity margin + 2 stroke limits per leg


def test_value_references_match_the_generated_header(fmu_file):
    md = read_model_description(str(fmu_file))
    header = (fmu.build_dir() / "fmu" / "gen" / "PKM_6PUS" / "fmu_vars.h").read_text()
    rows = dict((name, int(vr)) for vr, name in re.findall(r'\{(\d+)u, "([^"]+)"', header))
    assert rows == {v.name: v.valueReference for v in md.modelVariables}
    assert f'#define FMU_GUID "{md.guid}"' in header


def _fmu_gen():
    exe = fmu.build_dir() / "bin" / "fmu_gen"
    assert exe.exists(), f"{exe} is not built"
    return exe


@pytest.mark.parametrize("edit, message", [
    (lambda s: s.replace("output    | zdd ", "#"), "accel[2] is missing"),
    (lambda s: s.replace("@joint-limits core", "@joint-limits rail[{i}].qmin rail[{i}].qtop"),
     "no parameter 'rail[1].qtop'"),
    (lambda s: s.replace("| twist[0]  |", "| pose[0]   |"), "pose[0] used twice"),
    (lambda s: s.replace("| q         |", "| qq        |"), "unknown channel 'qq'"),
])
def test_generator_rejects_an_inconsistent_table(tmp_path, edit, message):
    table = tmp_path / "variables.txt"
    table.write_text(edit((REPO / "fmu/sixpus/variables.txt").read_text()))
    r = subprocess.run([str(_fmu_gen()), str(table), str(tmp_path / "md.xml"), str(tmp_path / "v.h")],
                       capture_output=True, text=True)
    assert r.returncode == 1
    assert message in r.stderr and str(table) in r.stderr, r.stderr
    assert not (tmp_path / "md.xml").exists()


def test_joint_limits_come_from_the_core_and_a_robot_without_them_gets_no_limit_events(tmp_path):
    # "@joint-limits core" reads pkm_model_joint_limits: the 6-PUS header lists rail[i].qmin /
    # .qmax (checked above through the 13 event indicators); the toy slider-crank declares none
    # (a crank turns without limit, like a continuous axis), so the line adds no limit event: the
    # same model description as the table without it (its one event indicator, the singularity).
    exe = fmu.build_dir() / "bin" / "fmu_gen_toy"
    assert exe.exists(), f"{exe} is not built"
    src = REPO / "c_core/tests/robots/slider_crank_fmu/variables.txt"
    table = tmp_path / "variables.txt"
    table.write_text(src.read_text().replace("@paramset    default", "@paramset    default\n@joint-limits core"))
    assert "@joint-limits core" in table.read_text()
    for t, d in ((table, tmp_path / "with"), (src, tmp_path / "without")):
        d.mkdir()
        r = subprocess.run([str(exe), str(t), str(d / "md.xml"), str(d / "v.h")], capture_output=True, text=True)
        assert r.returncode == 0, r.stderr
    with_line = (tmp_path / "with" / "md.xml").read_text()
    assert 'numberOfEventIndicators="1"' in with_line
    assert with_line == (tmp_path / "without" / "md.xml").read_text()


def test_generator_is_deterministic(tmp_path):
    out = []
    for k in range(2):
        d = tmp_path / str(k)
        d.mkdir()
        subprocess.run([str(_fmu_gen()), str(REPO / "fmu/sixpus/variables.txt"), str(d / "md.xml"),
                        str(d / "v.h")], check=True)
        out.append((d / "md.xml").read_text() + (d / "v.h").read_text())
    assert out[0] == out[1]
    # ... and it is what the build packed (same GUID).
    built = (fmu.build_dir() / "fmu" / "PKM_6PUS" / "modelDescription.xml").read_text()
    assert built == (tmp_path / "0" / "md.xml").read_text()
