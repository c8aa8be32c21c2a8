"""Source files of an import: MATLAB (v5 and v7.3/HDF5), plain HDF5, CSV and TSV here; ROS 2
bags and MCAP files in :mod:`.messages`, Parquet in :mod:`.tables` (dispatched by
:func:`open_source`).

:func:`open_source` looks at a file and lists its variables (name -> shape, cheap: nothing
is loaded); :meth:`Source.load` reads the variables an import needs.  Arrays come back
2-D in MATLAB's orientation (a column vector is (n, 1), a scalar (1, 1)); a CSV or TSV
column is an (n, 1) variable named by its header cell.
"""
from __future__ import annotations

import csv
import io
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ImportFailure

#: the formats a source may be read as (``[source] format`` in a map)
FORMATS = ("matlab", "hdf5", "csv", "tsv", "rosbag2", "mcap", "parquet")

_EXTENSIONS = {".mat": "matlab", ".h5": "hdf5", ".hdf5": "hdf5", ".csv": "csv", ".tsv": "tsv", ".tab": "tsv",
               ".txt": "csv", ".db3": "rosbag2", ".mcap": "mcap", ".parquet": "parquet", ".pq": "parquet"}


@dataclass
class Source:
    """A source file and what it holds.

    Attributes
    ----------
    path : Path
    format : str
        ``"matlab-v5"``, ``"matlab-v7.3"``, ``"hdf5"``, ``"csv"`` or ``"tsv"``.
    shapes : dict
        Variable name -> shape in MATLAB's orientation (a CSV column: ``(None, 1)``, its
        length unknown until read).
    what : dict
        Variable name -> what it is when it is not an array of numbers (``"char"``,
        ``"struct"``, ``"cell"``, ...), for the message that refuses it.
    """

    path: Path
    format: str
    shapes: dict
    what: dict = field(default_factory=dict)
    delimiter: str = ","
    header_line: int = 1
    data_offset: int = 0
    encoding: str = "utf-8"

    def row_label(self, indices) -> str:
        """How a message names rows of a variable: file lines for text, 1-based indices
        (as MATLAB counts) otherwise."""
        idx = [int(i) for i in indices[:5]]
        more = f" and {len(indices) - 5} more" if len(indices) > 5 else ""
        one = len(indices) == 1
        if self.format in ("csv", "tsv"):
            return ("line " if one else "lines ") + ", ".join(str(i + self.header_line + 1) for i in idx) + more
        return ("index " if one else "indices ") + ", ".join(str(i + 1) for i in idx) + more + " (1-based)"

    def load(self, names, progress: bool | None = None) -> dict:
        """The variables ``names`` as float arrays (2-D, MATLAB orientation).

        Raises
        ------
        ImportFailure
            A variable that is not numbers (text, a struct, a cell array, complex), a
            cell of a text file that is not a number (naming the line and column).
        """
        names = list(dict.fromkeys(names))
        for n in names:
            if n in self.what:
                raise ImportFailure(self.path, f"is a {self.what[n]}, not an array of numbers", variable=n)
        if self.format == "matlab-v5":
            return _load_mat5(self, names)
        if self.format in ("matlab-v7.3", "hdf5"):
            return _load_hdf5(self, names)
        return _load_text(self, names, progress)


