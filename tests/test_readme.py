"""Every command of the README and of the tour it links to (docs/guide.md) runs verbatim from a
fresh clone.

The tracked files are copied into an empty folder (a clone without ``results/`` or
``out/``), with the checkout's ``.venv`` and ``build`` linked in (what
``scripts/bootstrap.sh`` makes).  There every shell block of the README runs, line by line
in one bash per block (so that an ``export`` holds for the lines after it), in the README's
order and then the tour's (a one-line command both give, the same but for its comment, runs
the first time only: the second is the first's result), then every Python block, in order,
in one interpreter.  A file a command needs is shipped or written by an earlier README
command; the description the README asks to save as ``my_delta.toml`` is saved there first.

A few commands are not run here, each for the reason given in NOT_RUN (minutes of work, or
the whole test suite), and a benchmark runs with options appended that make it small
(SMALLER); the test fails when one of them leaves the README (the lists cannot go stale)
and when the README gains a command that neither runs nor is listed."""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
# ``cosim fmu my_delta.toml`` makes PKM_MY_DELTA in the build directory: removed afterwards (conftest.py)
FMUS_MADE = ("PKM_MY_DELTA",)
pytestmark = pytest.mark.usefixtures("build_restored")
# the README, then the tour: one document, in the order a reader meets it
PAGES = ("README.md", "docs/guide.md")
README = "\n".join((REPO / p).read_text() for p in PAGES)

# the commands not run here: what they are, and where the same code runs in the suite
NOT_RUN = {
    "./scripts/demo.sh": "the set-up, then `cosim demo` (tests/scenario/test_scenario_files.py::test_cosim_demo)",
    "./scripts/test.sh": "the set-up, then the whole test suite this test is part of",
    ".venv/bin/cosim blind-benchmark --cases 45": "minutes (tests/discrepancy: the blind benchmark on a few cases)",
    ".venv/bin/cosim blind-benchmark --cases 48": "minutes (tests/discrepancy: the held-out benchmark on a few cases)",
    ".venv/bin/python bench/foreign/mujoco_blind.py": "a benchmark of minutes (tests/discrepancy/test_foreign_mujoco.py)",
    ".venv/bin/python bench/foreign/mujoco_rate_noise.py": "a benchmark of minutes (tests/discrepancy)",
    ".venv/bin/python bench/foreign/drake_blind.py": "a benchmark of minutes (tests/discrepancy/test_foreign_drake.py)",
    ".venv/bin/python bench/foreign/drake_unlisted.py": "a benchmark of minutes (tests/discrepancy/"
                                                        "test_foreign_drake.py runs a hook on Drake against MuJoCo)",
    ".venv/bin/python bench/long_recording.py": "a benchmark of minutes (tests/discrepancy/test_long_recording.py)",
    ".venv/bin/python bench/discovery_mujoco_bench.py": "a benchmark of minutes "
                                                        "(tests/discrepancy/test_discovery_mujoco.py)",
    ".venv/bin/python bench/coverage_bench.py": "a benchmark of minutes (tests/discrepancy/test_coverage.py)",
    ".venv/bin/cosim sweep scenarios/sweeps/blind_benchmark.toml --scheduler": "needs a scheduler the user started, "
                                                                              "and minutes (tests/sweep/test_dask.py)",
    ".venv/bin/cosim sweep --bench": "a benchmark of minutes (tests/sweep)",
    ".venv/bin/cosim sweep scenarios/sweeps/calibration_noise.toml": "minutes; the runner and the LocalCluster of the "
                                                                     "pd_gains lines, which run (tests/sweep)",
    ".venv/bin/cosim quattro map": "a minute of figures (tests/quattro/test_quattro_cli.py draws the map)",
    ".venv/bin/cosim quattro cycle": "minutes of cycle fits (tests/quattro/test_cycle_time.py)",
    "xdg-open": "opens a browser on the page the line before wrote (tests/report draws such pages headless)",
}

# benchmarks run here as the README writes them, with options appended that make them small
# (argparse keeps an option's last value; an option the script does not take fails the run):
# the command (the first key it starts with), the options and why
SMALLER = {
    ".venv/bin/python bench/discovery_bench.py --hold-out": ("--robots 6pus --kinds viscous --seeds 1",
                                                             "36 blind diagnoses, one per library type, robot and "
                                                             "seed, minutes (tests/discrepancy/"
                                                             "test_discovery_held_out.py checks what they measure)"),
    ".venv/bin/python bench/discovery_bench.py": ("--robots 6pus --kinds drag --seeds 1 --clean 1",
                                                  "48 blind diagnoses, minutes (tests/discrepancy/test_discovery.py "
                                                  "checks what they measure)"),
}


def _blocks(lang):
    return re.findall(rf"```{lang}\n(.*?)```", README, flags=re.S)


def _commands(block):
    """The block's commands: lines, a double-quoted argument spanning lines kept whole."""
    out, cur = [], ""
    for line in block.splitlines():
        cur = f"{cur}\n{line}" if cur else line
        if cur.count('"') % 2 == 0:
            if cur.strip() and not cur.lstrip().startswith("#"):
                out.append(cur)
            cur = ""
    return out


