"""The column table of a pkm-recording on disk: CSV, Parquet or HDF5, read whole or in
blocks of rows (bounded memory for recordings of any length).  The JSON sidecar is the same
for all three (``cosim.recording``); the file's extension says which table it is:

* ``.csv``: header row + one line per sample (read by Arrow's C++ reader);
* ``.parquet``: one float64 column per recording column (Arrow), one row group per block
  written (a block read holds one row group);
* ``.h5`` / ``.hdf5``: one 1-D float64 dataset per recording column at the file's root,
  chunked so that a block of rows is read without the rest; the root attribute ``columns``
  lists them in order.

Example
-------
>>> import numpy as np
>>> write_table("/tmp/tab.parquet", ["time", "q1"], np.array([[0.0, 1.0], [0.1, 2.0]]))
>>> read_header("/tmp/tab.parquet"), read_table("/tmp/tab.parquet", ["time", "q1"])[:, 1].tolist()
(['time', 'q1'], [1.0, 2.0])
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

#: extension -> table format
SUFFIXES = {".csv": "csv", ".parquet": "parquet", ".h5": "hdf5", ".hdf5": "hdf5"}
#: table format -> the extension written
EXTENSION = {"csv": ".csv", "parquet": ".parquet", "hdf5": ".h5"}


def table_format(path) -> str:
    """``"csv"``, ``"parquet"`` or ``"hdf5"`` from the extension (anything else: CSV)."""
    return SUFFIXES.get(Path(path).suffix.lower(), "csv")


class TableUnreadable(ValueError):
    """The fast reader refused the table: the caller's careful reader says where and why."""


class TableWriter:
    """A table written block by block (memory: one block):

    >>> with TableWriter("/tmp/blocks.h5", ["time", "q1"]) as w:
    ...     w.write(np.array([[0.0, 1.0]])); w.write(np.array([[0.1, 2.0]]))
    >>> read_table("/tmp/blocks.h5", ["time", "q1"])[:, 1]
    array([1., 2.])
    """

    def __init__(self, path, header, fmt: str | None = None, chunk_rows: int = 65536):
        self.path, self.header, self.fmt = Path(path), list(header), fmt or table_format(path)
        self.rows = 0
        if self.fmt == "hdf5":
            import h5py

            self._f = h5py.File(self.path, "w")
            self._f.attrs["columns"] = self.header
            for h in self.header:
                self._f.create_dataset(h, shape=(0,), maxshape=(None,), dtype="f8", chunks=(chunk_rows,))
        elif self.fmt == "parquet":
            import pyarrow as pa
            import pyarrow.parquet as pq

            self._schema = pa.schema([(h, pa.float64()) for h in self.header])
            self._f = pq.ParquetWriter(self.path, self._schema)
        else:
            self._f = open(self.path, "wb")
            self._f.write((",".join(self.header) + "\n").encode())

    def write(self, block: np.ndarray) -> None:
        """Append rows (k, ncol), columns in header order."""
        import pyarrow as pa

        k = len(block)
        if self.fmt == "hdf5":
            for j, h in enumerate(self.header):
                d = self._f[h]
                d.resize((self.rows + k,))
                d[self.rows:] = block[:, j]
        elif self.fmt == "parquet":
            self._f.write_table(pa.table({h: block[:, j] for j, h in enumerate(self.header)}, schema=self._schema))
        else:
            import pyarrow.csv as pcsv

            pcsv.write_csv(pa.table({str(j): block[:, j] for j in range(block.shape[1])}), self._f,
                           pcsv.WriteOptions(include_header=False, quoting_style="none"))
        self.rows += k

    def close(self) -> None:
        self._f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def write_table(path, header, table: np.ndarray, fmt: str | None = None, chunk_rows: int = 100_000,
                bar=None) -> None:
    """Write a table (n, ncol) with its column names; ``fmt`` from the extension by default.
    CSV numbers are the shortest text that reads back as the same double."""
    with TableWriter(path, header, fmt) as w:
        for k in range(0, len(table), chunk_rows):
            w.write(table[k:k + chunk_rows])
            if bar is not None:
                bar.update(min(chunk_rows, len(table) - k))


