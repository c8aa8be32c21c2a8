"""Calibration benchmark (target: 60 parameters, 1000 poses, < 0.5 s) and the pose-selection study.

Both are commands, not tests: ``cosim calibrate --bench`` and ``cosim calibrate --design``.
"""
from __future__ import annotations

import time
import warnings

import numpy as np

from .data import SEED000_POSES, candidate_poses, joint_campaign, real_params
from .design import observability, pose_rows, select_poses, sixpus_seed_comparison
from .joint_problem import JointProblem
from .problems import CalibrationWarning
from .solvers import solve
from ..core.model import Model

__all__ = ["benchmark", "design_study"]


def _campaign(npose, seed):
    nom = Model("6pus")
    real = real_params(nom, rng=seed)
    poses = candidate_poses(nom, npose, rng=seed + 1)
    return nom, real, joint_campaign(nom, real, poses, rng=seed + 2)


def benchmark(npose: int = 1000, seed: int = 1, repeat: int = 3, baseline: bool = True) -> str:
    """Time to converge of the 6-PUS calibration on ``npose`` poses, single process.

    Rows: the solvers of :func:`cosim.calibration.solvers.solve` with the core's analytic
    regression rows, and the baseline ``scipy.optimize.least_squares`` (MINPACK
    Levenberg-Marquardt) with a finite-difference Jacobian, on the same problem.  Times
    are the best of ``repeat`` runs of the solve alone (the problem, i.e. the recording's
    poses and joints on the nominal model, is built once: "setup").
    """
    from scipy.optimize import least_squares

    nom, real, rec = _campaign(npose, seed)
    t = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        P = JointProblem(rec.pose, rec.q, nom)
    setup = time.perf_counter() - t
    truth = np.array([real[n] for n in P.names])

    def best(f):
        ts, out = [], None
        for _ in range(repeat):
            t0 = time.perf_counter()
            out = f()
            ts.append(time.perf_counter() - t0)
        return min(ts), out

    rows = []
    ref = None
    for method in ("gauss-newton", "pinv-iter", "pinv", "lm"):
        dt, s = best(lambda: solve(P, method))
        if method == "gauss-newton":
            ref = s
        rows.append((f"{method} (analytic rows)", dt, s.iterations, s.nfev, s.rms_after, s))
    if baseline:
        def fd():
            # the same weighted least-squares problem, derivatives by finite differences
            return least_squares(lambda x: -P.wresidual(x), P.p0, jac="2-point", method="lm", x_scale=P.prior,
                                 xtol=1e-12, ftol=1e-12, gtol=1e-12)

        dt, res = best(fd)
        rms = float(np.sqrt(np.mean(P.residual(res.x) ** 2)))
        rows.append(("baseline: scipy lm, finite-difference J", dt, res.nfev, res.nfev, rms, res.x))
    L = [f"6-PUS calibration benchmark: {P.nmeas // 6} poses, 60-parameter error model = {len(P.names)} calibrated "
         f"coordinates (|s| = 1), {P.nmeas} equations; target (docs/performance.md) < 0.5 s",
         f"  setup (problem from the recording's poses and joints): {setup * 1e3:.1f} ms",
         f"  {'method':<42} {'time [ms]':>10} {'iter':>5} {'f-evals':>8} {'RMS [um]':>9} {'max |p - p_GN|/SE':>18} "
         f"{'max |p - p_true|/SE':>20}"]
    for name, dt, it, nf, rms, s in rows:
        p = s.p if hasattr(s, "p") else s
        dgn = np.max(np.abs(p - ref.p) / ref.se)
        dtr = np.max(np.abs(p - truth) / ref.se)
        L.append(f"  {name:<42} {dt * 1e3:10.1f} {it:5d} {nf:8d} {rms * 1e6:9.3f} {dgn:18.2e} {dtr:20.2f}")
    # end to end: read the recording, identifiability, solve, verify on 20 % held out
    import tempfile
    from pathlib import Path

    from .fit import calibrate
    from ..recording import write_recording

    with tempfile.TemporaryDirectory() as d:
        path, _ = write_recording(Path(d) / "bench.csv", rec)
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationWarning)
            res = calibrate(path, holdout=0.2)
        e2e = time.perf_counter() - t0
    gn = rows[0][1]
    L.append(f"  end to end (read the CSV, identifiability, structural Gauss-Newton, verification on "
             f"{res.holdout_accuracy.n} held-out poses): {e2e * 1e3:.0f} ms, held-out position RMS "
             f"{res.holdout_accuracy.position[0] * 1e6:.0f} -> {res.holdout_accuracy.position[1] * 1e6:.1f} um")
    L.append(f"  Gauss-Newton converges in {gn * 1e3:.0f} ms: {'within' if gn < 0.5 else 'OVER'} the 0.5 s target"
             + (f"; {rows[-1][1] / gn:.1f}x faster than the finite-difference baseline" if baseline else ""))
    return "\n".join(L)


