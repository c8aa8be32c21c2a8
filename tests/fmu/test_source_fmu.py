"""The source-code FMUs (build/fmu/source/<ID>.fmu, fmu/source_fmu.cmake): FMPy validates them,
FMPy's own source-FMU build (fmpy.util.compile_platform_binary, gcc with "-I." only) compiles
one on this machine, and the binary it makes gives the binary FMU's trajectory."""
import os
import shutil
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.util import compile_platform_binary
from fmpy.validation import validate_fmu

from cosim import fmu
from cosim.core import Model


def source_fmu(robot):
    p = fmu.build_dir() / "fmu" / "source" / f"{fmu.fmu_id(robot)}.fmu"
    assert p.exists(), f"{p} is missing: the build makes a source-code FMU of every FMU"
    return p


@pytest.mark.parametrize("robot", ["6pus", "PKM_6PUS_CTRL", "hexapod_ups"])
def test_source_fmu_validates_and_lists_its_sources(robot):
    path = source_fmu(robot)
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    binary = read_model_description(str(fmu.fmu_path(robot)))
    assert md.guid == binary.guid  # the same model as the binary FMU
    files = md.buildConfigurations[0].sourceFileSets[0].sourceFiles
    names = set(zipfile.ZipFile(path).namelist())
    assert files and all(f"sources/{f}" in names for f in files)
    assert "sources/buildDescription.xml" in names and "sources/CMakeLists.txt" in names
    assert not any(n.startswith("binaries/") for n in names)


# A `gcc` first on PATH for FMPy's build: its one "gcc -c OPTIONS SOURCES..." call made one
# gcc call per source with the same options, run side by side on the machine's cores (the
# objects are those of the single call), each through ccache where it is installed (as the
# build's compiles are, scripts/bootstrap.sh: an object compiled before from the same
# preprocessed source, options and compiler is reused, any change compiles again); any other
# call (the link) is gcc's own.
PARALLEL_GCC = """#!{python}
import os, subprocess, sys
from concurrent.futures import ThreadPoolExecutor
GCC, CCACHE, args = {gcc!r}, {ccache!r}, sys.argv[1:]
sources = [a for a in args if a.endswith((".c", ".cc", ".cpp")) and os.path.isfile(a)]
if "-c" not in args or len(sources) < 2:
    os.execv(GCC, [GCC, *args])
options = [a for a in args if a not in sources]
compile_ = [CCACHE, GCC] if CCACHE else [GCC]
with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
    codes = list(pool.map(lambda s: subprocess.call([*compile_, *options, s]), sources))
sys.exit(next((c for c in codes if c), 0))
"""


def test_fmpy_compiles_the_source_fmu_and_it_runs_like_the_binary(tmp_path, monkeypatch):
    """FMPy's gcc build (no optimisation: its default options; its sources compiled side by
    side, through ccache where installed, PARALLEL_GCC), then 0.1 s of Co-Simulation under
    efforts near the gravity load: the same pose as the build's binary to 1e-12 m."""
    shim = tmp_path / "bin" / "gcc"
    shim.parent.mkdir()
    shim.write_text(PARALLEL_GCC.format(python=sys.executable, gcc=shutil.which("gcc"),
                                        ccache=shutil.which("ccache")))
    shim.chmod(0o755)
    monkeypatch.setenv("PATH", f"{shim.parent}{os.pathsep}{os.environ['PATH']}")
    out = tmp_path / "PKM_6PUS_compiled.fmu"
    compile_platform_binary(str(source_fmu("6pus")), output_filename=str(out))
    assert "binaries/linux64/PKM_6PUS.so" in zipfile.ZipFile(out).namelist()
    m = Model("6pus")
    tau = m.gravity_load(m.home()) + 0.05
    start = {f"tau[{i + 1}]": float(v) for i, v in enumerate(tau)}
    runs = [simulate_fmu(str(p), fmi_type="CoSimulation", stop_time=0.1, output_interval=1e-3,
                         start_values=start, output=list(m.facts.pose_names))
            for p in (out, fmu.fmu_path("6pus"))]
    got, ref = ([np.array([r[n] for n in m.facts.pose_names]) for r in runs])
    assert np.max(np.abs(ref[:, -1] - ref[:, 0])) > 1e-4  # it moved
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
