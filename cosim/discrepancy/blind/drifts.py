"""Drift cases: 6-PUS recordings whose plant has a parameter that drifts, simulated by the core
with the parameter's time course in its integrator (:meth:`cosim.core.Model.set_course`).

Two kinds, drawn from a seed:

- ``trend``: a rail's Coulomb friction falls linearly over the recording as a drive warms up,
  from ``c0`` in [0.08, 0.16] N to ``c1`` = ``c0`` x [0.2, 0.5];
- ``step``: a payload of [0.06, 0.15] kg put on at a time between 25 % and 55 % of the
  recording (inside the part a diagnosis fits on, train fraction 0.7).

The controller, the excitation and the sensor noise are the blind generator's
(``scenarios/blind/config.toml``).

Example
-------
>>> rec, truth = drift_case("trend", seed=101)      # doctest: +SKIP
>>> truth
{'param': 'rail[4].coulomb', 'kind': 'trend', 'start': 0.12, 'end': 0.041, 'rate': -0.0135, 't0': 0.0}
"""
from __future__ import annotations

import numpy as np

#: sample time, lead-in (dropped from the recording) and length of a case [s]
DT, LEAD, DURATION = 1e-3, 0.5, 6.0
KINDS = ("trend", "step")


def drift_case(kind: str, seed: int, duration: float = DURATION, step: dict | None = None):
    """One drift case: ``(recording, truth)``.

    Parameters
    ----------
    kind : {"trend", "step"}
        The drift (module docstring).
    seed : int
        Draws the drift and the excitation and noise.
    duration : float
        The run's length, lead-in included [s].
    step : dict, optional
        ``step``: the step instead of a payload drawn from the seed: ``param``, ``value`` (its
        value before), ``size`` and ``at`` (when, as a fraction of the recording).

    Returns
    -------
    recording : cosim.recording.Recording
        From the end of the lead-in; the nominal model's controller.
    truth : dict
        ``param``, ``kind``, ``start`` and ``end`` (its values at the recording's first and
        last sample), ``rate`` [unit/s] or ``size`` [unit] and ``t0`` [s] as the plant had them.
    """
    from ...core.model import Model
    from ...errors import InputError
    from ...master import make_reference
    from ...recording import Recording
    from ..excitation import excitation
    from ..runs import closed_loop
    from .cases import _controller, load_config

    if kind not in KINDS:
        raise InputError(f"drift_case: kind {kind!r} is none of {KINDS}")
    rng = np.random.default_rng(seed)
    cfg = load_config()
    m = Model("6pus")
    plant = m.copy()
    if kind == "trend":
        j = int(rng.integers(1, 7))
        c0 = float(rng.uniform(0.08, 0.16))
        c1 = c0 * float(rng.uniform(0.2, 0.5))
        param, course = f"rail[{j}].coulomb", {"rate": (c1 - c0) / duration, "t0": 0.0}
        plant.set_params({param: c0})
    else:
        param, size, at = "payload.m", float(rng.uniform(0.06, 0.15)), float(rng.uniform(0.25, 0.55))
        if step is not None:
            param, size, at = step["param"], step["size"], step["at"]
            plant.set_params({param: step["value"]})
        course = {"size": size, "t0": round(LEAD + at * (duration - LEAD), 3)}
    plant.set_course(param, kind, **course)
    traj = excitation(m, duration, seed=seed, lead_in=LEAD)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    ctrl = _controller("pd_gravity", m, cfg, DT)
    res = closed_loop(plant, ctrl, ref, noise=cfg["noise"]["6pus"], seed=seed)
    s = slice(int(LEAD / DT), None)
    rec = Recording("6pus", res.time[s], res.q[s], res.qd[s], res.tau_logged[s], qref=ref.q[s][: len(res.time[s])],
                    pose=res.pose[s], controller=dict(ctrl.describe(), rate_hz=1.0 / DT))
    t = rec.time
    truth = {"param": param, "kind": kind, "start": plant.value_at(param, float(t[0])),
             "end": plant.value_at(param, float(t[-1])), **course}
    return rec, truth
