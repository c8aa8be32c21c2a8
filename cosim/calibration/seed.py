"""The seeds' calibration examples, reproduced and explained.

* :func:`fourbar_seed_study` (Vitali 2020): the four-bar's pseudo-inverse
  identification at full precision and with the thesis' 4-decimal numbers, which
  explains why the thesis finds (0.2990, 0.5021, 0.5544, 0.6876) mm instead of the true
  (0.30, 0.50, 0.55, 0.70) mm: its output differences are differences of outputs rounded
  to 1e-4 mm, an error of up to 1e-4 mm that cond(A) ~ 1.3e3 amplifies.
* :func:`sixpus_seed_leg1` (Tiberi 2020 ch. 4.2): the leg-1 regression matrix of Table 4.22
  and its identifiability analysis.

The seed's numbers below are typed from the theses (the tests type their own copy).
"""
from __future__ import annotations

import numpy as np

from .ident import identifiability
from .joint_problem import JointProblem
from .solvers import solve

__all__ = ["SEED002", "SEED000_TABLE_4_22", "fourbar_seed_study", "sixpus_seed_leg1"]

#: Vitali 2020 ch. 1.1 and ch. 4, lengths in mm
SEED002 = {
    "theta_deg": np.arange(30.0, 61.0, 5.0),
    "lengths": np.array([600.0, 750.0, 790.0, 900.0]),
    "true_errors": np.array([0.30, 0.50, 0.55, 0.70]),
    "Xp": np.array([815.2891, 803.5676, 783.9942, 757.9735, 726.5904, 690.7086, 651.0450]),
    "Xpr": np.array([815.6833, 803.9667, 784.3931, 758.3677, 726.9759, 691.0819, 651.4034]),
    "dXp": np.array([0.3942, 0.3991, 0.3989, 0.3942, 0.3855, 0.3733, 0.3584]),
    "A": np.array([[1.2343, 0.8090, -0.5164, -0.1379], [1.1503, 0.7409, -0.4270, -0.1166],
                   [1.0599, 0.6870, -0.3574, -0.0943], [0.9670, 0.6445, -0.3031, -0.0735],
                   [0.8731, 0.6107, -0.2603, -0.0552], [0.7787, 0.5836, -0.2264, -0.0393],
                   [0.6839, 0.5616, -0.1992, -0.0257]]),
    "dl_thesis": np.array([0.2990, 0.5021, 0.5544, 0.6876]),
}

#: Tiberi 2020 Table 4.22: leg-1 regression rows at the ten poses of Tables 4.2-4.20 (world
#: frame), columns [X, Y, Z, Sx, Sy, Sz, L, sx, sy, sz]
SEED000_TABLE_4_22 = np.array([
    [1, 0.1019, 1.0824, -1, -0.1019, -1.0824, -1.4771, -0.0550, -0.0056, -0.0595],
    [1, 0.1121, 1.0738, -1, -0.1121, -1.0738, -1.4716, -0.0542, -0.0061, -0.0582],
    [1, 1.0480, 1.6470, -1, -1.0480, -1.6470, -2.1934, -0.1319, -0.1383, -0.2173],
    [1, 0.1086, 0.8269, -1, -0.1086, -0.8269, -1.3021, -0.0634, -0.0069, -0.0524],
    [1, 0.2630, 0.3440, -1, -0.2630, -0.3440, -1.0897, -0.0419, -0.0110, -0.0144],
    [1, 0.9434, 0.2043, -1, -0.9434, -0.2043, -1.3899, -0.0446, -0.0421, -0.0091],
    [1, 0.1389, 0.6173, -1, -0.1389, -0.6173, -1.1834, -0.0026, -0.0004, -0.0016],
    [1, 0.2260, 1.6368, -1, -0.2260, -1.6368, -1.9314, -0.0518, -0.0117, -0.0848],
    [1, 0.0489, 1.5925, -1, -0.0489, -1.5925, -1.8811, -0.0312, -0.0015, -0.0498],
    [1, -0.3401, 0.6347, -1, 0.3401, -0.6347, -1.2323, -0.0893, -0.0304, -0.0567],
])
SEED000_LEG_NAMES = ["X", "Y", "Z", "S0x", "S0y", "S0z", "L", "sx", "sy", "sz"]


