"""bench/diagnosis_time_bench.py's case directory: a recording written by older code that today's
reader refuses (the Quattro's pose column ``theta``, now ``rz``) is stale and written again."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "bench"))

import diagnosis_time_bench as bench  # noqa: E402

from cosim.recording import Recording, write_recording  # noqa: E402


def _quattro_csv(path: Path) -> Path:
    n = 20
    pose = np.tile([0.0, 0.0, -0.95, 0.0], (n, 1))
    rec = Recording(robot="quattro", time=np.arange(n) * 1e-3, q=np.full((n, 4), 0.25), qd=np.zeros((n, 4)),
                    tau=np.zeros((n, 4)), pose=pose)
    csv, _ = write_recording(path, rec)
    return Path(csv)


def _stale(csv: Path) -> None:
    """The file as the code before the core named the Quattro's pose angle rz wrote it."""
    lines = csv.read_text().splitlines(keepends=True)
    assert ",rz" in lines[0]
    csv.write_text(lines[0].replace(",rz", ",theta") + "".join(lines[1:]))


def test_readable_refuses_a_stale_case(tmp_path):
    csv = _quattro_csv(tmp_path / "quattro_backlash.csv")
    assert bench.readable(csv)
    _stale(csv)
    assert not bench.readable(csv)
    assert not bench.readable(tmp_path / "missing.csv")


def test_make_cases_writes_a_stale_case_again(tmp_path, monkeypatch):
    from cosim.discrepancy import blind

    written = []

    def make_case(spec, out, keys, cfg):  # the generator, without its 10 s simulation
        written.append(spec.case)
        return _quattro_csv(Path(out) / f"{spec.case}.csv"), None

    monkeypatch.setattr(blind, "make_case", make_case)
    csv = _quattro_csv(tmp_path / "quattro_backlash.csv")
    assert bench.make_cases(tmp_path, ["quattro_backlash"], mujoco=False) == {"quattro_backlash": csv}
    assert written == []  # a readable case is kept
    _stale(csv)
    paths = bench.make_cases(tmp_path, ["quattro_backlash"], mujoco=False)
    assert written == ["quattro_backlash"]
    assert bench.readable(paths["quattro_backlash"])
