"""FMUs of the described robots (fmu/described/, docs/robots.md): no code of their own, the
description packed into the binary.  Each must validate in fmpy, name its variables after the
robot's coordinates and units, and integrate like the core's own plant."""
from pathlib import Path

import numpy as np
import pytest

from cosim.core import Model, Simulator

REPO = Path(__file__).resolve().parents[2]
FMU_DIR = REPO / "build" / "fmu"
LISTED = [n.split("#")[0].strip() for n in (REPO / "robots" / "robots.list").read_text().splitlines()]
LISTED = [n for n in LISTED if n]


def fmu_of(name):
    f = FMU_DIR / f"PKM_{name.upper()}.fmu"
    assert f.exists(), f"{f} is missing: cmake builds one FMU per robots/robots.list entry"
    return f


@pytest.mark.parametrize("name", LISTED)
def test_described_fmu_validates_and_names_its_variables_from_the_core(name):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    f = fmu_of(name)
    assert validate_fmu(str(f)) == []
    md = read_model_description(str(f))
    m = Model(name)
    names = {v.name: v for v in md.modelVariables}
    for p, u in zip(m.facts.pose_names, m.facts.pose_units):
        assert names[p].unit == u and names[p + "d"].unit == f"{u}/s" and names[p + "0"].causality == "parameter"
        assert float(names[p + "0"].start) == pytest.approx(m.home()[m.facts.pose_names.index(p)], abs=1e-15)
    for i in range(1, m.ndof + 1):
        assert names[f"tau[{i}]"].unit == m.facts.effort_unit and names[f"q[{i}]"].unit == m.joint_unit
    assert all(k in names for k in m.params())  # every core parameter, by its name
    # the description travels inside the FMU (a copy for the reader in resources/)
    import zipfile

    assert f"resources/{name}.toml" in zipfile.ZipFile(f).namelist()


@pytest.mark.parametrize("name", [n for n in LISTED if n != "6pus"])  # PKM_6PUS (its own table): test_simulate.py
def test_described_fmu_integrates_like_the_core_plant(name, tmp_path):
    """Constant efforts that start the platform from home at 0.1 m/s2 (0.5 rad/s2) along every
    coordinate, 0.2 s: the FMU's pose against the core's Simulator with the same method and
    tolerances, at every communication point."""
    from fmpy import simulate_fmu

    m = Model(name)
    a0 = np.array([0.5 if u == "rad" else 0.1 for u in m.facts.pose_units])
    tau = m.inverse_dynamics(m.home(), np.zeros(m.ndof), a0)
    start = {f"tau[{i + 1}]": float(t) for i, t in enumerate(tau)}
    start.update({"solver.rtol": 1e-10, "solver.atol": 1e-12})
    res = simulate_fmu(str(fmu_of(name)), start_time=0.0, stop_time=0.2, output_interval=0.01,
                       start_values=start, output=list(m.facts.pose_names))
    sim = Simulator(m, method="erk", rtol=1e-10, atol=1e-12)
    sim.reset(0.0, m.home())
    sim.set_input(tau)
    core = []
    for t in res["time"]:
        if t > 0:
            sim.advance(float(t))
        core.append(sim.state[1])
    fmu = np.column_stack([res[p] for p in m.facts.pose_names])
    core = np.array(core)
    assert np.abs(fmu[-1] - fmu[0]).max() > 1e-5  # it moved
    np.testing.assert_allclose(fmu, core, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", LISTED)
def test_described_controller_fmu_validates(name):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu

    f = FMU_DIR / f"PKM_{name.upper()}_CTRL.fmu"
    assert f.exists(), f"{f} is missing: cmake builds a controller FMU per robots/robots.list entry"
    assert validate_fmu(str(f)) == []
    m = Model(name)
    v = {x.name: x for x in read_model_description(str(f)).modelVariables}
    assert v["q[1]"].unit == m.joint_unit and v["tau[1]"].unit == m.facts.effort_unit


def test_a_described_scenario_exports_as_ssp(tmp_path):
    import subprocess
    import sys
    import zipfile

    out = tmp_path / "d.ssp"
    p = subprocess.run([sys.executable, "-m", "cosim", "export-ssp", "scenarios/described/delta_clavel_step_pdg.toml",
                        "--out", str(out)], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    names = zipfile.ZipFile(out).namelist()
    assert any("PKM_DELTA_CLAVEL.fmu" in n for n in names) and any("PKM_DELTA_CLAVEL_CTRL.fmu" in n for n in names)
