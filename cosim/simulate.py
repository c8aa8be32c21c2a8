"""Time simulation of a robot model with the core's CVODE integrator (``pkm_sim``).

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

import ctypes as C
from dataclasses import dataclass, field

import numpy as np

from ._native import ArgumentError, PkmError, lib, pkm_sim_options, pkm_sim_stats, ptr, raise_for

__all__ = ["Simulator", "SimResult", "simulate", "default_options"]

_METHODS = {"bdf": 0, "adams": 1, "erk": 2, "erk23": 3}
_METHOD_NAMES = {v: k for k, v in _METHODS.items()}
#: integration method names and their pkm.h codes (pkm_lmm; the FMUs' solver.method)
METHOD_CODES = dict(_METHODS)


def default_options() -> dict:
    """The core's default integrator options (``pkm_sim_default_options``) as a dict."""
    o = pkm_sim_options()
    lib.pkm_sim_default_options(C.byref(o))
    return {
        "method": _METHOD_NAMES[o.method],
        "rtol": o.rtol,
        "atol": o.atol,
        "max_step": o.max_step,
        "max_steps": o.max_steps,
        "sing_min": o.sing_min,
    }


class Simulator:
    """An integration of one robot's task-space state under a held input.

    Parameters
    ----------
    model : cosim.core.Model
        The robot.  The simulator copies it: later ``model.set_params`` calls do not
        change a simulator that already exists.
    method : {"erk", "erk23", "bdf", "adams"}
        ``"erk"`` (default): explicit Runge-Kutta 5(4) (Dormand-Prince) that keeps its
        step size from one ``advance`` to the next, about one step per millisecond
        under a 1 kHz controller; for non-stiff motion.  ``"erk23"``: the Bogacki-Shampine
        3(2) pair, 4 instead of 7 forward-dynamics calls a step: faster at loose
        tolerances (docs/integration.md has the error / speed table).  ``"bdf"``: CVODE's BDF with
        Newton iteration and a dense difference-quotient Jacobian (stiff-safe: use it
        with Coulomb friction and a small ``drive.v_eps``).  ``"adams"``: CVODE's
        Adams with fixed-point iteration.
    rtol : float
        Relative tolerance of the local error (dimensionless).
    atol : float
        Absolute tolerance of the local error, applied to every state component
        [m, rad, m/s, rad/s].
    max_step : float
        Largest internal step [s]; 0 means unlimited.
    max_steps : int
        Largest number of internal steps within one ``advance``.
    sing_min : float
        The integration stops when the direct-singularity measure (``Model.singularity``
        column 1, in [0, 1]) falls below this value; 0 disables the check.

    Notes
    -----
    After ``Simulator(model)`` the state is the model's home pose at rest at t = 0 s
    with a zero input.  The result of an ``advance`` depends only on the simulator's
    state (:meth:`save_state`: t, x, xd, the held input, the explicit method's next
    step size and the actuator-delay history) and the options: restoring a saved
    state with :meth:`load_state` and advancing again reproduces the same numbers bit
    for bit.  ``reset`` starts afresh (the explicit method chooses a new first step).

    Examples
    --------
    >>> from cosim.core import Model
    >>> m = Model("6pus")
    >>> sim = Simulator(m)
    >>> sim.reset(0.0, m.home(), [0.01, 0, 0, 0, 0, 0])
    >>> sim.set_input(m.gravity_load(m.home()))
    >>> sim.advance(0.1)
    >>> t, x, xd = sim.state
    """

    def __init__(self, model, method: str = "erk", rtol: float = 1e-8, atol: float = 1e-10,
                 max_step: float = 0.0, max_steps: int = 100000, sing_min: float = 1e-4):
        if method not in _METHODS:
            raise ArgumentError(f"method must be one of {sorted(_METHODS)}, got {method!r}", "PKM_ERR_ARGUMENT")
        self.model = model
        self.ndof = model.ndof
        self.options = {"method": method, "rtol": float(rtol), "atol": float(atol), "max_step": float(max_step),
                        "max_steps": int(max_steps), "sing_min": float(sing_min)}
        opt = pkm_sim_options(_METHODS[method], float(rtol), float(atol), float(max_step), int(max_steps),
                              float(sing_min))
        err = C.create_string_buffer(1024)
        h = lib.pkm_sim_create(model._m, C.byref(opt), err, len(err))
        if not h:
            # pkm_sim_create reports by message only; map it to the status it stands for.
            msg = err.value.decode()
            if msg.startswith("pkm_sim options") or "is NULL" in msg:
                status = -1  # PKM_ERR_ARGUMENT
            elif "validate" in msg:
                status = -2  # PKM_ERR_PARAMETER
            elif msg.startswith("CVODE"):
                status = -7  # PKM_ERR_INTEGRATION
            else:
                status = -9  # PKM_ERR_INTERNAL
            raise_for(status, msg)
        self._s = C.c_void_p(h)
        self._x = np.empty(self.ndof)
        self._xd = np.empty(self.ndof)
        self._t = C.c_double(0.0)

    def __del__(self):
        try:
            if getattr(self, "_s", None):
                lib.pkm_sim_destroy(self._s)
                self._s = None
        except Exception:  # interpreter shutdown
            pass

    def _check(self, status: int) -> None:
        if status != 0:
            raise_for(status, lib.pkm_sim_error(self._s).decode())

    def _vec(self, v, name: str) -> np.ndarray:
        a = np.ascontiguousarray(v, dtype=np.float64)
        if a.shape != (self.ndof,):
            raise ArgumentError(f"{name} must have shape ({self.ndof},), got {a.shape}", "PKM_ERR_ARGUMENT")
        return a

    def reset(self, t0: float, x, xd=None) -> None:
        """Set the time t0 [s], pose x [m, rad] and pose rate xd [m/s, rad/s] (default 0).

        Raises the core's error (``UnreachableError``, ``JointLimitError``,
        ``SingularError``, ``ArgumentError``) if the state is not a valid start; the
        simulator keeps its previous state then.
        """
        x = self._vec(x, "x")
        xd = np.zeros(self.ndof) if xd is None else self._vec(xd, "xd")
        self._check(lib.pkm_sim_reset(self._s, float(t0), ptr(x), ptr(xd)))

    def set_input(self, tau) -> None:
        """Hold the actuator efforts tau [N or N m], shape (nd,), from now on."""
        tau = self._vec(tau, "tau")
        self._check(lib.pkm_sim_set_input(self._s, ptr(tau)))

    def advance(self, t_end: float) -> None:
        """Integrate to t_end [s] with the held input.

        On a stroke limit (``JointLimitError``), a direct singularity (``SingularError``)
        or a CVODE failure (``IntegrationError``), the state stays where the
        integration stopped and the exception's message names the leg and the time.
        """
        self._check(lib.pkm_sim_advance(self._s, float(t_end)))

    def save_state(self) -> np.ndarray:
        """The simulator's whole state as a 1-D array (``pkm_sim_state_save``), for
        :meth:`load_state` on this or another simulator of the same model and options."""
        buf = np.empty(int(lib.pkm_sim_state_size(self._s)))
        self._check(lib.pkm_sim_state_save(self._s, ptr(buf)))
        return buf

    def load_state(self, state) -> None:
        """Restore a state from :meth:`save_state`; a damaged or foreign one raises
        ``ArgumentError`` and changes nothing."""
        buf = np.ascontiguousarray(state, dtype=float).ravel()
        self._check(lib.pkm_sim_state_load(self._s, ptr(buf), buf.size))

    @property
    def state(self):
        """``(t, x, xd)``: time [s], pose [m, rad], pose rate [m/s, rad/s] (copies)."""
        self._check(lib.pkm_sim_get_state(self._s, C.byref(self._t), ptr(self._x), ptr(self._xd)))
        return float(self._t.value), self._x.copy(), self._xd.copy()

    @property
    def stats(self) -> dict:
        """CVODE counters summed over all advances since creation: steps, rhs_evals
        (including those of the difference-quotient Jacobian), jac_evals,
        error_test_fails, nonlin_conv_fails."""
        st = pkm_sim_stats()
        self._check(lib.pkm_sim_get_stats(self._s, C.byref(st)))
        return {name: int(getattr(st, name)) for name, _ in pkm_sim_stats._fields_}


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
        CVODE counters of the run (see :attr:`Simulator.stats`).
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
    cosim._native.PkmError
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
