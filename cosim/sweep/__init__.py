"""Sweeps: many scenario runs, calibration trials, blind cases or index-map tiles, on Dask.

The family: :mod:`.spec` (the spec file, its cases and their ids), :mod:`.case` (one
case and its record), :mod:`.shipping` (FMUs to the workers), :mod:`.store` (the
results file, resume), :mod:`.result` (``SweepResult``, the table), :mod:`.cluster`
(the LocalCluster or a scheduler, the fan-out), :mod:`.runner` (``run_sweep``; the
public API, re-exported here), :mod:`.kinds` (what one case of each kind runs),
:mod:`.bench` (``cosim sweep --bench``); the command is :mod:`cosim.cli.sweep`.
docs/sweep.md.
"""
from .runner import *  # noqa: F401,F403  (the public API of the family)
from .runner import __all__  # noqa: F401
