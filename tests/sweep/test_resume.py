"""A sweep stopped half way (on purpose, or killed with SIGKILL) resumes from what it had
written: no finished case runs twice and the final table is the uninterrupted one."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.sweep import load_spec, read_records, run_sweep, spec_from_dict

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]


def _log(path):
    p = Path(path)
    return [json.loads(line) for line in p.read_text().splitlines()] if p.exists() else []


def _product_spec(log, n=10, **base):
    return spec_from_dict({"kind": "function",
                           "base": {"function": "sweep_testfns:product", "b": 2, "log": str(log), **base},
                           "grid": {"a": list(range(n))}}, name="prod")


def test_max_cases_then_resume_runs_each_case_once(client, tmp_path):
    log = tmp_path / "log.jsonl"
    spec = _product_spec(log)
    first = run_sweep(spec, out=tmp_path / "out", client=client, max_cases=4, progress=False)
    assert (first.ran, first.skipped, first.pending) == (4, 0, 6) and len(first.rows) == 4
    assert len(_log(log)) == 4
    done_before = {r["a"] for r in first.rows}
    again = run_sweep(spec, out=tmp_path / "out", client=client, resume=True, progress=False)
    assert (again.ran, again.skipped, again.pending) == (6, 4, 0)
    runs = [e["a"] for e in _log(log)]
    assert sorted(runs) == list(range(10))                  # every case ran exactly once
    assert not done_before & set(runs[4:])                   # the resumed run skipped the finished ones
    ids = [r["case_id"] for r in read_records(tmp_path / "out")]
    assert len(ids) == len(set(ids)) == 10
    whole = run_sweep(_product_spec(tmp_path / "log2.jsonl"), out=tmp_path / "whole", workers=0, progress=False)
    assert [(r["a"], r["y"], r["nested.sum"], r["status"]) for r in again.rows] == \
        [(r["a"], r["y"], r["nested.sum"], r["status"]) for r in whole.rows]
    # a third run has nothing left to do
    third = run_sweep(spec, out=tmp_path / "out", client=client, resume=True, progress=False)
    assert third.ran == 0 and len(_log(log)) == 10


def test_failed_cases_are_kept_unless_retried(tmp_path):
    log = tmp_path / "log.jsonl"
    spec = _product_spec(log, n=4, fail_a=2)
    res = run_sweep(spec, out=tmp_path / "out", workers=0, progress=False)
    assert [r["status"] for r in res.rows] == ["ok", "ok", "error", "ok"]
    bad = res.failed[0]
    assert bad["a"] == 2 and bad["error_type"] == "ArithmeticError"
    assert "singular configuration at a = 2" in bad["error"]
    assert bad["where"].startswith("sweep_testfns.py:")
    assert run_sweep(spec, out=tmp_path / "out", workers=0, resume=True, progress=False).ran == 0
    again = run_sweep(spec, out=tmp_path / "out", workers=0, resume=True, retry_failed=True, progress=False)
    assert again.ran == 1 and [e["a"] for e in _log(log)] == [0, 1, 2, 3, 2]
    assert len(again.rows) == 4 and again.rows[2]["status"] == "error"


def test_ctrl_c_keeps_what_finished_and_writes_the_table(tmp_path):
    spec = _product_spec(tmp_path / "log.jsonl", n=5, interrupt_a=2)
    res = run_sweep(spec, out=tmp_path / "out", workers=0, progress=False)
    assert res.interrupted and (res.ran, res.pending) == (2, 3)
    assert "interrupted: 3 case(s) pending" in res.text()
    assert res.files["table"].read_text().count("\n") == 3


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    try:  # a zombie waiting for its parent counts as gone
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[1][0] != "Z"
    except OSError:
        return False


def test_a_killed_sweep_resumes_from_what_it_wrote(client, tmp_path):
    log = tmp_path / "log.jsonl"
    spec_file = tmp_path / "kill.toml"
    spec_file.write_text('name = "kill"\nkind = "function"\n[base]\nfunction = "sweep_testfns:product"\n'
                         f'b = 3\nsleep = 0.3\nlog = "{log}"\n[grid]\na = {list(range(12))}\n')
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))
    # a new process group (start_new_session): the CLI, its LocalCluster's nannies and workers
    cosim = Path(sys.executable).parent / "cosim"   # the console script (python -m cosim.cli would not see plugins)
    proc = subprocess.Popen([str(cosim), "sweep", str(spec_file), "--workers", "2",
                             "--out", str(out), "--no-progress"], cwd=REPO, env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    results = out / "results.jsonl"
    deadline = time.monotonic() + 90
    try:
        while time.monotonic() < deadline:
            if results.exists() and results.read_text().count("\n") >= 4:
                break
            if proc.poll() is not None:
                pytest.fail(f"the sweep ended before it was killed: {proc.stderr.read().decode()[-2000:]}")
            time.sleep(0.05)
        else:
            pytest.fail("the sweep wrote no 4 results within 90 s")
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        proc.wait()
        proc.stderr.close()
    before = read_records(out)
    k = len(before)
    assert 4 <= k < 12, k
    workers = {int(r["worker"].rsplit(":", 1)[1]) for r in before}
    t0 = time.monotonic()
    while any(_alive(p) for p in workers) and time.monotonic() - t0 < 10:
        time.sleep(0.1)
    assert not any(_alive(p) for p in workers), "worker processes of the killed sweep still run"
    with open(results, "a") as f:  # as if the kill had hit in the middle of a write
        f.write('{"case_id": "0123456789abcdef", "params": {"a": ')
    n_log = len(_log(log))
    res = run_sweep(load_spec(spec_file), out=out, client=client, resume=True, progress=False)
    assert (res.skipped, res.ran, res.pending) == (k, 12 - k, 0)
    rerun = {e["a"] for e in _log(log)[n_log:]}
    assert not rerun & {r["params"]["a"] for r in before}, "a finished case ran again"
    recs = read_records(out)
    assert len(recs) == 12 and len({r["case_id"] for r in recs}) == 12
    assert [(r["a"], r["y"], r["status"]) for r in res.rows] == [(a, 3 * a, "ok") for a in range(12)]
    assert res.files["table"].read_text().count("\n") == 13
