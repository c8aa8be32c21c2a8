"""Reading a recording: the sidecar and the table checked column by column, whole
(:func:`read_recording`) or in blocks of rows (:func:`iter_recording`), with the units, the
pose's scale and a declared joint convention (:mod:`cosim.recording`).
"""
from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .data import (FORMAT, FULL_POSE, FULL_POSE_UNITS, Recording, RecordingError, _RESERVED,
                             _declared, _described, _facts, _known, full_pose_allowed, sidecar_path)


def read_recording(path, robot: str | None = None) -> Recording:
    """Read and validate a ``pkm-recording/1`` table (CSV, Parquet or HDF5) and its sidecar.

    Parameters
    ----------
    path : str or Path
        The table (``.csv``, ``.parquet``, ``.h5``; the extension may be omitted).
    robot : str, optional
        Expected robot; also used if the sidecar is missing.

    Raises
    ------
    RecordingError
        Naming the file, row and column of the first problem: a missing sidecar or
        column, an unknown robot, a cell that is not a finite number, time not strictly
        increasing, too few rows.  Rows are file lines in a CSV, 1-based data rows in
        Parquet and HDF5.

    Example
    -------
    >>> import numpy as np
    >>> rec = Recording(robot="fourbar", time=np.arange(3) * 1e-3, q=np.zeros((3, 1)),
    ...                 qd=np.zeros((3, 1)), tau=np.ones((3, 1)))
    >>> read_recording(write_recording("/tmp/three.parquet", rec)[0]).tau[:, 0]
    array([1., 1., 1.])
    """
    path, side, meta, rname, nd, pose_cols = _open(path, robot)
    header, data = _read_table(path)
    layout = _layout(path, side, meta, rname, nd, pose_cols, header)
    if len(data) < 2:
        raise RecordingError(path, f"has {len(data)} data row(s); at least 2 are needed", row=len(data) + 2)
    return _block(layout, data, 0)


def iter_recording(path, robot: str | None = None, chunk_rows: int = 100_000):
    """The recording as consecutive :class:`Recording` blocks of at most ``chunk_rows``
    rows: memory is one block whatever the length of the file (one hour at 1 kHz is 3.6e6
    rows).  Validated as :func:`read_recording` does (time increasing across blocks too).

    Example
    -------
    >>> import numpy as np
    >>> rec = Recording(robot="fourbar", time=np.arange(10) * 1e-3, q=np.zeros((10, 1)),
    ...                 qd=np.zeros((10, 1)), tau=np.zeros((10, 1)))
    >>> csv_path, _ = write_recording("/tmp/ten.csv", rec)
    >>> [len(b) for b in iter_recording(csv_path, chunk_rows=4)]
    [4, 4, 2]
    """
    from ..recording_io import TableUnreadable, iter_blocks, table_format

    path, side, meta, rname, nd, pose_cols = _open(path, robot)
    fmt = table_format(path)
    header = _csv_header(path) if fmt == "csv" else _table_header(path, fmt)
    layout = _layout(path, side, meta, rname, nd, pose_cols, header)
    row0, last = 0, None
    try:
        for data in iter_blocks(path, header, chunk_rows, fmt):
            if not np.isfinite(data).all():
                raise TableUnreadable("a value is not finite")
            if last is not None and len(data) and data[0, 0] <= last:
                raise TableUnreadable("time goes back between blocks")
            yield _block(layout, data, row0)
            row0 += len(data)
            last = data[-1, 0] if len(data) else last
    except TableUnreadable as e:
        # the whole-file readers say where (a cell and its line, time going back); memory
        # is the file's only on this error path
        _block(layout, _read_table(path)[1], 0)
        raise RecordingError(path, str(e)) from None
    if row0 < 2:
        raise RecordingError(path, f"has {row0} data row(s); at least 2 are needed", row=row0 + 2)


