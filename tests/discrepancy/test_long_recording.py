"""Long recordings: the diagnosis works on a working set of blocks at the full rate
(cosim.discrepancy.working_set).  The blocks' residual is the whole recording's at the same
rows (no filter reaches across two blocks); a recording forced through the working set with
small blocks names the effects the whole recording names, with values inside their
intervals; reading keeps memory bounded by the budget, not by the length, and keeps the
excited blocks.  The hour itself: bench/long_recording.py."""
import tracemalloc

import numpy as np
import pytest
from disc_helpers import run

from cosim.core import Model
from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.residuals import Pipeline
from cosim.discrepancy.working_set import working_set
from cosim.recording import Recording, write_recording

HIDDEN = {"rail[3].coulomb": 0.03, "rail[1].viscous": 0.6}


@pytest.fixture(scope="module")
def noisy():
    """16 s of the 6-PUS with the blind cases' sensor noise and two hidden effects."""
    return run("6pus", HIDDEN, duration=16.0, seed=11, noise=blind.load_config()["noise"]["6pus"])


def test_the_residual_of_the_blocks_is_the_whole_recordings_at_the_same_rows(noisy):
    ws = working_set(noisy, max_samples=6000, block_seconds=1.0)
    assert len(ws.segments) > 3 and len(ws.recording) <= 6000
    m = Model("6pus")
    whole = Pipeline(noisy, m)
    part = Pipeline(ws.recording, m, segments=ws.segments)
    rows = np.searchsorted(noisy.time, ws.recording.time)  # the source row of each working-set row
    np.testing.assert_array_equal(noisy.time[rows], ws.recording.time)
    for params in ({}, {"rail[3].coulomb": 0.03, "actuator.delay": 0.004}, {"rail[2].encoder_offset": 1e-4},
                   {"sensor.delay": 0.006, "payload.m": 0.05}):
        a = part.evaluate(params).stack()
        b = whole.evaluate(params, positions=rows[part.idx]).stack()
        scale = np.abs(b).max(axis=0)
        # the same samples through the same filters: round-off only (a filter reaching into
        # the next block would differ by the size of the signal)
        assert np.all(np.abs(a - b).max(axis=0) <= 1e-9 * scale), (params, np.abs(a - b).max(axis=0) / scale)
    # the test can tell: at rows closer to a block's start than the margin the filters do
    # reach into the previous block, and the residual is another
    a0 = ws.segments[1][0]
    near = np.arange(a0 + 2, a0 + 6)
    gap = np.abs(part.evaluate({}, positions=near).eff - whole.evaluate({}, positions=rows[near]).eff).max()
    assert gap > 1e-3 * np.abs(whole.evaluate({}).eff).max()


def test_a_recording_forced_through_small_blocks_names_what_the_whole_names(noisy, tmp_path):
    whole = diagnose(noisy, replay=False, figures=False, discovery=False)
    assert whole.settings["working_set"]["whole"]
    path, _ = write_recording(tmp_path / "rec.parquet", noisy)
    part = diagnose(path, replay=True, figures=False, discovery=False, max_samples=8_000, block_seconds=2.0)
    s = part.settings["working_set"]
    assert not s["whole"] and s["rows"] <= 8_000 and len(s["blocks"]) >= 4 and s["source_rows"] == len(noisy)
    assert s["blocks"][-1][1] > noisy.time[-1] - 6.0  # spread to the end: the held-out part is the last blocks
    assert set(part.named()) == set(whole.named()) == {"coulomb", "viscous"}, (part.conclusion, whole.conclusion)
    w = {k: v for e in whole.effects for k, v in e["params"].items()}
    for e in part.effects:
        for k, v in e["params"].items():
            assert abs(v["value"] - w[k]["value"]) <= v["ci95"], (k, v, w[k])
    # the replay ran inside the held-out block
    runs = part.replay["runs"]
    assert "error" not in runs["fitted"] and runs["fitted"]["rms_tau"]
    assert part.replay["start"] >= s["blocks"][0][0]