def open_source(path, fmt: str | None = None, delimiter: str | None = None, encoding: str | None = None) -> Source:
    """Open a source file and list its variables (nothing is loaded yet).

    Parameters
    ----------
    path : str or Path
        A file, or a ROS 2 bag's folder (the one with ``metadata.yaml``).
    fmt : str, optional
        One of :data:`FORMATS`; default from the extension (``.mat``, ``.h5``/``.hdf5``,
        ``.csv``/``.txt``, ``.tsv``/``.tab``, ``.db3`` (a bag's), ``.mcap``,
        ``.parquet``/``.pq``), else from the content.
    delimiter : str, optional
        Of a text file; default a tab for TSV, else the one of ``, ; <tab>`` the header
        line has most of.

    Raises
    ------
    ImportFailure
        The file is missing, empty, a directory, or not of the format.

    Example
    -------
    >>> import numpy as np, scipy.io
    >>> scipy.io.savemat("/tmp/tiny.mat", {"t": np.arange(3.0)[:, None], "k": 2.0})
    >>> open_source("/tmp/tiny.mat").shapes == {"t": (3, 1), "k": (1, 1)}
    True
    """
    p = Path(path)
    if not p.exists():
        raise ImportFailure(p, "file not found")
    if p.is_dir() and (p / "metadata.yaml").is_file() and fmt in (None, "rosbag2"):
        return _open_other(p, "rosbag2")
    if p.is_dir():
        raise ImportFailure(p, "is a directory, not a source file")
    if not os.access(p, os.R_OK):
        raise ImportFailure(p, "is not readable (permissions)")
    if p.stat().st_size == 0:
        raise ImportFailure(p, "file is empty")
    if fmt is not None and fmt not in FORMATS:
        raise ImportFailure(p, f"unknown source format {fmt!r} (one of: {', '.join(FORMATS)})")
    fmt = fmt or _EXTENSIONS.get(p.suffix.lower()) or _sniff(p)
    if fmt in ("rosbag2", "mcap", "parquet"):
        return _open_other(p, fmt)
    if fmt == "matlab":
        return _open_mat(p)
    if fmt == "hdf5":
        return _open_hdf5(p, matlab=False)
    return _open_text(p, "\t" if fmt == "tsv" and delimiter is None else delimiter, fmt, encoding or "utf-8")


def _open_other(p: Path, fmt: str) -> Source:
    """The readers of the formats kept in their own modules."""
    if fmt == "parquet":
        from .tables import open_parquet

        return open_parquet(p)
    from .messages import open_messages

    return open_messages(p, fmt)


def _sniff(p: Path) -> str:
    head = p.open("rb").read(512)
    if head.startswith(b"MATLAB"):
        return "matlab"
    if head.startswith(b"\x89HDF"):
        return "hdf5"
    if head.startswith(b"\x89MCAP"):
        return "mcap"
    if head.startswith(b"PAR1"):
        return "parquet"
    if head.startswith(b"SQLite format 3\x00"):
        return "rosbag2"
    return "csv"


def _is_hdf5(p: Path) -> bool:
    import h5py

    return h5py.is_hdf5(str(p))


def _open_mat(p: Path) -> Source:
    if _is_hdf5(p):
        return _open_hdf5(p, matlab=True)
    import scipy.io

    try:
        listing = scipy.io.whosmat(str(p))
    except Exception as e:  # scipy raises ValueError, TypeError, OSError... on a foreign file
        listing = _listing_by_loading(p, e)
    shapes, what = {}, {}
    for name, shape, cls in listing:
        shapes[name] = tuple(shape)
        if cls not in ("double", "single", "int8", "uint8", "int16", "uint16", "int32", "uint32", "int64", "uint64",
                       "logical"):
            what[name] = cls
        if cls == "struct" and tuple(shape) == (1, 1):  # its fields, "name/field" as in a v7.3 (HDF5) file
            for field_name, a in _struct_fields(name, _read_mat5(p, [name])[name]):
                a = np.asarray(a)
                shapes[field_name] = tuple(a.shape) if a.ndim == 2 else (a.size, 1) if a.ndim == 1 else a.shape
                if a.dtype.kind not in "fiub":
                    what[field_name] = "struct" if a.dtype.names else "char" if a.dtype.kind == "U" else str(a.dtype)
    return Source(p, "matlab-v5", shapes, what)


def _listing_by_loading(p: Path, e: Exception) -> list:
    """whosmat's (name, shape, class) from the loaded file: scipy's whosmat fails on some
    files it reads (a MATLAB object among the variables, as a saved SerialLink)."""
    import scipy.io

    try:
        raw = scipy.io.loadmat(str(p))
    except Exception:
        raise ImportFailure(p, f"is not a MATLAB file (v5, or v7.3 which is HDF5): {_reason(e)}") from None
    out = []
    for name, a in raw.items():
        if name.startswith("__") or not isinstance(a, np.ndarray):
            continue
        cls = "struct" if a.dtype.names else "char" if a.dtype.kind == "U" else "object" if a.dtype.kind == "O" \
            else "double" if a.dtype.kind in "fiub" else str(a.dtype)
        out.append((name, a.shape, cls))
    return out


def _read_mat5(p: Path, names) -> dict:
    import scipy.io

    try:
        return scipy.io.loadmat(str(p), variable_names=names)
    except Exception as e:
        raise ImportFailure(p, f"cannot be read as MATLAB v5: {_reason(e)}") from None


