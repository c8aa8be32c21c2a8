"""Joint-space controllers (Zavala-Yoe et al. 2015 sec. 8.8) and their design/analysis with python-control.

All controllers are sampled at the co-simulation communication step ``dt``: at each
sample ``t_k`` they read the joint positions ``q`` [m or rad] and velocities ``qd``
and return the actuator efforts ``tau`` [N or N m] that the plant holds constant
(zero-order hold) until ``t_k + dt``.

* :func:`pd`: ``tau = Kp (qref - q) + Kd (qdref - qd)``.  Under gravity it settles with
  the error ``e_ss = Kp^-1 g(x)`` (:func:`predicted_steady_state_error`), ``g``
  the joint-space gravity load from the core.
* :func:`pd_gravity`: the same plus ``g(x)`` fed forward (Zavala-Yoe et al. 2015 step 6 of algorithm 3
  with ``J^T [0 0 mg 0 0 0]``); ``x`` is the pose the core's forward kinematics gives for
  the measured ``q`` (or the reference pose).  No steady-state error.
* :func:`pid`: PID with a filtered derivative, anti-windup and output limits (the core's
  law, as the compiled loop and the controller FMU run it).
* :func:`computed_torque`: ``qdd_cmd = qddref + Kd (qdref - qd) + Kp (qref - q)`` mapped
  to a pose acceleration and through the core's inverse dynamics, so the closed loop
  is a decoupled double integrator per joint when the model is exact.

Gains are designed from the decoupled joint double integrator ``m qdd = tau`` with the
effective joint mass ``m`` (:func:`joint_mass`) and checked on its zero-order-hold
discretisation at ``dt`` (:func:`design_pd`, :func:`closed_loop`), with python-control.
The physics (gravity load, inverse dynamics, kinematics) always comes from the core, and
so does every law: a controller here is its kind and gains as data, and calling it, or
running it in a closed loop on either back end, runs the core's ``pkm_ctrl``.

Example
-------
>>> from cosim.core import Model
>>> from cosim import controllers as ctl
>>> m = Model("6pus")
>>> mq = ctl.joint_mass(m, m.home())                     # (6, 6) [kg]
>>> d = ctl.design_pd(mass=mq.diagonal().max(), bandwidth_hz=5.0, damping=1.0, dt=1e-3)
>>> c = ctl.pd_gravity(m, kp=d.kp, kd=d.kd)
"""
from __future__ import annotations

from dataclasses import dataclass, field

import control
import numpy as np

from .errors import InputError


class ControllerError(InputError):
    """A controller that cannot be built or cannot act (says which gain/joint/time)."""


# ---------------------------------------------------------------------- helpers

def _gain(value, nd, name, unit):
    """A gain as an (nd, nd) matrix from a scalar, a per-joint vector or a matrix."""
    g = np.asarray(value, dtype=float)
    if g.ndim == 0:
        g = np.eye(nd) * g
    elif g.ndim == 1:
        if g.shape != (nd,):
            raise ControllerError(f"{name} has {g.shape[0]} entries, expected {nd} (one per joint) [{unit}]")
        g = np.diag(g)
    elif g.shape != (nd, nd):
        raise ControllerError(f"{name} has shape {g.shape}, expected ({nd}, {nd}) [{unit}]")
    if not np.all(np.isfinite(g)):
        raise ControllerError(f"{name} contains a value that is not finite [{unit}]")
    d = np.diag(g)
    if np.any(d < 0):
        j = int(np.argmax(d < 0))
        raise ControllerError(f"{name} of joint {j + 1} is negative ({d[j]} {unit}): the loop would be unstable")
    return g


def _limit(value, nd):
    if value is None:
        return None
    lim = np.broadcast_to(np.asarray(value, dtype=float), (nd,)).copy()
    if np.any(~np.isfinite(lim)) or np.any(lim <= 0):
        j = int(np.argmax(~np.isfinite(lim) | (lim <= 0)))
        raise ControllerError(f"saturation of joint {j + 1} must be a positive effort, got {lim[j]}")
    return lim


def _tolist(a):
    a = np.asarray(a)
    if a.ndim == 2 and np.allclose(a, np.diag(np.diag(a))):
        d = np.diag(a)
        return float(d[0]) if np.allclose(d, d[0]) else d.tolist()
    return a.tolist()


