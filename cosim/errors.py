"""The exceptions the core's statuses become (``pkm.h``, status section).

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

__all__ = ["PkmError", "ArgumentError", "ParameterError", "UnreachableError", "SingularError",
           "ConvergenceError", "JointLimitError", "IntegrationError", "UnsupportedError"]


class PkmError(RuntimeError):
    """An error reported by the core; ``status`` is the C status name."""

    def __init__(self, message: str, status: str = "PKM_ERR_INTERNAL"):
        super().__init__(message)
        self.status = status


class ArgumentError(PkmError, ValueError):
    """Bad argument: wrong shape, NaN or Inf in an input."""


class ParameterError(PkmError, ValueError):
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