def _pinv_solve(A, b):
    return np.linalg.pinv(A) @ b


def fourbar_seed_study() -> dict:
    """Vitali 2020's four-bar identification, exact and with the thesis' rounding.

    Returns a dict (lengths in mm) with:

    ``A``, ``dX``: the core's Jacobian and output differences (true - nominal) at full
    precision; ``cond_A``: cond(A) (2-norm); ``cond_A_scaled``: after column scaling;
    ``dl_one_step``: one pseudo-inverse step at full precision (linearisation error
    only); ``dl_iterated``: Gauss-Newton to convergence (the true errors);
    ``dl_rounded_dX``: exact A with the thesis' rounded dX; ``dl_rounded_A``: the thesis'
    A with exact dX; ``dl_thesis_inputs``: the thesis' A and dX (its answer);
    ``bound``: the first-order bound cond(A) ||d(dX)|| / ||dX|| on the relative error from
    a rounding of dX by 1e-4 mm; ``text``: the explanation as a table.
    """
    from ..core.model import Model
    from ..fourbar import output

    s = SEED002
    th = np.radians(s["theta_deg"])
    nom = Model("fourbar")
    real = Model("fourbar", params={n: (l + e) * 1e-3 for n, l, e in
                                    zip(["link[1].l", "link[2].l", "link[3].l", "link[4].l"], s["lengths"],
                                        s["true_errors"])})
    Xn, A = output(nom, th)
    Xr = output(real, th, jacobian=False)
    dX = (Xr - Xn) * 1e3
    prob = JointProblem(Xr, th, nom)
    gn = solve(prob, "gauss-newton")
    out = {
        "A": A, "dX": dX,
        "cond_A": float(np.linalg.cond(A)),
        "cond_A_scaled": float(np.linalg.cond(A / np.linalg.norm(A, axis=0))),
        "dl_one_step": _pinv_solve(A, dX),
        "dl_iterated": gn.dp * 1e3,
        "dl_rounded_dX": _pinv_solve(A, s["dXp"]),
        "dl_rounded_A": _pinv_solve(s["A"], dX),
        "dl_thesis_inputs": _pinv_solve(s["A"], s["dXp"]),
        "dX_rounding": s["dXp"] - dX,
        "A_rounding": s["A"] - A,
    }
    out["bound"] = out["cond_A"] * np.linalg.norm(out["dX_rounding"]) / np.linalg.norm(dX)
    tru = s["true_errors"]

    def row(label, v):
        return f"  {label:<44} " + " ".join(f"{x:8.4f}" for x in v) + f"   max error {np.abs(v - tru).max():.1e} mm"

    out["text"] = "\n".join([
        "Four-bar, Vitali 2020: identified length errors dl1..dl4 [mm] (true 0.30 0.50 0.55 0.70)",
        f"  cond(A) = {out['cond_A']:.4g} (columns scaled: {out['cond_A_scaled']:.4g})",
        row("one pinv step, full precision", out["dl_one_step"]),
        row("Gauss-Newton (pinv iterated), full precision", out["dl_iterated"]),
        row("exact A, thesis dX (rounded to 1e-4 mm)", out["dl_rounded_dX"]),
        row("thesis A (4 decimals), exact dX", out["dl_rounded_A"]),
        row("thesis A and dX: the thesis' answer", out["dl_thesis_inputs"]),
        f"  the thesis' dX differ from the exact ones by up to {np.abs(out['dX_rounding']).max():.1e} mm "
        f"(differences of outputs rounded to 1e-4 mm);",
        f"  cond(A) turns that relative error {np.linalg.norm(out['dX_rounding']) / np.linalg.norm(dX):.1e} into a "
        f"relative error of up to {out['bound']:.2g} on dl (observed "
        f"{np.linalg.norm(out['dl_thesis_inputs'] - tru) / np.linalg.norm(tru):.2g}).",
    ])
    return out


def sixpus_seed_leg1(cond_max: float = 100.0):
    """Identifiability of Tiberi 2020's leg-1 Table 4.22 (its QR check, and more)."""
    return identifiability(SEED000_TABLE_4_22, SEED000_LEG_NAMES,
                           ["m", "m", "m", "m", "m", "m", "m", "1", "1", "1"], cond_max=cond_max)
