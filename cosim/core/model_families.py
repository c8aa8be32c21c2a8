"""The robot-specific function families of :class:`cosim.core.Model` (a mixin of its methods),
each answered only by a robot whose core declares it (:meth:`cosim.core.Model.has`): the
6-PUS calibration rows and leg points, the four-bar output, the Quattro's indices, reduced
inertia and points.  The example is :class:`cosim.core.Model`'s.
"""
from __future__ import annotations

import numpy as np

from .._native import c_int_p, lib, ptr
from ..errors import ArgumentError
from .facts import quattro_index_names


class RobotFamilyMethods:
    """The robot-specific methods of :class:`cosim.core.Model` (which holds the core handles
    ``_m``, ``_d`` and the helpers ``_require``, ``_loop``, ``_check`` these use)."""

    def calib_rows(self, x, frame: str = "world"):
        """6-PUS calibration regression rows, shape (..., 6, 10): dq_i / d eta_i per leg.

        eta_i = [X, Y, Z, S0x, S0y, S0z, L, sx, sy, sz] (Tiberi 2020 eq. 4.1).  ``frame="world"``
        differentiates with respect to the world position of the platform point (the thesis'
        tables), ``"platform"`` with respect to ``leg[i].px/py/pz``.  Stroke limits are not
        applied (the rows are geometry); an unreachable or singular pose raises.
        """
        self._require("6pus_calib_rows", "calib_rows")
        frames = {"world": 0, "platform": 1}
        if frame not in frames:
            raise ArgumentError(f"frame must be 'world' or 'platform', got {frame!r}", "PKM_ERR_ARGUMENT")
        f = frames[frame]
        return self._loop("pkm_6pus_calib_rows", [x], ["x"], (6, 10), extra=(f,), what="pose")

    def leg_points(self, x):
        """6-PUS world positions ``(P, S)`` of the platform points and sliders, each (..., 6, 3) [m]."""
        self._require("6pus_leg_points", "leg_points")
        ps = self._loop("pkm_6pus_leg_points", [x], ["x"], (2, 6, 3), out_parts=2)
        return ps[..., 0, :, :], ps[..., 1, :, :]

    def fourbar_output(self, theta, jacobian: bool = True):
        """Four-bar coupler mid-point X [m] at crank angle(s) theta [rad], and dX/d(l1..l4)
        [m/m] of shape ``theta.shape + (4,)`` if ``jacobian`` (``pkm_fourbar_output``)."""
        self._require("fourbar_output", "fourbar_output")
        th = np.asarray(theta, dtype=float)
        flat = th.reshape(-1)
        X = np.empty(flat.shape)
        J = np.empty(flat.shape + (4,))
        out = np.empty(1)
        for k, t in enumerate(flat):
            row = J[k] if jacobian else None
            self._check(lib.pkm_fourbar_output(self._m, self._d, float(t), ptr(out), ptr(row)))
            X[k] = out[0]
        X = X.reshape(th.shape)
        return X if not jacobian else (X, J.reshape(th.shape + (4,)))

    def quattro_indices(self, poses) -> tuple[np.ndarray, np.ndarray]:
        """Performance indices of poses (..., 4) -> (values (..., n_index), status (...)), one
        core call (``pkm_quattro_indices``); names and units in :func:`quattro_index_names`."""
        self._require("quattro_indices", "quattro_indices")
        x = np.ascontiguousarray(poses, dtype=np.float64)
        if x.shape[-1:] != (4,):
            raise ArgumentError(f"poses must have 4 coordinates (x, y, z, theta) in the last axis, got {x.shape}",
                                "PKM_ERR_ARGUMENT")
        flat = x.reshape(-1, 4)
        n = flat.shape[0]
        nidx = len(quattro_index_names())
        out = np.empty((n, nidx))
        status = np.zeros(n, dtype=np.intc)
        lib.pkm_quattro_indices(self._m, self._d, n, ptr(flat), ptr(out), status.ctypes.data_as(c_int_p))
        return out.reshape(x.shape[:-1] + (nidx,)), status.reshape(x.shape[:-1])

    def quattro_constants(self) -> dict:
        """The Quattro's constants the indices and the cycle-time search read, by name
        (``pkm_quattro_constants``): ``tau_arm_max`` [N m] (arm-side torque limit),
        ``gear_ratio`` [-], ``base_height`` [m] (the Adept origin above the motor-axis plane),
        ``link_length`` [m] (b_r, which scales J in the indices)."""
        self._require("quattro_indices", "quattro_constants")
        n = 4  # PKM_QUATTRO_NCONSTANT in pkm.h
        out = np.empty(n)
        self._check(lib.pkm_quattro_constants(self._m, self._d, ptr(out)))
        return {lib.pkm_quattro_constant_name(i).decode(): float(out[i]) for i in range(n)}

    def quattro_gimre(self, x) -> np.ndarray:
        """Quattro generalized inertia matrix reduced to the end effector, (4, 4) at pose x
        [kg, kg m, kg m^2] (``pkm_quattro_gimre``)."""
        self._require("quattro_gimre", "quattro_gimre")
        xv = np.ascontiguousarray(x, dtype=np.float64)
        N = np.empty((4, 4))
        self._check(lib.pkm_quattro_gimre(self._m, self._d, ptr(xv), ptr(N)))
        return N

    def quattro_points(self, x) -> dict:
        """Quattro world points A, B, C (4, 3) [m] of the four arms at pose x (motor axis,
        elbow, platform joint) (``pkm_quattro_points``)."""
        self._require("quattro_points", "quattro_points")
        xv = np.ascontiguousarray(x, dtype=np.float64)
        A, B, Cp = np.empty((4, 3)), np.empty((4, 3)), np.empty((4, 3))
        self._check(lib.pkm_quattro_points(self._m, self._d, ptr(xv), ptr(A), ptr(B), ptr(Cp)))
        return {"A": A, "B": B, "C": Cp}
