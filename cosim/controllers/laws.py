"""The joint controllers the core implements, as data: PD, PD + gravity, PID and computed torque
(:func:`pd`, :func:`pd_gravity`, :func:`pid`, :func:`computed_torque`), the reference row they
read (:class:`Reference`) and their error (:class:`ControllerError`); described in
:mod:`cosim.controllers`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ControllerError


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
        from ..core.controller import CompiledController

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
        source thesis' choice) or at the reference pose.
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
