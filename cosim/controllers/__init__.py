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

from .design import (PDDesign, analyse_pd, closed_loop, design_pd, double_integrator, joint_mass,  # noqa: F401
                                predicted_steady_state_error, step_metrics)
from .discrete import DISCRETE_KEYS, DiscreteController, LTIController, discrete, lti_controller  # noqa: F401
from .laws import (ControllerError, JointController, PID, Reference, _gain, _joint_of,  # noqa: F401
                              computed_torque, pd, pd_gravity, pid)