def _open(path, robot):
    """The table's path, its sidecar's path and content, the robot's name, joints and pose
    columns (the sidecar checked)."""
    from ..recording_io import SUFFIXES

    path = Path(path)
    if not path.exists():
        for suffix in SUFFIXES:
            if path.with_suffix(suffix).exists():
                path = path.with_suffix(suffix)
                break
    if not path.exists():
        raise RecordingError(path, "file not found")
    if path.is_dir():
        raise RecordingError(path, "is a directory, not a recording")
    side = sidecar_path(path)
    meta = {}
    if side.exists():
        try:
            meta = json.loads(side.read_text())
        except json.JSONDecodeError as e:
            raise RecordingError(side, f"sidecar is not valid JSON: {e.msg}", row=e.lineno) from None
        if not isinstance(meta, dict):
            raise RecordingError(side, "sidecar must be a JSON object")
        if meta.get("format") != FORMAT:
            raise RecordingError(side, f"format is {meta.get('format')!r}, expected {FORMAT!r}")
    elif robot is None:
        raise RecordingError(path, f"JSON sidecar {side.name} is missing (it names the robot)")
    rname = meta.get("robot", robot)
    if robot is not None and rname != robot:
        raise RecordingError(side, f"recording is of robot {rname!r}, expected {robot!r}")
    facts = _facts(rname) if isinstance(rname, str) else None
    if facts is None and isinstance(rname, str) and (isinstance(meta.get("robot_file"), str)
                                                     or isinstance(meta.get("robot_description"), str)):
        facts = _described(side, rname, meta.get("robot_file"), meta.get("robot_description"))
    if facts is None:
        raise RecordingError(side, f"unknown robot {rname!r} (known: {_known()})")
    _check_units(side, meta.get("units"), rname)
    return path, side, meta, rname, facts.ndof, list(facts.tracker_names)


def _table_header(path, fmt):
    from ..recording_io import TableUnreadable, read_header

    try:
        return read_header(path, fmt)
    except TableUnreadable as e:
        raise RecordingError(path, str(e)) from None


def _read_table(path):
    """(header, data (n, ncol)) of a table: Arrow's readers; for a CSV they refuse (a word,
    a short row, a non-finite value), the careful reader that names the line and column."""
    from ..recording_io import TableUnreadable, read_table, table_format

    fmt = table_format(path)
    if fmt == "csv":
        header = _csv_header(path)
        if len(set(header)) == len(header):
            try:
                data = read_table(path, header, "csv")
                if np.isfinite(data).all():
                    return header, data
            except TableUnreadable:
                pass
        rows, header = _read_rows(path)
        return header, np.asarray(rows, dtype=float).reshape(len(rows), len(header))
    header = _table_header(path, fmt)
    try:
        data = read_table(path, header, fmt)
    except TableUnreadable as e:
        raise RecordingError(path, str(e)) from None
    bad = np.argwhere(~np.isfinite(data))
    if bad.size:
        r, c = bad[0]
        raise RecordingError(path, f"value {float(data[r, c])!r} is not a finite number", row=int(r) + 1,
                             column=header[c])
    return header, data


def _check_units(side, units, robot):
    """A sidecar may state its units; they must be the robot's SI units (no conversion is
    made, so a recording in mm or degrees is refused naming the field, not misread)."""
    if units is None:
        return
    if not isinstance(units, dict):
        raise RecordingError(side, f"units must be an object of column: unit, got {units!r}")
    from ..core.model import robot_facts

    f = robot_facts(robot)
    want = {"time": "s", "q": f.joint_unit, "qref": f.joint_unit, "qd": f"{f.joint_unit}/s",
            "tau": f.effort_unit, "f_ext": f.effort_unit, "tau_meas": f.effort_unit}
    for key, unit in units.items():
        if key in want and unit != want[key]:
            raise RecordingError(side, f"units.{key} = {unit!r}: a pkm-recording/1 file is in the robot's SI units "
                                       f"({key} in {want[key]}); convert the column (e.g. mm -> m) and drop or fix "
                                       f"the field")
        full = full_pose_allowed(f) and isinstance(unit, list) and len(unit) == 6
        want_pose = list(FULL_POSE_UNITS) if full else list(f.tracker_units)
        if key in ("pose", "x") and isinstance(unit, list) and list(unit) != want_pose:
            raise RecordingError(side, f"units.{key} = {unit!r}: the pose columns must be in {want_pose}")


def _check_pose_scale(path, robot, pose_cols, col):
    """Pose columns far beyond any robot's reach are a unit slip (mm for m, degrees for rad):
    say so, naming the column, instead of letting a later step fail on unreachable poses."""
    from ..core.model import robot_facts

    facts = robot_facts(robot)
    units = FULL_POSE_UNITS if list(pose_cols) == list(FULL_POSE) else facts.tracker_units
    for c, unit in zip(pose_cols, units):
        big = float(np.max(np.abs(col[c])))
        if unit == "m" and big > 2.0:
            raise RecordingError(path, f"values up to {big:g} m: was the column written in mm? (the format is in m)",
                                 column=c)
        if unit == "rad" and big > 2 * math.pi:
            raise RecordingError(path, f"values up to {big:g} rad: was the column written in degrees? (the format "
                                       f"is in rad)", column=c)


