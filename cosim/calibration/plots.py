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
    from .joint_problem import JointProblem

    joints = isinstance(res.problem, JointProblem) and res.problem.measure == "joints"
    if joints and "m" in res.problem.nominal.facts.pose_units:
        what = "position error |p_FK(q) - p_measured|"
    elif joints:
        what = "joint error |q - q_IK(pose)|"
    else:
        what = "output error |X - X_model|"
    unit = "urad" if what.startswith("joint") and res.problem.measurement_unit == "rad" else "um"
    fig, ax = plt.subplots(figsize=(8, 4))
    k = np.arange(acc.n)
    ax.semilogy(k, acc.per_pose[:, 0] * unit_scale, "o", ms=4, label=f"nominal (RMS {acc.position[0] * 1e6:.3g} {unit})")
    ax.semilogy(k, acc.per_pose[:, 1] * unit_scale, "s", ms=4,
                label=f"calibrated (RMS {acc.position[1] * 1e6:.3g} {unit})")
    ax.set_xlabel(f"{which} pose")
    ax.set_ylabel(f"{what} [{unit}]")
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

    # 3. estimated parameter errors with 3 standard errors, one panel per unit, the truth
    # overlaid when the recording has an answer key beside it (<name>.truth.json)
    s = res.solution
    idx = np.flatnonzero(s.free)
    units = list(getattr(res.problem, "units", [""] * len(s.names)))
    truth = _truth(res)
    nominal = dict(zip(s.names, map(float, s.p0)))
    kinds = [("m", 1e3, "mm"), ("1", 1e3, "1e-3 (direction components)")]
    panels = [(u, sc, lab, [j for j in idx if units[j] == u]) for u, sc, lab in kinds]
    panels = [pn for pn in panels if pn[3]] or [("", 1.0, "", list(idx))]
    width = max(6, 0.18 * idx.size + 3)
    fig, axes = plt.subplots(len(panels), 1, figsize=(width, 3.2 * len(panels) + 0.8), squeeze=False)
    for ax, (u, scale, label, js) in zip(axes[:, 0], panels):
        xs = np.arange(len(js))
        ax.errorbar(xs, s.dp[js] * scale, yerr=3 * s.se[js] * scale, fmt="o", ms=3, capsize=2,
                    label="estimate +- 3 SE")
        if truth:
            tv = [(truth[s.names[j]] - nominal[s.names[j]]) * scale if s.names[j] in truth else np.nan for j in js]
            ax.plot(xs, tv, "x", color="C3", ms=6, label="truth (answer key)")
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xticks(xs)
        ax.set_xticklabels([s.names[j] for j in js], rotation=90, fontsize=7)
        ax.set_ylabel(f"estimate - nominal [{label}]" if label else "estimate - nominal")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    axes[0, 0].set_title("estimated parameter errors, +-3 standard errors" + (
        "\n(truth: single coordinates may differ where only their combinations are identifiable; "
        "see calibration_report.txt)" if truth else ""), fontsize=10)
    fig.tight_layout()
    p = out / "calibration_estimates.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    paths.append(p)
    return paths


def _truth(res) -> dict:
    """The real parameters of a recording made with an answer key beside it, else {}."""
    import json

    src = Path(str(res.source))
    key = src.with_suffix(".truth.json")
    if not key.exists():
        return {}
    try:
        return {k: float(v) for k, v in json.loads(key.read_text()).get("real_parameters", {}).items()}
    except (ValueError, OSError, AttributeError):
        return {}
