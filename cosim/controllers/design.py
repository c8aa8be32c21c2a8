"""The design and analysis of PD gains with python-control: the effective joint mass, the
decoupled double integrator and its sampled closed loop (:func:`design_pd`, :func:`analyse_pd`),
the steady-state error under gravity and a step's metrics (:mod:`cosim.controllers`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .laws import ControllerError, _gain


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
    import control  # imported when used: it takes about 2 s of CPU with matplotlib, which a replay never needs

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
    import control

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
    import control

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
    import control

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
    import control

    info = control.step_info(y - y0, T=t - t[0], yfinal=amp, SettlingTimeThreshold=settling_threshold)
    keep = ("RiseTime", "SettlingTime", "Overshoot", "Undershoot", "PeakTime")
    out = {k: float(info[k]) for k in keep}
    out["Amplitude"] = float(amp)
    return out