def _csv_header(path):
    """The header row of a CSV table (stripped names)."""
    try:
        with open(path, newline="") as f:
            line = next(csv.reader(f), None)
    except UnicodeDecodeError as e:
        raise RecordingError(path, f"is not a text CSV file (byte 0x{e.object[e.start]:02x} at byte {e.start} is not "
                                   f"UTF-8): not a pkm-recording/1 file") from None
    if line is None:
        raise RecordingError(path, "file is empty (no header row)", row=1)
    return [h.strip() for h in line]


def _read_rows(path):
    """Every row of a CSV table as floats, cell by cell: slow, but says where a cell is wrong."""
    header = _csv_header(path)
    with open(path, newline="", errors="replace") as f:
        reader = csv.reader(f)
        next(reader)
        rows = []
        for lineno, row in enumerate(reader, start=2):
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != len(header):
                raise RecordingError(path, f"has {len(row)} fields, the header has {len(header)}", row=lineno)
            vals = []
            for c, cell in enumerate(row):
                try:
                    v = float(cell)
                except ValueError:
                    raise RecordingError(path, f"{cell!r} is not a number", row=lineno, column=header[c]) from None
                if not math.isfinite(v):
                    raise RecordingError(path, f"value {cell.strip()!r} is not a finite number", row=lineno,
                                         column=header[c])
                vals.append(v)
            rows.append(vals)
    return rows, header


@dataclass
class _Layout:
    """What the header and sidecar say of a table's columns (checked once, used per block)."""

    path: Path
    side: Path
    meta: dict
    robot: str
    nd: int
    pose_cols: list
    header: list
    has_qref: bool
    has_fext: bool
    has_pose: bool
    known: set
    sign: np.ndarray
    offset: np.ndarray
    convention: dict
    first_row: int      # how the first data row is numbered in messages (a CSV's line 2)


def _layout(path, side, meta, rname, nd, pose_cols, header) -> _Layout:
    from ..recording_io import table_format

    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise RecordingError(path, "column appears twice in the header", row=1, column=dup)
    if not header or header[0] != "time":
        raise RecordingError(path, f"first column must be 'time', found {header[0] if header else ''!r}", row=1,
                             column=header[0] if header else None)
    required = [f"{k}{i}" for i in range(1, nd + 1) for k in ("q", "qd", "tau")]
    for col in required:
        if col not in header:
            hint = ("; a rate not measured can be derived from the positions: cosim import, "
                    "derive = \"central_difference\" (docs/importing.md)" if col.startswith("qd") else "")
            raise RecordingError(path, f"required column is missing for robot {rname} ({nd} joints){hint}", row=1,
                                 column=col)

    def all_or_none(prefix, what):
        has = [f"{prefix}{i}" in header for i in range(1, nd + 1)]
        if any(has) and not all(has):
            raise RecordingError(path, f"{what} columns must be given for all joints or none", row=1,
                                 column=f"{prefix}{has.index(False) + 1}")
        return all(has)

    has_qref = all_or_none("qref", "qref")
    has_fext = all_or_none("f_ext", "f_ext (external effort)")
    if has_fext and not (isinstance(meta.get("units"), dict) and "f_ext" in meta["units"]):
        raise RecordingError(side, f"the recording has f_ext columns but the sidecar does not state their unit: add "
                                   f'"units": {{"f_ext": "{_facts(rname).effort_unit}"}} (the joints\' effort unit)')
    if "tau_meas1" in header and not (isinstance(meta.get("units"), dict) and "tau_meas" in meta["units"]):
        raise RecordingError(side, f"the recording has a measured effort (tau_meas columns) but the sidecar does not "
                                   f'state its unit: add "units": {{"tau_meas": "{_facts(rname).effort_unit}"}}')
    facts = _facts(rname)
    if full_pose_allowed(facts):
        others = [c for c in FULL_POSE if c not in pose_cols]
        seen = [c in header for c in others]
        if all(seen):
            pose_cols = list(FULL_POSE)  # a 6-DOF tracker: the declared components and the others
        elif any(seen):
            raise RecordingError(path, f"the full pose ({' '.join(FULL_POSE)}) must be given whole: "
                                       f"{', '.join(c for c, k in zip(others, seen) if k)} without this column",
                                 row=1, column=others[seen.index(False)])
    has_pose = [c in header for c in pose_cols]
    if any(has_pose) and not all(has_pose):
        missing = pose_cols[has_pose.index(False)]
        raise RecordingError(path, "pose columns must be given all or none", row=1, column=missing)
    known = set(required) | {"time"} | {f"{k}{i}" for k in ("qref", "f_ext") for i in range(1, nd + 1)} | set(pose_cols)
    sign, offset, conv = _joint_convention(side, meta.get("joint_convention"), nd)
    return _Layout(path, side, meta, rname, nd, pose_cols, header, has_qref, has_fext, all(has_pose), known, sign,
                   offset, conv, 2 if table_format(path) == "csv" else 1)


