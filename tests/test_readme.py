"""Every Python example of the README runs verbatim, and so do its cheap shell commands.

The blocks run in order in one fresh interpreter, from the repository root, after the
README's own command that writes the recording the last example reads.  Long-running
commands (the demo, benchmarks, sweeps, blind benchmarks) are tested by their own tests
and are not run here; the shell lines run are listed in CHEAP."""
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
README = (REPO / "README.md").read_text()

# shell commands of the README that take seconds (each is run as written, with the venv's cosim)
CHEAP = [".venv/bin/cosim run scenarios/6pus_step_pd.toml", ".venv/bin/cosim params 6pus",
         ".venv/bin/cosim params quattro --set appendix_a", ".venv/bin/cosim params emps --set reference",
         ".venv/bin/cosim export-ssp scenarios/6pus_step_pdg.toml --out out/6pus_step_pdg.ssp",
         ".venv/bin/cosim view results/6pus_step_pd/6pus_step_pd.csv",
         ".venv/bin/cosim import data/emps/DATA_EMPS.mat --map data/emps/emps_map.toml --out out/emps"]


def _blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", README, flags=re.S)


def test_the_cheap_readme_commands_are_in_the_readme_and_run():
    shell = "\n".join(_blocks("bash"))
    for cmd in CHEAP:
        assert cmd in shell, f"{cmd!r} is no longer in the README: update CHEAP"
        p = subprocess.run(cmd, shell=True, cwd=REPO, capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, f"{cmd}: {p.stderr[-1000:]}"


def _my_robot(tmp_path):
    """The README's "Describe your own robot" file, written where its examples can read it."""
    toml = next(b for b in _blocks("toml") if 'name = "my_delta"' in b)
    f = tmp_path / "my_delta.toml"
    f.write_text(toml)
    return f


def test_the_readme_robot_description_loads_and_lists_its_parameters(tmp_path):
    f = _my_robot(tmp_path)
    shell = "\n".join(_blocks("bash"))
    assert ".venv/bin/cosim params my_delta.toml" in shell
    p = subprocess.run([sys.executable, "-m", "cosim", "params", str(f)], cwd=REPO, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 0, p.stderr
    assert "rail[1].coulomb" in p.stdout and "leg[3].L" in p.stdout


def test_every_python_block_of_the_readme_runs(tmp_path):
    blocks = _blocks("python")
    assert len(blocks) >= 4
    subprocess.run(CHEAP[0], shell=True, cwd=REPO, check=True, capture_output=True, timeout=300)
    code = "\n".join(blocks).replace('"my_delta.toml"', repr(str(_my_robot(tmp_path))))
    p = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    assert "compiled" in p.stdout  # the closed-loop example says which loop ran


def test_the_fmpy_one_liner_runs_and_explains_its_number():
    one = next(b for b in _blocks("bash") if "simulate_fmu" in b)
    p = subprocess.run(one.replace(".venv/bin/python", sys.executable, 1), shell=True, cwd=REPO,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr[-1000:]
    assert re.search(r"z = \d+\.\d+ mm", p.stdout), p.stdout
