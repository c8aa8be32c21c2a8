"""Recordings in the ``pkm-recording/1`` format: read, write, validate.

A recording is a CSV file with a header row and a JSON sidecar of the same name:

* ``time`` [s], strictly increasing, first column;
* per joint ``i = 1..nd``: ``q<i>`` [m or rad], ``qd<i>`` [m/s or rad/s], ``tau<i>``
  [N or N m, actuator effort applied], optional ``qref<i>`` and ``f_ext<i>`` [N or N m, a
  measured external effort on joint i, positive along +q_i: a known input, not missing
  physics; the sidecar's ``units.f_ext`` must state its unit];
* optional pose columns: ``x, y, z`` [m] and ``rx, ry, rz`` [rad] (6-PUS),
  ``x, y, z, theta`` (Quattro), ``X`` [m] (four-bar output); a robot that declares only
  some of the six components (a 3-RPS tripod: ``z, rx, ry``) takes either its own columns or
  the full pose ``x, y, z, rx, ry, rz`` (a 6-DOF tracker, which also sees the parasitic
  motion: :func:`full_pose_allowed`; ``Recording.pose_full``, and ``pose`` its declared columns);
* any further columns are kept in ``Recording.extra``.

Sidecar: ``{"format": "pkm-recording/1", "robot": "6pus" | "quattro" | "fourbar",
"parameters": {...}, "controller": {...}, "notes": "..."}``, optionally
``"joint_convention": {"sign": [...], "offset": [...]}`` for a recording made in other
joint coordinates than the model's: per joint, ``recorded = sign * model + offset``
(``sign`` +1 or -1; ``offset`` in m or rad, default 0).  The reader converts ``q``,
``qd``, ``qref``, ``tau`` and ``f_ext`` to the model's convention (``Recording.joint_convention``
keeps what was declared; written recordings are in the model's convention).

Further sidecar fields (``units``, ``derived``, ``sensors``, ``source``: written by
``cosim import``, docs/recording.md) are kept in ``Recording.sidecar`` and written back.

Scenarios export this; calibration and the discrepancy engine read it.  A bad file gets
one :class:`RecordingError` naming the file, the row (line number in the file) and the
column.

Example
-------
>>> import numpy as np
>>> from cosim.recording import Recording, write_recording, read_recording
>>> t = np.arange(5) * 1e-3
>>> rec = Recording(robot="fourbar", time=t, q=np.zeros((5, 1)), qd=np.zeros((5, 1)),
...                 tau=np.zeros((5, 1)))
>>> csv_path, json_path = write_recording("/tmp/example.csv", rec)
>>> read_recording(csv_path).q.shape
(5, 1)
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from ..jsonable import jsonable
from .data import (FORMAT, FULL_POSE, FULL_POSE_UNITS, Recording, RecordingError, _RESERVED, _facts,  # noqa: F401
                             _si_units, _validate, full_pose_allowed, sidecar_path)
from .read import iter_recording, read_recording  # noqa: F401


def write_recording(path, rec: Recording, float_format: str | None = None, progress: bool | None = False,
                    chunk_rows: int = 100_000) -> tuple[Path, Path]:
    """Write ``rec`` as a table (CSV, Parquet or HDF5) plus its JSON sidecar; returns both paths.

    Parameters
    ----------
    path : str or Path
        The table: ``.csv``, ``.parquet`` or ``.h5`` (``cosim.recording_io``; ``.csv`` is
        added to any other name); the sidecar is the same name with ``.json``.
    rec : Recording
        What to write (validated first: shapes, time strictly increasing, every value finite).
    float_format : str, optional
        CSV only: printf format of every value; default the shortest text that reads back
        as the same double (Arrow's C++ writer: about ten times faster than formatting in
        Python).
    progress : bool or None
        A progress bar over the rows (None: on a terminal only).
    chunk_rows : int
        Rows formatted per write.

    Example
    -------
    >>> import numpy as np
    >>> rec = Recording(robot="fourbar", time=np.arange(3) * 1e-3, q=np.zeros((3, 1)),
    ...                 qd=np.zeros((3, 1)), tau=np.zeros((3, 1)))
    >>> write_recording("/tmp/three.csv", rec)[1].name
    'three.json'
    """
    from tqdm import tqdm

    from ..recording_io import SUFFIXES, write_table

    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        path = path.with_suffix(".csv")
    _validate(rec, path)
    path.parent.mkdir(parents=True, exist_ok=True)
    table, n = rec.table(), len(rec.time)
    with tqdm(total=n, unit="row", desc=f"writing {path.name}", delay=1.0, leave=False,
              disable=None if progress is None else not progress) as bar:
        if float_format is None or SUFFIXES[path.suffix.lower()] != "csv":
            write_table(path, rec.column_names(), table, chunk_rows=chunk_rows, bar=bar)
        else:
            with open(path, "w") as f:
                f.write(",".join(rec.column_names()) + "\n")
                for k in range(0, n, chunk_rows):
                    np.savetxt(f, table[k:k + chunk_rows], delimiter=",", fmt=float_format)
                    bar.update(min(chunk_rows, n - k))
    return path, _write_sidecar(path, rec)


def write_recording_blocks(path, blocks, progress: bool | None = False) -> tuple[Path, Path]:
    """Write consecutive :class:`Recording` blocks (one robot, the first block's sidecar
    fields, time increasing across blocks) as one recording; memory is one block, so a
    recording of any length can be written.  Returns the table's and the sidecar's paths.

    Example
    -------
    >>> import numpy as np
    >>> parts = [Recording(robot="fourbar", time=(np.arange(3) + 3 * k) * 1e-3, q=np.zeros((3, 1)),
    ...                    qd=np.zeros((3, 1)), tau=np.zeros((3, 1))) for k in range(4)]
    >>> len(read_recording(write_recording_blocks("/tmp/parts.h5", parts)[0]))
    12
    """
    from tqdm import tqdm

    from ..recording_io import SUFFIXES, TableWriter

    path = Path(path)
    if path.suffix.lower() not in SUFFIXES:
        path = path.with_suffix(".csv")
    path.parent.mkdir(parents=True, exist_ok=True)
    first, writer, rows = None, None, 0
    with tqdm(unit="row", desc=f"writing {path.name}", delay=1.0, leave=False,
              disable=None if progress is None else not progress) as bar:
        try:
            for b in blocks:
                _validate(b, path)
                if first is None:
                    first, writer = b, TableWriter(path, b.column_names())
                elif b.column_names() != writer.header:
                    raise RecordingError(path, f"block at row {rows + 2} has columns {b.column_names()}, the first "
                                               f"block {writer.header}")
                elif b.time[0] <= last:
                    raise RecordingError(path, f"time goes back between blocks ({last!r} then {b.time[0]!r})",
                                         row=rows + 2, column="time")
                writer.write(b.table())
                rows, last = rows + len(b), b.time[-1]
                bar.update(len(b))
        finally:
            if writer is not None:
                writer.close()
    if first is None:
        raise RecordingError(path, "no blocks to write")
    return path, _write_sidecar(path, first)


def _write_sidecar(path: Path, rec: Recording) -> Path:
    facts = _facts(rec.robot)
    meta = {"format": FORMAT, "robot": rec.robot, "parameters": rec.parameters,
            "controller": rec.controller, "notes": rec.notes, "units": _si_units(facts, rec)}
    meta.update({k: v for k, v in rec.sidecar.items() if k not in _RESERVED and k != "units"})
    side = sidecar_path(path)
    if facts is not None and facts.file:
        # A robot compiled from a description file: where it came from (relative to the
        # sidecar, so that a folder holding both can move) and the description itself, so
        # that a process that does not know the name can read the recording anywhere.
        src = Path(facts.file).resolve()
        meta["robot_file"] = os.path.relpath(src, side.parent.resolve())
        try:
            meta["robot_description"] = src.read_text()
        except OSError:
            pass
    side.write_text(json.dumps(meta, indent=2, default=jsonable))
    return side
