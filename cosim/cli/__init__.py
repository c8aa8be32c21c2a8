"""The ``cosim`` command: :mod:`.main` (the parser, ``command``, ``working``; re-exported
here) and one module per family of sub-commands (:mod:`.demo`, :mod:`.scenario`,
:mod:`.calibration`, :mod:`.quattro`, :mod:`.discrepancy`, :mod:`.sweep`,
:mod:`.benchmark`, :mod:`.fmu`), each a thin layer over the package functions.
"""
from .main import COMMANDS, command, main, working  # noqa: F401