@dataclass
class Reference:
    """The reference at one sample: joint and pose values (any may be None)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    x: np.ndarray | None = None
    xd: np.ndarray | None = None
    xdd: np.ndarray | None = None


#: the period a compiled copy of a law that does not use it (pd, pd_gravity,
#: computed_torque) is given when it runs outside a loop: the core wants one [s]
_ANY_PERIOD = 1.0


class _CoreLaw:
    """What every controller the core implements shares: its law runs in the core
    (``pkm_ctrl``) through a compiled copy (:class:`cosim.core.CompiledController`)
    built on first use; ``saturated`` counts the samples the saturation clipped since
    the last :meth:`reset`."""

    model = None
    dt = None
    saturated = 0
    _cc = None

    def _compiled(self, model=None):
        from .core.controller import CompiledController

        if self._cc is None:
            model = self.model or model
            if model is None:
                raise ControllerError(f"{self.kind} controller: its law is the core's and runs on a model: build "
                                      f"it with model=m, or run it in a closed loop (which gives it the plant's)")
            self._cc = CompiledController(self, model=model, dt=self.dt or _ANY_PERIOD)
        return self._cc

    def reset(self, t0: float, q0, x0=None) -> None:
        """Start a run at time t0 [s] from joints q0 (and pose x0 [m, rad] if known: the
        first guess of the forward kinematics of the measured joints)."""
        self._compiled().reset(x0)
        self.saturated = 0

    def __call__(self, t, q, qd, ref) -> np.ndarray:
        """One sample: ``tau`` [N or N m] from the readings ``q``, ``qd`` and the reference
        row ``ref`` (:class:`Reference`), by the core's law."""
        cc = self._compiled()
        tau = cc(t, q, qd, ref)
        self.saturated = cc.saturated
        return tau


@dataclass
class JointController(_CoreLaw):
    """A sampled joint-space controller of the core (``pkm.h`` ``pkm_ctrl_kind``): the
    kind, gains and saturation as data, the law the core's.

    Call ``ctrl(t, q, qd, ref)`` at each sample; returns ``tau`` (nd,) [N or N m].  A
    closed loop (:class:`cosim.closed_loop.ClosedLoop`) runs the core's law itself on
    either back end.  ``model`` is the model the controller believes in (gravity load,
    kinematics, inverse dynamics; None for a PD, which uses none).
    """

    ndof: int
    kp: np.ndarray
    kd: np.ndarray
    saturation: np.ndarray | None = None
    kind: str = "pd"
    units: tuple = ("N/m", "N s/m")
    saturated: int = 0
    info: dict = field(default_factory=dict)
    model: object = field(default=None, repr=False)
    #: where ``pd_gravity`` evaluates the gravity load: "measured" or "reference"
    gravity: str = "measured"

    def describe(self) -> dict:
        """Type and gains with units, for the recording sidecar."""
        d = {"type": self.kind, "kp": _tolist(self.kp), "kd": _tolist(self.kd),
             "kp_unit": self.units[0], "kd_unit": self.units[1]}
        if self.saturation is not None:
            d["saturation"] = _tolist(np.diag(self.saturation))
        d.update(self.info)
        return d


class PID(JointController):
    """PID with a filtered derivative, anti-windup and output limits, with an optional
    gravity feed-forward: the core's law (``pkm.h`` ``PKM_CTRL_PID``).  Build it with
    :func:`pid`."""

    def __init__(self, model, *, ki, deriv_filter, gravity_feedforward, dt, **kw):
        super().__init__(model=model, **kw)
        self.ki, self.deriv_filter = ki, deriv_filter
        self.gravity_feedforward, self.dt = gravity_feedforward, dt

    def describe(self) -> dict:
        d = super().describe()
        num, den = self.units[0].split("/")
        d.update({"ki": _tolist(self.ki), "ki_unit": f"{num}/({den} s)",
                  "deriv_filter": self.deriv_filter, "gravity_feedforward": bool(self.gravity_feedforward),
                  "dt": self.dt})
        return d


# -------------------------------------------------------------------- factories

def _pd_units(joint):
    if joint not in ("m", "rad"):
        raise ControllerError(f"joint unit must be 'm' (sliders) or 'rad' (revolute joints), got {joint!r}")
    return ("N/m", "N s/m") if joint == "m" else ("N m/rad", "N m s/rad")


def _joint_of(model):
    return model.joint_unit


def pd(*, ndof: int = 6, kp, kd, saturation=None, joint: str = "m", model=None) -> JointController:
    """Decentralised PD in joint space: ``tau = Kp (qref - q) + Kd (qdref - qd)``.

    Parameters
    ----------
    ndof : int
        Number of joints.
    kp : float or array_like, shape (nd,) or (nd, nd)
        Proportional gain [N/m for sliders, N m/rad for revolute joints].
    kd : float or array_like
        Derivative gain [N s/m or N m s/rad].
    saturation : float or array_like, shape (nd,), optional
        Largest effort magnitude per actuator [N or N m]; efforts are clipped.
    joint : {"m", "rad"}
        Unit of the joints (sliders or revolute), for the gains' units.
    model : cosim.core.Model, optional
        A model of the robot, to call the controller outside a closed loop (the core
        runs every law on a model; a closed loop gives it the plant's).

    Example
    -------
    >>> from cosim.core import Model
    >>> from cosim import controllers as ctl
    >>> m = Model("6pus")
    >>> c = ctl.pd(ndof=6, kp=300.0, kd=30.0, model=m)
    >>> q = m.ik(m.home())
    >>> tau = c(0.0, q, [0.0] * 6, ctl.Reference(q + 0.001, [0.0] * 6, [0.0] * 6))   # 0.3 N per rail
    """
    u = _pd_units(joint)
    if model is not None and model.ndof != ndof:
        raise ControllerError(f"pd: ndof = {ndof}, the model has {model.ndof} joints")
    return JointController(ndof=ndof, kp=_gain(kp, ndof, "kp", u[0]), kd=_gain(kd, ndof, "kd", u[1]),
                           saturation=_limit(saturation, ndof), kind="pd", units=u, model=model)


