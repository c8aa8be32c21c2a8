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

import csv
import json
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .jsonable import jsonable
from .errors import InputError

FORMAT = "pkm-recording/1"


def _facts(robot):
    """The core's facts of a robot (joints, tracker columns; cached by the core module), or
    None if it knows none."""
    from .core.model import robot_facts
    from .errors import PkmError

    try:
        return robot_facts(robot)
    except (PkmError, TypeError):
        return None


def _described(side, name, file, text=None):
    """The facts of a robot the core does not know by name, from the description file the
    sidecar names (relative to the sidecar, or absolute in recordings written before the
    path was made relative), else from the description the sidecar carries.  The core then
    knows the robot by name for the rest of the process."""
    from .core.model import Model
    from .errors import PkmError

    src = None
    if isinstance(file, str):
        p = Path(file)
        p = p if p.is_absolute() else side.parent / p
        if p.exists():
            src = p
    if src is None and isinstance(text, str):
        # the sidecar's own copy, written where the core can read it for the whole process
        global _CARRIED
        if _CARRIED is None:
            _CARRIED = Path(tempfile.mkdtemp(prefix="pkm-robots-"))
        src = _CARRIED / (Path(file).name if isinstance(file, str) else f"{name}.toml")
        src.write_text(text)
    if src is None:
        raise RecordingError(side, f"robot {name!r} is not one the core knows and its description file {file} "
                                   f"is gone (known: {_known()}; or set PKM_ROBOT_PATH, docs/robots.md)")
    try:
        m = Model(str(src))
    except PkmError as e:
        raise RecordingError(side, f"robot {name!r}: its description file {file} does not load: {e}") from None
    if m.robot != name:
        raise RecordingError(side, f"the description file {file} is of robot {m.robot!r}, the recording of {name!r}")
    return _facts(name)


#: folder of the descriptions carried by sidecars (made on first use, kept for the process)
_CARRIED = None


#: the six components of a platform's pose, in the core's order, with their units
FULL_POSE = ("x", "y", "z", "rx", "ry", "rz")
FULL_POSE_UNITS = ("m", "m", "m", "rad", "rad", "rad")


def _declared(robot) -> list:
    """Indices in x y z rx ry rz of a robot's tracker columns (:func:`full_pose_allowed`)."""
    return [FULL_POSE.index(n) for n in _facts(robot).tracker_names]


def full_pose_allowed(facts) -> bool:
    """Whether a recording of this robot may carry the full pose ``x y z rx ry rz`` instead of
    its own tracker columns: a robot whose tracker columns are some, not all, of the six
    platform components (a 3-PRS or 3-RPS head, a Delta, a five-bar), whose other components
    the core holds or solves (``Model.platform_pose``).  A 6-DOF tracker measures all six."""
    names = tuple(facts.tracker_names)
    return bool(names) and len(names) < 6 and set(names) <= set(FULL_POSE)


def _known():
    from .core.facts import robots

    return ", ".join(robots())


class RecordingError(InputError):
    """A malformed recording; the message names the file, row and column."""

    def __init__(self, path, message, row=None, column=None):
        where = str(path)
        if row is not None:
            where += f", row {row}"
        if column is not None:
            where += f", column {column!r}"
        super().__init__(f"{where}: {message}")
        self.path, self.row, self.column = path, row, column


