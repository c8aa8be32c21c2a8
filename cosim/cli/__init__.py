"""The ``cosim`` command: :mod:`.main` (the parser and ``main``), :mod:`.common` (the
sub-command registry ``command``, the argument types, ``working``) and one module per family
of sub-commands (:mod:`.demo`, :mod:`.scenario`, :mod:`.calibration`, :mod:`.quattro`,
:mod:`.discrepancy`, :mod:`.sweep`, :mod:`.benchmark`, :mod:`.importing`, :mod:`.fmu`,
:mod:`.parasitic`), each a thin layer over the package functions.
"""
from .common import COMMANDS, command, working  # noqa: F401
from .main import main  # noqa: F401
