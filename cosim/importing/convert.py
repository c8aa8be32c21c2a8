"""A source file and a map made into a pkm-recording (docs/importing.md)."""
from __future__ import annotations

import difflib
import time as _time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..recording import Recording, write_recording
from ..recording_io import EXTENSION
from . import angles
from . import units as U
from .errors import ImportFailure
from .mapfile import DERIVATIONS, JOINT_COLUMN, ImportMap, check_columns, read_map, si_unit
from .sources import Source, open_source


@dataclass
class Imported:
    """What :func:`import_recording` made: the recording, the files written (the table:
    CSV, Parquet or HDF5, and its sidecar), the source and how long it took [s]."""

    recording: Recording
    table: Path
    sidecar: Path
    source: Source
    seconds: float


def derive(x: np.ndarray, t: np.ndarray, method: str) -> np.ndarray:
    """The time derivative of ``x`` sampled at ``t`` by one of :data:`DERIVATIONS`.

    ``central_difference``: (x[k+1] - x[k-1]) / (t[k+1] - t[k-1]) inside, the one-sided
    difference at the first and last rows; ``backward_difference``: (x[k] - x[k-1]) /
    (t[k] - t[k-1]), the first row the forward difference.

    Example
    -------
    >>> t = np.arange(4) * 0.5
    >>> derive(t ** 2, t, "central_difference")
    array([0.5, 1. , 2. , 2.5])
    """
    if len(x) < 2:
        return np.zeros_like(x)
    dx, dt = np.diff(x), np.diff(t)
    if method == "backward_difference":
        d = dx / dt
        return np.concatenate([d[:1], d])
    out = np.empty_like(x)
    out[1:-1] = (x[2:] - x[:-2]) / (t[2:] - t[:-2])
    out[0], out[-1] = dx[0] / dt[0], dx[-1] / dt[-1]
    return out


def _missing(src: Source, var: str, column: str, role: str = "") -> ImportFailure:
    if hasattr(src, "missing"):  # a message log says topic and field (messages.py)
        return src.missing(var, column)
    names = list(src.shapes)
    close = difflib.get_close_matches(var, names, n=1)
    have = ", ".join(names[:20]) + (f", ... ({len(names)} in all)" if len(names) > 20 else "")
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return ImportFailure(src.path, f"{role}not in the file (it has: {have}){hint}", variable=var, column=column)


class _Resolver:
    """Scalars of the file, checked to be one number each, with what uses them."""

    def __init__(self, src: Source):
        self.src, self.uses, self.values = src, {}, {}

    def want(self, var: str, use: str) -> None:
        shape = self.src.shapes.get(var)
        if shape is None:
            raise _missing(self.src, var, use, role="scalar ")
        if None in shape or int(np.prod(shape)) != 1:
            what = "a column of the file" if None in shape else f"of shape {' x '.join(map(str, shape))}"
            raise ImportFailure(self.src.path, f"is {what}, not a scalar ({use} needs one number)", variable=var)
        self.uses.setdefault(var, use)

    def resolve(self, data: dict) -> None:
        for var, use in self.uses.items():
            v = float(data[var].item())
            if not np.isfinite(v):
                raise ImportFailure(self.src.path, f"is {v!r}, not a finite number ({use} needs one)", variable=var)
            self.values[var] = v

    def value(self, v):
        return self.values[v] if isinstance(v, str) else v


def _walk_variables(obj, where, found):
    """Every ``{ variable = "name" }`` inside a table: (field path, name)."""
    if isinstance(obj, dict):
        if set(obj) == {"variable"} and isinstance(obj["variable"], str):
            found.append((where, obj["variable"]))
            return
        for k, v in obj.items():
            _walk_variables(v, f"{where}.{k}", found)
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            _walk_variables(v, f"{where}[{i}]", found)


def _substitute(obj, values):
    if isinstance(obj, dict):
        if set(obj) == {"variable"} and isinstance(obj["variable"], str):
            return values[obj["variable"]]
        return {k: _substitute(v, values) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_substitute(v, values) for v in obj]
    return obj