def _struct_fields(name: str, a):
    """("name/field", value) of a 1 x 1 MATLAB struct, nested 1 x 1 structs walked."""
    a = np.asarray(a)
    if not a.dtype.names or a.size != 1:
        return
    rec = a.reshape(-1)[0]
    for f in a.dtype.names:
        v = np.asarray(rec[f])
        if v.dtype.names and v.size == 1:
            yield from _struct_fields(f"{name}/{f}", v)
        else:
            yield f"{name}/{f}", v


def _reason(e: Exception) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def _load_mat5(src: Source, names) -> dict:
    tops = sorted({n.split("/", 1)[0] for n in names})
    raw = _read_mat5(src.path, tops)
    fields = dict(kv for t in tops for kv in _struct_fields(t, raw[t]))  # a struct's fields, "name/field"
    return {n: _numbers(src, n, fields[n] if n in fields else raw[n]) for n in names}


def _numbers(src: Source, name: str, a) -> np.ndarray:
    a = np.asarray(a)
    if a.dtype.kind == "c":
        raise ImportFailure(src.path, "holds complex numbers", variable=name)
    if a.dtype.kind not in "fiub":
        raise ImportFailure(src.path, f"is not an array of numbers (type {a.dtype})", variable=name)
    a = a.astype(float, copy=False)
    return a.reshape(1, 1) if a.ndim == 0 else (a[:, None] if a.ndim == 1 else a)


def _open_hdf5(p: Path, matlab: bool) -> Source:
    import h5py

    shapes, what = {}, {}
    try:
        f = h5py.File(str(p), "r")
    except Exception as e:
        raise ImportFailure(p, f"is not an HDF5 file: {_reason(e)}") from None
    with f:
        def visit(name, obj):
            if name.startswith("#") or not isinstance(obj, h5py.Dataset):
                return
            shape = tuple(obj.shape[::-1]) if matlab else tuple(obj.shape)
            shapes[name] = shape
            cls = obj.attrs.get("MATLAB_class", b"double")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if obj.dtype.kind not in "fiub" or cls in ("char", "cell", "struct", "function_handle"):
                what[name] = cls if matlab else f"dataset of {obj.dtype}"

        f.visititems(visit)
    return Source(p, "matlab-v7.3" if matlab else "hdf5", shapes, what)


def _load_hdf5(src: Source, names) -> dict:
    import h5py

    out = {}
    with h5py.File(str(src.path), "r") as f:
        for n in names:
            a = f[n][()]
            # MATLAB writes column-major: h5py sees the transpose of what MATLAB shows
            out[n] = _numbers(src, n, a.T if src.format == "matlab-v7.3" else a)
    return out


def _open_text(p: Path, delimiter: str | None, fmt: str, encoding: str = "utf-8") -> Source:
    """The header of a text file: its first line that is neither blank nor a ``#`` comment;
    the data start at the byte after it (``Source.data_offset``)."""
    offset, lineno, line = 0, 0, ""
    with p.open("rb") as f:
        for lineno, raw in enumerate(f, start=1):
            start = 3 if lineno == 1 and raw.startswith(b"\xef\xbb\xbf") else 0   # a UTF-8 byte-order mark
            try:
                line = raw[start:].decode(encoding)
            except UnicodeDecodeError as e:
                at = offset + start + e.start
                raise ImportFailure(p, f"is not a text file in {encoding} (byte 0x{raw[start + e.start]:02x} at byte "
                                       f"{at}); a MATLAB file needs the .mat extension or [source] format = "
                                       f"\"matlab\"; a text file in another encoding [source] encoding = "
                                       f"\"latin-1\" (for example)") from None
            except LookupError:
                raise ImportFailure(p, f"unknown text encoding {encoding!r} ([source] encoding)") from None
            control = next((c for c in line if ord(c) < 32 and c not in "\t\r\n"), None)
            if control is not None:
                raise ImportFailure(p, f"is not a text file (control byte 0x{ord(control):02x} on line {lineno}); a "
                                       f"MATLAB file needs the .mat extension or [source] format = \"matlab\"")
            offset += len(raw)
            if line.strip() and not line.lstrip().startswith("#"):
                break
        else:
            raise ImportFailure(p, "has no header line (only blank or comment lines)")
    if delimiter is None:
        delimiter = max([",", ";", "\t"], key=line.count)
    header = [h.strip() for h in next(csv.reader([line], delimiter=delimiter))]
    if len(header) < 2 or any(not h for h in header):
        empty = [i + 1 for i, h in enumerate(header) if not h]
        why = f"field(s) {empty} are empty" if empty else "it has a single field"
        raise ImportFailure(p, f"line {lineno} is not a header of column names ({why}; delimiter {delimiter!r})")
    dup = [h for h in header if header.count(h) > 1]
    what = {h: "column named twice in the header (ambiguous)" for h in dup}
    return Source(p, fmt, {h: (None, 1) for h in header}, what, delimiter=delimiter, header_line=lineno,
                  data_offset=offset, encoding=encoding)