def pd_gravity(model, *, kp, kd, saturation=None, gravity: str = "measured") -> JointController:
    """PD plus gravity compensation (Zavala-Yoe et al. 2015 sec. 8.8).

    ``tau = Kp (qref - q) + Kd (qdref - qd) + g(x)``, ``g`` = ``model.gravity_load``.

    Parameters
    ----------
    model : cosim.core.Model
        The model the controller believes in (its gravity load and kinematics).
    kp, kd, saturation : see :func:`pd`.
    gravity : {"measured", "reference"}
        Evaluate ``g`` at the pose of the measured joints (forward kinematics, the
        seed's choice) or at the reference pose.
    """
    if gravity not in ("measured", "reference"):
        raise ControllerError(f"gravity must be 'measured' or 'reference', got {gravity!r}")
    nd = model.ndof
    u = _pd_units(_joint_of(model))
    c = JointController(ndof=nd, kp=_gain(kp, nd, "kp", u[0]), kd=_gain(kd, nd, "kd", u[1]),
                        saturation=_limit(saturation, nd), kind="pd_gravity", units=u, model=model, gravity=gravity)
    c.info = {"gravity": gravity}
    return c


def pid(model, *, kp, ki, kd, dt: float, deriv_filter: float = 0.0, saturation=None,
        gravity_feedforward: bool = False) -> JointController:
    """PID in joint space, the law of the core (``pkm.h`` ``PKM_CTRL_PID``).

    ``tau = Kp e + Ki i + Kd d (+ g(x))``, ``e = qref - q``; the integral
    ``i_k = i_{k-1} + dt e_k`` is frozen while the output is saturated and ``e`` pushes
    further into the limit (anti-windup); ``d`` is the backward difference of ``e``
    through a first-order filter of time constant ``deriv_filter``.

    Parameters
    ----------
    model : cosim.core.Model
        The model the controller believes in (joint count, gravity feed-forward).
    kp, kd : float or array_like
        As in :func:`pd` [N/m, N s/m or N m/rad, N m s/rad].
    ki : float or array_like
        Integral gain [N/(m s) or N m/(rad s)].
    dt : float
        Sample period [s] (the integral and the derivative use it).
    deriv_filter : float
        Derivative filter time constant Tf [s] (0: the plain backward difference).
    saturation : float or array_like, optional
        Largest effort magnitude per actuator [N or N m].
    gravity_feedforward : bool
        Add the gravity load at the pose of the measured joints.

    Example
    -------
    >>> from cosim.core import Model
    >>> from cosim import controllers as ctl
    >>> m = Model("6pus")
    >>> c = ctl.pid(m, kp=2000, ki=4000, kd=30, dt=1e-3, deriv_filter=2e-3, saturation=80)
    """
    nd = model.ndof
    u = _pd_units(_joint_of(model))
    if not (isinstance(dt, (int, float)) and np.isfinite(dt) and dt > 0):
        raise ControllerError(f"pid: dt = {dt!r} s must be a positive number")
    if not (isinstance(deriv_filter, (int, float)) and np.isfinite(deriv_filter) and deriv_filter >= 0):
        raise ControllerError(f"pid: deriv_filter = {deriv_filter!r} s must be >= 0")
    return PID(model, ki=_gain(ki, nd, "ki", u[0] + "/s"), deriv_filter=float(deriv_filter),
               gravity_feedforward=bool(gravity_feedforward), dt=float(dt), ndof=nd,
               kp=_gain(kp, nd, "kp", u[0]), kd=_gain(kd, nd, "kd", u[1]), saturation=_limit(saturation, nd),
               kind="pid", units=u)