def _model(m: ImportMap, robot: str | None, params: dict):
    from ..core.model import Model
    from ..errors import PkmError

    ref = robot if robot is not None else m.robot_ref()
    try:
        return Model(ref, params=params or None)
    except PkmError as e:
        if robot is not None:
            raise ImportFailure(robot, f"robot does not load: {e}") from None
        what = "robot or parameters" if params else "robot"
        raise ImportFailure(m.path, f"{what} {m.robot!r} does not load: {e}", field="robot") from None


def _vector(src: Source, var: str, a: np.ndarray, column: str, pick: int | None) -> np.ndarray:
    shape = a.shape
    if min(shape) == 1 and pick in (None, 1):
        return a.ravel()
    if min(shape) == 1:
        raise ImportFailure(src.path, f"is a vector, it has no column {pick}", variable=var, column=column)
    if pick is None:
        raise ImportFailure(src.path, f"is a matrix of shape {shape[0]} x {shape[1]}: say which column with "
                                      f"column = 1..{shape[1]} in the map", variable=var, column=column)
    if pick > shape[1]:
        raise ImportFailure(src.path, f"has {shape[1]} columns, the map asks for column {pick}", variable=var,
                            column=column)
    return a[:, pick - 1]


def to_recording(source, map_path, *, robot: str | None = None, progress: bool | None = None) -> Recording:
    """Read a source file through a map into a :class:`~cosim.recording.Recording` (not
    written; :func:`import_recording` writes it).

    Parameters
    ----------
    source : str or Path
        MATLAB (v5 or v7.3), HDF5, CSV or TSV file.
    map_path : str or Path
        The map (TOML, docs/importing.md).
    robot : str, optional
        A robot name or description file overriding the map's ``robot``.
    progress : bool or None
        A progress bar while reading a text file (None: on a terminal only).

    Raises
    ------
    ImportFailure
        One line naming the file, the variable or map field, the column and what is wrong.

    Example
    -------
    >>> import numpy as np, scipy.io
    >>> from pathlib import Path
    >>> t = np.arange(5) * 1e-3
    >>> scipy.io.savemat("/tmp/rig.mat", {"t": t[:, None], "a": np.sin(t)[:, None], "u": t[:, None], "g": 2.0})
    >>> _ = Path("/tmp/rig.toml").write_text('robot = "fourbar"\\n[columns]\\ntime = "t"\\n'
    ...     'q1 = { variable = "a", unit = "deg" }\\nqd1 = { derive = "central_difference" }\\n'
    ...     'tau1 = { variable = "u", scale = { variable = "g" } }\\n')
    >>> rec = to_recording("/tmp/rig.mat", "/tmp/rig.toml")
    >>> bool(rec.tau[-1, 0] == 2 * t[-1])
    True
    """
    return _convert(source, map_path, robot, progress)[0]


