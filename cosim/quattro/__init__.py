"""Adept Quattro s650H (Virzi 2010): :mod:`.maps` (performance-index maps, figures, the
Adept frame; re-exported here) and :mod:`.cycle_time` (the cycle-time model against the
measured tables).  docs/quattro.md.
"""
from .maps import *  # noqa: F401,F403  (the public API of the family)
from .maps import BETTER, __all__, indices  # noqa: F401
