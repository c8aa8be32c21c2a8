"""Test oracle: a two-mass drive simulated by scipy's solve_ivp, not by the core.

A motor inertia ``jm`` with viscous friction ``bm``, driven by a torque ``u(t)``, is joined to a
link inertia ``jl`` with viscous friction ``bl`` by a spring of stiffness ``k`` with a dead band
of total width ``gap``: the transmitted torque is k (d - gap/2) for d > gap/2, k (d + gap/2) for
d < -gap/2 and 0 between, with d = motor angle - link angle.  Both start at rest at 0.

Used by tests/identification/test_encoders.py and tests/discrepancy/test_link_encoders.py
(import it after putting this folder on ``sys.path``)."""
from types import SimpleNamespace

import numpy as np
import scipy.integrate


def dead_band_spring(d, k, gap):
    """Torque [N m] a spring of stiffness ``k`` [N m/rad] with a dead band of total width ``gap``
    [rad] transmits at deflection ``d`` [rad] (array or scalar)."""
    return k * (np.maximum(d - gap / 2, 0.0) + np.minimum(d + gap / 2, 0.0))


def two_mass_drive(u, *, jm, bm, jl, bl, k, gap, duration=4.0, rate=1000.0):
    """The drive's motion under the motor torque ``u(t)`` [N m] (a function of time [s]).

    Parameters
    ----------
    u : callable
        Motor torque [N m] at time t [s] (numpy in and out).
    jm, jl : float
        Motor and link inertia [kg m2].
    bm, bl : float
        Motor and link viscous friction [N m s/rad].
    k, gap : float
        Spring stiffness [N m/rad] and total dead band [rad].
    duration, rate : float
        Samples at ``rate`` [Hz] over [0, ``duration``) [s].

    Returns
    -------
    SimpleNamespace
        ``t`` [s], ``motor``, ``link`` [rad], ``motor_rate``, ``link_rate`` [rad/s], ``u`` (the
        motor torque at t) and ``transmitted`` (the spring's torque) [N m], each of shape (n,).

    Examples
    --------
    >>> d = two_mass_drive(lambda t: np.sin(t), jm=1.0, bm=1.0, jl=1.0, bl=1.0, k=1e3, gap=0.0, duration=0.1)
    >>> d.t.shape, float(d.motor[0])
    ((100,), 0.0)
    """
    def f(t, s):
        th, q, thd, qd = s
        ts = dead_band_spring(th - q, k, gap)
        return [thd, qd, (u(t) - bm * thd - ts) / jm, (ts - bl * qd) / jl]

    t = np.arange(0, duration, 1 / rate)
    sol = scipy.integrate.solve_ivp(f, (0, duration), [0, 0, 0, 0], t_eval=t, method="DOP853", rtol=1e-9,
                                    atol=1e-12, max_step=1e-3)
    th, q, thd, qd = sol.y
    return SimpleNamespace(t=t, motor=th, link=q, motor_rate=thd, link_rate=qd, u=u(t),
                           transmitted=dead_band_spring(th - q, k, gap))
