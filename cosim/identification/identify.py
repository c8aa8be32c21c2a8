"""Base-parameter identification of a serial arm from a recording (:func:`identify`)."""
from __future__ import annotations

import json
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.signal
import scipy.stats

from ..errors import InputError
from .base import BaseParameters, base_parameters
from .consistent import consistent_fit, pseudo_inertia
from .regressor import DRIVE, _check_serial, link_params, regressor, standard_values


def one_blas_thread():
    """BLAS on one thread while the identification runs (many small solves: on a busy machine a
    multi-threaded OpenBLAS spends more time handing them between threads than solving them)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is in requirements.txt
        return nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


class IdentificationError(InputError):
    """The recording cannot give a physically consistent arm (or cannot be identified at all)."""


@dataclass
class Identification:
    """What :func:`identify` found.

    ``names[j]`` is base parameter j's independent standard parameter and
    ``combinations[j]`` the whole combination; ``beta`` the physically consistent estimate (the
    nominal from now on), ``beta_ls`` the unconstrained weighted least squares, ``se`` its
    standard error (the larger of the residuals' covariance and the window bootstrap's),
    ``low``/``high`` the 95 % interval of ``beta_ls`` (+- 1.96 se).  ``params`` are the core's
    parameters of the identified model (links, drive terms, ``payload.m`` = 0: the last link
    holds the payload); ``standard`` its standard parameters by name.  ``sigma`` [N m] the
    residual RMS per joint of the consistent model on the samples fitted, ``rms`` [N m] the
    recorded efforts' RMS there; ``gap`` the consistent fit's cost over the unconstrained one
    (chi-square units) and ``gap_bound`` its 0.1 % bound.
    """

    robot: str
    names: list
    combinations: list
    beta: np.ndarray
    beta_ls: np.ndarray
    se: np.ndarray
    low: np.ndarray
    high: np.ndarray
    params: dict
    standard: dict
    sigma: np.ndarray
    rms: np.ndarray
    gap: float
    gap_bound: float
    samples: int
    base: BaseParameters = field(repr=False)

    def model(self, robot=None):
        """A :class:`cosim.core.Model` of the identified arm (``robot``: the description identified)."""
        from ..core import Model

        return Model(robot or self.robot, params=self.params)

    def write(self, path, robot=None) -> Path:
        """The identified model as a JSON parameter file (``cosim params --json``'s), which
        ``cosim diagnose --model`` takes as the nominal."""
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(self.model(robot).to_json() + "\n")
        return p

    def table(self) -> list[dict]:
        """One row per base parameter: name, combination, estimate, least squares, se, interval."""
        return [{"name": n, "combination": c, "value": float(b), "least_squares": float(bl), "se": float(s),
                 "low": float(lo), "high": float(hi)}
                for n, c, b, bl, s, lo, hi in zip(self.names, self.combinations, self.beta, self.beta_ls, self.se,
                                                  self.low, self.high)]

    def to_json(self) -> str:
        return json.dumps({"robot": self.robot, "samples": self.samples, "gap": self.gap, "gap_bound": self.gap_bound,
                           "sigma": list(self.sigma), "rms": list(self.rms), "base_parameters": self.table(),
                           "parameters": self.params}, indent=2)


def _lowpass(cutoff, fs):
    if not 0 < cutoff < 0.45 * fs:
        raise InputError(f"cutoff {cutoff} Hz: must be positive and below 0.45 x the sample rate ({fs:.6g} Hz)")
    return scipy.signal.butter(4, cutoff / (fs / 2))


def prepare(time, q, qd, tau, cutoff: float):
    """(q, qd, qdd, tau, fs) with q and qd through a zero-phase 4th-order Butterworth low-pass
    of ``cutoff`` [Hz], qdd the filtered rates' central differences, tau as recorded (it goes
    through the same filter beside the regressor: :func:`_parallel_filter`), fs [Hz] the sample
    rate."""
    t = np.asarray(time, dtype=float)
    fs = 1.0 / float(np.median(np.diff(t)))
    b, a = _lowpass(cutoff, fs)
    if len(t) < 3 * (max(len(a), len(b)) + 1) + 1 or len(t) < 4 * fs / cutoff:
        raise InputError(f"the recording holds {len(t)} samples: too few for a {cutoff} Hz filter")
    qf, qdf = (scipy.signal.filtfilt(b, a, np.asarray(x, dtype=float), axis=0) for x in (q, qd))
    return qf, qdf, np.gradient(qdf, t, axis=0), np.asarray(tau, dtype=float), fs


def _parallel_filter(W, y, nd, cutoff, fs, stride):
    """The regressor's columns through the low-pass the efforts went through (Gautier's parallel
    filtering: filter(W) phi = filter(tau) also for the terms nonlinear in the motion, such as
    Coulomb friction), the filter's transients at both ends (1 / cutoff) dropped, one sample in
    ``stride`` kept (default: about 10 cutoff per second)."""
    b, a = _lowpass(cutoff, fs)
    n = len(y) // nd
    Wf = scipy.signal.filtfilt(b, a, W.reshape(n, nd * W.shape[1]), axis=0).reshape(W.shape)
    edge = int(np.ceil(fs / cutoff))
    stride = stride or max(1, int(fs / (10 * cutoff)))
    keep = np.arange(edge, n - edge, stride)
    rows = (keep[:, None] * nd + np.arange(nd)).ravel()
    return Wf[rows], y[rows], keep


def _weighted_ls(Wb, y, nd, windows, bootstrap, seed):
    """Base parameters by least squares with the joints weighted by their residuals' RMS (a
    first unweighted pass); standard errors from the residual covariance and from a
    bootstrap over contiguous windows of samples (which keeps the residuals' correlation)."""
    beta0 = np.linalg.lstsq(Wb, y, rcond=None)[0]
    sig = np.sqrt(np.mean((y - Wb @ beta0).reshape(-1, nd) ** 2, axis=0)).clip(1e-12)
    w = np.tile(1.0 / sig, len(y) // nd)
    A, b = Wb * w[:, None], y * w
    Q, R = np.linalg.qr(A)
    beta = np.linalg.solve(R, Q.T @ b)
    dof = max(len(y) - len(beta), 1)
    s2 = float(np.sum((b - A @ beta) ** 2) / dof)
    Rinv = np.linalg.inv(R)
    se_cov = np.sqrt(s2 * np.sum(Rinv ** 2, axis=1))
    n = len(y) // nd
    edges = np.linspace(0, n, windows + 1).astype(int) * nd
    spans = list(zip(edges[:-1], edges[1:]))
    G = np.array([A[i:j].T @ A[i:j] for i, j in spans])  # each window's normal equations
    g = np.array([A[i:j].T @ b[i:j] for i, j in spans])
    rng = np.random.default_rng(seed)
    draws = []
    for _ in range(bootstrap):
        count = np.bincount(rng.integers(0, windows, windows), minlength=windows).astype(float)
        draws.append(np.linalg.lstsq(np.tensordot(count, G, 1), count @ g, rcond=None)[0])
    se_boot = np.std(draws, axis=0, ddof=1) if bootstrap > 1 else np.zeros_like(beta)
    return beta, np.maximum(se_cov, se_boot), R, se_cov


def _refuse(base, beta, beta_c, se, phi, nlinks, gap, bound):
    j = int(np.argmax(np.abs(beta_c - beta) / se))
    worst = min(range(nlinks), key=lambda i: np.linalg.eigvalsh(pseudo_inertia(phi[10 * i:10 * i + 10]))[0]
                / max(np.abs(phi[10 * i:10 * i + 10]).max(), 1e-300))
    raise IdentificationError(
        f"the recording's base parameters are not a rigid arm's: the nearest physically consistent ones cost "
        f"{gap:.4g} in chi-square units over the least squares (0.1 % bound {bound:.4g}); furthest: "
        f"{base.combination(j, 4)} = {beta[j]:.6g} +- {se[j]:.3g} against {beta_c[j]:.6g}; link {worst + 1} at the "
        "boundary (a mass, inertia or friction the recording makes non-physical, or missing physics in the model)")


def identify(recording, robot=None, *, param_set: str | None = None, params: dict | None = None, drive=DRIVE, extra=(),
             cutoff: float = 10.0, stride: int | None = None, tol: float = 1e-8, windows: int = 20,
             bootstrap: int = 200, seed: int = 0, strict: bool = True) -> Identification:
    """Identify a serial arm's base inertial and drive parameters from a recording.

    The efforts are linear in the standard parameters (:mod:`cosim.identification.regressor`,
    from the core); the identifiable combinations are found by QR (:mod:`~.base`), fitted by
    weighted least squares with intervals, then made physically consistent (:mod:`~.consistent`:
    positive masses, rigid bodies' inertias, friction and rotor inertia >= 0).

    Parameters
    ----------
    recording : str, Path or cosim.recording.Recording
        A pkm-recording with ``q`` [rad or m], ``qd`` [rad/s or m/s] and the efforts ``tau``
        [N m or N] of every joint.
    robot : str or cosim.core.Model, optional
        The arm's description (default: the recording's robot); its parameters start the fit
        and fix what no recording sees.  A payload is folded into the last link.
    param_set, params : optional
        Named set and overrides of that description.
    drive : sequence of str
        Drive-layer terms identified on every joint (effort linear in each).
    extra : sequence of str
        Further parameters identified, by full name, the efforts linear in each (e.g.
        ``joint[2].force_k1``, ``joint[2].force_k2``: a force polynomial in the position).
    cutoff : float
        Low-pass filter cut-off of positions, rates and efforts [Hz].
    stride, tol, windows, bootstrap, seed
        Samples kept (one in ``stride``), the rank tolerance (:func:`~.base.base_parameters`),
        the bootstrap's windows and draws and its random seed.
    strict : bool
        Raise :class:`IdentificationError` when the least-squares base parameters are
        significantly not a rigid arm's (else return the nearest consistent model anyway).

    Returns
    -------
    Identification

    Examples
    --------
    >>> from cosim.identification import identify
    >>> ident = identify("out/kuka/kr300_A.csv", "robots/kr300.toml")  # doctest: +SKIP
    >>> ident.write("out/kuka/kr300_identified.json")  # cosim diagnose --model  # doctest: +SKIP
    """
    from ..core import Model
    from ..recording import Recording, read_recording

    rec = recording if isinstance(recording, Recording) else read_recording(str(recording))
    model = robot if isinstance(robot, Model) else Model(robot or rec.robot, param_set, params)
    model = model.copy()
    _check_serial(model)
    if "payload.m" in model.params():
        model.set_params({"payload.m": 0.0})
    nd = model.ndof
    if rec.q.shape[1] != nd:
        raise InputError(f"the recording has {rec.q.shape[1]} joints, {model.robot} {nd}")
    with one_blas_thread():
        q, qd, qdd, tau, fs = prepare(rec.time, rec.q, rec.qd, rec.tau, cutoff)
        W0, names, rest = regressor(model, q, qd, qdd, drive, extra)
        W, y, keep = _parallel_filter(W0, tau.ravel() - rest, nd, cutoff, fs, stride)
        base = base_parameters(W, names, tol)
        beta, se, R, _ = _weighted_ls(W[:, base.independent], y, nd, windows, bootstrap, seed)
        L = R * (np.sqrt(np.sum(np.linalg.inv(R) ** 2, axis=1)) / se)[None, :]  # L'L: the inverse covariance of se
        phi0 = standard_values(model, drive, extra)
        phi, gap = consistent_fit(base.matrix, L, beta, phi0, names, nd)
    bound = float(scipy.stats.chi2.ppf(0.999, len(beta)))
    beta_c = base.project(phi)
    if strict and gap > bound:
        _refuse(base, beta, beta_c, se, phi, nd, gap, bound)
    out = {k: v for i in range(1, nd + 1) for k, v in link_params(i, phi[10 * i - 10:10 * i]).items()}
    out.update({n: float(v) for n, v in zip(names[10 * nd:], phi[10 * nd:])})
    if "payload.m" in model.params():
        out["payload.m"] = 0.0
    res = (y - W @ phi).reshape(-1, nd)
    return Identification(
        robot=model.source, names=base.names, combinations=[base.combination(j) for j in range(len(beta))],
        beta=beta_c, beta_ls=beta, se=se, low=beta - 1.96 * se, high=beta + 1.96 * se, params=out,
        standard=dict(zip(names, map(float, phi))), sigma=np.sqrt(np.mean(res ** 2, axis=0)),
        rms=np.sqrt(np.mean(y.reshape(-1, nd) ** 2, axis=0)), gap=gap, gap_bound=bound, samples=len(keep), base=base)
