"""Blind cases: recordings with hidden effects, their answer keys, and the benchmark.

A case is a closed-loop recording (:func:`cosim.discrepancy.runs.closed_loop`) of a
core plant in which one or two effects of the library are set (the "hidden" physics)
while the recording's sidecar gives the nominal model only.  The controller (PD +
gravity compensation or computed torque, designed on the nominal model) tracks an
exciting trajectory (:mod:`cosim.discrepancy.excitation`), so the positions track well
and the signature is in the effort and the readings.  The answer key goes to a
separate directory; :func:`cosim.discrepancy.diagnose` reads only the recording.

Magnitudes, noise and the controller come from ``scenarios/blind/config.toml``.

Example
-------
>>> from cosim.discrepancy import blind
>>> rec_path, key_path = blind.make_case(blind.CaseSpec("c1", "6pus", ["coulomb"], seed=1),
...                                      out_dir="/tmp/blind", key_dir="/tmp/blind_keys")
"""
from __future__ import annotations

from .cases import (CONFIG, CaseSpec, REPO, _controller, derived_sizes, load_config, make_case, plan,  # noqa: F401
                          simulate_case, types_for, with_robot)
from .sampling import (Hidden, TYPES, UNLISTED, UNLISTED_TERMS, sample_effect, sample_unlisted,  # noqa: F401
                             unlisted_errors, unlisted_structure_ok)
from .scoring import (HOLD_OUT_WITH, benchmark, format_summary, interval_holds, same_physics_stand_in,  # noqa: F401
                            score, stated_intervals, summarize)
