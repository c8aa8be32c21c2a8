"""Choice of measurement poses: which poses condition the calibration best.

The regression matrix of a set of poses decides how well the parameters can be
identified; this module scores a set and chooses one from candidates.

Scores (:func:`observability`), per independent block (6-PUS leg) on the column-scaled
matrix (Tiberi 2020 eq. 3.13), worst block reported:

* ``O1 = (mu_1 mu_2 ... mu_n)^(1/n) / sqrt(m)``: the observability index of Borm and Menq
  (the geometric mean of the singular values, per measurement): larger is better;
* ``logdet = sum log mu_j^2``: the D-optimality criterion, log det(J^T J);
* ``cond = mu_1 / mu_n``: smaller is better.

Selection (:func:`select_poses`): D-optimal design, greedy then exchange (Fedorov):
start from an empty set (with a tiny ridge so the first poses can be compared), add the
candidate that increases det(J^T J) most until n poses are chosen, then swap a chosen
pose for a candidate whenever that increases the determinant, until no swap does.  A
6-PUS pose contributes one row per leg, so the update of each leg's information matrix
is rank one: ``det(M + a a^T) = det(M) (1 + a^T M^-1 a)``, evaluated for all candidates at
once.
"""
from __future__ import annotations

import numpy as np

from .ident import column_scale
from ..errors import InputError

__all__ = ["observability", "select_poses", "pose_rows", "common_scale", "sixpus_seed_comparison"]


def pose_rows(problem, p=None) -> tuple[np.ndarray, list]:
    """Per-pose regression rows of a problem, arranged for the design.

    Returns ``A`` of shape (npose, nblock, nrow_per_block, ncol_per_block) and the block
    labels; for the 6-PUS one row per leg and pose, for the four-bar one block of one row.
    """
    J = problem.wjacobian(problem.p0 if p is None else p)  # rows weighted as the solver weighs them
    if problem.blocks is None:
        return J[:, None, None, :], ["all"]
    nb = len(problem.blocks)
    npose = J.shape[0] // nb
    ncol = len(problem.blocks[0][2])
    A = np.empty((npose, nb, 1, ncol))
    for b, (_, rows, cols) in enumerate(problem.blocks):
        A[:, b, 0, :] = J[np.ix_(rows, cols)]
    return A, [b[0] for b in problem.blocks]


def common_scale(A) -> list:
    """Column scales of every candidate's rows, per block: the scale :func:`select_poses`
    uses, and the one to pass to :func:`observability` to compare sets."""
    A = np.asarray(A, float)
    return [column_scale(A[:, b].reshape(-1, A.shape[-1])) for b in range(A.shape[1])]


def observability(A, idx=None, scale=None) -> dict:
    """Scores of the poses ``idx`` (default all) of per-pose rows ``A`` (see :func:`pose_rows`).

    Returns ``{"O1", "logdet", "cond"}`` (worst block for O1 and cond, sum for logdet) and
    the per-block values under ``"blocks"``.  O1 and logdet use the column scales
    ``scale[b]`` if given (a common scale makes sets comparable), cond always the set's
    own column scaling (Tiberi 2020 eq. 3.13, as in the identifiability report).
    """
    A = np.asarray(A)
    sel = A if idx is None else A[np.asarray(idx)]
    out = {"blocks": []}
    for b in range(A.shape[1]):
        Jb = sel[:, b].reshape(-1, A.shape[-1])
        h = column_scale(Jb) if scale is None else scale[b]
        s = np.linalg.svd(Jb * h, compute_uv=False)
        so = np.linalg.svd(Jb * column_scale(Jb), compute_uv=False)
        n = A.shape[-1]
        if s.size < n or s[-1] <= 0:
            o1, ld, c = 0.0, -np.inf, np.inf
        else:
            o1 = float(np.exp(np.mean(np.log(s))) / np.sqrt(Jb.shape[0]))
            ld = float(2 * np.sum(np.log(s)))
            c = float(so[0] / so[-1])
        out["blocks"].append({"O1": o1, "logdet": ld, "cond": c})
    out["O1"] = min(b["O1"] for b in out["blocks"])
    out["logdet"] = float(sum(b["logdet"] for b in out["blocks"]))
    out["cond"] = max(b["cond"] for b in out["blocks"])
    return out