def _convert(source, map_path, robot, progress) -> tuple[Recording, Source]:
    m = read_map(map_path)
    model = _model(m, robot, {})
    facts = model.facts
    check_columns(m, facts)
    src = open_source(source, m.source.get("format"), m.source.get("delimiter"), m.source.get("encoding"))
    scal = _Resolver(src)
    for k, v in m.parameters.items():
        if isinstance(v, dict):
            scal.want(v["variable"], f"parameters.{k}")
    # which columns the file can feed; scalars each one needs
    present, absent = {}, []
    for name, c in m.columns.items():
        if c.derive or c.period is not None:
            present[name] = c
            continue
        if c.variable not in src.shapes:
            if c.optional:
                absent.append(name)
                continue
            raise _missing(src, c.variable, name)
        if None not in src.shapes[c.variable] and int(np.prod(src.shapes[c.variable])) == 0:
            raise ImportFailure(src.path, "is empty (0 values)", variable=c.variable, column=name)
        present[name] = c
        for what in ("scale", "offset"):
            v = getattr(c, what)
            if isinstance(v, str):
                scal.want(v, f"columns.{name}.{what}")
    for name, c in list(present.items()):
        if c.derive and c.source not in present:  # derived from an optional column that is absent
            del present[name]
            absent.append(name)
    found = []
    _walk_variables(m.controller, "controller", found)
    _walk_variables(m.sensors, "sensors", found)
    for where, var in found:
        scal.want(var, where)
    vectors = [c.variable for c in present.values() if c.variable]
    data = src.load(vectors + list(scal.uses), progress=progress)
    scal.resolve(data)
    params = {k: scal.value(v["variable"] if isinstance(v, dict) else v) for k, v in m.parameters.items()}
    if params:
        model = _model(m, robot, params)  # the names and values checked by the core

    # time first: every other column is checked against its length
    tc = m.columns["time"]
    cols, n, tvar = {}, None, tc.variable
    for name, c in present.items():
        if c.variable:
            a = data[c.variable]
            if c.row is not None:  # one signal per row: its row, as a column
                if c.row > a.shape[0]:
                    raise ImportFailure(src.path, f"has {a.shape[0]} rows, the map asks for row {c.row}",
                                        variable=c.variable, column=name)
                a = a[c.row - 1:c.row, :].T
            v = _vector(src, c.variable, a, name, c.column)
            if name == "time" or (tc.period is not None and n is None):
                n = len(v)
            cols[name] = v
    if tc.period is not None:
        tvar = f"period {tc.period:g}"
        cols["time"] = tc.start + tc.period * np.arange(n, dtype=float)
    for name, c in present.items():
        if not c.variable:
            continue
        v = cols[name]
        if len(v) != n:
            raise ImportFailure(src.path, f"has {len(v)} values, time ({tvar}) has {n}", variable=c.variable,
                                column=name)
    if n < 2:
        raise ImportFailure(src.path, f"has {n} sample(s); a recording needs at least 2", variable=tvar, column="time")
    for name, c in present.items():
        if c.derive:
            continue
        si = si_unit(name, facts)
        f = U.factor(c.unit, si) if c.unit is not None else 1.0
        raw = cols[name]
        scale, offset = scal.value(c.scale), scal.value(c.offset)
        v = raw if (scale, offset, f) == (1.0, 0.0, 1.0) else (raw * scale + offset) * f
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise ImportFailure(src.path, f"has {bad.size} non-finite value(s) (NaN, Inf or an empty cell) at "
                                          f"{src.row_label(bad)}", variable=c.variable or tvar, column=name)
        cols[name] = angles.wrap(v) if c.angle == "wrap" else angles.unwrap(v) if c.angle == "unwrap" else v
    t = cols["time"]
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        k = int(back[0]) + 1
        more = f" ({back.size} places in all)" if back.size > 1 else ""
        raise ImportFailure(src.path, f"time is not strictly increasing at {src.row_label([k])}: {float(t[k - 1])!r} "
                                      f"then {float(t[k])!r} s{more}", variable=tvar, column="time")
    angles.check_limits(model, src, cols, present)
    derived = {}
    for name, c in present.items():
        if c.derive:
            x = cols[c.source]  # a wrapped angle's rate is its continuous angle's
            cols[name] = derive(angles.unwrap(x) if present[c.source].angle == "wrap" else x, t, c.derive)
            derived[name] = {"from": c.source, "method": c.derive, "formula": DERIVATIONS[c.derive]}
    return _assemble(m, src, facts, cols, present, absent, derived, scal), src