def computed_torque(model, *, kp, kd, saturation=None) -> JointController:
    """Computed torque (inverse-dynamics control) in joint space.

    ``qdd_cmd = qddref + Kd (qdref - qd) + Kp (qref - q)``; the core maps it to a pose
    acceleration at the pose of the measured joints and returns the efforts of its
    inverse dynamics.  With an exact model each joint error obeys
    ``e'' + Kd e' + Kp e = 0``.

    Parameters
    ----------
    model : cosim.core.Model
        The model the controller believes in.
    kp : float or array_like
        Outer-loop stiffness [1/s^2] (``wn^2``).
    kd : float or array_like
        Outer-loop damping [1/s] (``2 zeta wn``).
    saturation : float or array_like, optional
        Largest effort magnitude per actuator [N or N m].
    """
    nd = model.ndof
    return JointController(ndof=nd, kp=_gain(kp, nd, "kp", "1/s^2"), kd=_gain(kd, nd, "kd", "1/s"),
                           saturation=_limit(saturation, nd), kind="computed_torque", units=("1/s^2", "1/s"),
                           model=model)


# ----------------------------------------------------------- design and analysis

def joint_mass(model, x) -> np.ndarray:
    """Joint-space mass matrix ``Mq = J^-T Mx J^-1`` [kg or kg m^2] at pose x.

    The core gives the task-space mass matrix ``Mx`` (kinetic energy ``xd' Mx xd / 2``)
    and ``J`` (``qd = J xd``); the same kinetic energy in joint velocities is
    ``qd' Mq qd / 2``.

    Parameters
    ----------
    model : cosim.core.Model
        The robot model.
    x : array_like, shape (nd,)
        Pose [m, rad].

    Returns
    -------
    ndarray, shape (nd, nd)
        Symmetric joint-space mass matrix; its diagonal is the effective mass of each
        actuator with the others held.
    """
    J = model.jacobian(x)
    Mx = model.mass_matrix(x)
    Jinv = np.linalg.inv(J)
    Mq = Jinv.T @ Mx @ Jinv
    return 0.5 * (Mq + Mq.T)


def double_integrator(mass: float, dt: float | None = None):
    """The decoupled joint ``m qdd = tau - g`` as a state-space system.

    Parameters
    ----------
    mass : float
        Effective joint mass [kg or kg m^2].
    dt : float, optional
        Sampling period [s]: discretised with a zero-order hold (``control.c2d``), exact
        for a piecewise-constant tau; continuous if None.

    Returns
    -------
    control.StateSpace
        States ``[q, qd]``, inputs ``[tau, g]``, output ``q``.
    """
    if not (mass > 0 and np.isfinite(mass)):
        raise ControllerError(f"the effective joint mass must be positive, got {mass}")
    sys = control.ss([[0, 1], [0, 0]], [[0, 0], [1 / mass, -1 / mass]], [[1, 0]], [[0, 0]],
                     inputs=["tau", "g"], outputs=["q"], states=["q", "qd"])
    return sys if dt is None else control.c2d(sys, dt, method="zoh")


def closed_loop(mass: float, kp: float, kd: float, dt: float | None = None, gravity_comp: bool = False):
    """PD loop around one joint, inputs ``[qref, g]``, outputs ``[q, e = qref - q]``.

    ``tau = kp (qref - q) - kd qd (+ g if gravity_comp)`` on :func:`double_integrator`.

    Parameters
    ----------
    mass : float
        Effective joint mass [kg or kg m^2].
    kp, kd : float
        Gains [N/m, N s/m] (or per radian).
    dt : float, optional
        Sampling period [s] (plant discretised by zero-order hold: exact for the
        sampled loop); continuous if None.
    gravity_comp : bool
        Feed the gravity load forward (PD + G).

    Returns
    -------
    control.StateSpace
    """
    plant = double_integrator(mass, dt)
    A, B = np.asarray(plant.A), np.asarray(plant.B)
    K = np.array([[kp, kd]])
    # u = kp r - K x (+ g): substitute into x+ = A x + B_tau u + B_g g
    Acl = A - B[:, :1] @ K
    Bcl = np.column_stack([B[:, 0] * kp, B[:, 1] + (B[:, 0] if gravity_comp else 0.0)])
    C = np.array([[1.0, 0.0], [-1.0, 0.0]])
    D = np.array([[0.0, 0.0], [1.0, 0.0]])
    return control.ss(Acl, Bcl, C, D, dt if dt is not None else 0,
                      inputs=["qref", "g"], outputs=["q", "e"], states=["q", "qd"])


@dataclass
class PDDesign:
    """Gains from a bandwidth/damping spec and what python-control predicts for them."""

    mass: float
    kp: float
    kd: float
    wn: float
    damping: float
    dt: float | None
    poles: np.ndarray
    step_info: dict
    stable: bool

    def as_dict(self) -> dict:
        return {"mass": self.mass, "kp": self.kp, "kd": self.kd, "wn": self.wn, "damping": self.damping,
                "dt": self.dt, "poles": [complex(p) if np.iscomplex(p) else float(np.real(p)) for p in self.poles],
                "predicted_step": self.step_info, "stable": self.stable}


