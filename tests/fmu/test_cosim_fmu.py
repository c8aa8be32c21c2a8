"""``cosim fmu``: a robot's FMUs for the platforms asked for, for a listed robot or a
description file anywhere (its FMUs made in a tree of their own and copied into the build
directory, the checkout untouched, no other FMU of the build removed or replaced while they
build, two description files at once), and a scenario whose robot is a file run with
``--plant fmu``.  The module leaves the build directory as it found it (fixture
``build_restored``)."""
import json
import shutil
import subprocess
import sys
import threading
import time
import tomllib
import zipfile
from pathlib import Path

import numpy as np
import pytest
from continuous_axis import continuous_pendulum

from cosim import fmu

REPO = Path(__file__).resolve().parents[2]
# the FMUs made here of description files leave the build directory afterwards (tests/conftest.py)
FMUS_MADE = ("PKM_MY_PENDULUM", "PKM_MY_STEWART")
pytestmark = pytest.mark.usefixtures("build_restored")


def cosim(*args):
    return subprocess.run([sys.executable, "-m", "cosim", *args], capture_output=True, text=True, cwd=REPO)


def platforms_in(path):
    return {n.split("/")[1] for n in zipfile.ZipFile(path).namelist()
            if n.startswith("binaries/") and n.count("/") == 2 and not n.endswith("/")}


