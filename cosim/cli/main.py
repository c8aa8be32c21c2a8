"""Command-line interface: ``cosim <command> ...``, a thin layer over the package functions."""
from __future__ import annotations

import argparse
import sys

COMMANDS = {}


def command(name, help):
    """Register ``fn(args)`` as a sub-command; ``fn.configure(parser)`` adds its options."""

    def deco(fn):
        COMMANDS[name] = (fn, help)
        return fn

    return deco


def robot_arg(value: str) -> str:
    """argparse type of every ``--robot``: a robot the core lists, or a path to a
    description file (checked when the command makes the model, with the file's line)."""
    from ..core import robots

    if value in robots() or value.endswith(".toml") or "/" in value:
        return value
    raise argparse.ArgumentTypeError(
        f"unknown robot {value!r} (known: {', '.join(robots())}; or a path to a description file, docs/robots.md)")


def _params_configure(p):
    from ..core import robot_facts, robots

    names = robots()
    sets = "; ".join(f"{r}: {', '.join(robot_facts(r).param_sets)}" for r in names)
    p.add_argument("robot", type=robot_arg, help=f"robot name ({', '.join(names)}) or a description file")
    p.add_argument("--set", dest="param_set", default=None, help=f"named parameter set ({sets})")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


@command("params", "print a robot's parameter set with units (table or --json)")
def cmd_params(args):
    from ..core import Model

    m = Model(args.robot, args.param_set)
    if args.json:
        print(m.to_json())
        return 0
    info = m.param_info()
    w = max(len(p.name) for p in info) if info else 4
    print(f"{'name':<{w}}  {'value':>14}  {'unit':<10}  description")
    for p in info:
        print(f"{p.name:<{w}}  {p.value:>14.6g}  {p.unit:<10}  {p.description}")
    return 0


cmd_params.configure = _params_configure


def _robots_configure(p):
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


@command("robots", "list the robots: the ones written in C++ and the descriptions in robots/ and PKM_ROBOT_PATH")
def cmd_robots(args):
    import json

    from ..core import robot_facts, robots

    rows = []
    for r in robots():
        f = robot_facts(r)
        rows.append({"name": r, "coordinates": " ".join(f.pose_names), "joints": f"{f.ndof} {f.joint_noun}{'s' if f.ndof > 1 else ''} [{f.joint_unit}]",
                     "sets": ", ".join(f.param_sets), "file": f.file or "(C++)", "title": f.title})
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    cols = ["name", "coordinates", "joints", "file", "title"]
    w = {c: max(len(c), *(len(r[c]) for r in rows)) for c in cols[:-1]}
    print("  ".join(f"{c:<{w[c]}}" for c in cols[:-1]) + "  title")
    for r in rows:
        print("  ".join(f"{r[c]:<{w[c]}}" for c in cols[:-1]) + "  " + r["title"])
    print("\nEvery command's --robot also takes a path to a description file (docs/robots.md).")
    return 0


cmd_robots.configure = _robots_configure


def _load_plugins():
    # Capability modules register their own sub-commands on import.
    import importlib

    for mod in ("demo", "scenario", "calibration", "quattro", "discrepancy", "sweep", "benchmark", "importing",
                "fmu"):
        importlib.import_module(f"cosim.cli.{mod}")


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


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line (what is wrong, with the valid choices); the usage is
    one ``--help`` away."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def main(argv=None) -> int:
    _load_plugins()
    parser = _Parser(prog="cosim", description=__doc__)
    parser.add_argument("--quiet", dest="global_quiet", action="store_true",
                        help="no progress bars (they show on a terminal only, after 2 s)")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, (fn, help) in COMMANDS.items():
        p = sub.add_parser(name, help=help, description=help)
        if hasattr(fn, "configure"):
            fn.configure(p)
        p.set_defaults(_fn=fn)
    args = parser.parse_args(argv)
    if args.global_quiet:
        import os

        os.environ["TQDM_DISABLE"] = "1"  # every tqdm bar of the package (and of dask) stays off
    from ..errors import PkmError
    from ..master import MasterError

    try:
        return int(args._fn(args) or 0)
    except (PkmError, ValueError, FileNotFoundError, MasterError) as e:
        print(f"cosim {args.command}: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # The reader went away (`cosim params 6pus | head`): stop quietly, as Unix tools do.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
