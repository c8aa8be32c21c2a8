"""The map of an import: a TOML file saying which source variable feeds which recording
column, with scale, offset and unit, which columns are derived or optional, the robot, the
rig's controller, its sensors and nominal parameters (docs/importing.md).

:func:`read_map` checks the file's structure (every field known, of the right type, every
unit known); :func:`check_columns` checks the columns against the robot once it is known.
"""
from __future__ import annotations

import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from . import units as U
from .angles import ANGLE_OPTIONS, angle_column_error
from .errors import ImportFailure
from .sources import FORMATS

#: how a velocity column can be derived from its position column (docs/importing.md)
DERIVATIONS = {
    "central_difference": "(x[k+1] - x[k-1]) / (t[k+1] - t[k-1]); one-sided differences at the first and last rows",
    "backward_difference": "(x[k] - x[k-1]) / (t[k] - t[k-1]); the forward difference at the first row",
}

#: the map's top-level fields
TOP = ("robot", "notes", "source", "columns", "controller", "sensors", "parameters", "injection")
#: fields of a column
COLUMN_FIELDS = ("variable", "column", "row", "scale", "offset", "unit", "optional", "derive", "from", "period", "start",
                 "angle", "topic", "field")
#: fields of a sensor
SENSOR_FIELDS = ("resolution", "noise_std", "unit")
#: a per-joint recording column: prefix and joint number
JOINT_COLUMN = re.compile(r"^(q|qd|tau|qref|qdref|f_ext|inject|tau_meas|q_link)([1-9][0-9]*)$")
#: per-joint columns kept in the recording's extra columns (not its own arrays); q_link<i>: a
#: link-side encoder of joint i (q<i> is then the motor side in joint units), on any joints
EXTRA_PREFIXES = ("qdref", "inject", "tau_meas", "q_link")
#: the injection points at which a signal is an effort (cosim.injection)
COMMAND_POINTS = ("command", "command_after_saturation")
#: the position column each derivable velocity column comes from
DERIVED_FROM = {"qd": "q", "qdref": "qref"}


@dataclass
class Column:
    """How one recording column is made (values = (variable * scale + offset) in ``unit``,
    converted to the column's SI unit), or derived from another column."""

    name: str
    variable: str | None = None
    column: int | None = None          # 1-based column of a matrix variable
    row: int | None = None             # 1-based row of a matrix variable holding one signal per row
    scale: object = 1.0                # a number, or the name of a scalar variable (str)
    offset: object = 0.0               # idem, in the unit after the scale
    unit: str | None = None            # of the variable (after scale and offset); None: the SI unit
    optional: bool = False
    derive: str | None = None          # a key of DERIVATIONS
    source: str | None = None          # the column a derived one comes from
    period: float | None = None        # time only: a sampling period instead of a variable
    start: float = 0.0
    angle: str | None = None           # "wrap" or "unwrap" (angles.ANGLE_OPTIONS), an angle column only


@dataclass
class ImportMap:
    """A parsed map file (see the module docstring)."""

    path: Path
    robot: str
    columns: dict
    notes: str = ""
    source: dict = field(default_factory=dict)
    controller: dict = field(default_factory=dict)
    sensors: dict = field(default_factory=dict)
    parameters: dict = field(default_factory=dict)
    #: where the signal of the inject<i> columns was added (cosim.injection), {} for none
    injection: dict = field(default_factory=dict)

    def robot_ref(self) -> str:
        """The robot as the core takes it: a listed name, or the description file's path
        (relative paths are relative to the map)."""
        r = self.robot
        if r.endswith(".toml") or "/" in r:
            p = Path(r)
            return str(p if p.is_absolute() else self.path.parent / p)
        return r


def _fail(path, field_name, message):
    raise ImportFailure(path, message, field=field_name)


def _number_or_variable(path, name, v, allow_variable=True):
    """A finite number, or ``{ variable = "name" }`` (returned as the name, a str)."""
    if allow_variable and isinstance(v, dict):
        if set(v) != {"variable"} or not isinstance(v["variable"], str) or not v["variable"]:
            _fail(path, name, f'must be a number or {{ variable = "name" }} (a scalar of the file), got {v!r}')
        return v["variable"]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        alt = ' or { variable = "name" }' if allow_variable else ""
        _fail(path, name, f"must be a finite number{alt}, got {v!r}")
    return float(v)


