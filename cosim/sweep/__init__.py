"""Sweeps: many scenario runs, calibration trials, blind cases or index-map tiles, on Dask.

The family: :mod:`.runner` (specs, case ids, ``run_sweep``, records; re-exported
here), :mod:`.kinds` (what one case of each kind runs), :mod:`.bench` (``cosim sweep
--bench``) and :mod:`.cli` (``cosim sweep``).  docs/sweep.md.
"""
from .runner import *  # noqa: F401,F403  (the public API of the family)
from .runner import __all__  # noqa: F401