@dataclass
class Recording:
    """One recorded (or simulated) run.

    Arrays have one row per sample: ``time`` (n,) [s]; ``q``, ``qd``, ``tau``, ``qref``
    (n, nd); ``pose`` (n, npose) in the robot's tracker columns (the core's
    ``RobotFacts.tracker_names``: the pose coordinates; ``X`` for the four-bar);
    ``f_ext`` (n, nd) [N or N m], the measured external effort on each joint (positive
    along +q_i), None when the recording has none; ``pose_full`` (n, 6), the full pose of a
    6-DOF tracker (:meth:`set_full_pose`), None when not recorded.
    """

    robot: str
    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    qref: np.ndarray | None = None
    pose: np.ndarray | None = None
    extra: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)
    notes: str = ""
    path: Path | None = None
    #: the joint convention the file declared (``sign``, ``offset`` per joint); the arrays
    #: are already in the model's convention.  Empty: the model's own.
    joint_convention: dict = field(default_factory=dict)
    #: measured external effort per joint (n, nd) [N or N m], None when not recorded
    f_ext: np.ndarray | None = None
    #: further sidecar fields, kept verbatim (``units``, ``derived``, ``sensors``, ``source``)
    sidecar: dict = field(default_factory=dict)
    #: the full pose x y z rx ry rz [m, rad] a 6-DOF tracker measured (n, 6), for a robot that
    #: declares some of the six (its parasitic components too); ``pose`` is then its declared
    #: columns.  None when the recording has the robot's own tracker columns only.
    pose_full: np.ndarray | None = None

    @property
    def ndof(self) -> int:
        return _facts(self.robot).ndof

    @property
    def pose_columns(self) -> list[str]:
        return list(_facts(self.robot).tracker_names)

    def set_full_pose(self, X) -> None:
        """Set the full pose a 6-DOF tracker measured, (n, 6) x y z rx ry rz [m, rad], and
        ``pose`` to its declared columns (a robot that declares some of the six:
        :func:`full_pose_allowed`)."""
        X = np.asarray(X, float)
        self.pose_full = X
        self.pose = X[:, _declared(self.robot)] if X.ndim == 2 and X.shape[1] == 6 else None

    def __len__(self) -> int:
        return len(self.time)

    def slice(self, start: int, stop: int) -> "Recording":
        """Rows ``start:stop`` as a new recording (same metadata)."""
        s = slice(start, stop)
        return Recording(
            self.robot, self.time[s], self.q[s], self.qd[s], self.tau[s],
            None if self.qref is None else self.qref[s],
            None if self.pose is None else self.pose[s],
            {k: v[s] for k, v in self.extra.items()},
            dict(self.parameters), dict(self.controller), self.notes, self.path, dict(self.joint_convention),
            f_ext=None if self.f_ext is None else self.f_ext[s], sidecar=dict(self.sidecar),
            pose_full=None if self.pose_full is None else self.pose_full[s],
        )

    def column_names(self) -> list[str]:
        nd = self.ndof
        cols = ["time"]
        for i in range(1, nd + 1):
            cols += [f"q{i}", f"qd{i}", f"tau{i}"] + ([f"qref{i}"] if self.qref is not None else [])
            cols += [f"f_ext{i}"] if self.f_ext is not None else []
        if self.pose_full is not None:
            cols += list(FULL_POSE)
        elif self.pose is not None:
            cols += self.pose_columns
        cols += list(self.extra)
        return cols

    def table(self) -> np.ndarray:
        """All columns as one (n, ncol) array in ``column_names()`` order."""
        nd, parts = self.ndof, [self.time[:, None]]
        for i in range(nd):
            parts += [self.q[:, i:i + 1], self.qd[:, i:i + 1], self.tau[:, i:i + 1]]
            if self.qref is not None:
                parts.append(self.qref[:, i:i + 1])
            if self.f_ext is not None:
                parts.append(self.f_ext[:, i:i + 1])
        if self.pose_full is not None:
            parts.append(self.pose_full)
        elif self.pose is not None:
            parts.append(self.pose)
        parts += [np.asarray(v, float)[:, None] for v in self.extra.values()]
        return np.hstack(parts)


def sidecar_path(csv_path) -> Path:
    return Path(csv_path).with_suffix(".json")