def _unit(path, name, u):
    if not isinstance(u, str):
        _fail(path, name, f"must be a unit name (a string), got {u!r}")
    if U.canonical(u) not in U.UNITS:
        _fail(path, name, f"unknown unit {u!r} (known: {', '.join(U.UNITS)})")
    return u


def read_map(path) -> ImportMap:
    """Read and check a map file's structure.

    Raises
    ------
    ImportFailure
        Naming the map file and the field: TOML syntax (with its line), an unknown field,
        a field of the wrong type, an unknown unit or derivation.

    Example
    -------
    >>> from pathlib import Path
    >>> _ = Path("/tmp/m.toml").write_text('robot = "fourbar"\\n[columns]\\ntime = "t"\\nq1 = "a"\\n'
    ...                                     'qd1 = { derive = "central_difference" }\\ntau1 = "u"\\n')
    >>> sorted(read_map("/tmp/m.toml").columns)
    ['q1', 'qd1', 'tau1', 'time']
    """
    path = Path(path)
    if not path.exists():
        raise ImportFailure(path, "map file not found")
    if path.is_dir():
        raise ImportFailure(path, "is a directory, not a map file")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as e:
        raise ImportFailure(path, f"is not valid TOML: {e}") from None
    except UnicodeDecodeError:
        raise ImportFailure(path, "is not a text (UTF-8) TOML file") from None
    for k in doc:
        if k not in TOP:
            _fail(path, k, f"unknown field (a map has: {', '.join(TOP)})")
    robot = doc.get("robot")
    if not isinstance(robot, str) or not robot:
        _fail(path, "robot", "must name the robot: a listed name (cosim robots) or a description file's path "
                             "relative to the map")
    notes = doc.get("notes", "")
    if not isinstance(notes, str):
        _fail(path, "notes", f"must be a string, got {notes!r}")
    src = doc.get("source", {})
    if not isinstance(src, dict):
        _fail(path, "source", "must be a table")
    for k, v in src.items():
        if k == "format" and v not in FORMATS:
            _fail(path, "source.format", f"must be one of {', '.join(FORMATS)}, got {v!r}")
        elif k == "delimiter" and (not isinstance(v, str) or len(v) != 1):
            _fail(path, "source.delimiter", f"must be one character, got {v!r}")
        elif k == "encoding" and (not isinstance(v, str) or not v):
            _fail(path, "source.encoding", f"must be a text encoding's name (e.g. \"latin-1\"), got {v!r}")
        elif k not in ("format", "delimiter", "encoding"):
            _fail(path, f"source.{k}", "unknown field (source has: format, delimiter, encoding)")
    cols = doc.get("columns")
    if not isinstance(cols, dict) or not cols:
        _fail(path, "columns", "the map needs a [columns] table (recording column = source variable)")
    columns = {name: _column(path, name, spec) for name, spec in cols.items()}
    ctrl = doc.get("controller", {})
    if not isinstance(ctrl, dict):
        _fail(path, "controller", "must be a table (copied into the sidecar's controller object)")
    sensors = doc.get("sensors", {})
    if not isinstance(sensors, dict):
        _fail(path, "sensors", "must be a table of column = { resolution, noise_std, unit }")
    for name, s in sensors.items():
        f = f"sensors.{name}"
        if name not in columns:
            _fail(path, f, "names no column of [columns]")
        if not isinstance(s, dict):
            _fail(path, f, "must be a table { resolution = ..., noise_std = ..., unit = ... }")
        for k, v in s.items():
            if k not in SENSOR_FIELDS:
                _fail(path, f"{f}.{k}", f"unknown field (a sensor has: {', '.join(SENSOR_FIELDS)})")
            if k == "unit":
                _unit(path, f"{f}.unit", v)
            else:
                val = _number_or_variable(path, f"{f}.{k}", v)
                if isinstance(val, float) and val < 0:
                    _fail(path, f"{f}.{k}", f"must be >= 0, got {val!r}")
    params = doc.get("parameters", {})
    if not isinstance(params, dict):
        _fail(path, "parameters", "must be a table of parameter name = value")
    for k, v in params.items():
        _number_or_variable(path, f"parameters.{k!r}", v)
    injection = doc.get("injection", {})
    if injection:
        from ..injection import declaration_errors

        why = declaration_errors(injection)
        if why:
            _fail(path, "injection", why)
    return ImportMap(path, robot, columns, notes, dict(src), ctrl, sensors, params, dict(injection))


