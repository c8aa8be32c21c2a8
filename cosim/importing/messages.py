"""Message logs as sources of an import: ROS 2 bags (the folder with ``metadata.yaml``, sqlite3
``.db3`` or MCAP storage) and plain MCAP files, read with ``rosbags`` (no ROS install).

A variable of such a source is one numeric field of one topic's messages, named
``"<topic>:<field>"`` (a map says ``{ topic = "/joint_states", field = "position[0]" }``,
:func:`variable_name`).  A field is a path into the message: attribute names joined by dots,
array elements by ``[k]`` (0-based, as ROS counts): ``position[0]``, ``header.stamp``,
``twist.linear.x``; ``[label]`` picks the element at the place ``label`` has in the ``name`` list
of the message holding the array, on every message (``position[elbow]`` of a
sensor_msgs/JointState, whatever the order of its joints).  A ``builtin_interfaces/Time`` (``header.stamp``) is read in seconds; the
pseudo-fields :data:`CLOCKS` are the log's own times of each message.

Times (a stamp or a log time) are made relative to the first message of the topic that gives
the recording's time, computed in integer nanoseconds (an absolute epoch in a float64 would keep
only ~0.2 us).  Columns from several topics are aligned on the time topic's messages by their
log times: each row takes the last message of the other topic logged at or before it (a zero-order
hold, the value a command has until the next one); rows logged before every topic used has a
message are left out.
"""
from __future__ import annotations

import dataclasses
import difflib
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import ImportFailure

#: pseudo-fields: the log's times of a message [s] (``log_time`` as the recorder received it)
CLOCKS = ("log_time",)
#: fields read as times (relative to the time topic's first message, in s)
_TIME_TYPES = ("builtin_interfaces/msg/Time",)
_STEP = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)|\[([0-9]+)\]|\[([^\[\]0-9][^\[\]]*)\]")
_PATH = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*|\[[0-9]+\]|\[[^\[\]0-9][^\[\]]*\])*$")


class _Name(str):
    """A step ``[label]``: the element of an array at the place ``label`` has in the ``name``
    list of the message holding the array (sensor_msgs/JointState's ``position[elbow]``)."""
_SEP = ":"


def variable_name(topic: str, field_path: str) -> str:
    """The name a topic's field has as a variable of the source.

    Example
    -------
    >>> variable_name("/joint_states", "position[0]")
    '/joint_states:position[0]'
    """
    return f"{topic}{_SEP}{field_path}"


def split_name(name: str) -> tuple[str, str]:
    """``(topic, field)`` of a variable name (:func:`variable_name` reversed)."""
    topic, _, path = name.rpartition(_SEP)
    return topic, path


def _steps(path: str):
    """A field path as steps: attribute names (str) and indices (int); None if malformed."""
    if not _PATH.match(path):
        return None
    return [m.group(1) if m.group(1) is not None else int(m.group(2)) if m.group(2) is not None
            else _Name(m.group(3)) for m in _STEP.finditer(path)]


def _is_message(v) -> bool:
    return dataclasses.is_dataclass(v) and not isinstance(v, type)


#: arrays longer than this are not listed element by element (an image's bytes); their elements
#: are still found when a map names one (:class:`_Fields`)
_LISTED = 64


def _leaves(msg, prefix=""):
    """The numeric fields of a message: path -> value (arrays element by element, up to
    :data:`_LISTED` elements)."""
    out = {}
    if _is_message(msg):
        if getattr(msg, "__msgtype__", "") in _TIME_TYPES:
            out[prefix] = msg     # read as a time; its parts as numbers too
        for f in dataclasses.fields(msg):
            if f.name.startswith("__"):
                continue
            out.update(_leaves(getattr(msg, f.name), f"{prefix}.{f.name}" if prefix else f.name))
    elif isinstance(msg, (list, tuple, np.ndarray)) and len(msg) <= _LISTED:
        for k, v in enumerate(msg):
            out.update(_leaves(v, f"{prefix}[{k}]"))
    elif isinstance(msg, (bool, int, float, np.number, np.bool_)):
        out[prefix] = msg
    return out


@dataclass
class _Topic:
    name: str
    msgtype: str
    count: int
    connections: list
    first: object = None                      # the first message, decoded
    fields: dict = field(default_factory=dict)  # leaf path -> value in the first message