def select_poses(A, n: int, start=None, exchange: bool = True, max_passes: int = 20, ridge: float = 1e-9):
    """D-optimal choice of n poses among the candidates' rows ``A`` (see :func:`pose_rows`).

    Parameters
    ----------
    A : ndarray, shape (ncand, nblock, nrow, ncol)
    n : int
        Poses to choose.
    start : array_like of int, optional
        Initial set for the exchange (default: greedy from scratch).
    exchange : bool
        Improve the greedy set by exchanges.
    ridge : float
        Relative ridge that lets the first (fewer than ncol) poses be ranked.

    Returns
    -------
    idx : ndarray of int
        Chosen candidate indices.
    history : list of float
        log det after each greedy addition and each accepted exchange.
    """
    A = np.asarray(A, float)
    nc, nb, nr, ncol = A.shape
    if n > nc:
        raise InputError(f"cannot choose {n} poses among {nc} candidates")
    h = np.array(common_scale(A))
    As = A * h[None, :, None, :]
    eps = ridge * np.mean(np.einsum("kbrc,kbrc->b", As, As)) / ncol

    def info(sel):
        M = np.tile(eps * np.eye(ncol), (nb, 1, 1))
        for k in sel:
            M += np.einsum("brc,brd->bcd", As[k], As[k])
        return M

    def logdet(M):
        return float(sum(np.linalg.slogdet(M[b])[1] for b in range(nb)))

    def gains(M):
        # log det(M + A_k^T A_k) - log det(M) for every candidate k, per block
        Minv = np.linalg.inv(M)
        B = np.einsum("kbrc,bcd,kbsd->kbrs", As, Minv, As)
        I = np.eye(nr)
        return np.sum(np.linalg.slogdet(I + B)[1], axis=1)

    chosen = [] if start is None else list(np.asarray(start, int))
    M = info(chosen)
    history = []
    while len(chosen) < n:
        g = gains(M)
        g[chosen] = -np.inf
        k = int(np.argmax(g))
        chosen.append(k)
        M += np.einsum("brc,brd->bcd", As[k], As[k])
        history.append(logdet(M))
    if exchange:
        for _ in range(max_passes):
            swapped = False
            for pos in range(len(chosen)):
                j = chosen[pos]
                Mr = M - np.einsum("brc,brd->bcd", As[j], As[j])
                g = gains(Mr)
                g[chosen] = -np.inf
                k = int(np.argmax(g))
                cur = logdet(M)
                if logdet(Mr) + g[k] > cur + 1e-9 * abs(cur) + 1e-12:
                    chosen[pos] = k
                    M = Mr + np.einsum("brc,brd->bcd", As[k], As[k])
                    history.append(logdet(M))
                    swapped = True
            if not swapped:
                break
    return np.array(chosen), history


def sixpus_seed_comparison(n: int = 10, ncand: int = 1000, seed: int = 5) -> dict:
    """Tiberi 2020's ten hand-picked poses against n D-optimal poses, on the seed's own problem.

    Tiberi 2020 calibrates leg 1 with the platform point in the world frame; there the rail
    origin is not identifiable and the identifiable columns are X, Y, Z, L, sx, sy, sz.
    Its ten poses give Table 4.22 (typed in :mod:`cosim.calibration.seed`; the seed's leg 1
    is this robot's leg 1).  Here the same seven columns come from the core's rows
    (``PKM_FRAME_WORLD``) at ``ncand`` candidate poses, n of them are chosen D-optimally,
    and both sets are scored with a common column scale (the candidates' RMS column
    norms) for O1 and their own scaling for cond.

    Returns ``{"seed": scores, "dopt": scores, "idx": chosen candidate indices,
    "poses": their poses}``.
    """
    import warnings as _w

    from .data import candidate_poses
    from .joint_problem import JointProblem
    from .problems import PKM_FRAME_WORLD, CalibrationWarning, calib_rows
    from .seed import SEED000_TABLE_4_22
    from ..core.model import Model

    cols = [0, 1, 2, 6, 7, 8, 9]  # X, Y, Z, L, sx, sy, sz
    nom = Model("6pus")
    cand = candidate_poses(nom, ncand, rng=seed)
    with _w.catch_warnings():
        _w.simplefilter("ignore", CalibrationWarning)
        work = JointProblem(cand, nom.ik(cand), nom).working_model()
    rows = calib_rows(work, cand, PKM_FRAME_WORLD)[:, 0, cols]  # leg 1
    A = rows[:, None, None, :]
    idx, _ = select_poses(A, n)
    h = [1.0 / np.sqrt(np.mean(rows ** 2, axis=0))]
    As = SEED000_TABLE_4_22[:, cols][:, None, None, :]
    return {"seed": observability(As, scale=h), "dopt": observability(A, idx, scale=h), "idx": idx,
            "poses": cand[idx]}