class _Counted:
    """A binary file that moves a progress bar by the bytes read."""

    def __init__(self, f, bar):
        self.f, self.bar, self.closed = f, bar, False

    def read(self, n=-1):
        b = self.f.read(n)
        self.bar.update(len(b))
        return b

    def readable(self):
        return True

    def close(self):
        self.closed = True


def _load_text(src: Source, names, progress) -> dict:
    """Arrow's C++ CSV reader on the columns needed; anything it refuses (a word in a number
    column, a comment line, a short row) goes to the slower pass that says where."""
    import pyarrow as pa
    import pyarrow.csv as pcsv
    from tqdm import tqdm

    header = list(src.shapes)
    size = src.path.stat().st_size
    try:
        with src.path.open("rb") as raw, tqdm(total=size, unit="B", unit_scale=True, desc=f"reading {src.path.name}",
                                              delay=1.0, leave=False,
                                              disable=None if progress is None else not progress) as bar:
            raw.seek(src.data_offset)
            bar.update(src.data_offset)
            table = pcsv.read_csv(
                _Counted(raw, bar),
                read_options=pcsv.ReadOptions(column_names=header, block_size=1 << 22, encoding=src.encoding),
                parse_options=pcsv.ParseOptions(delimiter=src.delimiter),
                convert_options=pcsv.ConvertOptions(include_columns=names,
                                                    column_types={n: pa.float64() for n in names}))
        return {n: table.column(n).to_numpy().astype(float, copy=False)[:, None] for n in names}
    except (pa.ArrowInvalid, pa.ArrowNotImplementedError, UnicodeDecodeError):
        return _load_text_slowly(src, names)


def _load_text_slowly(src: Source, names) -> dict:
    header = list(src.shapes)
    cols = [header.index(n) for n in names]
    parts = []
    with src.path.open("rb") as raw:
        raw.seek(src.data_offset)
        f = io.TextIOWrapper(raw, encoding=src.encoding, errors="replace", newline="")
        first = src.header_line + 1
        while True:
            lines = f.readlines(1 << 22)  # about 4 MB of lines at a time
            if not lines:
                break
            parts.append(_parse_lines(src, lines, first, cols, names))
            first += len(lines)
    data = np.vstack(parts) if parts else np.empty((0, len(names)))
    return {n: data[:, j:j + 1] for j, n in enumerate(names)}


def _parse_lines(src: Source, lines, first: int, cols, names) -> np.ndarray:
    """Numbers of the columns ``cols`` of ``lines`` (file lines ``first``...): numpy's
    parser, and on any refusal a line-by-line pass that says where (an empty cell or
    ``nan`` is a NaN, reported later with the other non-finite rows)."""
    try:
        return np.loadtxt(lines, delimiter=src.delimiter, usecols=cols, ndmin=2, dtype=float, quotechar='"',
                          comments="#")
    except ValueError:
        pass
    rows = []
    nfield = len(src.shapes)
    for k, line in enumerate(csv.reader(io.StringIO("".join(lines)), delimiter=src.delimiter)):
        if not line or all(not c.strip() for c in line) or line[0].lstrip().startswith("#"):
            continue
        lineno = first + k
        if len(line) != nfield:
            raise ImportFailure(src.path, f"line {lineno} has {len(line)} fields, the header has {nfield}")
        row = []
        for c, name in zip(cols, names):
            cell = line[c].strip()
            try:
                row.append(float(cell) if cell else np.nan)
            except ValueError:
                raise ImportFailure(src.path, f"line {lineno}: {cell!r} is not a number", variable=name) from None
        rows.append(row)
    return np.asarray(rows, dtype=float).reshape(-1, len(cols))