def _idle_and_busy(chunks, rows, busy):
    """Synthetic 6-PUS rows at 1 kHz in chunks: at rest except the blocks of 10 s listed in
    ``busy`` (index of the block), where every joint oscillates."""
    nd = 6
    for c in range(chunks):
        t = (c * rows + np.arange(rows)) * 1e-3
        on = np.isin((t // 10.0).astype(int), busy)[:, None]
        q = 0.1 + on * 0.01 * np.sin(2 * np.pi * 0.7 * t[:, None] + np.arange(nd))
        yield Recording("6pus", t, q, np.gradient(q, 1e-3, axis=0), np.zeros((rows, nd)), qref=q,
                        pose=np.zeros((rows, 6)))


def test_reading_holds_the_budget_not_the_length_and_keeps_the_excited_blocks():
    # 2,000,000 rows (33 min at 1 kHz, 25 columns: 400 MB) read in chunks of 50,000 rows;
    # one block in each group of 20 moves
    busy = list(range(7, 200, 20))  # 10 busy blocks of 10 s
    tracemalloc.start()
    ws = working_set(_idle_and_busy(40, 50_000, busy), max_samples=100_000, block_seconds=10.0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert ws.source_rows == 2_000_000
    assert 50_000 <= len(ws.recording) <= 100_000
    row_bytes = 8 * (1 + 4 * 6 + 6)
    # the kept rows, one chunk being read and one block being cut: far below the 400 MB read
    assert peak < 3 * (100_000 + 2 * 50_000) * row_bytes, f"{peak / 1e6:.0f} MB"
    # a CSV-like stream (length unknown): strata of 1, 2, 4, ... blocks until 10 hold all
    per = ws.stratum_blocks
    assert per == 32
    kept = [int(a // 10.0) for a, _ in ws.summary()["blocks"]]
    assert [k // per for k in kept] == list(range(len(kept))) == list(range(7))  # one per stratum
    for k in kept:  # a stratum with a moving block keeps one
        assert (k in busy) == any(b // per == k // per for b in busy), (k, kept)


def test_cli_refuses_a_working_set_that_is_not_a_positive_number(tmp_path, capsys):
    from cosim.cli.main import main

    rec = Recording("6pus", np.arange(10) * 1e-3, np.zeros((10, 6)), np.zeros((10, 6)), np.zeros((10, 6)))
    path, _ = write_recording(tmp_path / "r.csv", rec)
    for args in (["--max-samples", "0"], ["--max-samples", "many"], ["--block-seconds", "-1"]):
        assert main(["diagnose", str(path), *args]) == 2
        err = capsys.readouterr().err
        assert args[0] in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err


def test_a_csv_cell_only_the_careful_reader_takes_is_read_as_read_recording_reads_it(tmp_path):
    from cosim.recording import read_recording

    t = np.arange(300) * 1e-3
    rec = Recording("fourbar", t, np.sin(t)[:, None], np.cos(t)[:, None], np.zeros((300, 1)))
    path, _ = write_recording(tmp_path / "spaced.csv", rec)
    lines = path.read_text().splitlines()
    lines[150] = " " + lines[150].replace(",", ", ")  # blanks around the numbers of one row
    path.write_text("\n".join(lines) + "\n")
    whole = read_recording(path)
    for kw in ({}, {"max_samples": 100, "block_seconds": 0.05, "chunk_rows": 50}):
        ws = working_set(path, **kw)
        assert ws.source_rows == 300
        rows = np.searchsorted(whole.time, ws.recording.time)
        np.testing.assert_array_equal(ws.recording.q, whole.q[rows])


def test_the_working_set_default_is_one_number_in_the_code_the_help_and_the_docs(capsys):
    """--help, docs/discrepancy.md, docs/recording.md and docs/guide.md say the default the
    code uses (they once said 200000 and 100000)."""
    import re
    from pathlib import Path

    from cosim.cli.main import main
    from cosim.discrepancy.working_set import MAX_SAMPLES

    try:
        assert main(["diagnose", "--help"]) == 0
    except SystemExit as e:
        assert e.code == 0
    helptext = " ".join(capsys.readouterr().out.split())
    said = re.findall(r"most rows the diagnosis holds \(default (\d+)", helptext)
    assert said == [str(MAX_SAMPLES)], helptext
    root = Path(__file__).resolve().parents[2]
    for page in ("docs/discrepancy.md", "docs/recording.md", "docs/guide.md"):
        text = (root / page).read_text()
        nums = re.findall(r"(?:max.samples[^\n]{0,60}?|default )([\d,]{6,})", text)
        assert nums and all(int(n.replace(",", "")) == MAX_SAMPLES for n in nums), (page, nums)
