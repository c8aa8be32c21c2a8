"""Time simulation of a robot model with the core's integrator (``pkm_sim``: explicit Runge-Kutta 5(4) by default, CVODE BDF / Adams on request).

The state is the task-space pose and its rate, ``(x, xd)``; the input is the actuator
effort ``tau``, held constant between updates (zero-order hold).  The equations of
motion, the integration and the stop conditions (stroke limits, direct singularity) are
all in the C++ core; this module moves numpy arrays across the C ABI.  See
``docs/integration.md``.

Units are SI: time [s], pose [m, rad], pose rate [m/s, rad/s], joints q [m or rad],
joint rates qd [m/s or rad/s], efforts tau [N or N m].

Example
-------
>>> import numpy as np
>>> from cosim.core import Model
>>> from cosim.simulate import Simulator, simulate
>>> m = Model("6pus")
>>> x0 = m.home()
>>> res = simulate(m, x0, t_end=0.5, dt=1e-3, tau=m.gravity_load(x0))   # held at home
>>> res.x.shape
(501, 6)
>>> sim = Simulator(m, method="adams", rtol=1e-9)
>>> sim.reset(0.0, x0)
>>> sim.set_input(m.gravity_load(x0))
>>> sim.advance(0.01)
>>> t, x, xd = sim.state
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import ArgumentError, PkmError
# The integrator's handle lives in the binding (cosim.core owns every foreign call).
from .core.simulator import METHOD_CODES, Simulator, default_options

__all__ = ["Simulator", "SimResult", "simulate", "default_options", "METHOD_CODES"]


@dataclass
class SimResult:
    """Sampled trajectory of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Sample times [s].
    x : ndarray, shape (n, nd)
        Pose [m, rad].
    xd : ndarray, shape (n, nd)
        Pose rate [m/s, rad/s].
    q : ndarray, shape (n, nd)
        Actuated joints [m or rad] (core inverse kinematics of ``x``).
    qd : ndarray, shape (n, nd)
        Joint rates [m/s or rad/s] (core ``J(x) xd``).
    tau : ndarray, shape (n, nd)
        Effort applied from ``t[k]`` on [N or N m] (zero-order hold); the last row
        repeats the effort of the last interval.
    stats : dict
        The integrator's counters of the run (see :attr:`Simulator.stats`).
    error : PkmError or None
        The core's error that stopped the run early (then the last row is the state
        where it stopped), else None.
    """

    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    stats: dict = field(default_factory=dict)
    error: PkmError | None = None


def _input_fn(tau, model, n_steps, t0, dt):
    nd = model.ndof
    if tau is None:
        zero = np.zeros(nd)
        return lambda k, t, x, xd: zero
    if callable(tau):
        return lambda k, t, x, xd: tau(t, x, xd)
    a = np.asarray(tau, dtype=np.float64)
    if a.shape == (nd,):
        return lambda k, t, x, xd: a
    if a.shape == (n_steps, nd):
        return lambda k, t, x, xd: a[k]
    raise ArgumentError(f"tau must be None, a callable, shape ({nd},) or ({n_steps}, {nd}), got {a.shape}",
                        "PKM_ERR_ARGUMENT")


def simulate(model, x0, xd0=None, t_end: float = 1.0, dt: float = 1e-3, tau=None, t0: float = 0.0,
             **options) -> SimResult:
    """Simulate a robot from (x0, xd0) to t_end with the input updated every dt.

    Parameters
    ----------
    model : cosim.core.Model
        The robot (copied by the simulator).
    x0 : array_like, shape (nd,)
        Initial pose [m, rad].
    xd0 : array_like, shape (nd,), optional
        Initial pose rate [m/s, rad/s]; default at rest.
    t_end : float
        Final time [s].
    dt : float
        Sampling and input-update period [s]; the number of intervals is
        ``round((t_end - t0) / dt)`` and the samples are ``t0 + k dt``.
    tau : None, array_like or callable, optional
        Actuator efforts [N or N m], held over each interval: None (zero), a constant
        shape (nd,), a table shape (n_steps, nd), or a controller
        ``tau(t, x, xd) -> (nd,)`` called at every sample with the state there.
    t0 : float
        Initial time [s].
    **options
        Integrator options of :class:`Simulator` (method, rtol, atol, max_step,
        max_steps, sing_min).

    Returns
    -------
    SimResult
        Samples ``t, x, xd, q, qd, tau`` as numpy arrays.

    Raises
    ------
    cosim.errors.PkmError
        The core's error (``JointLimitError``, ``SingularError``, ``IntegrationError``,
        ``UnreachableError``, ``ArgumentError``) when the integration cannot reach
        t_end; its message names the leg and the time, and its ``result`` attribute
        holds the :class:`SimResult` up to the state where the integration stopped.

    Examples
    --------
    >>> from cosim.core import Model
    >>> m = Model("6pus", params={"gravity.z": 0.0})
    >>> res = simulate(m, m.home(), xd0=[0.01, 0, 0, 0, 0, 0.05], t_end=1.0, dt=1e-3)
    >>> res.q[-1]            # slider strokes at t = 1 s [m]
    array([...])
    """
    if not (np.isfinite(dt) and dt > 0):
        raise ArgumentError(f"dt = {dt} s must be finite and > 0", "PKM_ERR_ARGUMENT")
    if not (np.isfinite(t_end) and np.isfinite(t0) and t_end >= t0):
        raise ArgumentError(f"t_end = {t_end} s must be finite and >= t0 = {t0} s", "PKM_ERR_ARGUMENT")
    n_steps = int(round((t_end - t0) / dt))
    nd = model.ndof
    sim = Simulator(model, **options)
    x0 = np.asarray(x0, dtype=np.float64)
    sim.reset(t0, x0, xd0)
    u = _input_fn(tau, model, n_steps, t0, dt)

    t = np.empty(n_steps + 1)
    X = np.empty((n_steps + 1, nd))
    XD = np.empty((n_steps + 1, nd))
    U = np.empty((n_steps + 1, nd))
    t[0], X[0], XD[0] = sim.state
    error = None
    k = 0
    for k in range(n_steps):
        uk = np.asarray(u(k, t[k], X[k].copy(), XD[k].copy()), dtype=np.float64)
        U[k] = uk
        sim.set_input(uk)
        t_next = t_end if k == n_steps - 1 else t0 + (k + 1) * dt
        try:
            sim.advance(t_next)
        except PkmError as e:
            error = e
            t[k + 1], X[k + 1], XD[k + 1] = sim.state
            U[k + 1] = uk
            k += 1
            break
        t[k + 1], X[k + 1], XD[k + 1] = sim.state
    else:
        k = n_steps
        U[k] = U[k - 1] if n_steps > 0 else u(0, t[0], X[0], XD[0])
    n = k + 1
    t, X, XD, U = t[:n], X[:n], XD[:n], U[:n]
    q = model.ik(X)
    qd = model.joint_velocity(X, XD)
    res = SimResult(t, X, XD, q, qd, U, sim.stats, error)
    if error is not None:
        error.result = res
        raise error
    return res