def _skipped(cmd):
    return next((k for k in NOT_RUN if cmd.startswith(k)), None)


def _as_run(cmd):
    """The command as this test runs it: the README's, with SMALLER's options appended
    (before its comment)."""
    k = next((k for k in SMALLER if cmd.startswith(k)), None)
    if k is None:
        return cmd
    line, hash_, comment = cmd.partition(" #")
    return f"{line.rstrip()} {SMALLER[k][0]}" + (f"  #{comment}" if hash_ else "")


def _same(cmd):
    """What a one-line command runs, its comment left out (two commands with one value do the
    same); a command of several lines is itself."""
    return cmd if "\n" in cmd or '"' in cmd or "'" in cmd else _as_run(cmd).partition(" #")[0].strip()


@pytest.fixture(scope="module")
def clone(tmp_path_factory):
    """A fresh clone where every README command has run: (folder, [(command, result)])."""
    root = tmp_path_factory.mktemp("clone")
    files = subprocess.run(["git", "ls-files", "-z"], cwd=REPO, capture_output=True, text=True, check=True)
    for f in filter(None, files.stdout.split("\0")):
        if (REPO / f).is_file():
            (root / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(REPO / f, root / f)
    for d in (".venv", "build"):
        (root / d).symlink_to(REPO / d)
    toml = next(b for b in _blocks("toml") if 'name = "my_delta"' in b)
    (root / "my_delta.toml").write_text(toml)  # "Save this as my_delta.toml"
    env = {**os.environ, "TQDM_DISABLE": "1", "MPLBACKEND": "Agg"}
    env.pop("PKM_LIB", None)
    ran, passed = [], {}  # passed: what a command that exited 0 printed, by _same(command)
    for block in _blocks("bash"):
        cmds = [c for c in _commands(block) if not _skipped(c)]
        # a command the README and the tour both give runs once: the second time it is the
        # first's result (in a block that exports nothing, it does the same in the same clone)
        exports = any(c.lstrip().startswith("export ") for c in cmds)
        todo = [i for i, c in enumerate(cmds) if exports or _same(c) not in passed]
        p, done = None, []
        if todo:
            # one bash per block, stopping at the first failure; each command echoed first
            script = "set -e\n" + "\n".join(f"echo '>>> {i}' >&2\n{_as_run(cmds[i])}" for i in todo)
            p = subprocess.run(["bash", "-c", script], cwd=root, capture_output=True, text=True, env=env, timeout=900)
            done = [int(m) for m in re.findall(r"^>>> (\d+)$", p.stderr, flags=re.M)]
        for i, c in enumerate(cmds):
            if i not in todo:
                ran.append((c, 0, passed[_same(c)]))
                continue
            failed = p.returncode != 0 and done and i == done[-1]
            status = p if failed else (None if done and i > done[-1] else 0)
            ran.append((c, status, p.stdout))
            if status == 0 and not exports:
                passed.setdefault(_same(c), p.stdout)
    return root, ran


def test_every_readme_command_runs_verbatim_from_a_fresh_clone(clone):
    _, ran = clone
    bad = [f"{c}\n  exit {r.returncode}: {r.stderr[-1500:]}" for c, r, _ in ran if r not in (0, None)]
    bad += [f"{c}\n  not run: an earlier command of its block failed" for c, r, _ in ran if r is None]
    assert not bad, "\n".join(bad)
    assert len(ran) >= 30


def test_the_commands_not_run_are_in_the_readme_and_every_other_command_ran(clone):
    _, ran = clone
    every = [c for b in _blocks("bash") for c in _commands(b)]
    for k in NOT_RUN:
        assert any(c.startswith(k) for c in every), f"{k!r} is no longer in the README: update NOT_RUN"
    for k in SMALLER:
        assert any(c.startswith(k) for c in every), f"{k!r} is no longer in the README: update SMALLER"
    assert {c for c, _, _ in ran} == {c for c in every if not _skipped(c)}


def test_the_commands_write_what_the_readme_says(clone):
    root, _ = clone
    for f in ("results/6pus_step_pd/6pus_step_pd.csv", "results/6pus_step_pd/6pus_step_pd_view.html",
              "out/6pus_step_pdg.ssp", "out/slider_crank/slider_crank_campaign.csv", "out/diagnosis/report.md",
              "out/diagnosis/report.html", "out/diagnosis.png", "out/6pus.json", "results/pd/results.csv"):
        assert (root / f).is_file(), f


def test_every_python_block_of_the_readme_runs(clone):
    root, _ = clone
    blocks = _blocks("python")
    assert len(blocks) >= 6
    p = subprocess.run([sys.executable, "-c", "\n".join(blocks)], cwd=root, capture_output=True, text=True,
                       timeout=600, env={**os.environ, "MPLBACKEND": "Agg"})
    assert p.returncode == 0, p.stderr[-3000:]
    assert "compiled" in p.stdout  # the closed-loop example says which loop ran
    assert "stribeck" in p.stdout.lower()  # the diagnosis example names the hidden effect


def test_the_fmpy_one_liner_explains_its_number(clone):
    _, ran = clone
    status, out = next((r, out) for c, r, out in ran if "simulate_fmu" in c)
    assert status == 0 and re.search(r"z = \d+\.\d+ mm", out), out
