"""Python binding of the reference core: models, kinematics, dynamics, integration, control.

Every physical quantity is computed by the C++ core (``libpkm``); this package only moves
numpy arrays across the C ABI (declared once in :mod:`cosim._native`).  Batched calls take
arrays of shape ``(n, nd)`` (``nd`` = number of actuators = pose coordinates) and cost one
C call, so a million poses are one call.  Units are SI: m, rad, kg, N, N m, s.

One module per concern:

- :mod:`cosim.core.facts`: robot names, named parameters, :class:`RobotFacts`
- :mod:`cosim.core.model`: :class:`Model` (parameters, kinematics, dynamics), with its
  drive-layer methods from :mod:`cosim.core.model_drive` and its robot-specific families
  from :mod:`cosim.core.model_families`
- :mod:`cosim.core.simulator`: :class:`Simulator` (``pkm_sim``) and its options
- :mod:`cosim.core.controller`: :class:`CompiledController` (``pkm_ctrl``)
- :mod:`cosim.core.loop`: one ``pkm_closed_loop`` call
- :mod:`cosim.core.drive`: a drive's command-to-effort map (``pkm_effort_map``)
- :mod:`cosim.core.reading_delay`: :class:`ReadingDelay` (``pkm_reading_delay``), the
  readings' delay line of the stepwise loop
- errors: :mod:`cosim.errors`

The names below are the public API, importable from ``cosim.core``.

Example
-------
>>> from cosim.core import Model
>>> m = Model("6pus")                       # default parameter set
>>> x = m.home()                            # (x, y, z, rx, ry, rz) [m, rad]
>>> q = m.ik(x)                             # slider strokes [m]
>>> m.fk(q, x_guess=x + 1e-3)               # back to the pose
array([...])
>>> m.set_params({"platform.m": 0.42})      # overrides by name, checked by the core
"""
from ..errors import ArgumentError, ParameterError, PkmError, UnsupportedError
from .controller import DISCRETE_LAWS, INJECT_POINTS, KINDS, CompiledController
from .drive import effort_map
from .facts import ParamInfo, RobotFacts, quattro_index_names, quattro_index_units, robots
from .loop import LOOP_FIELDS, closed_loop_call
from .reading_delay import ReadingDelay
from .model import Model, robot_facts
from .simulator import METHOD_CODES, METHODS, Simulator, default_options

__all__ = ["Model", "ParamInfo", "RobotFacts", "robots", "robot_facts", "quattro_index_names",
           "quattro_index_units", "Simulator", "default_options", "METHOD_CODES", "METHODS", "ReadingDelay",
           "CompiledController", "KINDS", "DISCRETE_LAWS", "INJECT_POINTS", "effort_map", "LOOP_FIELDS",
           "closed_loop_call", "PkmError", "ParameterError", "ArgumentError",
           "UnsupportedError"]
