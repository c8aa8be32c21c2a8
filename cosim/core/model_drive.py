"""The drive layer's part of :class:`cosim.core.Model` (a mixin of its methods): the mechanism's
inverse dynamics apart from the drive layer's efforts, the sensors' readings and the
actuators' effort map.  The example is :class:`cosim.core.Model`'s.
"""
from __future__ import annotations

import ctypes as C

import numpy as np

from .._native import lib, ptr
from ..errors import ArgumentError


class DriveLayerMethods:
    """The drive-layer methods of :class:`cosim.core.Model` (which holds the core handles
    ``_m``, ``_d`` and the call helpers ``_single``, ``_batch``, ``_batch_or_loop``, ``_arr``,
    ``_check`` these use)."""

    def mechanism_inverse_dynamics(self, x, xd, xdd):
        """The mechanism's part of :meth:`inverse_dynamics` [N or N m], shape (n, nd): links,
        platform, payload and gravity, without the drive layer (no parameter of
        :meth:`drive_layer_params` changes it; ``pkm_mechanism_inverse_dynamics_batch``).

        Example: ``m.add_drive_inverse_dynamics(x, xd, xdd, m.mechanism_inverse_dynamics(x, xd, xdd))``
        equals ``m.inverse_dynamics(x, xd, xdd)`` bit for bit."""
        return self._batch(lib.pkm_mechanism_inverse_dynamics_batch, [x, xd, xdd], ["x", "xd", "xdd"])

    def add_drive_inverse_dynamics(self, x, xd, xdd, mechanism):
        """``mechanism`` (n, nd) plus the drive layer's efforts at (x, xd, xdd): joint force and
        offset, friction, rotor inertia [N or N m]; a new array
        (``pkm_add_drive_inverse_dynamics_batch``).  With ``mechanism`` from
        :meth:`mechanism_inverse_dynamics` of a model with the same mechanism parameters, the
        result is :meth:`inverse_dynamics` bit for bit."""
        return self._add_to(lib.pkm_add_drive_inverse_dynamics_batch, (x, xd, xdd), ("x", "xd", "xdd"), mechanism)

    def add_drive_efforts(self, q, qd, qdd, mechanism):
        """:meth:`add_drive_inverse_dynamics` from the joint motion at the poses: ``q`` =
        :meth:`ik` [m or rad], ``qd`` = :meth:`joint_velocity`, ``qdd`` = :meth:`joint_acceleration`
        (``pkm_add_drive_efforts_batch``), for several drive layers added along one motion: the
        same result bit for bit."""
        return self._add_to(lib.pkm_add_drive_efforts_batch, (q, qd, qdd), ("q", "qd", "qdd"), mechanism)

    def _add_to(self, fn, inputs, names, mechanism):
        arrs = [np.ascontiguousarray(self._arr(a, n).reshape(-1, self.ndof)) for a, n in zip(inputs, names)]
        tau = np.array(self._arr(mechanism, "mechanism"), dtype=np.float64, order="C").reshape(-1, self.ndof)
        if len({len(a) for a in arrs + [tau]}) != 1:
            raise ArgumentError(f"{', '.join(names)} and mechanism must have the same number of rows, got "
                                f"{[len(a) for a in arrs + [tau]]}", "PKM_ERR_ARGUMENT")
        status = np.zeros(len(tau), dtype=np.intc)
        self._check(fn(self._m, self._d, len(tau), *[ptr(a) for a in arrs], ptr(tau),
                       status.ctypes.data_as(C.POINTER(C.c_int))))
        return tau

    def drive_layer_params(self) -> frozenset:
        """Names of the drive layer's parameters (``pkm_param_in_drive_layer``): friction, rotor
        inertia, joint force and offset, actuators, sensors; the others are the mechanism's."""
        return frozenset(n for i, n in enumerate(self.param_names()) if lib.pkm_param_in_drive_layer(self._m, i) == 1)

    def measure_joints(self, x, xd, tau, times=None, what="item"):
        """Joint readings of the model's sensors at (x, xd) with applied effort tau, shape
        (..., nd) (``pkm_measure_joints``: encoder offset, backlash, compliance).  A failing
        row is named in the error (with its time from ``times``, if given)."""
        q = self._single("pkm_measure_joints", (x, xd, tau), (self.ndof,))
        if q is not None:
            return q
        return self._batch_or_loop("pkm_measure_joints_batch", "pkm_measure_joints", [x, xd, tau],
                                   ["x", "xd", "tau"], times, what)

    def sensor_readings(self, x, xd, tau, drive=None):
        """``(q, qd)``: the sensors' joint readings and rates at one state (x, xd) [m, rad] under
        the applied effort tau (``pkm_sensor_readings``): :meth:`measure_joints` and the joint
        rates, and on a joint that is two bodies, given ``drive = (theta, theta_d)`` (e.g.
        ``Simulator.drive_state``), its drive body plus the encoder offset, and its rate."""
        v = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, xd, tau)]
        th, thd = (None, None) if drive is None else (np.ascontiguousarray(a, dtype=np.float64) for a in drive)
        q, qd = np.empty(self.ndof), np.empty(self.ndof)
        self._check(lib.pkm_sensor_readings(self._m, self._d, *(ptr(a) for a in v), ptr(th), ptr(thd), ptr(q),
                                            ptr(qd)))
        return q, qd

    def two_body_joints(self) -> int:
        """How many joints are two bodies (``drive.two_body = 1`` and a backlash or a compliance
        on them; docs/integration.md)."""
        return int(lib.pkm_model_two_body_joints(self._m))

    def actuator_effort(self, tau_cmd, times=None, what="item"):
        """Effort reaching the mechanism for a commanded one, shape (..., nd) (``pkm_actuator_effort``:
        dead zone, saturation).  A failing row is named in the error (with its time from
        ``times``, if given)."""
        u = self._single("pkm_actuator_effort", (tau_cmd,), (self.ndof,))
        if u is not None:
            return u
        return self._batch_or_loop("pkm_actuator_effort_batch", "pkm_actuator_effort", [tau_cmd], ["tau_cmd"],
                                   times, what)
