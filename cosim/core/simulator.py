"""The core's integrator (``pkm_sim``): a robot's task-space state under a held input, its
options and its saved state (docs/integration.md).
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, pkm_sim_options, pkm_sim_stats, ptr, raise_for
from ..errors import ArgumentError
from ._handles import _release


def _method_table() -> dict:
    """The core's table of integration methods (``pkm_sim_method``): ``{name: (code, title)}``."""
    out = {}
    for i in range(lib.pkm_sim_method_count()):
        code, name, title, avail = C.c_int(), C.c_char_p(), C.c_char_p(), C.c_int()
        if lib.pkm_sim_method(i, C.byref(code), C.byref(name), C.byref(title), C.byref(avail)) == 0:
            out[name.value.decode()] = (code.value, title.value.decode())
    return out


#: integration methods of the core by short name: (pkm_lmm code, title), the core's one list
METHODS = _method_table()
_METHODS = {k: v[0] for k, v in METHODS.items()}
_METHOD_NAMES = {v: k for k, v in _METHODS.items()}
#: integration method names and their pkm.h codes (pkm_lmm; the FMUs' solver.method)
METHOD_CODES = dict(_METHODS)
#: integration method names and their titles ("explicit Runge-Kutta 5(4)")
METHOD_TITLES = {k: v[1] for k, v in METHODS.items()}


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
        _release(self, "_s", "pkm_sim_destroy")

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

    def set_external(self, f) -> None:
        """Hold a known external effort f [N or N m] per joint, positive along +q, from now on
        (``pkm_sim_set_external``): added to the actuator effort, not saturated, not delayed."""
        f = self._vec(f, "f")
        self._check(lib.pkm_sim_set_external(self._s, ptr(f)))

    def advance(self, t_end: float) -> None:
        """Integrate to t_end [s] with the held input.

        On a stroke limit (``JointLimitError``), a direct singularity (``SingularError``)
        or an integrator failure (``IntegrationError``), the state stays where the
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
    def drive_state(self):
        """``(theta, theta_d)``: drive-side position [m or rad] and rate per joint
        (``pkm_sim_drive_state``): the drive body's on a joint that is two bodies
        (``drive.two_body = 1`` with a backlash or a compliance), the joint's own otherwise."""
        th, thd = np.empty(self.ndof), np.empty(self.ndof)
        self._check(lib.pkm_sim_drive_state(self._s, ptr(th), ptr(thd)))
        return th, thd

    @property
    def applied_effort(self) -> np.ndarray:
        """Effort acting on the mechanism now [N or N m] (``pkm_sim_applied_effort``): the
        held input after saturation, or with ``actuator.delay`` the command issued that much
        earlier (zero before the first)."""
        tau = np.empty(self.ndof)
        self._check(lib.pkm_sim_applied_effort(self._s, ptr(tau)))
        return tau

    @property
    def stats(self) -> dict:
        """Integrator counters summed over all advances since creation: steps, rhs_evals
        (with BDF including those of the difference-quotient Jacobian), jac_evals,
        error_test_fails, nonlin_conv_fails."""
        st = pkm_sim_stats()
        self._check(lib.pkm_sim_get_stats(self._s, C.byref(st)))
        return {name: int(getattr(st, name)) for name, _ in pkm_sim_stats._fields_}


# --------------------------------------------------------- compiled controllers
