"""Geometric calibration: identify a robot's geometry from measured poses and joints.

The family, one module per job: :mod:`.fit` (``calibrate``, ``accuracy``, the result
objects; re-exported here), :mod:`.joint_problem` (the one problem class, residuals and Jacobians from the core),
:mod:`.error_model` (the error model a robot ships as data), :mod:`.problems` (the interface),
:mod:`.ident` (identifiability), :mod:`.solvers`, :mod:`.design` (pose selection),
:mod:`.data` (synthetic campaigns), :mod:`.seed` (the seeds' examples), :mod:`.plots`,
:mod:`.bench` and :mod:`.cli` (``cosim calibrate``).  docs/calibration.md.
"""
from .fit import *  # noqa: F401,F403  (the public API of the family)
from .fit import __all__  # noqa: F401