def design_pd(*, mass: float, bandwidth_hz: float | None = None, wn: float | None = None,
              damping: float = 1.0, dt: float | None = 1e-3) -> PDDesign:
    """PD gains placing the poles of ``m s^2 + kd s + kp`` at ``wn``, ``damping``.

    Parameters
    ----------
    mass : float
        Effective joint mass [kg or kg m^2] (e.g. the largest diagonal entry of
        :func:`joint_mass`; use 1 for computed-torque outer-loop gains).
    bandwidth_hz : float, optional
        Natural frequency ``wn / (2 pi)`` [Hz].
    wn : float, optional
        Natural frequency [rad/s] (give this or ``bandwidth_hz``).
    damping : float
        Damping ratio [-].
    dt : float or None
        Communication step [s]; the returned poles and predicted step metrics are of
        the sampled loop (zero-order hold) when given.

    Returns
    -------
    PDDesign
        ``kp = m wn^2`` [N/m], ``kd = 2 damping wn m`` [N s/m], closed-loop poles
        (z-plane if sampled), step metrics from ``control.step_info`` and stability.
    """
    if (bandwidth_hz is None) == (wn is None):
        raise ControllerError("give exactly one of bandwidth_hz and wn")
    w = 2 * np.pi * bandwidth_hz if wn is None else float(wn)
    if not (w > 0 and np.isfinite(w)):
        raise ControllerError(f"the natural frequency must be positive, got {w} rad/s")
    if not (damping > 0):
        raise ControllerError(f"the damping ratio must be positive, got {damping}")
    kp, kd = mass * w**2, 2 * damping * w * mass
    cl = closed_loop(mass, kp, kd, dt)
    poles = control.poles(cl)
    stable = bool(np.all(np.abs(poles) < 1)) if dt else bool(np.all(np.real(poles) < 0))
    info = control.step_info(cl[0, 0], T=_horizon(w, damping, dt)) if stable else {}
    return PDDesign(float(mass), float(kp), float(kd), w, float(damping), dt, poles,
                    {k: float(v) for k, v in info.items()}, stable)


def _horizon(wn, damping, dt):
    # Long enough for the slowest pole to settle well inside 2 %.
    slow = wn * (damping - np.sqrt(damping**2 - 1)) if damping > 1 else wn * damping
    T = 12.0 / slow
    return np.arange(0, T, dt) if dt else np.linspace(0, T, 4001)


def analyse_pd(*, mass: float, kp: float, kd: float, dt: float | None = 1e-3) -> dict:
    """What python-control predicts for given PD gains on the decoupled joint.

    Parameters
    ----------
    mass : float
        Effective joint mass [kg or kg m^2].
    kp, kd : float
        Gains [N/m, N s/m] (or per radian).
    dt : float, optional
        Sampling period [s]; continuous if None.

    Returns a dict with the natural frequency ``wn`` [rad/s], ``damping`` [-],
    closed-loop ``poles``, ``stable``, the step metrics (``RiseTime``, ``SettlingTime``
    [s], ``Overshoot`` [%] ...) and ``gravity_compliance``: the steady-state error per
    unit of gravity load, ``e_ss / g`` [m/N], from the loop's DC gain (equals 1/kp).
    """
    wn = np.sqrt(kp / mass)
    z = kd / (2 * np.sqrt(kp * mass))
    cl = closed_loop(mass, kp, kd, dt)
    poles = control.poles(cl)
    stable = bool(np.all(np.abs(poles) < 1)) if dt else bool(np.all(np.real(poles) < 0))
    out = {"mass": float(mass), "kp": float(kp), "kd": float(kd), "wn": float(wn), "damping": float(z),
           "poles": [float(np.real(p)) if abs(np.imag(p)) < 1e-12 else str(complex(p)) for p in poles],
           "stable": stable}
    if stable:
        info = control.step_info(cl[0, 0], T=_horizon(wn, z, dt))
        out.update({k: float(v) for k, v in info.items()})
        # e = qref - q for a unit gravity load, at DC
        out["gravity_compliance"] = float(np.real(control.dcgain(cl[1, 1])))
    return out


def predicted_steady_state_error(model, x, kp) -> np.ndarray:
    """``e_ss = Kp^-1 g(x)`` [m or rad]: where a PD loop settles under gravity.

    At rest ``qd = 0`` and the efforts balance the gravity load ``g(x)`` from the core,
    so ``Kp (qref - q) = g``.

    Parameters
    ----------
    model : cosim.core.Model
        The robot model (its gravity load).
    x : array_like, shape (nd,)
        The pose where the robot settles [m, rad]: the reference pose gives the
        first-order estimate (:func:`cosim.scenario.predicted_equilibrium_error`
        solves for the settled pose).
    kp : float or array_like
        Proportional gain [N/m or N m/rad].

    Returns
    -------
    ndarray, shape (nd,)
        ``qref - q`` at rest.
    """
    nd = model.ndof
    K = _gain(kp, nd, "kp", "N/m")
    return np.linalg.solve(K, model.gravity_load(x))