def test_listed_robot_with_the_platforms_asked_for(tmp_path):
    r = cosim("fmu", "6pus", "--platforms", "linux64,win64", "--source", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["PKM_6PUS.fmu", "PKM_6PUS_CTRL.fmu", "PKM_6PUS_CTRL_sources.fmu", "PKM_6PUS_sources.fmu"]
    assert platforms_in(tmp_path / "PKM_6PUS.fmu") == {"linux64", "win64"}
    assert platforms_in(tmp_path / "PKM_6PUS_CTRL.fmu") == {"linux64", "win64"}
    assert fmu.validate(tmp_path / "PKM_6PUS.fmu") == []


def test_fmi3_with_the_platforms_asked_for(tmp_path):
    r = cosim("fmu", "6pus", "--fmi", "3", "--platforms", "linux64,aarch64-linux", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["PKM_6PUS.fmu", "PKM_6PUS_CTRL.fmu"]
    for name in ("PKM_6PUS.fmu", "PKM_6PUS_CTRL.fmu"):
        assert platforms_in(tmp_path / name) == {"x86_64-linux", "aarch64-linux"}
        assert 'fmiVersion="3.0"' in zipfile.ZipFile(tmp_path / name).read("modelDescription.xml").decode()
        assert fmu.validate(tmp_path / name) == []


def test_a_mistake_in_the_description_file_is_one_line_and_exit_2(tmp_path):
    """The file's line, before anything is built (no tree made for it)."""
    desc = tmp_path / "my_broken.toml"
    desc.write_text('title = "broken"\n[robot\n')
    r = cosim("fmu", str(desc), "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and f"{desc}:2: table header not closed" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (fmu.build_dir() / "fmu_descriptions" / "PKM_MY_BROKEN").exists()


@pytest.mark.parametrize("args, says", [
    (["--fmi", "3", "--source"], "FMI 3: the source-code FMUs are FMI 2.0 only"),
    (["--platforms", "darwin64"], "unknown platform 'darwin64'"),
])
def test_what_cannot_be_made_is_one_line_and_exit_2(tmp_path, args, says):
    r = cosim("fmu", "6pus", *args, "--out", str(tmp_path))
    assert r.returncode == 2 and says in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def _fmus_of_the_build(b):
    """The FMUs the build directory holds of the robots it lists (every ``.fmu`` under
    ``fmu/``, FMI 2.0, FMI 3.0 and source-code, but those the tests make of description
    files), and its ``CMakeCache.txt``: path -> (inode, mtime)."""
    files = [p for p in (b / "fmu").rglob("*.fmu") if not p.name.startswith("PKM_MY_")]
    files.append(b / "CMakeCache.txt")
    return {p: (p.stat().st_ino, p.stat().st_mtime_ns) for p in files}


class _Watch(threading.Thread):
    """Polls files every 5 ms while it runs: ``events`` lists each one found missing or
    replaced (another inode or mtime) against ``files`` (path -> (inode, mtime))."""

    def __init__(self, files):
        super().__init__(daemon=True)
        self.files, self.events, self.stop = files, [], threading.Event()

    def run(self):
        while not self.stop.is_set():
            for p, seen in self.files.items():
                try:
                    st = p.stat()
                    now = (st.st_ino, st.st_mtime_ns)
                except FileNotFoundError:
                    now = None
                if now != seen and (p, now) not in self.events:
                    self.events.append((p, now))
            time.sleep(0.005)


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Two description files outside the repository made into FMUs by two ``cosim fmu`` at
    once, while every other FMU of the build directory is watched: ``my_pendulum.toml`` (the
    pendulum made a continuous axis without gravity) for linux64, ``my_stewart.toml`` (the
    bundled hexapod under another name) for the three platforms."""
    d = tmp_path_factory.mktemp("mine")
    mine = continuous_pendulum(d, "my_pendulum")
    mine.write_text(mine.read_text().replace("vector = [0.0, 0.0, -9.81]", "vector = [0.0, 0.0, 0.0]"))
    shutil.copyfile(REPO / "robots" / "hexapod_ups.toml", d / "my_stewart.toml")
    runs = {"my_pendulum": "linux64", "my_stewart": "linux64,win64,aarch64-linux"}
    status = subprocess.run(["git", "status", "--porcelain"], capture_output=True, text=True, cwd=REPO).stdout
    others = _fmus_of_the_build(fmu.build_dir())
    assert any(p.parent.name == "fmi3" for p in others), "no FMI 3.0 FMU in the build to watch"
    watch = _Watch(others)
    watch.start()
    try:
        procs = {name: subprocess.Popen([sys.executable, "-m", "cosim", "fmu", str(d / f"{name}.toml"), "--platforms",
                                         platforms, "--out", str(d / name)], cwd=REPO, text=True,
                                        stdout=subprocess.PIPE, stderr=subprocess.PIPE)
                 for name, platforms in runs.items()}
        results = {name: (p.wait(), p.stdout.read(), p.stderr.read()) for name, p in procs.items()}
    finally:
        watch.stop.set()
        watch.join()
    after = subprocess.run(["git", "status", "--porcelain"], capture_output=True, text=True, cwd=REPO).stdout
    return {"dir": d, "results": results, "events": watch.events, "others": others,
            "status": (status, after)}


def test_two_description_files_at_once_leave_every_other_fmu_in_place(made):
    """Both runs succeed, and no FMU of another robot (nor the build's CMakeCache.txt) was
    removed or replaced at any moment while they ran."""
    for name, (rc, out, err) in made["results"].items():
        assert rc == 0, (name, err)
    assert [(str(p), what) for p, what in made["events"]] == []
    assert _fmus_of_the_build(fmu.build_dir()) == made["others"]


def test_a_description_files_fmu_for_linux64_only(made):
    """``cosim fmu my.toml --platforms linux64`` builds its FMUs for linux64 only.  Its FMU
    spins the pendulum past 100 rad on the closed form q = tau t^2 / (2 M), M = m l^2 + I."""
    from fmpy import read_model_description, simulate_fmu

    plant = made["dir"] / "my_pendulum" / "PKM_MY_PENDULUM.fmu"
    assert platforms_in(plant) == {"linux64"}
    assert platforms_in(fmu.fmu_path("PKM_MY_PENDULUM")) == {"linux64"}  # no other platform was built for it
    (tau_name,) = [v.name for v in read_model_description(str(plant)).modelVariables if v.causality == "input"]
    (q_name,) = [v.name for v in read_model_description(str(plant)).modelVariables if v.name.startswith("q[")]
    r = simulate_fmu(str(plant), stop_time=10.0, output_interval=0.5, start_values={tau_name: 0.6},
                     output=[q_name])
    M = 1.0 * 0.5**2 + 1e-4
    np.testing.assert_allclose(r[q_name], 0.6 * r["time"] ** 2 / (2 * M), rtol=1e-6, atol=1e-9)
    assert r[q_name][-1] > 100


def test_description_file_anywhere(made):
    out = made["dir"] / "my_stewart"
    plant = out / "PKM_MY_STEWART.fmu"
    assert platforms_in(plant) == {"linux64", "win64", "aarch64-linux"}
    assert fmu.validate(plant) == []
    assert "resources/my_stewart.toml" in zipfile.ZipFile(plant).namelist()
    assert (out / "PKM_MY_STEWART_CTRL.fmu").exists()
    before, after = made["status"]
    assert after == before  # nothing in the checkout changed


def test_scenario_of_a_description_file_runs_with_the_fmu_plant(made, tmp_path):
    spec = tomllib.loads((REPO / "scenarios" / "described" / "hexapod_ups_step_pd.toml").read_text())
    text = (REPO / "scenarios" / "described" / "hexapod_ups_step_pd.toml").read_text()
    text = text.replace(f'robot = "{spec["robot"]}"', f'robot = "{made["dir"] / "my_stewart.toml"}"')
    sc = tmp_path / "mine.toml"
    sc.write_text(text)
    runs = {}
    for plant in ("fmu", "core"):
        r = cosim("run", str(sc), "--plant", plant, "--duration", "0.1", "--no-figures", "--json",
                  "--out", str(tmp_path / plant))
        assert r.returncode == 0, r.stderr
        runs[plant] = json.loads(r.stdout)
    assert runs["fmu"]["plant"]["kind"] == "fmu"
    assert "PKM_MY_STEWART.fmu" in json.dumps(runs["fmu"]["plant"])


def test_files_of_a_description_file_are_named_by_its_stem(tmp_path):
    """``my_delta_viscous_3.csv``, not ``my_delta.toml_viscous_3.csv``."""
    desc = tmp_path / "my_delta.toml"
    shutil.copyfile(REPO / "robots" / "linear_delta.toml", desc)
    r = cosim("blind-case", "--robot", str(desc), "--effect", "viscous", "--seed", "3", "--out", str(tmp_path / "cases"),
              "--keys", str(tmp_path / "keys"))
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "cases").iterdir() if p.suffix == ".csv") == ["my_delta_viscous_3.csv"]
