"""Recordings as CSV, Parquet or HDF5 tables, read whole or in blocks of rows."""
import json
import tracemalloc

import h5py
import numpy as np
import pytest

from cosim.recording import Recording, RecordingError, iter_recording, read_recording, write_recording


def _rec(n=50):
    rng = np.random.default_rng(5)
    return Recording(robot="quattro", time=np.arange(n) * 1e-3, q=rng.normal(size=(n, 4)),
                     qd=rng.normal(size=(n, 4)), tau=rng.normal(size=(n, 4)), qref=rng.normal(size=(n, 4)),
                     f_ext=rng.normal(size=(n, 4)), extra={"label": np.arange(n) % 3 * 1.0}, notes="formats")


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".h5"])
def test_round_trip_exact_in_every_format(tmp_path, suffix):
    rec = _rec()
    path, side = write_recording(tmp_path / f"r{suffix}", rec)
    assert path.suffix == suffix and side.name == "r.json"
    back = read_recording(path)
    for name in ("time", "q", "qd", "tau", "qref", "f_ext"):
        np.testing.assert_array_equal(getattr(back, name), getattr(rec, name))
    np.testing.assert_array_equal(back.extra["label"], rec.extra["label"])
    assert back.notes == "formats"
    # the extension may be left out
    assert len(read_recording(tmp_path / "r")) == 50


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".h5"])
def test_blocks_put_together_are_the_recording(tmp_path, suffix):
    rec = _rec(1003)
    path, _ = write_recording(tmp_path / f"b{suffix}", rec)
    blocks = list(iter_recording(path, chunk_rows=100))
    assert [len(b) for b in blocks] == [100] * 10 + [3]
    np.testing.assert_array_equal(np.concatenate([b.time for b in blocks]), rec.time)
    np.testing.assert_array_equal(np.vstack([b.f_ext for b in blocks]), rec.f_ext)
    np.testing.assert_array_equal(np.concatenate([b.extra["label"] for b in blocks]), rec.extra["label"])


def test_time_going_back_between_blocks_is_found_at_its_line(tmp_path):
    rec = _rec(300)
    path, _ = write_recording(tmp_path / "t.csv", rec)
    lines = path.read_text().splitlines()
    cells = lines[101].split(",")       # data row 100 (0-based), the first of the second block
    cells[0] = "0.05"
    lines[101] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=r"t.csv, row 102, column 'time': time is not strictly increasing"):
        for _ in iter_recording(path, chunk_rows=100):
            pass


def test_a_word_in_a_csv_is_found_by_the_block_reader(tmp_path):
    path, _ = write_recording(tmp_path / "w.csv", _rec(300))
    text = path.read_text().splitlines()
    text[250] = "oops," + text[250].split(",", 1)[1]
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(RecordingError, match=r"w.csv, row 251, column 'time': 'oops' is not a number"):
        list(iter_recording(path, chunk_rows=100))


def test_non_finite_in_parquet_names_row_and_column(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    path, _ = write_recording(tmp_path / "p.parquet", _rec(20))
    t = pq.read_table(path)
    q3 = t.column("q3").to_numpy().copy()
    q3[7] = np.nan
    pq.write_table(t.set_column(t.schema.get_field_index("q3"), "q3", pa.array(q3)), path)
    with pytest.raises(RecordingError, match=r"p.parquet, row 8, column 'q3': value nan is not a finite"):
        read_recording(path)


def test_hdf5_without_its_column_list(tmp_path):
    path, _ = write_recording(tmp_path / "h.h5", _rec(20))
    with h5py.File(path, "a") as f:
        del f.attrs["columns"]
    with pytest.raises(RecordingError, match=r"h.h5: has no 'columns' attribute"):
        read_recording(path)


def test_reading_in_blocks_keeps_memory_to_a_block(tmp_path):
    n = 200_000
    rec = Recording(robot="fourbar", time=np.arange(n) * 1e-3, q=np.zeros((n, 1)), qd=np.zeros((n, 1)),
                    tau=np.ones((n, 1)))
    path, _ = write_recording(tmp_path / "m.parquet", rec)
    whole = n * 4 * 8                        # the table's bytes (4 columns)
    tracemalloc.start()
    rows = sum(len(b) for b in iter_recording(path, chunk_rows=5000))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert rows == n
    assert peak < whole / 8, (peak, whole)


def test_written_in_blocks_is_the_recording(tmp_path):
    from cosim.recording import write_recording_blocks

    rec = _rec(250)
    path, side = write_recording_blocks(tmp_path / "wb.parquet", (rec.slice(k, k + 60) for k in range(0, 250, 60)))
    back = read_recording(path)
    np.testing.assert_array_equal(back.q, rec.q)
    np.testing.assert_array_equal(back.f_ext, rec.f_ext)
    assert json.loads(side.read_text())["units"]["f_ext"] == "N m"     # the Quattro's arms turn
    with pytest.raises(RecordingError, match=r"row 62, column 'time': time goes back between blocks"):
        write_recording_blocks(tmp_path / "bad.csv", [rec.slice(0, 60), rec.slice(10, 70)])


def _independent_read(path):
    """Oracle: the written table read by other libraries, not by cosim: Python's csv module,
    pyarrow's Parquet reader, h5py; {column: array}."""
    if path.suffix == ".csv":
        import csv

        with open(path, newline="") as fh:
            rows = list(csv.reader(fh))
        return {name: np.array([float(r[k]) for r in rows[1:]]) for k, name in enumerate(rows[0])}
    if path.suffix == ".parquet":
        import pyarrow.parquet as pq

        t = pq.read_table(path)
        return {name: t.column(name).to_numpy() for name in t.column_names}
    with h5py.File(path, "r") as f:
        return {name: f[name][()] for name in f.keys()}


@pytest.mark.parametrize("suffix", [".csv", ".parquet", ".h5"])
def test_written_columns_are_what_other_readers_see(tmp_path, suffix):
    rec = _rec()
    path, _ = write_recording(tmp_path / f"r{suffix}", rec)
    cols = _independent_read(path)
    np.testing.assert_array_equal(cols["time"], rec.time)
    for name in ("q", "qd", "tau", "qref", "f_ext"):
        for j in range(4):
            np.testing.assert_array_equal(cols[f"{name}{j + 1}"], getattr(rec, name)[:, j], err_msg=f"{name}{j + 1}")
    np.testing.assert_array_equal(cols["label"], rec.extra["label"])
    assert len(cols) == 1 + 5 * 4 + 1