def read_header(path, fmt: str | None = None) -> list:
    """The column names of a Parquet or HDF5 table (a CSV's header is read by
    ``cosim.recording``, which reports its problems by line)."""
    fmt = fmt or table_format(path)
    try:
        if fmt == "parquet":
            import pyarrow.parquet as pq

            return list(pq.ParquetFile(path).schema_arrow.names)
        import h5py

        with h5py.File(path, "r") as f:
            cols = f.attrs.get("columns")
            if cols is None:
                raise TableUnreadable("has no 'columns' attribute listing the recording's columns")
            return [c.decode() if isinstance(c, bytes) else str(c) for c in cols]
    except TableUnreadable:
        raise
    except Exception as e:  # Arrow, h5py and OSError have their own exception types for a foreign file
        raise TableUnreadable(f"is not a {fmt} recording table: {str(e).splitlines()[0] if str(e) else e!r}") from None


def iter_blocks(path, header, chunk_rows: int = 100_000, fmt: str | None = None):
    """Blocks of rows (float64 arrays (k, ncol), columns in ``header`` order), at most
    ``chunk_rows`` rows each; memory is one block, whatever the length of the file.

    Raises
    ------
    TableUnreadable
        A cell the fast reader does not take (CSV), a missing or non-numeric column.
    """
    import pyarrow as pa

    fmt = fmt or table_format(path)
    if fmt == "hdf5":
        import h5py

        with h5py.File(path, "r") as f:
            for h in header:
                if h not in f or f[h].ndim != 1 or f[h].dtype.kind not in "fiu":
                    raise TableUnreadable(f"column {h!r} is not a 1-D dataset of numbers")
            n = len(f[header[0]])
            if any(len(f[h]) != n for h in header):
                raise TableUnreadable("its column datasets do not all have the same length")
            for k in range(0, n, chunk_rows):
                yield np.column_stack([f[h][k:k + chunk_rows] for h in header]).astype(float, copy=False)
        return
    try:
        if fmt == "parquet":
            import pyarrow.parquet as pq

            # one row group at a time (iter_batches reads ahead and holds far more than a batch)
            f = pq.ParquetFile(path)
            batches = (b for i in range(f.num_row_groups)
                       for b in f.read_row_group(i, columns=list(header)).to_batches(max_chunksize=chunk_rows))
        else:
            import pyarrow.csv as pcsv

            reader = pcsv.open_csv(
                path, read_options=pcsv.ReadOptions(column_names=list(header), skip_rows=1, block_size=1 << 22),
                convert_options=pcsv.ConvertOptions(column_types={h: pa.float64() for h in header}))
            batches = _rebatch(reader, chunk_rows)
        for b in batches:
            yield np.column_stack([b.column(j).to_numpy(zero_copy_only=False) for j in range(b.num_columns)]
                                  ).astype(float, copy=False).reshape(b.num_rows, len(header))
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError, KeyError) as e:
        raise TableUnreadable(str(e).splitlines()[0] if str(e) else repr(e)) from None


def _rebatch(reader, rows: int):
    """Record batches of at most ``rows`` rows from a stream of batches of any size."""
    for b in reader:
        for k in range(0, b.num_rows, rows):
            yield b.slice(k, rows)


def read_table(path, header, fmt: str | None = None) -> np.ndarray:
    """The whole table (n, ncol) (see :func:`iter_blocks`)."""
    fmt = fmt or table_format(path)
    n = None
    if fmt == "parquet":
        import pyarrow.parquet as pq

        n = pq.ParquetFile(path).metadata.num_rows
    elif fmt == "hdf5":
        import h5py

        with h5py.File(path, "r") as f:
            n = len(f[header[0]]) if header and header[0] in f else None
    if n is None:
        blocks = list(iter_blocks(path, header, 1 << 20, fmt))
        return np.vstack(blocks) if blocks else np.empty((0, len(header)))
    out, k = np.empty((n, len(header))), 0
    for b in iter_blocks(path, header, 1 << 20, fmt):
        out[k:k + len(b)] = b
        k += len(b)
    return out[:k]