def _column(path, name, spec) -> Column:
    f = f"columns.{name}"
    if isinstance(spec, str):
        spec = {"variable": spec}
    if not isinstance(spec, dict):
        _fail(path, f, f'must be a variable name or a table {{ variable = "...", ... }}, got {spec!r}')
    for k in spec:
        if k not in COLUMN_FIELDS:
            _fail(path, f"{f}.{k}", f"unknown field (a column has: {', '.join(COLUMN_FIELDS)})")
    c = Column(name)
    if "derive" in spec:
        extra = set(spec) - {"derive", "from"}
        if extra:
            _fail(path, f"{f}.{sorted(extra)[0]}", "a derived column takes only derive (and from): it is computed "
                                                   "from its position column, in SI units")
        if spec["derive"] not in DERIVATIONS:
            _fail(path, f"{f}.derive", f"unknown derivation {spec['derive']!r} (one of: {', '.join(DERIVATIONS)})")
        m = JOINT_COLUMN.match(name)
        if not m or m.group(1) not in DERIVED_FROM:
            _fail(path, f"{f}.derive", "only a velocity column (qd<i>, qdref<i>) can be derived")
        c.derive, c.source = spec["derive"], f"{DERIVED_FROM[m.group(1)]}{m.group(2)}"
        if spec.get("from", c.source) != c.source:
            _fail(path, f"{f}.from", f"{name} is derived from {c.source}, got {spec['from']!r}")
        return c
    if "from" in spec:
        _fail(path, f"{f}.from", "only a derived column (derive = ...) takes from")
    if "period" in spec:
        if name != "time":
            _fail(path, f"{f}.period", "only time can be given as a sampling period")
        if "variable" in spec:
            _fail(path, f"{f}.period", "give time either as a variable or as a period, not both")
        c.period = _number_or_variable(path, f"{f}.period", spec["period"], allow_variable=False)
        if c.period <= 0:
            _fail(path, f"{f}.period", f"must be > 0, got {c.period!r}")
        c.start = _number_or_variable(path, f"{f}.start", spec.get("start", 0.0), allow_variable=False)
    elif "start" in spec:
        _fail(path, f"{f}.start", "start goes with period (time = { period = ..., start = ... })")
    elif "topic" in spec or "field" in spec:
        c.variable = _topic_field(path, f, spec)
    else:
        v = spec.get("variable")
        if not isinstance(v, str) or not v:
            _fail(path, f"{f}.variable", "missing: the source variable (or column header) this column comes from")
        c.variable = v
    if "column" in spec:
        k = spec["column"]
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            _fail(path, f"{f}.column", f"must be a column number >= 1 of a matrix variable, got {k!r}")
        c.column = k
    if "row" in spec:
        k = spec["row"]
        if isinstance(k, bool) or not isinstance(k, int) or k < 1:
            _fail(path, f"{f}.row", f"must be a row number >= 1 of a matrix variable, got {k!r}")
        if c.column is not None:
            _fail(path, f"{f}.row", "give column or row, not both: a column is one signal of an n x k matrix, a row "
                                    "one of a k x n matrix")
        c.row = k
    if "scale" in spec:
        c.scale = _number_or_variable(path, f"{f}.scale", spec["scale"])
    if "offset" in spec:
        c.offset = _number_or_variable(path, f"{f}.offset", spec["offset"])
    if "unit" in spec:
        c.unit = _unit(path, f"{f}.unit", spec["unit"])
    if "angle" in spec:
        if spec["angle"] not in ANGLE_OPTIONS:
            _fail(path, f"{f}.angle", f"must be one of {', '.join(map(repr, ANGLE_OPTIONS))}, got {spec['angle']!r}")
        c.angle = spec["angle"]
    if "optional" in spec:
        if not isinstance(spec["optional"], bool):
            _fail(path, f"{f}.optional", f"must be true or false, got {spec['optional']!r}")
        c.optional = spec["optional"]
    return c