def _assemble(m, src, facts, cols, present, absent, derived, scal) -> Recording:
    nd = facts.ndof

    def block(prefix, required=False):
        have = [f"{prefix}{i}" in cols for i in range(1, nd + 1)]
        if not any(have) and not required:
            return None
        if not all(have):
            miss = f"{prefix}{have.index(False) + 1}"
            gone = " (its variable is absent from the file)" if miss in absent else ""
            raise ImportFailure(m.path, f"{prefix} columns must be given for all {nd} joints or none: {miss} is "
                                        f"missing{gone}", field=f"columns.{miss}")
        return np.column_stack([cols[f"{prefix}{i}"] for i in range(1, nd + 1)])

    pose_names = list(facts.tracker_names)
    have_pose = [c in cols for c in pose_names]
    if any(have_pose) and not all(have_pose):
        miss = pose_names[have_pose.index(False)]
        raise ImportFailure(m.path, f"pose columns must be given all or none ({', '.join(pose_names)}): {miss} is "
                                    f"missing", field=f"columns.{miss}")
    extra = {name: v for name, v in cols.items() if (mm := JOINT_COLUMN.match(name)) and mm.group(1) == "qdref"}
    sensors = {}
    for name, s in m.sensors.items():
        if name not in cols:
            continue
        si = si_unit(name, facts)
        unit = s.get("unit", m.columns[name].unit)
        f = U.factor(unit, si) if unit is not None else 1.0
        sensors[name] = {k: scal.value(v["variable"] if isinstance(v, dict) else v) * f
                         for k, v in s.items() if k != "unit"}
        sensors[name]["unit"] = si
    made = {}
    for name, c in present.items():
        if c.derive:
            made[name] = f"derived from {c.source} ({c.derive})"
            continue
        what = c.variable if c.variable else f"{c.start:g} + {c.period:g} * k"
        if c.column:
            what += f"[:, {c.column}]"
        if c.row:
            what += f"[{c.row}, :]"
        sc, off = c.scale, c.offset
        if sc != 1.0:
            what += f" * {sc} ({scal.values[sc]:.17g})" if isinstance(sc, str) else f" * {sc:.17g}"
        if off != 0.0:
            what += f" + {off} ({scal.values[off]:.17g})" if isinstance(off, str) else f" + {off:.17g}"
        if c.unit is not None:
            what += f" [{c.unit}]"
        if c.angle:
            what += f", {c.angle}ped"
        made[name] = what
    side = {"source": {"file": src.path.name, "format": src.format, "map": m.path.name, "columns": made}}
    if absent:
        side["source"]["absent_optional"] = absent
    if derived:
        side["derived"] = derived
    if sensors:
        side["sensors"] = sensors
    controller = _substitute(m.controller, scal.values)
    params = {k: scal.value(v["variable"] if isinstance(v, dict) else v) for k, v in m.parameters.items()}
    return Recording(
        robot=facts.name, time=cols["time"], q=block("q", True), qd=block("qd", True), tau=block("tau", True),
        qref=block("qref"), pose=np.column_stack([cols[c] for c in pose_names]) if all(have_pose) else None,
        extra=extra, parameters=params, controller=controller, notes=m.notes, f_ext=block("f_ext"), sidecar=side,
    )


def import_recording(source, map_path, out, *, name: str | None = None, robot: str | None = None,
                     file_format: str = "csv", progress: bool | None = None) -> Imported:
    """Import a source file through a map and write the pkm-recording ``out/<name>.csv``
    (or ``.parquet``, ``.h5``) with its sidecar ``out/<name>.json``.

    Parameters
    ----------
    source, map_path, robot, progress
        As :func:`to_recording` (``progress`` also covers the writing).
    out : str or Path
        Folder of the recording (made if missing).
    name : str, optional
        File name without extension; default the source's.
    file_format : str
        The recording's table: ``"csv"``, ``"parquet"`` or ``"hdf5"`` (docs/recording.md).

    Raises
    ------
    ImportFailure
        As :func:`to_recording`; also an ``out`` that is a file or cannot be written.

    Example
    -------
    >>> import numpy as np, scipy.io
    >>> from pathlib import Path
    >>> t = np.arange(5) * 1e-3
    >>> scipy.io.savemat("/tmp/rig2.mat", {"t": t[:, None], "a": t[:, None], "u": t[:, None]})
    >>> _ = Path("/tmp/rig2.toml").write_text('robot = "fourbar"\\n[columns]\\ntime = "t"\\nq1 = "a"\\n'
    ...                                       'qd1 = { derive = "central_difference" }\\ntau1 = "u"\\n')
    >>> res = import_recording("/tmp/rig2.mat", "/tmp/rig2.toml", "/tmp/imported", file_format="parquet")
    >>> res.table.name, len(res.recording)
    ('rig2.parquet', 5)
    """
    t0 = _time.perf_counter()
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ImportFailure(out, "exists and is not a directory (--out names the folder of the recording)")
    rec, src = _convert(source, map_path, robot, progress)
    if file_format not in EXTENSION:
        raise ImportFailure(out, f"unknown recording format {file_format!r} (one of: {', '.join(EXTENSION)})")
    target = out / f"{name or Path(source).stem}{EXTENSION[file_format]}"
    try:
        table, side = write_recording(target, rec, progress=progress)
    except OSError as e:
        raise ImportFailure(target, f"cannot be written: {e.strerror or e}") from None
    rec.path = table
    return Imported(rec, table, side, src, _time.perf_counter() - t0)