def step_metrics(t, y, y0: float | None = None, yfinal: float | None = None,
                 settling_threshold: float = 0.02) -> dict:
    """Rise time, settling time, overshoot of a simulated step, by ``control.step_info``.

    Parameters
    ----------
    t : array_like, shape (n,)
        Time [s] from the step instant.
    y : array_like, shape (n,)
        Response [any unit].
    y0 : float, optional
        Value before the step (default ``y[0]``).
    yfinal : float, optional
        Settled value (default: the last sample).
    settling_threshold : float
        Settling band as a fraction of the step amplitude.

    Returns
    -------
    dict
        ``RiseTime`` and ``SettlingTime`` [s], ``Overshoot`` and ``Undershoot`` [%],
        ``PeakTime`` [s], ``Amplitude`` (``yfinal - y0``).
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    y0 = y[0] if y0 is None else y0
    yf = y[-1] if yfinal is None else yfinal
    amp = yf - y0
    if amp == 0:
        raise ControllerError("step_metrics: the response does not move (zero amplitude)")
    info = control.step_info(y - y0, T=t - t[0], yfinal=amp, SettlingTimeThreshold=settling_threshold)
    keep = ("RiseTime", "SettlingTime", "Overshoot", "Undershoot", "PeakTime")
    out = {k: float(info[k]) for k in keep}
    out["Amplitude"] = float(amp)
    return out


# ------------------------------------------------ a python-control LTI design

class LTIController(_CoreLaw):
    """A discrete LTI controller on the joint error, ``x+ = A x + B e``, ``tau = C x + D e``
    (``e = qref - q``), with optional gravity feed-forward: what ``pkm_ctrl`` kind LTI runs.

    Build it with :func:`lti_controller` from a python-control design.
    """

    kind = "lti"

    def __init__(self, A, B, C, D, *, dt: float, model=None, gravity_feedforward: bool = False, saturation=None):
        self.A, self.B, self.C, self.D = (np.atleast_2d(np.asarray(a, float)) for a in (A, B, C, D))
        self.dt, self.model, self.gravity_feedforward, self.saturation = dt, model, gravity_feedforward, saturation
        self.kp = self.kd = None

    def describe(self) -> dict:
        """Everything needed to rebuild it (the recording sidecar's ``controller``)."""
        d = {"type": "lti", "nx": int(self.A.shape[0]), "dt": self.dt,
             "gravity_feedforward": bool(self.gravity_feedforward),
             "A": self.A.tolist(), "B": self.B.tolist(), "C": self.C.tolist(), "D": self.D.tolist()}
        if self.saturation is not None:
            d["saturation"] = np.asarray(self.saturation, float).tolist()
        return d


def lti_controller(sys_d, *, ndof: int, model=None, gravity_feedforward: bool = False,
                   saturation=None) -> LTIController:
    """A python-control discrete ``StateSpace`` (inputs: the nd joint errors [m or rad];
    outputs: the nd efforts [N or N m]) as a controller the core, the compiled loop and
    the controller FMU run.  A SISO design is applied to every joint (block diagonal).

    Parameters
    ----------
    sys_d : control.StateSpace
        Discrete-time (``sys_d.dt > 0``), e.g. ``control.c2d(pid_tf, dt)`` converted with
        ``control.ss``.
    ndof : int
        Number of joints.
    model : cosim.core.Model, optional
        The model the controller believes in (the gravity feed-forward; needed to call it
        outside a closed loop).
    gravity_feedforward : bool
        Add the gravity load at the pose of the measured joints to the output.
    saturation : float or array_like, shape (nd,), optional
        Largest effort magnitude per actuator [N or N m].

    Example
    -------
    >>> import control
    >>> from cosim.core import Model
    >>> from cosim import controllers as ctl
    >>> m = Model("6pus")
    >>> pd = control.c2d(control.tf([30.0, 300.0], [1.0]) * control.tf([1.0], [1e-3, 1.0]), 1e-3)
    >>> c = ctl.lti_controller(control.ss(pd), ndof=6, model=m, gravity_feedforward=True)
    """
    if not (getattr(sys_d, "dt", None) and sys_d.dt is not True and sys_d.dt > 0):
        raise ControllerError("lti_controller needs a discrete-time system (sys.dt > 0): use control.c2d first")
    ss = control.ss(sys_d)
    A, B, C, D = (np.asarray(a, float) for a in (ss.A, ss.B, ss.C, ss.D))
    if B.shape[1] == 1 and C.shape[0] == 1 and ndof > 1:
        I = np.eye(ndof)
        A, B, C, D = np.kron(I, A), np.kron(I, B), np.kron(I, C), np.kron(I, D)
    if B.shape[1] != ndof or C.shape[0] != ndof:
        raise ControllerError(f"the design has {B.shape[1]} inputs and {C.shape[0]} outputs; the robot has {ndof} "
                              f"joints")
    return LTIController(A, B, C, D, dt=float(ss.dt), model=model, gravity_feedforward=gravity_feedforward,
                         saturation=saturation)


# ------------------------------------------------------------ a rig's controller as data

#: the keys of a discrete controller's description (sidecar / scenario ``[controller]``)
DISCRETE_KEYS = ("kind", "type", "period", "law", "kp", "kv", "ki", "kd", "position_filter", "velocity",
                 "velocity_filter", "saturation", "output_gain", "delay_samples", "units")


class DiscreteController(_CoreLaw):
    """A rig's sampled controller described as data (``pkm.h`` ``PKM_CTRL_DISCRETE``):
    position filter, velocity by backward difference or from the reading, velocity
    filter, law (``"cascade_pp"``: ``u = kv (kp (qref - qf) - v)``; ``"pid"``:
    ``u = kp (qref - qf) + ki i + kd (qdref - v)``), output limits in controller units,
    output gain to effort units, computation delay in samples.  The core runs it (the
    compiled loop, or one sample at a time through a compiled copy in the stepwise loop);
    nothing of the law is computed in Python.  Build it with :func:`discrete`.
    """

    kind = "discrete"

    def __init__(self, ndof, *, period, law, kp, kv, ki, kd, position_filter, velocity, velocity_filter, limits,
                 output_gain, delay_samples, model=None, description=None):
        self.ndof, self.dt, self.law = ndof, period, law
        self.kp, self.kv, self.ki, self.kd = kp, kv, ki, kd
        self.position_filter, self.velocity, self.velocity_filter = position_filter, velocity, velocity_filter
        self.limits, self.output_gain, self.delay_samples = limits, output_gain, delay_samples
        self.saturation = None  # the limits act on the controller's output, in its own units
        self.model = model
        self._desc = description

    def describe(self) -> dict:
        """The description it was built from (plain numbers), for the recording sidecar."""
        return dict(self._desc)


def _gain_matrix(v, nd, name, *, required):
    if v is None:
        if required:
            raise ControllerError(f"controller.{name}: missing (a number, or one per joint)")
        return None
    try:
        a = np.asarray(v, float)
    except (TypeError, ValueError):
        raise ControllerError(f"controller.{name}: {v!r} is not a number or a list of numbers") from None
    if a.ndim == 0:
        a = np.full(nd, float(a))
    if a.shape != (nd,):
        raise ControllerError(f"controller.{name}: {a.size} values for {nd} joints (give one, or one per joint)")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ControllerError(f"controller.{name}: gains must be finite and >= 0, got {a.tolist()}")
    return np.diag(a)


def _filter(v, name):
    if v is None:
        return None
    if not isinstance(v, dict) or "b" not in v:
        raise ControllerError(f"controller.{name}: a table {{b = [...], a = [...]}} of filter coefficients "
                              f"(a defaults to [1.0])")
    extra = set(v) - {"b", "a"}
    if extra:
        raise ControllerError(f"controller.{name}: unknown key(s) {sorted(extra)} (keys: b, a)")
    out = {}
    for k in ("b", "a"):
        raw = v.get(k, [1.0])
        try:
            c = np.atleast_1d(np.asarray(raw, float))
        except (TypeError, ValueError):
            raise ControllerError(f"controller.{name}.{k}: {raw!r} is not a list of numbers") from None
        if c.ndim != 1 or not 1 <= c.size <= 16 or not np.all(np.isfinite(c)):
            raise ControllerError(f"controller.{name}.{k}: 1 to 16 finite coefficients, got {raw!r}")
        out[k] = c.tolist()
    if out["a"][0] == 0:
        raise ControllerError(f"controller.{name}.a: a[0] must not be 0")
    return out


def discrete(desc: dict, *, ndof: int, model=None) -> DiscreteController:
    """A rig's discrete controller from its description (a recording's sidecar
    ``"controller"``, a scenario's ``[controller]`` with ``kind = "discrete"``).

    Parameters
    ----------
    desc : dict
        ``period`` [s] (> 0); ``law`` ``"cascade_pp"`` (``kp`` [1/s], ``kv`` [controller
        units per joint rate]) or ``"pid"`` (``kp``, optional ``ki``, ``kd``); gains a
        number or one per joint; ``position_filter`` and ``velocity_filter`` optional
        ``{"b": [...], "a": [...]}`` (``a`` defaults to ``[1.0]``; the filter starts at rest
        on the first reading); ``velocity`` ``"backward_difference"`` (of the filtered
        position, default) or ``"measured"`` (the reading ``qd``); ``saturation``
        ``[low, high]`` in controller units, or one pair per joint; ``output_gain``
        effort per controller unit (default 1), a number or one per joint;
        ``delay_samples`` the computation delay (default 0); ``units`` free text.
    ndof : int
        Joints of the robot.
    model : cosim.core.Model, optional
        Needed to run it outside the compiled loop (the stepwise loop).

    Returns
    -------
    DiscreteController

    Raises
    ------
    ControllerError
        One line naming the field: ``controller.kv: missing (...)``.

    Example
    -------
    >>> c = discrete({"kind": "discrete", "period": 0.001, "law": "cascade_pp", "kp": 160.18, "kv": 243.45,
    ...               "velocity_filter": {"b": [0.5, 0.5]}, "saturation": [-10.0, 10.0],
    ...               "output_gain": 35.15, "delay_samples": 1}, ndof=1)
    """
    if not isinstance(desc, dict):
        raise ControllerError("controller: a table of the discrete controller's fields")
    unknown = sorted(set(desc) - set(DISCRETE_KEYS))
    if unknown:
        raise ControllerError(f"controller.{unknown[0]}: not a field of a discrete controller "
                              f"({', '.join(k for k in DISCRETE_KEYS if k != 'type')})")
    nd = int(ndof)
    try:
        period = float(desc.get("period"))
    except (TypeError, ValueError):
        raise ControllerError(f"controller.period: the sample period in s, got {desc.get('period')!r}") from None
    if not (np.isfinite(period) and period > 0):
        raise ControllerError(f"controller.period: must be > 0 s, got {period}")
    law = desc.get("law", "cascade_pp")
    if law not in ("cascade_pp", "pid"):
        raise ControllerError(f"controller.law: {law!r} is not 'cascade_pp' or 'pid'")
    cascade = law == "cascade_pp"
    kp = _gain_matrix(desc.get("kp"), nd, "kp", required=True)
    kv = _gain_matrix(desc.get("kv"), nd, "kv", required=cascade)
    ki = _gain_matrix(desc.get("ki"), nd, "ki", required=False)
    kd = _gain_matrix(desc.get("kd"), nd, "kd", required=False)
    if cascade and (ki is not None or kd is not None):
        raise ControllerError("controller.ki/kd: the cascade_pp law has kp and kv only (ki, kd are the pid law's)")
    if not cascade and kv is not None:
        raise ControllerError("controller.kv: the pid law has kp, ki, kd (kv is the cascade_pp law's)")
    velocity = desc.get("velocity", "backward_difference")
    if velocity not in ("backward_difference", "measured"):
        raise ControllerError(f"controller.velocity: {velocity!r} is not 'backward_difference' or 'measured'")
    limits = None
    if desc.get("saturation") is not None:
        try:
            s = np.asarray(desc["saturation"], float)
        except (TypeError, ValueError):
            raise ControllerError(f"controller.saturation: {desc['saturation']!r} is not [low, high]") from None
        s = np.broadcast_to(s, (nd, 2)) if s.shape == (2,) else s
        if s.shape != (nd, 2):
            raise ControllerError(f"controller.saturation: [low, high] or one pair per joint ({nd}), "
                                  f"got shape {np.shape(desc['saturation'])}")
        if not np.all(np.isfinite(s)) or np.any(s[:, 0] >= s[:, 1]):
            raise ControllerError(f"controller.saturation: finite [low, high] with low < high, got {s.tolist()}")
        limits = (s[:, 0].copy(), s[:, 1].copy())
    try:
        gain = np.broadcast_to(np.asarray(desc.get("output_gain", 1.0), float), (nd,)).copy()
    except (TypeError, ValueError):
        raise ControllerError(f"controller.output_gain: a number or one per joint ({nd}), "
                              f"got {desc.get('output_gain')!r}") from None
    if not np.all(np.isfinite(gain)) or np.any(gain == 0):
        raise ControllerError(f"controller.output_gain: finite and non-zero, got {gain.tolist()}")
    delay = desc.get("delay_samples", 0)
    if isinstance(delay, bool) or not isinstance(delay, (int, np.integer, float)) or delay != int(delay) \
            or not 0 <= delay <= 64:
        raise ControllerError(f"controller.delay_samples: a whole number of samples in [0, 64], got {delay!r}")
    plain = {k: v for k, v in desc.items() if k != "type"}
    plain["kind"] = "discrete"
    return DiscreteController(nd, period=period, law=law, kp=kp, kv=kv, ki=ki, kd=kd,
                              position_filter=_filter(desc.get("position_filter"), "position_filter"),
                              velocity=velocity, velocity_filter=_filter(desc.get("velocity_filter"), "velocity_filter"),
                              limits=limits, output_gain=gain, delay_samples=int(delay), model=model,
                              description=plain)