def design_study(n: int = 10, ncand: int = 1000, nval: int = 200, trials: int = 5, seed: int = 5) -> str:
    """Pose selection vs hand-picked and random poses (6-PUS, Tiberi 2020's ten poses).

    Scores (O1, log det, cond: see :mod:`cosim.calibration.design`) of: the seed's ten
    poses (leg 1 only, where the core can compute its rows; the whole robot cannot reach
    them all), ``n`` random reachable poses, and ``n`` D-optimal poses chosen among
    ``ncand`` candidates; then the accuracy after calibrating ``trials`` random "real"
    robots from each set, on ``nval`` common validation poses.
    """
    from .fit import accuracy, calibrate

    nom = Model("6pus")
    cand = candidate_poses(nom, ncand, rng=seed)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", CalibrationWarning)
        P = JointProblem(cand, nom.ik(cand), nom)
    A, _ = pose_rows(P)
    idx, _ = select_poses(A, n)
    rng = np.random.default_rng(seed)
    rnd = rng.choice(len(cand), n, replace=False)
    L = [f"Pose selection, 6-PUS, {n} poses (scores on the column-scaled regression rows; larger O1 and smaller "
         f"cond are better)"]
    cmp = sixpus_seed_comparison(n, ncand, seed)
    L.append(f"  leg 1 in Tiberi 2020's own problem (world frame; identifiable X, Y, Z, L, sx, sy, sz): seed's ten poses "
             f"(Table 4.22): O1 {cmp['seed']['O1']:.3g}, cond {cmp['seed']['cond']:.3g};  {n} D-optimal poses: "
             f"O1 {cmp['dopt']['O1']:.3g}, cond {cmp['dopt']['cond']:.3g}")
    q_all, st_all = nom.ik(SEED000_POSES, errors="status")
    L.append(f"  whole robot: {int(np.sum(st_all == 0))} of Tiberi 2020's 10 poses are inside this robot's strokes and "
             f"reach: {int(np.sum(st_all == 0))} equations per leg for 9 parameters, not enough to calibrate")
    h = [np.linalg.norm(A[:, b].reshape(-1, A.shape[-1]), axis=0) ** -1 for b in range(A.shape[1])]
    scores = {}
    for name, ii in (("random", rnd), ("D-optimal", idx)):
        o = observability(A, ii, scale=h)
        scores[name] = o
        L.append(f"  {name:<10} {n} poses: O1 (worst leg) {o['O1']:.3g}, log det {o['logdet']:.1f}, cond (worst leg) "
                 f"{o['cond']:.3g}")
    res = {"random": [], "D-optimal": []}
    for t in range(trials):
        real = real_params(nom, rng=1000 + t)
        val = joint_campaign(nom, real, candidate_poses(nom, nval, rng=2000 + t), rng=3000 + t)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", CalibrationWarning)
            Pv = JointProblem(val.pose, val.q, nom)
            for name, ii in (("random", rng.choice(len(cand), n, replace=False)), ("D-optimal", idx)):
                rec = joint_campaign(nom, real, cand[ii], rng=4000 + t)
                r = calibrate(rec, model="prediction")
                a = accuracy(Pv, r.solution.p)
                res[name].append((a.position[0], a.position[1]))
    for name, v in res.items():
        v = np.array(v)
        L.append(f"  calibrated from {n} {name} poses ({trials} real robots, prediction model): validation position "
                 f"RMS {np.sqrt(np.mean(v[:, 0] ** 2)) * 1e6:.0f} um -> {np.sqrt(np.mean(v[:, 1] ** 2)) * 1e6:.1f} um "
                 f"(median over robots {np.median(v[:, 1]) * 1e6:.1f} um)")
    return "\n".join(L)