class _Fields(dict):
    """Variable name -> shape; a name not listed (an element of a long array) is looked up in
    its topic's first message when asked for."""

    def __init__(self, src):
        super().__init__()
        self.src = src

    def __contains__(self, name):
        if dict.__contains__(self, name):
            return True
        topic, path = split_name(name)
        t = self.src.topics.get(topic)
        steps = _steps(path)
        if t is None or t.first is None or steps is None:
            return False
        try:
            v = _value(t.first, steps)
        except (IndexError, AttributeError, TypeError, KeyError):
            return False
        if isinstance(v, (bool, int, float, np.number, np.bool_)) or getattr(v, "__msgtype__", "") in _TIME_TYPES:
            t.fields[path] = v
            self[name] = (t.count, 1)
            return True
        return False

    def get(self, name, default=None):
        return self[name] if name in self else default


@dataclass
class MessageSource:
    """A ROS 2 bag or an MCAP file (see the module docstring); used as a
    :class:`~cosim.importing.sources.Source` (the same attributes and methods).

    Attributes
    ----------
    path : Path
    format : str
        ``"rosbag2"`` or ``"mcap"``.
    shapes : dict
        Variable name (``"<topic>:<field>"``) -> shape (messages, 1).
    topics : dict
        Topic name -> its type, message count and the fields of its first message.
    dropped : int
        Rows of the time topic left out by the last :meth:`load` (logged before a message of
        every topic used).
    """

    path: Path
    format: str
    shapes: dict
    what: dict = field(default_factory=dict)
    topics: dict = field(default_factory=dict)
    dropped: int = 0
    _reader_path: Path | None = None

    def row_label(self, indices) -> str:
        idx = [int(i) for i in indices[:5]]
        more = f" and {len(indices) - 5} more" if len(indices) > 5 else ""
        one = len(indices) == 1
        return ("message " if one else "messages ") + ", ".join(str(i + 1 + self.dropped) for i in idx) + more + \
            " of the time topic (1-based)"

    # -- the names a map may use ------------------------------------------------------
    def missing(self, var: str, column: str) -> ImportFailure:
        """The error for a variable the map names and the file does not have: an unknown
        topic, a field its messages do not have, an index beyond an array's length."""
        topic, path = split_name(var)
        where = f"topic {topic!r}, field {path!r} (column {column})"
        if topic not in self.topics:
            have = ", ".join(sorted(self.topics)) or "none"
            close = difflib.get_close_matches(topic, list(self.topics), n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            return ImportFailure(self.path, f"{where}: no such topic in the {self._kind()} (its topics: {have}){hint}")
        t = self.topics[topic]
        if t.count == 0:
            return ImportFailure(self.path, f"{where}: the topic has no messages")
        steps = _steps(path)
        if steps is None:
            return ImportFailure(self.path, f"{where}: not a field path (names joined by '.', indices as [k], "
                                            f"e.g. position[0] or header.stamp)")
        obj = parent = t.first
        for k, s in enumerate(steps):
            done = _format_path(steps[:k])
            if isinstance(s, _Name):
                names = getattr(parent, "name", None) if _is_message(parent) else None
                if not isinstance(names, (list, tuple, np.ndarray)):
                    return ImportFailure(self.path, f"{where}: [{s}] picks by name, but the message holding {done} "
                                                    f"has no name list (give an index, e.g. {done}[0])")
                if s not in list(names):
                    return ImportFailure(self.path, f"{where}: {s!r} is not in the first message's name list (it "
                                                    f"has: {', '.join(map(str, names))})")
                obj = obj[list(names).index(s)]
            elif isinstance(s, int):
                if not isinstance(obj, (list, tuple, np.ndarray)):
                    return ImportFailure(self.path, f"{where}: {done or 'the message'} is not an array")
                if not 0 <= s < len(obj):
                    return ImportFailure(self.path, f"{where}: index {s} is out of range: {done} has {len(obj)} "
                                                    f"value(s) in the first message (indices 0..{len(obj) - 1})")
                obj = obj[s]
            else:
                if not _is_message(obj) or s.startswith("__") or not hasattr(obj, s):
                    names = _field_names(obj)
                    close = difflib.get_close_matches(s, names, n=1)
                    hint = f"; did you mean {_format_path(steps[:k] + [close[0]])!r}?" if close else ""
                    return ImportFailure(self.path, f"{where}: {t.msgtype}{' ' + done if done else ''} has no "
                                                    f"field {s!r} (it has: {', '.join(names)}){hint}")
                parent, obj = obj, getattr(obj, s)
        if isinstance(obj, (list, tuple, np.ndarray)):
            return ImportFailure(self.path, f"{where}: is an array of {len(obj)} value(s); name one element, "
                                            f"e.g. {path}[0]")
        return ImportFailure(self.path, f"{where}: is not a number (a {type(obj).__name__})")

    def _kind(self) -> str:
        return "bag" if self.format == "rosbag2" else "file"

    # -- loading ------------------------------------------------------------------------
    def load(self, names, progress: bool | None = None) -> dict:
        names = list(dict.fromkeys(names))
        wanted = {}
        for n in names:
            topic, path = split_name(n)
            if n not in self.shapes:
                raise self.missing(n, "?")
            wanted.setdefault(topic, []).append((n, path))
        times = [n for n in names if _is_time(self.topics[split_name(n)[0]], split_name(n)[1])]
        base = split_name(times[0] if times else names[0])[0]
        values, logs = _read(self, wanted, progress)
        return _align(self, base, names, values, logs)


def _format_path(steps) -> str:
    out = ""
    for s in steps:
        out += f"[{s}]" if isinstance(s, (int, _Name)) else (f".{s}" if out else s)
    return out


def _field_names(obj) -> list:
    if _is_message(obj):
        return [f.name for f in dataclasses.fields(obj) if not f.name.startswith("__")]
    return []


def _is_time(topic: _Topic, path: str) -> bool:
    return path in CLOCKS or path in topic.fields and _is_message(topic.fields[path])


def _value(msg, steps):
    parent = msg
    for s in steps:
        if isinstance(s, int):
            msg = msg[s]
        elif isinstance(s, _Name):
            msg = msg[_place(parent, s)]
        elif _is_message(msg) and not s.startswith("__"):
            parent, msg = msg, getattr(msg, s)
        else:
            raise AttributeError(s)
    return msg


def _place(parent, label: str) -> int:
    """Where ``label`` is in the ``name`` list of ``parent`` (IndexError when it is not)."""
    names = getattr(parent, "name", None) if _is_message(parent) else None
    if not isinstance(names, (list, tuple, np.ndarray)) or label not in list(names):
        raise IndexError(label)
    return list(names).index(label)


def _read(src: MessageSource, wanted: dict, progress) -> tuple[dict, dict]:
    """One pass over the log: per variable its values (time fields in integer ns), per topic
    the log times [ns] of its messages."""
    from tqdm import tqdm

    values = {n: [] for pairs in wanted.values() for n, _ in pairs}
    logs = {t: [] for t in wanted}
    plans = {t: [(n, p, _steps(p)) for n, p in pairs] for t, pairs in wanted.items()}
    with _open_reader(src) as reader:
        conns = [c for c in reader.connections if c.topic in wanted]
        total = sum(src.topics[t].count for t in wanted)
        with tqdm(total=total, unit="msg", desc=f"reading {src.path.name}", delay=1.0, leave=False,
                  disable=None if progress is None else not progress) as bar:
            for conn, stamp, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                t = conn.topic
                logs[t].append(int(stamp))
                k = len(logs[t])
                for n, path, steps in plans[t]:
                    if path == "log_time":
                        values[n].append(int(stamp))
                        continue
                    try:
                        v = _value(msg, steps)
                    except (IndexError, AttributeError):
                        raise ImportFailure(src.path, f"topic {t!r}, field {path!r}: message {k} (1-based) has no "
                                                      f"such element (an array shorter than the first message's, "
                                                      f"or a name missing from its name list)") from None
                    if _is_message(v):
                        v = int(v.sec) * 1_000_000_000 + int(v.nanosec)
                    values[n].append(v)
                bar.update(1)
    return values, {t: np.asarray(v, dtype=np.int64) for t, v in logs.items()}


def _align(src: MessageSource, base: str, names, values, logs) -> dict:
    """The variables on the base topic's rows: other topics by zero-order hold on log times."""
    tb = logs[base]
    first = max(int(logs[t][0]) for t in logs)
    keep = np.flatnonzero(tb >= first)
    src.dropped = int(keep[0]) if keep.size else len(tb)
    out = {}
    for n in names:
        topic, path = split_name(n)
        raw = values[n]
        if _is_time(src.topics[topic], path):
            a = np.asarray(raw, dtype=np.int64)
            a = (a - a[src.dropped] if keep.size else a).astype(float) * 1e-9
        else:
            a = np.asarray(raw, dtype=float)
        if topic != base:
            idx = np.searchsorted(logs[topic], tb[keep], side="right") - 1
            a = a[idx]
        else:
            a = a[keep]
        out[n] = a[:, None]
    return out


class _Reader:
    """rosbags' AnyReader on a bag folder or a plain MCAP file, opened and closed."""

    def __init__(self, src: MessageSource):
        self.src = src

    def __enter__(self):
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore

        self.r = AnyReader([self.src._reader_path], default_typestore=get_typestore(Stores.ROS2_HUMBLE))
        try:
            self.r.open()
        except Exception as e:  # rosbags raises its own errors, and sqlite/mcap ones, on a foreign file
            raise ImportFailure(self.src.path, f"cannot be read as a {_what(self.src.format)}: {_reason(e)}") from None
        return self.r

    def __exit__(self, *exc):
        self.r.close()
        return False


def _open_reader(src: MessageSource) -> _Reader:
    return _Reader(src)


def _what(fmt: str) -> str:
    return "ROS 2 bag" if fmt == "rosbag2" else "MCAP file"


def _reason(e: Exception) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def open_messages(p: Path, fmt: str) -> MessageSource:
    """Open a ROS 2 bag (its folder, or a ``.db3``/``.mcap`` file inside it) or a plain MCAP
    file and list its topics and the numeric fields of each topic's first message.

    Raises
    ------
    ImportFailure
        Not a bag or MCAP file, a bag with no messages.

    Example
    -------
    >>> import numpy as np
    >>> from rosbags.rosbag2 import Writer
    >>> from rosbags.typesys import Stores, get_typestore
    >>> ts = get_typestore(Stores.ROS2_HUMBLE)
    >>> F = ts.types["std_msgs/msg/Float64"]
    >>> import shutil; shutil.rmtree("/tmp/tiny_bag", ignore_errors=True)
    >>> with Writer("/tmp/tiny_bag", version=9) as w:
    ...     c = w.add_connection("/u", F.__msgtype__, typestore=ts)
    ...     w.write(c, 5, ts.serialize_cdr(F(data=1.5), F.__msgtype__))
    >>> sorted(open_messages(Path("/tmp/tiny_bag"), "rosbag2").shapes)
    ['/u:data', '/u:log_time']
    """
    reader_path = p
    if fmt == "rosbag2" and p.is_file():
        if not (p.parent / "metadata.yaml").exists():
            raise ImportFailure(p, "is a file of a ROS 2 bag without its metadata.yaml beside it: a bag is the "
                                   "folder holding both (give the folder)")
        reader_path = p.parent
    src = MessageSource(p, fmt, {}, _reader_path=reader_path)
    src.shapes = _Fields(src)
    with _open_reader(src) as reader:
        for c in reader.connections:
            t = src.topics.setdefault(c.topic, _Topic(c.topic, c.msgtype, 0, []))
            t.count += int(c.msgcount)
            t.connections.append(c)
        if not any(t.count for t in src.topics.values()):
            raise ImportFailure(p, f"the {src._kind()} has no messages (topics: "
                                   f"{', '.join(sorted(src.topics)) or 'none'})")
        pending = {name for name, t in src.topics.items() if t.count}
        for conn, _, raw in reader.messages(connections=[c for t in src.topics.values() for c in t.connections]):
            t = src.topics[conn.topic]
            if t.first is None:
                try:
                    t.first = reader.deserialize(raw, conn.msgtype)
                except Exception as e:
                    raise ImportFailure(p, f"topic {conn.topic!r}: its messages of type {conn.msgtype} cannot be "
                                           f"decoded: {_reason(e)}") from None
                pending.discard(conn.topic)
            if not pending:
                break
    for name, t in src.topics.items():
        if t.first is None:
            continue
        t.fields = _leaves(t.first)
        for path in list(t.fields) + list(CLOCKS):
            src.shapes[variable_name(name, path)] = (t.count, 1)
    return src