def _block(lay: _Layout, data: np.ndarray, row0: int) -> Recording:
    """The rows ``data`` (n, ncol) of a table, the first being data row ``row0`` (0-based),
    as a checked :class:`Recording` in the model's joint convention."""
    col = {h: data[:, j] for j, h in enumerate(lay.header)}
    t = col["time"]
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise RecordingError(lay.path, f"time is not strictly increasing ({t[k - 1]:.17g} then {t[k]:.17g})",
                             row=row0 + k + lay.first_row, column="time")

    def stack(prefix):
        return np.column_stack([col[f"{prefix}{i}"] for i in range(1, lay.nd + 1)])

    if lay.has_pose:
        _check_pose_scale(lay.path, lay.robot, lay.pose_cols, col)
    sign, offset, meta = lay.sign, lay.offset, lay.meta
    return Recording(
        robot=lay.robot,
        time=t,
        q=sign * (stack("q") - offset),
        qd=sign * stack("qd"),
        tau=sign * stack("tau"),
        qref=sign * (stack("qref") - offset) if lay.has_qref else None,
        pose=(np.column_stack([col[c] for c in lay.pose_cols])[:, _declared(lay.robot)]
              if lay.has_pose and lay.pose_cols == list(FULL_POSE) and lay.nd < 6 else
              np.column_stack([col[c] for c in lay.pose_cols]) if lay.has_pose else None),
        pose_full=(np.column_stack([col[c] for c in FULL_POSE])
                   if lay.has_pose and lay.pose_cols == list(FULL_POSE) and lay.nd < 6 else None),
        extra={h: col[h] for h in lay.header if h not in lay.known},
        parameters=meta.get("parameters") or {},
        controller=meta.get("controller") or {},
        notes=meta.get("notes", ""),
        path=lay.path,
        joint_convention=lay.convention,
        f_ext=sign * stack("f_ext") if lay.has_fext else None,
        sidecar={k: v for k, v in meta.items() if k not in _RESERVED},
    )


def _joint_convention(side, conv, nd):
    """``(sign, offset, declared)`` of a sidecar's ``joint_convention`` (recorded = sign *
    model + offset per joint); identity when absent.  A bad field is a RecordingError
    naming it."""
    if conv is None:
        return np.ones(nd), np.zeros(nd), {}
    if not isinstance(conv, dict) or set(conv) - {"sign", "offset"}:
        raise RecordingError(side, 'joint_convention must be {"sign": [...], "offset": [...]} (recorded = sign * '
                                   'model + offset per joint)')
    out = []
    for key, default in (("sign", 1.0), ("offset", 0.0)):
        v = conv.get(key, [default] * nd)
        if not isinstance(v, list) or len(v) != nd:
            raise RecordingError(side, f"joint_convention.{key} must be a list of {nd} numbers, one per joint")
        for i, e in enumerate(v):
            ok = isinstance(e, (int, float)) and not isinstance(e, bool) and math.isfinite(e)
            if not ok or (key == "sign" and e not in (1, -1)):
                want = "+1 or -1" if key == "sign" else "a finite number [m or rad]"
                raise RecordingError(side, f"joint_convention.{key}[{i}] = {e!r} must be {want} (joint {i + 1})")
        out.append(np.asarray(v, float))
    return out[0], out[1], {"sign": out[0].tolist(), "offset": out[1].tolist()}
