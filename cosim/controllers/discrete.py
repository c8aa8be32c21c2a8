"""Controllers as matrices and as a rig's data: a discrete LTI controller on the joint error
(:class:`LTIController`, :func:`lti_controller`) and a rig's discrete controller
(:func:`discrete`); the core runs both (:mod:`cosim.controllers`).
"""
from __future__ import annotations

import numpy as np

from .laws import ControllerError, _CoreLaw


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
    import control  # imported when used (about 2 s of CPU with matplotlib)

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
