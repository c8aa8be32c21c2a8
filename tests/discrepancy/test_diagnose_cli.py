"""The CLI: ``cosim diagnose`` on a blind case and on a malformed file, the report files."""
import json

from cosim.cli import main


def test_diagnose_command_prints_the_answer_and_writes_the_report(blind_subset, tmp_path, capsys):
    csv, key = blind_subset["6pus_coulomb_101"]
    out = tmp_path / "report"
    assert main(["diagnose", str(csv), "--out", str(out), "--no-replay"]) == 0
    text = capsys.readouterr().out
    joint = json.loads(key.read_text())["effects"][0]["joints"][0]
    assert f"Coulomb friction, joint {joint}" in text
    assert "how much better" in text
    md = (out / "report.md").read_text()
    for section in ("## Where the model goes wrong", "## Why: the missing physics", "## How much better",
                    f"`rail[{joint}].coulomb`"):
        assert section in md
    for fig in ("residuals.png", "velocity.png", "workspace.png", "heldout.png"):
        assert (out / fig).stat().st_size > 10_000
        assert f"({fig})" in md
    d = json.loads((out / "diagnosis.json").read_text())
    assert list(d["theta"]) == [f"rail[{joint}].coulomb"]


def test_diagnose_command_reports_a_bad_file_without_a_traceback(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("time,q1\n0,1\n")
    (tmp_path / "bad.json").write_text(json.dumps({"format": "pkm-recording/1", "robot": "6pus"}))
    assert main(["diagnose", str(bad), "--out", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "cosim diagnose: error:" in err and "bad.csv" in err and "column 'qd1'" in err


def test_blind_benchmark_progress_is_a_bar_a_line_per_case_or_nothing(capsys):
    from cosim.cli.discrepancy import _case_progress

    for quiet, verbose, want_lines in ((True, False, 0), (False, True, 2), (False, False, 2)):
        progress, bar = _case_progress(2, quiet, verbose)
        progress("   case01    6pus  coulomb  ok")
        progress("   case02    6pus  clean    ok")
        bar.close()
        out = capsys.readouterr().out
        # pytest's capture is no terminal: the default falls back to a line per case
        assert len([ln for ln in out.splitlines() if "case0" in ln]) == want_lines, (quiet, verbose, out)


def test_blind_benchmark_hold_out_diagnoses_each_case_without_its_type(tmp_path, capsys):
    out = tmp_path / "bench"
    assert main(["blind-benchmark", "--cases", "2", "--clean", "0", "--seed", "3", "--hold-out", "--quiet",
                 "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "structure left unexplained reported:" in text
    res = json.loads((out / "benchmark.json").read_text())
    rows = res["cases"]
    assert len(rows) == 2 and all(r["held_out"] for r in rows)
    for r in rows:
        assert not set(r["hidden"]) & set(r["named"]), r  # the hidden types were not in the library
    assert res["summary"]["structure_when_held_out"] == sum(bool(r["structure"]) for r in rows) / 2