def _validate(rec: Recording, path) -> None:
    if _facts(rec.robot) is None:
        raise RecordingError(path, f"unknown robot {rec.robot!r} (known: {_known()})")
    n, nd = len(rec.time), rec.ndof
    for name in ("q", "qd", "tau", "qref", "f_ext"):
        a = getattr(rec, name)
        if a is None:
            continue
        if a.shape != (n, nd):
            raise RecordingError(path, f"{name} has shape {a.shape}, expected ({n}, {nd}) for robot {rec.robot}")
    if rec.pose is not None and rec.pose.shape != (n, len(rec.pose_columns)):
        raise RecordingError(path, f"pose has shape {rec.pose.shape}, expected ({n}, {len(rec.pose_columns)})")
    if rec.pose_full is not None:
        if not full_pose_allowed(_facts(rec.robot)):
            raise RecordingError(path, f"a full pose (x y z rx ry rz) is for a robot that declares some of them; "
                                       f"{rec.robot} declares {' '.join(rec.pose_columns)}")
        if rec.pose_full.shape != (n, 6):
            raise RecordingError(path, f"pose_full has shape {rec.pose_full.shape}, expected ({n}, 6)")
    bad = np.flatnonzero(np.diff(rec.time) <= 0)
    if bad.size:
        k = bad[0] + 1
        raise RecordingError(path, f"time is not strictly increasing ({rec.time[k - 1]!r} then {rec.time[k]!r})",
                             row=k + 2, column="time")
    tab = rec.table()
    nonfinite = np.argwhere(~np.isfinite(tab))
    if nonfinite.size:
        r, c = nonfinite[0]
        raise RecordingError(path, f"value {float(tab[r, c])!r} is not a finite number", row=r + 2,
                             column=rec.column_names()[c])


#: sidecar fields the format defines itself (``Recording.sidecar`` cannot override them)
_RESERVED = ("format", "robot", "parameters", "controller", "notes", "joint_convention", "robot_file",
             "robot_description")


def _si_units(facts, rec: Recording) -> dict:
    """The sidecar's ``units`` of a written recording: the robot's SI units, per kind of column."""
    ju, eu = facts.joint_unit, facts.effort_unit
    units = {"time": "s", "q": ju, "qd": f"{ju}/s", "tau": eu}
    if rec.pose_full is not None:
        units["pose"] = list(FULL_POSE_UNITS)
    if rec.qref is not None:
        units["qref"] = ju
    if rec.f_ext is not None:
        units["f_ext"] = eu
    if "tau_meas1" in rec.extra:  # a measured effort (a torque sensor, a current times its constant)
        units["tau_meas"] = eu
    if "inject1" in rec.extra:  # an injected signal (cosim.injection): an effort at the command
        point = (rec.sidecar.get("injection") or {}).get("point")
        units["inject"] = eu if point in ("command", "command_after_saturation") else ju
    return units


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

    from .recording_io import SUFFIXES, write_table

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

    from .recording_io import SUFFIXES, TableWriter

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
    from .recording_io import TableUnreadable, iter_blocks, table_format

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
    from .recording_io import SUFFIXES

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
    from .recording_io import TableUnreadable, read_header

    try:
        return read_header(path, fmt)
    except TableUnreadable as e:
        raise RecordingError(path, str(e)) from None


def _read_table(path):
    """(header, data (n, ncol)) of a table: Arrow's readers; for a CSV they refuse (a word,
    a short row, a non-finite value), the careful reader that names the line and column."""
    from .recording_io import TableUnreadable, read_table, table_format

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
    from .core.model import robot_facts

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
    from .core.model import robot_facts

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
    from .recording_io import table_format

    if len(set(header)) != len(header):
        dup = next(h for h in header if header.count(h) > 1)
        raise RecordingError(path, "column appears twice in the header", row=1, column=dup)
    if not header or header[0] != "time":
        raise RecordingError(path, f"first column must be 'time', found {header[0] if header else ''!r}", row=1,
                             column=header[0] if header else None)
    required = [f"{k}{i}" for i in range(1, nd + 1) for k in ("q", "qd", "tau")]
    for col in required:
        if col not in header:
            raise RecordingError(path, f"required column is missing for robot {rname} ({nd} joints)", row=1,
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
