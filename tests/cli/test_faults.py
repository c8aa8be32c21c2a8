"""A fault of the toolkit (not of the input) on the command line: one line "internal error:
<type>: <message> (please report it ...)" and exit code 70, never a traceback, and never
the "error:" line and exit code 2 of a user's mistake.  The faults are injected: a library
function the command calls is replaced by one that fails as a bug would (a plain
ValueError, numpy's included, a ZeroDivisionError, a failed import); the same place raising
the package's InputError is a mistake again."""
import contextlib
import importlib
import io
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim.core.model import Model
from cosim.errors import InputError, PkmError, is_input_error

cli_main = importlib.import_module("cosim.cli.main")  # the module (cosim.cli.main is also its function)
REPO = Path(__file__).resolve().parents[2]
REPORT = "(please report it with the command that caused it; COSIM_TRACEBACK=1 shows where)"


def _call(argv):
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = cli_main.main(argv)
    return code, err.getvalue()


def _numpy_shape_fault(self):
    return np.zeros(2) + np.zeros(3)  # numpy's own ValueError: operands could not be broadcast


def _plain_value_error(self):
    raise ValueError("an index 7 out of a table of 6")


def _division(self):
    return 1 / 0


@pytest.mark.parametrize("fault,expect", [
    (_plain_value_error, "cosim params: internal error: ValueError: an index 7 out of a table of 6 " + REPORT),
    (_division, "cosim params: internal error: ZeroDivisionError: division by zero " + REPORT),
    (_numpy_shape_fault, "cosim params: internal error: ValueError: operands could not be broadcast together"),
])
def test_a_fault_inside_a_command_is_an_internal_error_with_exit_code_70(monkeypatch, fault, expect):
    monkeypatch.delenv("COSIM_TRACEBACK", raising=False)
    monkeypatch.setattr(Model, "param_info", fault)
    code, err = _call(["params", "6pus"])
    lines = err.strip().splitlines()
    assert code == 70 and len(lines) == 1 and lines[0].startswith(expect) and lines[0].endswith(REPORT), (code, err)
    assert "error: " not in lines[0].replace("internal error: ", ""), err


def test_the_same_place_raising_an_input_error_is_a_mistake_with_exit_code_2(monkeypatch):
    def mistake(self):
        raise InputError("leg[2].L = -1 m: must be > 0")

    monkeypatch.setattr(Model, "param_info", mistake)
    code, err = _call(["params", "6pus"])
    assert (code, err) == (2, "cosim params: error: leg[2].L = -1 m: must be > 0\n")


def test_a_core_status_is_a_mistake_unless_the_core_calls_it_internal(monkeypatch):
    def internal(self):
        raise PkmError("a table index out of range", "PKM_ERR_INTERNAL")

    def unreachable(self):
        raise PkmError("leg 1 cannot reach the pose", "PKM_ERR_UNREACHABLE")

    monkeypatch.setattr(Model, "param_info", internal)
    code, err = _call(["params", "6pus"])
    assert code == 70 and err.startswith("cosim params: internal error: PkmError: a table index out of range"), err
    monkeypatch.setattr(Model, "param_info", unreachable)
    assert _call(["params", "6pus"]) == (2, "cosim params: error: leg 1 cannot reach the pose\n")


def test_a_fault_while_starting_is_an_internal_error_too(monkeypatch):
    def broken_import():
        raise ImportError("cannot import name 'plot_map' from 'cosim.plots'")

    monkeypatch.setattr(cli_main, "_load_plugins", broken_import)
    code, err = _call(["params", "6pus"])
    assert code == 70 and err == f"cosim params: internal error: ImportError: cannot import name 'plot_map' from " \
                                 f"'cosim.plots' {REPORT}\n", err


def test_cosim_traceback_raises_the_fault_itself(monkeypatch):
    monkeypatch.setenv("COSIM_TRACEBACK", "1")
    monkeypatch.setattr(Model, "param_info", _division)
    with pytest.raises(ZeroDivisionError):
        _call(["params", "6pus"])


def test_the_installed_command_exits_70_with_one_line():
    # A shell's view: a fresh interpreter in which the command's library call divides by zero.
    code = ("import sys; from cosim.core.model import Model; Model.param_info = lambda self: 1 / 0; "
            "from cosim.cli.main import main; sys.exit(main(['params', '6pus']))")
    env = {k: v for k, v in os.environ.items() if k != "COSIM_TRACEBACK"}
    p = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120, env=env)
    assert p.returncode == 70 and p.stdout == "" and "Traceback" not in p.stderr, (p.returncode, p.stderr)
    assert p.stderr == f"cosim params: internal error: ZeroDivisionError: division by zero {REPORT}\n", p.stderr


def test_input_errors_are_value_errors_and_the_package_errors_derive_from_input_error():
    from cosim.calibration.problems import CalibrationDataError
    from cosim.controllers import ControllerError
    from cosim.discrepancy.residuals import DiagnosisError
    from cosim.errors import ArgumentError, ParameterError, UnreachableError
    from cosim.importing.errors import ImportFailure
    from cosim.recording import RecordingError
    from cosim.report import ReportError
    from cosim.scenario import ScenarioError
    from cosim.sweep.errors import SweepSpecError
    from cosim.trajectories import TrajectoryError

    for cls in (ArgumentError, ParameterError, CalibrationDataError, ControllerError, DiagnosisError, ImportFailure,
                ReportError, ScenarioError, SweepSpecError, TrajectoryError):
        assert issubclass(cls, InputError) and issubclass(cls, ValueError), cls
    assert is_input_error(RecordingError("x.csv", "column 'q1' is missing"))
    assert is_input_error(UnreachableError("leg 1 cannot reach the pose", "PKM_ERR_UNREACHABLE"))
    assert not is_input_error(ValueError("plain")) and not is_input_error(ZeroDivisionError())


@pytest.mark.parametrize("raised,code,start", [
    (ZeroDivisionError("division by zero"), 70, "cosim run: internal error: ZeroDivisionError: reference "),
    (PkmError("leg 3 cannot reach the pose", "PKM_ERR_UNREACHABLE"), 2, "cosim run: error: reference "),
])
def test_a_fault_the_co_simulation_wraps_is_still_a_fault(monkeypatch, tmp_path, raised, code, start):
    # The co-simulation says what stopped it (MasterError, "reference ...: cannot map it to
    # joints: ..."); what it wraps decides whose the problem is.
    import cosim.trajectories

    def joint_reference(*a, **k):
        raise raised

    monkeypatch.delenv("COSIM_TRACEBACK", raising=False)
    monkeypatch.setattr(cosim.trajectories, "joint_reference", joint_reference)
    rc, err = _call(["run", str(REPO / "scenarios" / "6pus_step_pd.toml"), "--out", str(tmp_path / "run")])
    lines = err.strip().splitlines()
    assert rc == code and len(lines) == 1 and lines[0].startswith(start) and str(raised) in lines[0], (rc, err)
