"""Command-line interface: ``cosim <command> ...``, a thin layer over the package functions."""
from __future__ import annotations

import argparse
import sys

from ..errors import is_input_error
from .common import COMMANDS, Interrupted, command, os_error_text, robot_arg


def _params_configure(p):
    from ..core.facts import robots
    from ..core.model import robot_facts

    names = robots()
    sets = "; ".join(f"{r}: {', '.join(robot_facts(r).param_sets)}" for r in names)
    p.add_argument("robot", type=robot_arg, help=f"robot name ({', '.join(names)}) or a description file")
    p.add_argument("--set", dest="param_set", default=None, help=f"named parameter set ({sets})")
    p.add_argument("--json", action="store_true", help="print JSON instead of a table")


@command("params", "print a robot's parameter set with units (table or --json)")
def cmd_params(args):
    from ..core.model import Model

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

    from ..core.facts import robots
    from ..core.model import robot_facts

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
    # Capability modules register their own sub-commands on import (the registry is
    # cosim.cli.common), in the order `cosim --help` lists them.
    from . import demo, scenario, calibration, quattro, discrepancy, sweep, benchmark, importing, fmu, parasitic, urdf  # noqa: F401, I001
    from . import identify  # noqa: F401, I001


class _Parser(argparse.ArgumentParser):
    """Argument errors in one line (what is wrong, with the valid choices); the usage is
    one ``--help`` away."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


EXIT_INPUT = 2  # a mistake in the input: the command line, a file, a value
EXIT_INTERRUPTED = 130  # ctrl-C
EXIT_INTERNAL = 70  # a fault of the toolkit (EX_SOFTWARE of sysexits.h); Python's own 1 is left to a crash


def main(argv=None) -> int:
    """``cosim ...``: the exit code: 0; 2 for a mistake in the input, said in one line
    ("error: ..."); 130 when interrupted by ctrl-C; 70 for a fault of the toolkit itself,
    also one line ("internal error: ..."; ``COSIM_TRACEBACK=1`` raises it instead, with
    its traceback).  ``cosim sweep`` adds 3 and 4 (docs/sweep.md)."""
    argv = sys.argv[1:] if argv is None else list(argv)
    called = next((a for a in argv if not a.startswith("-")), None)
    try:
        return _main(argv, called)
    except KeyboardInterrupt:  # while starting (imports) or saying the outcome
        print("cosim: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as e:  # noqa: BLE001 - while starting (imports, options): a fault, in one line
        return _fault(e, f"cosim {called}" if called in COMMANDS else "cosim")


def _main(argv, called) -> int:
    _load_plugins()
    parser = _Parser(prog="cosim", description=__doc__)
    parser.add_argument("--quiet", dest="global_quiet", action="store_true",
                        help="no progress bars (they show on a terminal only, after 2 s)")
    sub = parser.add_subparsers(dest="command", required=True)
    # Only the command called gets its options: building another's may ask the core or load
    # a capability module (its --help lists, e.g., the effects the blind generator can hide).
    for name, (fn, help) in COMMANDS.items():
        p = sub.add_parser(name, help=help, description=help)
        if name == called and hasattr(fn, "configure"):
            fn.configure(p)
        p.set_defaults(_fn=fn)
    try:
        args = parser.parse_args(argv)
    except SystemExit as e:  # --help, or a mistake argparse has said in one line
        return e.code if isinstance(e.code, int) else EXIT_INPUT
    if args.global_quiet:
        import os

        os.environ["TQDM_DISABLE"] = "1"  # every tqdm bar of the package (and of dask) stays off
    from ..fmu import FMUError
    from ..errors import MasterError
    from ..sweep.errors import SweepError

    prog = f"cosim {args.command}"
    try:
        return int(args._fn(args) or 0)
    except Interrupted as e:
        print(f"{prog}: {e}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        # The reader went away (`cosim params 6pus | head`): stop quietly, as Unix tools do.
        import os

        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except OSError as e:  # a file that is missing, cannot be read or written: the path is the user's
        return _mistake(prog, _one_line(e) if isinstance(e, FileNotFoundError) and not e.filename else os_error_text(e))
    except MemoryError:
        return _mistake(prog, "out of memory: ask for less (a smaller grid, a shorter run or recording)")
    except Exception as e:  # noqa: BLE001 - sorted below: the input's mistake, or a fault of the toolkit
        fault = _fault_in(e, (MasterError, FMUError, SweepError))
        if fault is None:
            return _mistake(prog, _one_line(e))
        return _fault(e, prog, type(fault).__name__)


def _fault_in(e: BaseException, wrappers) -> BaseException | None:
    """The fault of the toolkit in ``e``, or None when ``e`` is the input's mistake: an input
    error, or one of ``wrappers`` (the co-simulation, an FMU, a sweep: they say what stopped
    them, at which time, FMU call or spec) that wraps none, an input error or a file error."""
    if is_input_error(e) or isinstance(e, OSError):
        return None
    if isinstance(e, wrappers):
        return None if e.__cause__ is None else _fault_in(e.__cause__, wrappers)
    return e


def _mistake(prog: str, message: str) -> int:
    print(f"{prog}: error: {message}", file=sys.stderr)
    return EXIT_INPUT


def _fault(e: Exception, prog: str, kind: str | None = None) -> int:
    """A fault of the toolkit (not of the input), in one line: its type (``kind``: the type
    of the fault a wrapper holds) and message; ``COSIM_TRACEBACK=1`` raises it instead, so
    that the traceback shows where."""
    import os

    if os.environ.get("COSIM_TRACEBACK"):
        raise e
    print(f"{prog}: internal error: {kind or type(e).__name__}: {_one_line(e)} (please report it with the command "
          f"that caused it; COSIM_TRACEBACK=1 shows where)", file=sys.stderr)
    return EXIT_INTERNAL


def _one_line(e) -> str:
    return " ".join(str(e).split()) or type(e).__name__
