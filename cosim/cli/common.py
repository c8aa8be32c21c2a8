"""What every sub-command module of ``cosim`` uses: the registry of sub-commands, the
argparse types that refuse a bad file or folder in one line before any work, ctrl-C
handling (:class:`exits_on_interrupt`, :class:`Interrupted`) and the ticking progress
line (:class:`working`).  :mod:`cosim.cli.main` builds the parser from the registry."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

COMMANDS = {}


def command(name, help):
    """Register ``fn(args)`` as a sub-command; ``fn.configure(parser)`` adds its options."""

    def deco(fn):
        COMMANDS[name] = (fn, help)
        return fn

    return deco


def robot_arg(value: str) -> str:
    """argparse type of every ``--robot``: a robot the core lists or knows by another name
    (``6pus_described`` for ``6pus``), or a path to a description file (checked when the
    command makes the model, with the file's line)."""
    from .._native import lib
    from ..core.facts import robots

    if value in robots():
        return value
    if value.endswith((".toml", ".urdf")) or "/" in value:
        return input_file(value)
    if lib.pkm_robot_param_set_count(value.encode()) >= 0:  # the core's -1: no such robot
        return value
    raise argparse.ArgumentTypeError(
        f"unknown robot {value!r} (known: {', '.join(robots())}; or a path to a description file, docs/robots.md)")


class exits_on_interrupt:
    """``with exits_on_interrupt("cosim run: interrupted ...") as guard:`` a ctrl-C inside
    the block ends the process within milliseconds (the message on stderr, exit code 130),
    even while the main thread is inside one long call into the core or numpy (Python runs
    its own handler only between two instructions of the main thread, seconds later during
    the set-up of a long run).  For work that has nothing to keep; ``guard.disarm()`` (or
    leaving the block) gives ctrl-C back to the main thread, where it raises
    KeyboardInterrupt as before.

    How: the signal module's wakeup file descriptor receives the signal's number from
    whichever thread the signal lands in, and a watcher thread blocked on reading it (the
    interpreter lock released) says the message and exits."""

    def __init__(self, message: str):
        self.message = message
        self._thread = None
        self._lock = None

    def __enter__(self):
        import signal
        import socket
        import threading

        if threading.current_thread() is not threading.main_thread():
            return self  # only the main thread may set the wakeup descriptor
        self._r, self._w = socket.socketpair()
        self._w.setblocking(False)
        self._old = signal.set_wakeup_fd(self._w.fileno(), warn_on_full_buffer=False)
        self._lock, self._armed = threading.Lock(), True
        self._thread = threading.Thread(target=self._watch, name="exits_on_interrupt", daemon=True)
        self._thread.start()
        return self

    def _watch(self):
        import os
        import signal

        while True:
            data = self._r.recv(64)
            with self._lock:
                if not self._armed or not data:
                    return
                if signal.SIGINT in data:
                    sys.stderr.write(self.message + "\n")
                    sys.stderr.flush()
                    os._exit(130)

    @property
    def armed(self) -> bool:
        """A ctrl-C now ends the process."""
        return self._thread is not None

    def disarm(self):
        """ctrl-C back to the main thread (KeyboardInterrupt); idempotent."""
        import signal

        if self._thread is None:
            return
        with self._lock:  # the watcher cannot be half-way through its message
            self._armed = False
        signal.set_wakeup_fd(self._old)
        self._w.send(b"\0")
        self._thread.join(timeout=1.0)
        self._r.close()
        self._w.close()
        self._thread = None

    def __exit__(self, *exc):
        self.disarm()
        return False


class working:
    """``with working("diagnosing rec.csv"):`` shows, on a terminal and once the work has
    taken two seconds, a line with the elapsed time that keeps ticking until the work is
    done (for commands whose work has no natural count); nothing when stderr is not a
    terminal or with ``cosim --quiet``."""

    def __init__(self, what: str):
        self.what = what
        self._stop = None

    def __enter__(self):
        import os
        import threading

        if os.environ.get("TQDM_DISABLE") or not sys.stderr.isatty():
            return self
        self._stop = threading.Event()

        def tick():
            from tqdm import tqdm

            if self._stop.wait(2.0):
                return
            bar = tqdm(total=None, desc=self.what, bar_format="{desc}: {elapsed}", leave=False)
            while not self._stop.wait(0.5):
                bar.refresh()
            bar.close()

        self._thread = threading.Thread(target=tick, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        if self._stop is not None:
            self._stop.set()
            self._thread.join(timeout=1.0)
        return False


class Interrupted(Exception):
    """ctrl-C during a command that keeps what it did: the message says when it stopped
    and where the partial results are (``interrupted at t = 1.234 s, partial results in
    results/x``); the exit code is 130."""


def os_error_text(e: OSError) -> str:
    """One line for a file-system error: the path and what is wrong with it."""
    text = os_error_reason(e)
    name = e.filename if e.filename is not None else ""
    return f"{name}: {text}" if name else text


def os_error_reason(e: OSError) -> str:
    """What is wrong in a file-system error, in words (without the path)."""
    import errno

    what = {errno.EISDIR: "is a directory, not a file", errno.ENOTDIR: "a part of this path is a file, not a folder",
            errno.EEXIST: "already exists", errno.EACCES: "permission denied",
            errno.EPERM: "operation not permitted (a read-only place?)", errno.EROFS: "read-only file system",
            errno.ENOSPC: "no space left on the device", errno.ENOENT: "no such file or folder"}
    return what.get(e.errno, e.strerror or type(e).__name__)


def _probe_writable(d: Path) -> None:
    """Raise the OSError of writing a file into the folder ``d`` (made if missing)."""
    import tempfile

    d.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryFile(dir=d):
        pass


def _where(e: OSError, value: str) -> str:
    """The reason of ``e``, with its path when it is not ``value`` itself."""
    same = e.filename is None or Path(e.filename) == Path(value)
    return os_error_reason(e) if same else os_error_text(e)


def _arg_error(message):
    return argparse.ArgumentTypeError(message)


def input_file(value: str) -> str:
    """argparse type of an input file: refused at once (one line) when it is a folder or
    cannot be read; a missing file is left to the command, whose message says what it
    looked for."""
    p = Path(value)
    if p.is_dir():
        raise _arg_error(f"{value} is a folder; give a file")
    if p.exists():
        try:
            with open(p, "rb") as f:
                f.read(1)
        except OSError as e:
            raise _arg_error(f"cannot read {value}: {os_error_reason(e)}") from None
    return value


def toml_file(value: str) -> str:
    """argparse type of a TOML input (scenario, sweep spec): :func:`input_file`, then text
    that TOML reads; what the file means is the command's to check."""
    import tomllib

    input_file(value)
    p = Path(value)
    if p.is_file():
        try:
            tomllib.loads(p.read_text(encoding="utf-8"))
        except UnicodeDecodeError as e:
            raise _arg_error(f"{value} is not a text file (byte 0x{e.object[e.start]:02x} at byte {e.start} is not "
                             f"UTF-8): give a TOML file") from None
        except tomllib.TOMLDecodeError as e:
            raise _arg_error(f"{value}: not valid TOML: {e}") from None
    return value


def output_dir(value: str) -> str:
    """argparse type of an ``--out`` folder: made now, and refused (one line) when the path
    is an existing file or the folder cannot be written, before any work is done."""
    p = Path(value)
    if p.exists() and not p.is_dir():
        raise _arg_error(f"{value} is an existing file; --out takes a folder")
    try:
        _probe_writable(p)
    except OSError as e:
        raise _arg_error(f"cannot write in {value}: {_where(e, value)}") from None
    return value


def output_file(value: str) -> str:
    """argparse type of an ``--out`` file: refused (one line) when the path is a folder or
    its folder cannot be written, before any work is done."""
    p = Path(value)
    if p.is_dir():
        raise _arg_error(f"{value} is a folder; --out takes the file to write")
    try:
        _probe_writable(p.parent)
    except OSError as e:
        raise _arg_error(f"cannot write {value}: {_where(e, value)}") from None
    return value


def recording_file(value: str) -> str:
    """argparse type of a recording (CSV + JSON sidecar): :func:`input_file`, then the
    CSV's joint and pose columns against the robot its sidecar names, so that a sidecar
    naming the wrong robot is said as such (not as a pose or forward-kinematics error
    further on, nor with joint columns silently left out)."""
    import json
    import re

    from ..core.facts import robots
    from ..core.model import robot_facts
    from ..recording import FULL_POSE, full_pose_allowed

    input_file(value)
    csv = Path(value)
    if not csv.exists() and csv.with_suffix(".csv").exists():
        csv = csv.with_suffix(".csv")
    side = csv.with_suffix(".json")
    try:
        robot = json.loads(side.read_text()).get("robot")
        facts = robot_facts(robot)
        with open(csv, encoding="utf-8") as f:
            header = [c.strip() for c in f.readline().split(",")]
    except Exception:  # noqa: BLE001 - anything else wrong is the reader's to say, naming row and column
        return value
    joints = sorted({int(m.group(2)) for c in header if (m := re.fullmatch(r"(q|qd|tau|qref)(\d+)", c))})
    n = joints[-1] if joints else 0
    # more joints than the robot has, or fewer but every one complete (not a column left out)
    complete = all(f"{c}{i}" in header for i in range(1, n + 1) for c in ("q", "qd", "tau"))
    poses = {p for r in robots() for p in robot_facts(r).tracker_names} | {"theta", "rx", "ry", "rz"}
    own = set(facts.tracker_names) | (set(FULL_POSE) if full_pose_allowed(facts) else set())  # a 6-DOF tracker
    alien = [c for c in header if c in poses and c not in own]
    if n > facts.ndof or (0 < n < facts.ndof and complete) or (alien and complete):
        same = [r for r in robots() if robot_facts(r).ndof == n and r != robot]
        what = (f"joint columns q1..q{n} ({n} joints)" if joints and n != facts.ndof
                else f"pose columns {', '.join(alien)}")
        raise _arg_error(f"{csv}: the sidecar {side.name} names robot {robot!r} ({facts.ndof} {facts.joint_noun}s, "
                         f"pose {' '.join(facts.tracker_names)}) but the file has {what}: does the sidecar name the "
                         f"right robot?" + (f" (robots with {n} joint{'s' * (n != 1)}: {', '.join(same)})" if same else ""))
    return value
