"""ctrl-C (SIGINT): the compiled loop stops within 0.2 s keeping its samples; `cosim run`,
`cosim diagnose` and `cosim sweep` exit with 130, one line on stderr and no traceback (the
Dask workers included), and leave what they had done readable: a run its recording up to the
interruption, a sweep its results file and table."""
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.core import Model
from cosim.closed_loop import LoopInterrupted
from cosim.master import CorePlant, make_reference, run
from cosim.recording import read_recording

REPO = Path(__file__).resolve().parents[2]
SCEN = REPO / "scenarios"
#: first lines of every command started here: ctrl-C as a terminal's foreground process gets it
#: (a suite started in the background by a shell without job control runs with SIGINT ignored,
#: and its children inherit that)
AS_IN_A_TERMINAL = "import signal\nsignal.signal(signal.SIGINT, signal.default_int_handler)\n"


@pytest.fixture(autouse=True)
def _sigint_as_in_a_terminal():
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, old)


def test_the_compiled_loop_stops_within_0_2_s_of_the_signal_and_keeps_its_samples(monkeypatch):
    import cosim.closed_loop as cl

    m = Model("6pus")
    ref = make_reference(m, tr.step(m.home(), m.home() + [0, 0, 0.01, 0, 0, 0]), duration=200.0)
    sent, started, finished = {}, threading.Event(), threading.Event()
    call = cl.closed_loop_call

    def observed(*a, **k):  # the loop's C call, watched to know when the loop runs
        started.set()
        return call(*a, **k)

    monkeypatch.setattr(cl, "closed_loop_call", observed)

    def interrupt():
        started.wait(60)
        time.sleep(0.3)
        if not finished.is_set():
            sent["t"] = time.perf_counter()
            os.kill(os.getpid(), signal.SIGINT)

    threading.Thread(target=interrupt, daemon=True).start()
    with pytest.raises(LoopInterrupted) as e:
        try:
            run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), ref)
        finally:
            finished.set()
    latency = time.perf_counter() - sent["t"]
    part = e.value.partial
    assert part.loop == "compiled"
    assert 2 < len(part) < len(ref.time), len(part)  # stopped inside the loop
    assert latency < 0.2, f"{latency:.3f} s from the signal to the exception"
    assert np.all(np.isfinite(part["q"])) and np.all(np.isfinite(part["tau_applied"]))
    # the samples kept are the ones an uninterrupted run gives
    short = run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30),
                make_reference(m, tr.step(m.home(), m.home() + [0, 0, 0.01, 0, 0, 0]), duration=0.5))
    np.testing.assert_array_equal(part["q"][:len(short)], short["q"])


def _cosim(args):
    """`cosim ARGS` in a process that says "ready" once its imports are done (the package's
    and the libraries' the commands load), so that the signal lands in the command's work,
    not in Python's start-up."""
    code = (AS_IN_A_TERMINAL
            + "import importlib, sys\nm = importlib.import_module('cosim.cli.main')\nm._load_plugins()\n"
            "import cosim.scenario, cosim.discrepancy, cosim.sweep.runner, cosim.fmu, control, fmpy, distributed\nprint('ready', flush=True)\n"
            f"sys.exit(m.main({list(args)!r}))")
    return subprocess.Popen([sys.executable, "-c", code], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env={**os.environ, "TQDM_DISABLE": "1"}, start_new_session=True)


def _interrupt(p, when):
    """Wait for "ready", then for ``when()`` (polled), send SIGINT to the process group;
    (exit code, stdout, stderr)."""
    assert p.stdout.readline().strip() == "ready"
    t0 = time.monotonic()
    while not when() and time.monotonic() - t0 < 120 and p.poll() is None:
        time.sleep(0.05)
    assert p.poll() is None, "the command ended before the signal"
    os.killpg(p.pid, signal.SIGINT)  # as ctrl-C in a terminal: to the command and every process it started
    out, err = p.communicate(timeout=120)
    return p.returncode, out, err


def _one_line(err):
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err[-2000:]
    return err.strip().splitlines()[-1]


