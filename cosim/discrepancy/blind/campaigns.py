"""Campaign cases: several closed-loop runs of the EMPS axis, with or without a parameter that
drifts between the runs (:mod:`cosim.discrepancy.campaign_drift`).

Every run is a core simulation of the same plant (Coulomb friction ``c`` in [15, 25] N and
viscous friction ``v`` in [100, 200] N s/m hidden from the frictionless nominal model), each
run with its own excitation and noise, PD control designed on the nominal model.  The runs
start at times drawn with gaps of 10 to 30 min (``times``).  With a drift, one of the two
frictions changes linearly with the runs' start time, by a fraction drawn in
``[-0.25, -0.05]`` or ``[0.05, 0.25]`` of its first value over the campaign (a drive that warms
up, a lubricant that thins); without, every run has the same values.

Example
-------
>>> runs, times, truth = drift_campaign(seed=3, robot=rail_robot)  # doctest: +SKIP
>>> truth["param"], truth["values"][0], truth["values"][-1]  # doctest: +SKIP
('rail[1].coulomb', 21.3, 18.4)
"""
from __future__ import annotations

import numpy as np

#: sample time, lead-in dropped from every run [s]
DT, LEAD = 1e-3, 0.5
#: sensor noise of the runs (position [m], rate [m/s], effort [N])
NOISE = {"q": 1e-6, "qd": 1e-4, "tau": 0.5}
#: the parameters that may drift
PARAMS = ("rail[1].coulomb", "rail[1].viscous")


def _run(robot: str, hidden: dict, duration: float, seed: int):
    """One closed-loop run of ``robot`` with ``hidden`` parameters, after the lead-in."""
    from ...core.model import Model
    from ...master import make_reference
    from ..excitation import excitation
    from ..runs import closed_loop
    from .cases import _controller, load_config

    m = Model(robot)
    traj = excitation(m, duration, seed=seed)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    plant = m.copy()
    plant.set_params(hidden)
    ctrl = _controller("pd_gravity", m, load_config(), DT)
    res = closed_loop(plant, ctrl, ref, noise=NOISE, seed=seed)
    return res.to_recording(effort="logged", start=int(LEAD / DT), qref=ref.q, controller=ctrl.describe())


def drift_campaign(seed: int, *, robot: str, runs: int = 8, duration: float = 2.0, drift: bool = True):
    """A campaign case: ``(recordings, start times [s], truth)``.

    Parameters
    ----------
    seed : int
        Draws the plant, the drift, the start times and every run's excitation and noise.
    robot : str
        A one-axis rail robot with ``rail[1].coulomb`` and ``rail[1].viscous`` (the EMPS axis
        is the one measured in bench/campaign_drift.py).
    runs : int
        Number of runs.
    duration : float
        Each run's length, lead-in included [s].
    drift : bool
        Whether a parameter drifts between the runs (module docstring).

    Returns
    -------
    recordings : list of cosim.recording.Recording
    times : numpy.ndarray
        The runs' start times [s], the first at 0.
    truth : dict
        ``hidden`` (the first run's parameters), and with a drift ``param``, ``values`` (its
        value in each run), ``change`` (last minus first) and ``relative`` (over the first).
    """
    rng = np.random.default_rng(seed)
    hidden = {"rail[1].coulomb": float(rng.uniform(15.0, 25.0)), "rail[1].viscous": float(rng.uniform(100.0, 200.0))}
    times = np.concatenate([[0.0], np.cumsum(rng.uniform(600.0, 1800.0, runs - 1))])
    truth = {"hidden": dict(hidden)}
    values = None
    if drift:
        param = PARAMS[int(rng.integers(len(PARAMS)))]
        rel = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.25))
        values = hidden[param] * (1.0 + rel * times / times[-1])
        truth.update(param=param, values=values.tolist(), change=float(values[-1] - values[0]), relative=rel)
    recs = []
    for k in range(runs):
        h = dict(hidden) if values is None else dict(hidden, **{truth["param"]: float(values[k])})
        recs.append(_run(robot, h, duration, seed * 1000 + k))
    return recs, times, truth
