"""The package's exceptions: the mistakes of its caller (:class:`InputError` and its
subclasses) and the statuses of the core (``pkm.h``, status section).

:class:`InputError` is what every check of the caller's input raises: a file, a row or
column of it, a parameter, a joint, a time, an option.  Its subclasses (:class:`ArgumentError`,
:class:`ParameterError`, :class:`ScenarioError`, :class:`RecordingError`,
:class:`DiagnosisError`...) say which input.  :class:`InputError` is a ``ValueError``, so a
caller that catches ``ValueError`` catches it too; the command line tells it (one line,
exit code 2) from a fault of the toolkit (any other exception: one line, exit code 70).
Every exception of the package's modules is defined here (and importable from the module
that raises it, e.g. ``cosim.scenario.ScenarioError``).

Every core call that fails raises one of these, with the core's message (what and where:
leg, pose, time, parameter) and ``status``, the C status name.  They subclass the built-in
exceptions a Python caller expects (``ValueError`` for a bad argument or parameter,
``NotImplementedError`` for a function the robot does not provide).

>>> from cosim.core import Model
>>> from cosim.errors import UnreachableError
>>> try:
...     Model("6pus").ik([0.0, 0.0, 0.5, 0.0, 0.0, 0.0])
... except UnreachableError as e:
...     print(e.status)
PKM_ERR_UNREACHABLE
"""
from __future__ import annotations

__all__ = ["InputError", "is_input_error", "PkmError", "ArgumentError", "ParameterError", "UnreachableError",
           "SingularError", "ConvergenceError", "JointLimitError", "IntegrationError", "UnsupportedError",
           "MasterError", "InjectionError", "DiagnosisError", "CampaignError", "FMUError", "RecordingError",
           "ControllerError", "ReportError", "LoopInterrupted", "TrajectoryError", "ImportFailure", "URDFError",
           "ScenarioError"]


class InputError(ValueError):
    """A mistake in the caller's input; the message says what is wrong and where (file,
    row, column, parameter, joint, time).

    >>> from cosim.errors import InputError
    >>> issubclass(InputError, ValueError)
    True
    """


class PkmError(RuntimeError):
    """An error reported by the core; ``status`` is the C status name.  Every status but
    ``PKM_ERR_INTERNAL`` (a bug of the core) describes the input: a pose, a parameter, a
    joint's stroke, a time step (:func:`is_input_error`)."""

    def __init__(self, message: str, status: str = "PKM_ERR_INTERNAL"):
        super().__init__(message)
        self.status = status


class ArgumentError(PkmError, InputError):
    """Bad argument: wrong shape, NaN or Inf in an input."""


class ParameterError(PkmError, InputError):
    """A parameter value is invalid."""


class UnreachableError(PkmError):
    """A pose outside the workspace of a leg or arm."""


class SingularError(PkmError):
    """A singular configuration."""


class ConvergenceError(PkmError):
    """An iterative solver (forward kinematics) did not converge."""


class JointLimitError(PkmError):
    """A stroke or joint range was exceeded."""


class IntegrationError(PkmError):
    """The integrator (explicit Runge-Kutta or CVODE) failed."""


class UnsupportedError(PkmError, NotImplementedError):
    """The robot does not provide the function."""


_FAULTS = ("PKM_ERR_INTERNAL", "PKM_ERR_UNKNOWN")  # a bug of the core, or a status this package does not know


def is_input_error(error: BaseException) -> bool:
    """Whether ``error`` is a mistake in the caller's input (an :class:`InputError`, or a
    core status other than an internal one) rather than a fault of the toolkit.

    Parameters
    ----------
    error : BaseException
        The exception caught.

    Returns
    -------
    bool
        True for the caller's mistakes; False for everything else (a plain ``ValueError``
        raised by numpy included).

    Examples
    --------
    >>> from cosim.errors import ParameterError, PkmError, is_input_error
    >>> is_input_error(ParameterError("platform.m = -1 kg must be > 0", "PKM_ERR_PARAMETER"))
    True
    >>> is_input_error(PkmError("unexpected", "PKM_ERR_INTERNAL")), is_input_error(ValueError("numpy"))
    (False, False)
    """
    if isinstance(error, PkmError):
        return error.status not in _FAULTS
    return isinstance(error, InputError)


class MasterError(RuntimeError):
    """A co-simulation that could not go on (:func:`cosim.master.run`); says at which time
    and why.

    ``partial`` holds the :class:`cosim.run_record.RunRecord` of the samples taken before the
    failure.
    """

    def __init__(self, message, partial=None):
        super().__init__(message)
        self.partial = partial


# ------------------------------------------- the exceptions of the package's modules


#: raised by :mod:`cosim.injection` (and importable from it)
class InjectionError(InputError):
    """An injected signal or its declaration is wrong; the message says what and where."""


#: raised by :mod:`cosim.discrepancy.residuals` (and importable from it)
class DiagnosisError(InputError):
    """A recording (or model) the engine cannot diagnose; the message says what is missing."""


#: raised by :mod:`cosim.discrepancy.campaign` (and importable from it)
class CampaignError(InputError):
    """A campaign the engine cannot diagnose: runs of two robots, sampled at different
    rates, a per-run quantity of a kind it cannot take out, a campaign file without runs."""


#: raised by :mod:`cosim.fmu` (and importable from it)
class FMUError(RuntimeError):
    """An FMI call failed; ``log`` holds the FMU's log lines of that instance."""

    def __init__(self, message: str, log: list[str] | None = None):
        super().__init__(message)
        self.log = list(log or [])


#: raised by :mod:`cosim.recording` (and importable from it)
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


#: raised by :mod:`cosim.controllers` (and importable from it)
class ControllerError(InputError):
    """A controller that cannot be built or cannot act (says which gain/joint/time)."""


#: raised by :mod:`cosim.report` (and importable from it)
class ReportError(InputError):
    """A recording or robot the report cannot draw (says which and why)."""


#: raised by :mod:`cosim.closed_loop` (and importable from it)
class LoopInterrupted(KeyboardInterrupt):
    """Ctrl-C during a run: ``partial`` holds what was recorded before it."""

    def __init__(self, partial):
        super().__init__("closed loop interrupted")
        self.partial = partial


#: raised by :mod:`cosim.trajectories` (and importable from it)
class TrajectoryError(InputError):
    """A trajectory specification that cannot be evaluated (says which item is wrong)."""


#: raised by :mod:`cosim.importing.errors` (and importable from it)
class ImportFailure(InputError):
    """A source file or a map that cannot be imported.

    The message is one line: the file, then the variable (of the source) or the field (of
    the map) and the recording column it feeds, then what is wrong.  The CLI prints it and
    exits with status 2.
    """

    def __init__(self, path, message, variable=None, column=None, field=None):
        where = str(path)
        if field is not None:
            where += f", field {field}"
        if variable is not None:
            where += f", variable {variable!r}"
        if column is not None:
            where += f" (column {column})"
        super().__init__(f"{where}: {message}")
        self.path, self.variable, self.column, self.field = path, variable, column, field


#: raised by :mod:`cosim.robots.urdf` (and importable from it)
class URDFError(InputError):
    """A URDF the toolkit cannot read as a serial arm; the message names file, line and element."""


#: raised by :mod:`cosim.scenario` (and importable from it)
class ScenarioError(InputError):
    """A scenario file that cannot be run; names the file and the key."""