def _topic_field(path, f, spec) -> str:
    """A message log's field (a ROS 2 bag, an MCAP file): ``topic`` and ``field``, as the
    source's variable name (messages.py)."""
    from .messages import variable_name

    if "variable" in spec:
        _fail(path, f"{f}.variable", "give either variable (a file's variable) or topic and field (a message "
                                     "log's), not both")
    for k in ("topic", "field"):
        v = spec.get(k)
        if not isinstance(v, str) or not v:
            other = "field" if k == "topic" else "topic"
            _fail(path, f"{f}.{k}", f"missing or not a string: a message log's column needs topic and field "
                                    f"(e.g. topic = \"/joint_states\", field = \"position[0]\"), got {other} only"
                  if k not in spec else f"must be a non-empty string, got {v!r}")
    return variable_name(spec["topic"], spec["field"])


def si_unit(name: str, facts, injection: dict | None = None) -> str | None:
    """The SI unit of a recording column for a robot (None: not a column of the format); an
    ``inject<i>`` column's is the effort's or the joint's by the ``injection`` point."""
    if name == "time":
        return "s"
    m = JOINT_COLUMN.match(name)
    if m and 1 <= int(m.group(2)) <= facts.ndof:
        ju = facts.joint_unit
        inj = facts.effort_unit if (injection or {}).get("point", "command") in COMMAND_POINTS else ju
        return {"q": ju, "qref": ju, "qd": f"{ju}/s", "qdref": f"{ju}/s", "tau": facts.effort_unit,
                "f_ext": facts.effort_unit, "inject": inj, "tau_meas": facts.effort_unit, "q_link": ju}[m.group(1)]
    if name in facts.tracker_names:
        return facts.tracker_units[list(facts.tracker_names).index(name)]
    return None


def check_columns(m: ImportMap, facts) -> None:
    """Check the map's columns against the robot: names of the format, the required ones
    present (and not optional), units of the right kind.

    Raises
    ------
    ImportFailure
        Naming the field.
    """
    nd = facts.ndof
    for name, c in m.columns.items():
        si = si_unit(name, facts, m.injection)
        if si is None:
            known = ["time"] + [f"{p}1..{p}{nd}" for p in ("q", "qd", "tau", "qref", "qdref", "f_ext", "inject",
                                                             "tau_meas", "q_link")]
            known += list(facts.tracker_names)
            _fail(m.path, f"columns.{name}", f"not a recording column of robot {facts.name} ({nd} joint"
                                             f"{'s' if nd > 1 else ''}; columns: {', '.join(known)})")
        if name.startswith("tau_meas") and c.unit is None:
            _fail(m.path, f"columns.{name}.unit", f"missing: a measured effort needs its unit ({si} or another "
                                                  f"{'torque' if si == 'N m' else 'force'} unit; a motor current: "
                                                  f"scale = its torque constant, unit = {si!r})")
        if name.startswith("inject") and not m.injection:
            _fail(m.path, f"columns.{name}", "an injected signal needs [injection] point = \"command\" | "
                                             "\"command_after_saturation\" | \"reference\" | \"measurement\" and, "
                                             "at the command, in_effort = true | false (does tau include it?)")
        if c.unit is not None:
            try:
                U.factor(c.unit, si)
            except ValueError as e:
                _fail(m.path, f"columns.{name}.unit", str(e))
        if c.angle is not None and (why := angle_column_error(name, si, facts)):
            _fail(m.path, f"columns.{name}.angle", why)
    for name in ["time"] + [f"{p}{i}" for i in range(1, nd + 1) for p in ("q", "qd", "tau")]:
        if name not in m.columns:
            hint = f' (or derive it: {name} = {{ derive = "central_difference" }})' if name.startswith("qd") else ""
            _fail(m.path, "columns", f"{name} is missing: robot {facts.name} needs time and, per joint, q, qd and tau"
                                     f"{hint}")
        if m.columns[name].optional:
            _fail(m.path, f"columns.{name}.optional", f"{name} is required by the recording format, it cannot be "
                                                      f"optional")
    for name, s in m.sensors.items():
        if "unit" in s:
            try:
                U.factor(s["unit"], si_unit(name, facts))
            except ValueError as e:
                _fail(m.path, f"sensors.{name}.unit", str(e))
    for name, c in m.columns.items():
        if c.derive and c.source not in m.columns:
            _fail(m.path, f"columns.{name}.derive", f"{name} is derived from {c.source}, which the map does not give")
