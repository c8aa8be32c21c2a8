"""Residuals of a recording against the core: the effort and kinematic families.

What the recorded columns mean (``pkm-recording/1``, docs/discrepancy.md):

* ``q<i>``: the joint readings (encoders), i.e. the core's sensor model
  ``pkm_measure_joints`` of the true state, possibly delayed (``sensor.delay``);
* ``qd<i>``: the joint-rate readings (a velocity sensor: true rate, same delay);
* ``tau<i>``: the effort the controller *commanded*, held over the following sample
  (zero-order hold).  What reaches the mechanism may differ: the actuator clips it
  (``<j>[i].effort_max``) and delays it (``actuator.delay``);
* pose columns, if present: an external tracker measuring the true pose;
* ``f_ext<i>``, if present (``Recording.f_ext``): a measured external effort per joint,
  positive along +q, a known input added to what the actuator applies;
* ``inject<i>``, if present (:mod:`cosim.injection`): a signal the rig added into its
  loop; one added to the command and logged without it is added to ``tau``.

Effort residual, for a model with parameters theta (sample time t)::

    r_eff(t) = S[sat(tau)](t - d_a - d_s) + S[f_ext](t) - S[ID(x, xd, xdd)](t)

``S`` is a zero-phase Savitzky-Golay smoother (``window``, ``polyorder``); ``x =
FK(q)``, ``xd = pose_velocity(x, qd)`` and ``xdd = pose_acceleration(x, xd, qdd)`` at
every sample, with ``qdd`` the central difference of the recorded rates: the mean
acceleration over the two steps around the sample, which the zero-order-hold efforts
of those two steps produce (their mean is the effort used at the sample).  The inverse
dynamics is evaluated sample by sample and then smoothed exactly like the effort, so
the two sides see the same linear filter: the mass matrix varies with the pose and
friction is discontinuous in the rate, and smoothing the motion before the inverse
dynamics instead would leave a bias at every jerk peak (measured on a noiseless
closed-loop run of the 6-PUS: 1.7e-3 N RMS that way, 5e-6 N this way).  The noise of
the difference is high-frequency and the smoother removes it.
Everything is the core's: FK, pose velocity and acceleration, inverse dynamics,
saturation.

Kinematic residual (with tracker pose)::

    r_kin(t) = S[q_rec](t) - S[measure_joints(pose, xd, tau_applied)](t - d_s)

Residuals are evaluated on decimated interior samples (every ``step``-th sample,
away from the ends where the smoother extrapolates).  A parameter change of the model
(dict of core parameter names) changes the residual through the core only; the
engine's regressors are finite differences of :meth:`Pipeline.evaluate`.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import convolve1d
from scipy.signal import savgol_coeffs, savgol_filter

from .._native import PkmError, UnsupportedError
from . import _corecalls as cc
from ._kinshare import changed, kinematic_entries, same_kinematics
from ._memo import Memo
from ._smooth_rows import smoothed_rows
from ..errors import DiagnosisError
from .recorded import applied_efforts, check_joint_limits, uniform_step


#: parameters of the actuator (applied to the recorded command) and of the sensors
ACTUATOR_KEYS = (".effort_max", ".dead_zone", "actuator.delay")
SENSOR_KEYS = (".encoder_offset", ".backlash", ".compliance", "sensor.delay")


def _is(name, keys):
    return any(name.endswith(k) or name == k for k in keys)


@functools.lru_cache(maxsize=4096)
def _is_kept(name, keys) -> bool:
    """:func:`_is`, kept (each evaluation asks it of every parameter set)."""
    return _is(name, keys)


@dataclass
class Residual:
    """Residual channels at the pipeline's sample positions: ``eff`` (m, nd) [N or N m],
    ``kin`` (m, nd) [m or rad] or None."""

    eff: np.ndarray
    kin: np.ndarray | None

    def stack(self) -> np.ndarray:
        """Channels side by side: (m, nd) or (m, 2 nd)."""
        return self.eff if self.kin is None else np.hstack([self.eff, self.kin])


def _at(a, pos):
    """Linear interpolation of rows of a (n, c) at fractional row positions pos (m,)."""
    i0 = np.floor(pos).astype(int)
    f = (pos - i0)[:, None]
    i0 = np.clip(i0, 0, len(a) - 2)
    return a[i0] * (1.0 - f) + a[i0 + 1] * f


def reference_motion(model, qref, dt, x_guess):
    """The pose motion ``(x, xd, xdd)`` of the reference joint positions ``qref`` (rows at
    step ``dt`` [s]) through the core (forward kinematics from the poses ``x_guess``, its rates
    and accelerations from a 7-point cubic fit of ``qref``), or None where the forward kinematics
    fails: the motion the controller was asked for, whose inverse dynamics is the pipeline's
    reference effort (:attr:`Pipeline.tau_ref_s`)."""
    qref = np.asarray(qref, float)
    try:
        x = model.fk(qref, x_guess=x_guess)
    except PkmError:
        return None
    qd = savgol_filter(qref, 7, 3, deriv=1, delta=dt, axis=0, mode="interp")
    qdd = savgol_filter(qref, 7, 3, deriv=2, delta=dt, axis=0, mode="interp")
    xd = cc.pose_velocity(model, x, qd)
    return x, xd, cc.pose_acceleration(model, x, xd, qdd)


class Pipeline:
    """The residual pipeline of one recording against one model.

    Parameters
    ----------
    rec : cosim.recording.Recording
        The recording.
    model : cosim.core.Model
        The nominal model (the engineer's belief); not modified.
    geometry : iterable of str, optional
        Core parameters that move the pose computed from the joints (default: those of
        the library's geometry effect); a change of one of them recomputes the pose.
    window : float
        Length of the Savitzky-Golay window [s] (odd number of samples, >= 7).
    polyorder : int
        Polynomial order of the smoother.
    step : int, optional
        Decimation of the residual samples (default: window / 5).
    zoh : bool
        The recorded effort is a zero-order-hold command (applied from its sample to the
        next): its value at a sample time is the mean of the held values on both sides.
    max_delay : float
        Largest delay the engine considers [s] (sets the margin at the ends).
    segments : list of (int, int), optional
        Row ranges ``[start, stop)`` of separate stretches of motion placed one after the
        other in ``rec`` (the blocks of a long recording's working set,
        :mod:`.working_set`); each is uniformly sampled at the same step, and residuals are
        evaluated only where the smoother and the delays stay inside one stretch.  Default:
        the whole recording is one stretch.
    kinematics : Pipeline, optional
        A pipeline of the same recording whose model differs from ``model`` only in parameters
        that move no joint (a mass, an inertia, a force on the platform): its poses and their
        rates and the kinematic entries of its cache are taken instead of computed again, the
        same values (:mod:`._kinshare`).  Ignored when that does not hold.

    Raises
    ------
    DiagnosisError
        Too short, non-uniformly sampled, wrong robot, a robot without dynamics, or
        joints whose forward kinematics fails (says at which time).
    """

    def __init__(self, rec, model, *, window: float = 0.05, polyorder: int = 3, step: int | None = None,
                 zoh: bool = True, max_delay: float = 0.02, geometry=None, segments=None,
                 kinematics=None):
        where = str(rec.path) if rec.path else "recording"
        if rec.robot != model.robot:
            raise DiagnosisError(f"{where}: recording of robot {rec.robot!r}, model of {model.robot!r}")
        self.rec, self.model, self.where = rec, model, where
        t = np.asarray(rec.time, float)
        n, nd = len(t), model.ndof
        if n < 3:
            raise DiagnosisError(f"{where}: {n} samples; a diagnosis needs a recording of at least a second")
        self.segments = [(0, n)] if segments is None else [(int(a), int(b)) for a, b in segments]
        dt = uniform_step(t, self.segments, where, whole=segments is None)
        w = int(round(window / dt)) | 1
        w = max(w, 7)
        self.dt, self.n, self.nd, self.window, self.polyorder = dt, n, nd, w, polyorder
        self.step = step or max(1, int(round(w / 5)))
        self.max_shift = int(math.ceil(max_delay / dt)) + 2
        margin = w // 2 + self.max_shift
        need = 2 * margin + 20 * self.step
        if segments is None and n < need:
            raise DiagnosisError(
                f"{where}: {n} samples ({t[-1] - t[0]:.3g} s at {1 / dt:.4g} Hz) are too few: the smoothing window "
                f"is {w} samples and the delays searched reach {max_delay * 1e3:.3g} ms, so at least {need} samples "
                f"({need * dt:.3g} s) are needed")
        if segments is None:
            self.idx = np.arange(margin, n - margin, self.step)
        else:
            # three more samples at the inner ends: the differences of the rates and of the
            # reference reach that far before the smoother
            pad = margin + 3
            self.idx = np.concatenate([np.arange(a + pad, b - pad, self.step) for a, b in self.segments])
            if len(self.idx) < 20:
                raise DiagnosisError(f"{where}: its blocks of {min(b - a for a, b in self.segments)} samples are too "
                                     f"short for a smoothing window of {w} samples and delays up to "
                                     f"{max_delay * 1e3:.3g} ms")
        self.t = t
        try:
            model.inverse_dynamics(model.home(), np.zeros(nd), np.zeros(nd))
        except UnsupportedError:
            raise DiagnosisError(f"{where}: the {model.robot} model of the core has no inverse dynamics, so the "
                                 f"effort residual cannot be formed") from None
        self.zoh = zoh
        self.tau_c, self.f_ext = applied_efforts(rec, n, nd, zoh, where)
        self.q = np.asarray(rec.q, float)
        self.qd = np.asarray(rec.qd, float)
        check_joint_limits(model, t, self.q, where, whole=segments is None)
        self.pose = None if rec.pose is None else np.asarray(rec.pose, float)
        self._smooth_args = dict(window_length=w, polyorder=polyorder, axis=0, mode="interp")
        self._coeffs = savgol_coeffs(w, polyorder, delta=dt)
        self.q_s = self.S(self.q)
        self.qd_s = self.S(self.qd)
        self.qdd_s = self.S(self.qd, deriv=1)
        self.tau_s = self.S(self.tau_c)
        self.f_ext_s = None if self.f_ext is None else self.S(self.f_ext)
        # Central difference: (qd[k+1] - qd[k-1]) / 2 dt is the mean acceleration over the
        # two steps around sample k, exactly what the zero-order-hold efforts held over
        # those two steps produce (their mean is tau_c[k]): no bias for any motion.
        qdd_l = savgol_filter(self.qd, 3, 2, deriv=1, delta=dt, axis=0, mode="interp")
        # Rate-reading noise (the 5-point quadratic fit leaves 0.717 sigma of white noise)
        # and the samples whose smoothing window is mostly at rest: there the friction
        # (and the backlash side) depend on a rate below what the readings resolve, so
        # they are left out of the fit of that joint's channels.
        qd_l = savgol_filter(self.qd, 5, 2, axis=0, mode="interp")
        self.qd_noise = 1.4826 * np.median(np.abs(self.qd - qd_l), axis=0) / 0.717
        slow = (np.abs(qd_l) < 3.0 * self.qd_noise).astype(float)
        self.usable = self.S(slow)[self.idx] < 0.2

        # Pose, rate and acceleration of every sample (for the inverse dynamics) and of
        # the smoothed joints (descriptors of the motion, geometry corrections).
        same = same_kinematics(kinematics, rec, model, window=w, polyorder=polyorder, segments=segments, zoh=zoh)
        self._pose_motion(model, qdd_l, kinematics if same else None)
        self.tau_ref_s = self._reference_effort(model, kinematics.ref_motion if same else False)
        self.nominal = model.params()
        if geometry is None:
            from .effects import groups_for

            geometry = [p for g in groups_for(model, True)[0] if g.effect.kind == "geometry" for p in g.params]
        self.geometry = frozenset(geometry)
        # the evaluations' cache and scratch model: the pipeline's attributes are fixed from here on
        self._memo = Memo(model, self.nominal)
        # the actuators' efforts and the sensors' readings too when neither's parameters differ
        command = same and not any(_is(k, ACTUATOR_KEYS + SENSOR_KEYS) for k in changed(kinematics, model))
        for key, v in (kinematic_entries(kinematics, command) if same else []):
            self._memo.get(key, lambda v=v: v)
        # a few recorded samples whose joint motion tells whether a parameter moves it (_moves_joints)
        rows = np.linspace(0, n - 1, min(n, 16)).astype(int)
        self._probe = (self.x_f[rows], self.xd_f[rows], self.xdd_f[rows])
        # The mechanism's inverse dynamics is kept apart from the drive layer's (friction,
        # rotor inertia, joint force): most candidates move only the drive layer, and the
        # mechanism's part, the costly one, is then the nominal one.
        self._drive_params = model.drive_layer_params()
        self._compliant = any(k.endswith(".compliance") and v != 0 for k, v in self.nominal.items())
        self._built = True

    def _pose_motion(self, model, qdd_l, k):
        """The pose, rate and acceleration of every recorded sample, the pose of the smoothed
        joints and the pose rate at the tracker's poses: those of the pipeline ``k`` (of the same
        kinematics, :func:`._kinshare.same_kinematics`), else computed through the core."""
        if k is not None:
            self.x_f, self.xd_f, self.xdd_f, self.x_s = k.x_f, k.xd_f, k.xdd_f, k.x_s
            if self.pose is not None:
                self.xd_p = k.xd_p
            return
        t = self.t
        self.x_f = self._fk(model, self.q, self.pose)
        self.xd_f = cc.pose_velocity(model, self.x_f, self.qd, times=t)
        self.xdd_f = cc.pose_acceleration(model, self.x_f, self.xd_f, qdd_l, times=t)
        self.x_s = self._fk(model, self.q_s, self.x_f)
        if self.pose is not None:
            self.xd_p = cc.pose_velocity(model, self.pose, self.qd, times=t)

    def __setattr__(self, name, value):
        if getattr(self, "_built", False):
            raise AttributeError(f"Pipeline.{name}: a pipeline is fixed once built (its evaluations' cache and "
                                 f"scratch model are its Memo)")
        object.__setattr__(self, name, value)

    def _reference_effort(self, model, motion=False):
        """Smoothed inverse dynamics of the reference (``qref``) through the nominal
        model, or None: a noise-free image of the commanded effort, the instrument of the
        delay estimates (the recorded command carries the controller's reaction to the
        rate noise, and so do the motion terms, as its derivative: a delay signature
        built from either correlates with the residual's noise).  ``motion``: the
        reference's pose motion (x, xd, xdd) or None as another pipeline of the same
        kinematics found it (False: computed here)."""
        self.ref_motion = None
        if self.rec.qref is None:
            return None
        if motion is not False:
            self.ref_motion = motion
            return None if motion is None else self.S(model.inverse_dynamics(*motion))
        self.ref_motion = reference_motion(model, self.rec.qref, self.dt, self.x_f)
        return None if self.ref_motion is None else self.S(model.inverse_dynamics(*self.ref_motion))

    @property
    def has_reference(self) -> bool:
        """The recording has a reference the core could follow (``qref``)."""
        return self.ref_motion is not None

    def reference_effort(self, params: dict | None = None) -> np.ndarray:
        """Smoothed inverse dynamics of the model with ``params`` along the reference
        motion, at the sample positions, (m, nd) [N or N m].  Its change with a mass or
        an inertia is the instrument of that parameter: the same regressor as the one of
        the recorded motion, without the noise of the measured rates and accelerations
        (docs/discrepancy.md, "errors in variables")."""
        if self.ref_motion is None:
            raise DiagnosisError(f"{self.where}: the recording has no reference (qref columns)")
        params = {k: float(v) for k, v in (params or {}).items() if self.nominal.get(k) != float(v)}
        key = ("ref", tuple(sorted(params.items())))

        def ev():
            m = self.model_for(params)
            return self.S_rows(self._inverse_dynamics(m, "ref", params.items(), *self.ref_motion), self.idx)
        return self._cached(key, ev)

    def _inverse_dynamics(self, m, motion, params, x, xd, xdd):
        """``m.inverse_dynamics(x, xd, xdd)`` bit for bit, its mechanism's part cached under
        ``motion`` (which names x, xd, xdd) and the mechanism's parameters among ``params``
        (the model's parameters that differ from the nominal ones)."""
        mech = tuple(sorted((k, v) for k, v in params if k not in self._drive_params))
        M = self._cached(("M", motion, mech), lambda: m.mechanism_inverse_dynamics(x, xd, xdd))
        if any(self._moves_joints(k) for k, _ in mech):
            return m.add_drive_inverse_dynamics(x, xd, xdd, M)
        # the nominal mechanism's joint motion along this motion, for every drive layer tried on it
        # (a mass, a payload, gravity or a platform force leaves the joint motion as it is)
        J = self._cached(("J", motion), lambda: (m.ik(x), m.joint_velocity(x, xd), m.joint_acceleration(x, xd, xdd)))
        return m.add_drive_efforts(*J, M)

    def _moves_joints(self, name) -> bool:
        """Does the mechanism's parameter ``name`` move the joint motion of a pose motion (the
        joint positions, rates and accelerations of :meth:`Model.ik` and its rates)?  A geometry
        parameter does (:attr:`geometry`); another one does when the joint motion of a few
        recorded samples changes with it (a length, a position or a direction of the mechanism
        not among the library's geometry), not when it is a mass, an inertia, gravity or a force
        on the platform: the core's kinematics does not read those."""
        if name in self.geometry:
            return True
        return self._cached(("moves joints", name), lambda: self._memo.moves_joints(name, self._probe))

    def delay_signature(self, name: str, d: float, positions=None):
        """Change of the effort residual for a delay ``d`` [s] of ``name``
        ("actuator.delay" or "sensor.delay") built from the reference effort, (m, nd);
        None without a reference."""
        if self.tau_ref_s is None:
            return None
        pos = self.idx if positions is None else np.asarray(positions)
        T = self.tau_ref_s
        return _at(T, pos - d / self.dt) - T[pos]

    # ------------------------------------------------------------------ helpers
    def S(self, a, deriv: int = 0):
        """Zero-phase Savitzky-Golay smoothing (deriv=1: its time derivative)."""
        return savgol_filter(a, deriv=deriv, delta=self.dt, **self._smooth_args)

    def S_inner(self, a):
        """:meth:`S` of the rows whose smoothing window lies inside the recording, bit for bit,
        without the polynomial fits of the rows nearer its ends (half a window at each end;
        NaN there): an evaluation reads its smoothed signals a margin of at least half a
        window away from the ends, and those fits cost as much as the smoothing itself."""
        y = convolve1d(np.asarray(a, float), self._coeffs, axis=0, mode="constant")
        h = self.window // 2
        y[:h] = np.nan
        y[len(y) - h:] = np.nan
        return y

    def _smoothed_at_samples(self, a):
        """:meth:`S_inner` of ``a`` at the decimated samples ``idx`` (the rows an evaluation reads),
        NaN at the other rows: an array of S_inner's shape, whose size the evaluation cache
        weighs as S_inner's (the entries it keeps are those it kept for S_inner: a second
        pipeline takes some of them, :mod:`._kinshare`)."""
        out = np.full(np.shape(a), np.nan)
        out[self.idx] = self.S_rows(a, self.idx)
        return out

    def S_rows(self, a, rows):
        """``S_inner(a)[rows]``, bit for bit, smoothing the rows ``rows`` alone where they are the
        decimated samples (:func:`._smooth_rows.smoothed_rows`: an evaluation reads no other)."""
        rows = np.asarray(rows)
        h = self.window // 2
        if len(rows) and rows.min() >= h and rows.max() < len(a) - h:
            return smoothed_rows(a, self._coeffs, rows)
        return self.S_inner(a)[rows]

    @property
    def has_pose(self) -> bool:
        return self.pose is not None

    @property
    def channels(self) -> list:
        names = [f"tau{i + 1}" for i in range(self.nd)]
        if self.has_pose:
            names += [f"q{i + 1}" for i in range(self.nd)]
        return names

    def _fk(self, model, q, guess):
        t = self.t
        if guess is None:
            # A chain of solves on a coarse grid, each from the previous pose, gives
            # every sample a guess close to its pose.
            # Each stretch of motion starts its chain from home, as the first one does.
            coarse = np.unique(np.concatenate([np.arange(a, b, 20) for a, b in self.segments]))
            starts = {a for a, _ in self.segments}
            xs = np.empty((len(coarse), model.ndof))
            g = model.home()
            for k, i in enumerate(coarse):
                try:
                    g = model.fk(q[i], x_guess=model.home() if i in starts else g)
                except PkmError as e:
                    raise DiagnosisError(f"{self.where}: forward kinematics of the recorded joints failed at t = "
                                         f"{t[i]:.6g} s (row {i + 2}): {e}") from None
                xs[k] = g
            guess = np.column_stack([np.interp(np.arange(len(q)), coarse, xs[:, c]) for c in range(model.ndof)])
        x, status = model.fk(q, x_guess=guess, errors="status")
        bad = np.flatnonzero(status != 0)
        if bad.size:
            i = int(bad[0])
            try:
                model.fk(q[i], x_guess=guess[i])
            except PkmError as e:
                raise DiagnosisError(f"{self.where}: forward kinematics of the recorded joints failed at t = "
                                     f"{t[i]:.6g} s (row {i + 2}): {e}") from None
        return x

    def segment_of(self, row: int) -> tuple[int, int]:
        """The row range ``[start, stop)`` of the stretch of motion holding ``row``."""
        for a, b in self.segments:
            if a <= row < b:
                return a, b
        raise IndexError(f"row {row} is outside the recording's {self.n} rows")

    def model_for(self, params: dict):
        """The nominal model with ``params`` set: one scratch copy whose parameters are
        set through the C API (a fresh ``Model.copy`` per evaluation would cost more
        than the evaluation itself).  Valid until the next call."""
        if not params:
            return self.model
        return self._memo.scratch.set(params)

    def _cached(self, key, fn):
        """fn(), kept under ``key`` in the pipeline's :class:`._memo.Memo` (least recently used
        first out)."""
        return self._memo.get(key, fn)

    def split(self, train_fraction: float = 0.7):
        """Boolean masks (train, held-out) over the sample positions: the last part of
        the recording is held out of the fit."""
        t = self.t[self.idx]
        cut = self.t[0] + train_fraction * (self.t[-1] - self.t[0])
        return t < cut, t >= cut

    # --------------------------------------------------------------- evaluation
    def evaluate(self, params: dict | None = None, positions=None) -> Residual:
        """Residuals of the model with ``params`` (core names -> values) set.

        ``positions`` are sample indices (default: the decimated interior samples).
        """
        params = {k: float(v) for k, v in (params or {}).items() if self.nominal.get(k) != float(v)}
        if positions is None:  # a selection asks for the same parameters again (a chi-square, a Jacobian's centre)
            return self._memo.residual(params, lambda: self._evaluate(params, self.idx))
        return self._evaluate(params, np.asarray(positions))

    def _evaluate(self, params: dict, pos) -> Residual:
        """:meth:`evaluate` at the sample positions ``pos`` of ``params`` (only those that differ
        from the nominal ones, as floats)."""
        m = self.model_for(params)
        d_a = m.param("actuator.delay") / self.dt
        d_s = m.param("sensor.delay") / self.dt
        # 1e-9: the largest delay searched, (max_shift - 2) dt, divided by dt may round above max_shift - 2
        if max(d_a, d_s) > self.max_shift - 2 + 1e-9:
            raise DiagnosisError(f"a delay of {max(d_a, d_s) * self.dt * 1e3:.3g} ms is beyond the "
                                 f"{(self.max_shift - 2) * self.dt * 1e3:.3g} ms the pipeline was built for")
        dyn = tuple(sorted((k, v) for k, v in params.items() if not _is_kept(k, ACTUATOR_KEYS + SENSOR_KEYS)))
        act = tuple(sorted((k, v) for k, v in params.items() if k.endswith((".effort_max", ".dead_zone"))))
        sens = tuple(sorted((k, v) for k, v in params.items() if _is_kept(k, SENSOR_KEYS) and k != "sensor.delay"))
        geo = tuple((k, v) for k, v in dyn if self._is_geometry(k))

        A = self._cached(("A", act), lambda: self._applied(m, act))
        if pos is self.idx or np.isin(pos, self.idx).all():
            B = self._cached(("B", dyn), lambda: self._smoothed_at_samples(
                self._inverse_dynamics(m, "recorded", dyn, self.x_f, self.xd_f, self.xdd_f)))
        else:  # rows the smoothing at the samples leaves out: smoothed whole, not kept
            B = self.S_inner(self._inverse_dynamics(m, "recorded", dyn, self.x_f, self.xd_f, self.xdd_f))
        # Readings lagging by d_s show the motion of t - d_s, driven by the command of
        # t - d_s - d_a: the residual is labelled by the recorded motion's sample, so an
        # actuator delay and a sensor lag give the same effort residual (they are the same
        # closed loop) and differ only in the readings against the tracker.
        p_m = pos
        eff = _at(A[1], pos - d_a - d_s) - B[pos]
        if self.f_ext_s is not None:
            eff = eff + self.f_ext_s[pos]  # recorded with the motion it drives
        if geo or sens:
            eff -= self._pose_term(m, params, np.clip(np.round(p_m).astype(int), 0, self.n - 1), bool(sens))
        kin = None
        if self.has_pose:
            compliant = any(k.endswith(".compliance") and v != 0 for k, v in sens) or self._compliant
            key = ("K", sens, geo) + ((act, round(d_a, 9)) if compliant else ())
            K = self._cached(key, lambda: self._readings(m, A[0], d_a))
            kin = self.q_s[pos] - _at(K, pos - d_s)
        return Residual(eff, kin)

    def _is_geometry(self, name):
        return name in self.geometry

    def _applied(self, m, act):
        """Effort applied by the actuators for the recorded command: (raw, smoothed)."""
        if not act:
            return self.tau_c, self.tau_s
        raw = cc.actuator_effort(m, self.tau_c, times=self.t)
        return raw, self.S_inner(raw)

    def pose_term(self, params: dict, positions=None):
        """Change of the effort residual when the pose is recomputed for a model with
        ``params`` (geometry and sensor parameters); (m, nd)."""
        params = {k: float(v) for k, v in params.items() if self.nominal.get(k) != float(v)}
        m = self.model_for(params)
        pos = self.idx if positions is None else np.asarray(positions)
        sens = any(_is(k, SENSOR_KEYS) and k != "sensor.delay" for k in params)
        return -self._pose_term(m, params, pos, sens)

    def _pose_term(self, m, params, i, sensors: bool):
        """Change of the inverse dynamics when the pose of the smoothed joints is
        recomputed with the model's geometry and, with ``sensors``, from the joints
        corrected for the model's sensor errors (decimated samples: a smooth term).
        ``m`` is the model with ``params`` set."""
        x0 = self.x_s[i]
        q, qd, qdd = self.q_s[i], self.qd_s[i], self.qdd_s[i]
        # the nominal pose's rates at these samples are the same for every candidate
        at = ("smoothed", i.tobytes())
        xd0, xdd0 = self._cached(("P0",) + at, lambda: self._nominal_rates(x0, qd, qdd))
        if sensors:
            # reading = q + e(q, qd, tau): one fixed-point step from the nominal pose
            # (e is the sensor error, at most a few 1e-4 of the stroke).
            e = cc.measure_joints(m, x0, xd0, self.tau_s[i]) - m.ik(x0)
            x, xd, xdd = self._posed(m, q - e, x0, qd, qdd)
        else:  # the pose motion depends on the parameters that move the joints only
            kin = tuple(sorted((k, v) for k, v in params.items() if self._moves_joints(k)))
            x, xd, xdd = self._cached(("X", kin) + at, lambda: self._posed(m, q, x0, qd, qdd))
        return m.inverse_dynamics(x, xd, xdd) - self._inverse_dynamics(m, at, params.items(), x0, xd0, xdd0)

    @staticmethod
    def _posed(m, q, x0, qd, qdd):
        """Pose (from the guess x0), pose rate and acceleration of model m for joints q, qd, qdd."""
        x = m.fk(q, x_guess=x0)
        xd = cc.pose_velocity(m, x, qd)
        return x, xd, cc.pose_acceleration(m, x, xd, qdd)

    def _nominal_rates(self, x0, qd, qdd):
        """Pose rate and acceleration of the nominal model at poses x0 for joint rates qd and
        accelerations qdd."""
        xd0 = cc.pose_velocity(self.model, x0, qd)
        return xd0, cc.pose_acceleration(self.model, x0, xd0, qdd)

    def _readings(self, m, applied, d_a):
        """Smoothed joint readings the model's sensors give at the tracker poses."""
        tau = applied if d_a == 0 else _at(applied, np.clip(np.arange(self.n) - d_a, 0, self.n - 1))
        return self.S_inner(cc.measure_joints(m, self.pose, self.xd_p, tau, times=self.t))

    # ------------------------------------------------------------ descriptors
    def motion(self, positions=None):
        """Smoothed joint rate and acceleration and the pose at the sample positions."""
        pos = self.idx if positions is None else positions
        return self.qd_s[pos], self.qdd_s[pos], self.x_s[pos]