def test_run_interrupted_keeps_its_recording_up_to_then(tmp_path):
    # the FMU plant runs the Python loop (about a tenth of a millisecond per step): 120 s
    # of motion take more than ten seconds, and the signal comes 3 s after the start
    sc = tmp_path / "long.toml"
    sc.write_text((SCEN / "6pus_step_pd.toml").read_text().replace("duration = 2.0", "duration = 120.0")
                  .replace('plant = "core"', 'plant = "fmu"'))
    out = tmp_path / "out"
    p = _cosim(["run", str(sc), "--out", str(out), "--no-figures"])
    start = []
    rc, _, err = _interrupt(p, lambda: start.append(time.monotonic()) or time.monotonic() - start[0] > 3.0)
    line = _one_line(err)
    assert rc == 130, err
    assert line.startswith("cosim run: interrupted at t = ") and f"partial results in {out}" in line, line
    t_stop = float(line.split("t = ")[1].split(" s")[0])
    csv = out / "6pus_step_pd.csv"  # the scenario's name
    assert f"partial results in {csv} (" in line
    rec = read_recording(csv)
    assert 0 < rec.time[-1] < 120.0 and rec.time[-1] == pytest.approx(t_stop, abs=1e-3)
    assert np.all(np.diff(rec.time) > 0) and np.all(np.isfinite(rec.q))
    assert not (out / "6pus_step_pd_metrics.json").exists()  # no metrics of a run that did not end
    assert "interrupted at t =" in json.loads(csv.with_suffix(".json").read_text())["notes"]


def test_run_interrupted_during_its_set_up_stops_at_once_with_the_loops_words(tmp_path):
    # a 1000 s run at 1 kHz: its set-up (the reference of 1e6 samples, the noise draws, the
    # row buffers) takes seconds, much of it inside single calls into the core and numpy,
    # where Python would see the signal only when the call returns
    sc = tmp_path / "long.toml"
    sc.write_text((SCEN / "6pus_step_pd.toml").read_text().replace("duration = 2.0", "duration = 1000.0"))
    out = tmp_path / "out"
    p = _cosim(["run", str(sc), "--out", str(out), "--no-figures"])
    assert p.stdout.readline().strip() == "ready"
    time.sleep(0.5)
    assert p.poll() is None
    sent = time.monotonic()
    os.killpg(p.pid, signal.SIGINT)
    _, err = p.communicate(timeout=120)
    latency = time.monotonic() - sent
    assert p.returncode == 130, err
    # the words of a loop interrupted before its first step, and nothing written
    assert _one_line(err) == "cosim run: interrupted before the first step, nothing written", err
    assert latency < 0.5, f"{latency:.2f} s from the signal to the exit"
    assert not out.exists() or not any(out.iterdir())


def test_diagnose_interrupted_says_so_in_one_line(tmp_path):
    from cosim.discrepancy import blind

    csv, _ = blind.make_case(blind.CaseSpec("c", "6pus", ["coulomb"], 3), tmp_path / "rec", tmp_path / "key")
    p = _cosim(["diagnose", str(csv), "--out", str(tmp_path / "d")])
    start = []
    rc, _, err = _interrupt(p, lambda: start.append(time.monotonic()) or time.monotonic() - start[0] > 1.0)
    assert rc == 130, err
    assert _one_line(err).startswith("cosim diagnose: interrupted after "), err
    assert not (tmp_path / "d" / "diagnosis.json").exists()


def test_sweep_interrupted_on_two_dask_workers_exits_130_quietly_and_keeps_its_results(tmp_path):
    spec = tmp_path / "gains.toml"
    spec.write_text(f'name = "gains"\nkind = "scenario"\n[base]\nscenario = "{SCEN / "6pus_step_pd.toml"}"\n'
                    'plant = "core"\nduration = 1.0\n[grid]\n"controller.kp" = [150.0, 200.0, 300.0, 400.0, 600.0, '
                    '800.0, 1000.0, 1200.0]\n"controller.kd" = [15.0, 30.0, 45.0, 60.0]\n')
    out = tmp_path / "sw"
    results = out / "results.jsonl"
    p = _cosim(["sweep", str(spec), "--workers", "2", "--out", str(out), "--no-progress"])
    rc, stdout, err = _interrupt(p, lambda: results.exists() and len(results.read_text().splitlines()) >= 2)
    line = _one_line(err)
    assert rc == 130, err
    assert line.startswith("cosim sweep: interrupted after ") and "--resume" in line, line
    done = [json.loads(r) for r in results.read_text().splitlines()]
    assert 2 <= len(done) < 32 and all(r["status"] == "ok" for r in done)
    table = (out / "results.csv").read_text().splitlines()
    assert len(table) == 1 + len(done)
    assert "pending" in stdout
