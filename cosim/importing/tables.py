"""Parquet files as sources of an import, read with pyarrow.

A variable is a column: numbers (an (n, 1) variable), a list of numbers of the same length on
every row (an (n, k) matrix: the map picks one with ``column = 1..k``, as for a MATLAB matrix),
or a timestamp (read in seconds since the Unix epoch, ``offset`` in the map may move it).
A struct column's fields are variables named ``struct.field``.  Rows are counted from 1, as a
table viewer shows them.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ImportFailure


@dataclass
class ParquetSource:
    """A Parquet file (see the module docstring); used as a
    :class:`~cosim.importing.sources.Source` (the same attributes and methods): ``format``
    is ``"parquet"``, ``shapes`` column name -> (rows, 1), (rows, k) or (rows, None) for
    lists whose length is known when read, ``what`` the columns that are not numbers."""

    path: Path
    format: str
    shapes: dict
    what: dict = field(default_factory=dict)

    def row_label(self, indices) -> str:
        idx = [int(i) for i in indices[:5]]
        more = f" and {len(indices) - 5} more" if len(indices) > 5 else ""
        return ("row " if len(indices) == 1 else "rows ") + ", ".join(str(i + 1) for i in idx) + more + " (1-based)"

    def load(self, names, progress: bool | None = None) -> dict:
        import pyarrow.parquet as pq

        names = list(dict.fromkeys(names))
        for n in names:
            if n in self.what:
                raise ImportFailure(self.path, f"is a {self.what[n]}, not an array of numbers", variable=n)
        tops = list(dict.fromkeys(n.split(".")[0] if n not in self._top else n for n in names))
        try:
            table = pq.read_table(str(self.path), columns=tops).flatten() if tops else None
        except Exception as e:  # pyarrow raises ArrowInvalid, OSError... on a damaged file
            raise ImportFailure(self.path, f"cannot be read as Parquet: {_reason(e)}") from None
        out = {}
        for n in names:
            while n not in table.column_names:      # nested structs flatten one level at a time
                table = table.flatten()
            out[n] = _numbers(self, n, table.column(n))
        return out

    @property
    def _top(self) -> set:
        return {n for n in self.shapes if "." not in n}


def _reason(e: Exception) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def _numbers(src: ParquetSource, name: str, col) -> np.ndarray:
    import pyarrow as pa
    import pyarrow.compute as pc

    typ = col.type
    if pa.types.is_timestamp(typ):
        ns = pc.cast(col, pa.timestamp("ns", tz=typ.tz)).cast(pa.int64()).to_numpy(zero_copy_only=False)
        return (ns.astype(float) * 1e-9)[:, None]
    if pa.types.is_list(typ) or pa.types.is_large_list(typ) or pa.types.is_fixed_size_list(typ):
        lengths = pc.list_value_length(col).to_numpy(zero_copy_only=False)
        if lengths.size and (np.any(lengths != lengths[0]) or np.isnan(lengths.astype(float)).any()):
            bad = np.flatnonzero(lengths != lengths[0])
            k = int(bad[0]) if bad.size else 0
            raise ImportFailure(src.path, f"its lists have different lengths: {int(lengths[0])} at row 1, "
                                          f"{lengths[k]} at {src.row_label([k])}", variable=name)
        flat = pc.list_flatten(col).to_numpy(zero_copy_only=False).astype(float)
        return flat.reshape(len(lengths), int(lengths[0]) if lengths.size else 0)
    if pa.types.is_boolean(typ):
        col = pc.cast(col, pa.int8())
    a = col.to_numpy(zero_copy_only=False)
    return np.asarray(a, dtype=float)[:, None]


def _kind(typ) -> str | None:
    """None for a column of numbers (or a list of numbers, a timestamp), else what it is."""
    import pyarrow as pa

    if pa.types.is_integer(typ) or pa.types.is_floating(typ) or pa.types.is_boolean(typ) or \
            pa.types.is_timestamp(typ) or pa.types.is_decimal(typ):
        return None
    if pa.types.is_list(typ) or pa.types.is_large_list(typ) or pa.types.is_fixed_size_list(typ):
        return None if _kind(typ.value_type) is None and not pa.types.is_timestamp(typ.value_type) else \
            f"list of {typ.value_type}"
    return f"column of {typ}"


def open_parquet(p: Path) -> ParquetSource:
    """List a Parquet file's columns (nothing is read but its footer).

    Raises
    ------
    ImportFailure
        Not a Parquet file.

    Example
    -------
    >>> import pyarrow as pa, pyarrow.parquet as pq
    >>> pq.write_table(pa.table({"t": [0.0, 0.1], "q": [[1.0, 2.0], [3.0, 4.0]]}), "/tmp/tiny.parquet")
    >>> open_parquet(Path("/tmp/tiny.parquet")).shapes
    {'t': (2, 1), 'q': (2, None)}
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        f = pq.ParquetFile(str(p))
    except Exception as e:
        raise ImportFailure(p, f"is not a Parquet file: {_reason(e)}") from None
    n = f.metadata.num_rows
    shapes, what = {}, {}

    def add(name, typ):
        if pa.types.is_struct(typ):
            for i in range(typ.num_fields):
                add(f"{name}.{typ.field(i).name}", typ.field(i).type)
            return
        k = _kind(typ)
        if pa.types.is_fixed_size_list(typ):
            shapes[name] = (n, typ.list_size)
        elif pa.types.is_list(typ) or pa.types.is_large_list(typ):
            shapes[name] = (n, None)      # the length of its lists is known when read
        else:
            shapes[name] = (n, 1)
        if k is not None:
            what[name] = k

    for fld in f.schema_arrow:
        add(fld.name, fld.type)
    return ParquetSource(p, "parquet", shapes, what)
