"""Figures of a calibration run (matplotlib, written as PNG files)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_result"]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_result(res, outdir) -> list:
    """Accuracy, singular values and estimates of a :class:`cosim.calibration.CalibrationResult`."""
    plt = _plt()
    out = Path(outdir)
    paths = []
    unit_scale = 1e6

    # 1. accuracy per pose, nominal vs calibrated
    acc = res.holdout_accuracy or res.calibration_accuracy
    which = "held-out" if res.holdout_accuracy else "calibration"
    fig, ax = plt.subplots(figsize=(8, 4))
    k = np.arange(acc.n)
    ax.semilogy(k, acc.per_pose[:, 0] * unit_scale, "o", ms=4, label=f"nominal (RMS {acc.position[0] * 1e6:.3g} um)")
    ax.semilogy(k, acc.per_pose[:, 1] * unit_scale, "s", ms=4,
                label=f"calibrated (RMS {acc.position[1] * 1e6:.3g} um)")
    what = "position error |p_FK(q) - p_measured|" if res.robot == "6pus" else "output error |X - X_model|"
    ax.set_xlabel(f"{which} pose")
    ax.set_ylabel(f"{what} [um]")
    ax.set_title(f"{res.robot} calibration ({res.solution.method}): accuracy gain {acc.gain:.3g}x on {which} poses")
    ax.legend()
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    p = out / "calibration_accuracy.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)

    # 2. singular values of the scaled regression matrix, per block
    fig, ax = plt.subplots(figsize=(8, 4))
    for b in res.identifiability.blocks:
        s = np.maximum(b.singular_values / b.singular_values[0], 1e-18)
        ax.semilogy(np.arange(1, s.size + 1), s, "o-", ms=4, label=b.label)
    ax.axhline(1.0 / res.identifiability.cond_max, color="k", ls="--",
               label=f"1/cond_max = 1/{res.identifiability.cond_max:g}")
    ax.set_xlabel("singular value index")
    ax.set_ylabel("mu_j / mu_1 (column-scaled J)")
    ax.set_title("identifiability: singular values at the nominal parameters")
    ax.legend(fontsize=8, ncol=2)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    p = out / "calibration_singular_values.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)

    # 3. estimated parameter errors with 3 standard errors
    s = res.solution
    idx = np.flatnonzero(s.free)
    fig, ax = plt.subplots(figsize=(max(6, 0.18 * idx.size + 3), 4))
    ax.errorbar(np.arange(idx.size), s.dp[idx] * 1e3, yerr=3 * s.se[idx] * 1e3, fmt="o", ms=3, capsize=2)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xticks(np.arange(idx.size))
    ax.set_xticklabels([s.names[j] for j in idx], rotation=90, fontsize=7)
    ax.set_ylabel("estimate - nominal [mm or 1e-3]")
    ax.set_title("estimated parameter errors, +-3 standard errors")
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    p = out / "calibration_estimates.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)
    return paths
