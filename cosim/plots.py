"""Figures of scenario runs (matplotlib, Agg backend: files only, no display needed)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def scenario_figure(out, path) -> Path:
    """Write the figure of a scenario run (layout by reference type) to ``path``."""
    kind = out.scenario.spec["reference"]["type"]
    # Any other reference (an excitation) is shown as motion: every pose coordinate.
    fn = {"step": step_figure, "letter_m": tracking_figure, "poses": pose_set_figure}.get(kind, motion_figure)
    return fn(out, path)


def motion_figure(out, path) -> Path:
    """Every pose coordinate vs its reference, joint tracking errors, efforts."""
    return step_figure(out, path, coords="all")


def step_figure(out, path, coords: str = "moved") -> Path:
    """Moved pose coordinates (``coords="all"``: every one) vs reference, joint errors vs
    predicted e_ss, efforts."""
    plt = _plt()
    res, m = out.result, out.metrics
    t = res["time"]
    fig, ax = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    from .core.model import robot_facts

    facts = robot_facts(res.robot)
    names, units = list(facts.pose_names), list(facts.pose_units)
    moved = list(m.get("step_info", {}).get("pose", {}).keys()) or [names[min(2, len(names) - 1)]]
    if coords == "all":
        moved = names
    shown = []
    for nm in moved:
        i = names.index(nm) if nm in names else 0
        scale, unit = (1e3, "mm") if units[i] == "m" else (np.degrees(1.0), "deg")
        shown.append(unit)
        ax[0].plot(t, res["x"][:, i] * scale, label=f"{nm} [{unit}]")
        ax[0].plot(t, res["xref"][:, i] * scale, "--", label=f"{nm} ref [{unit}]")
    ax[0].set_ylabel(f"pose [{', '.join(dict.fromkeys(shown))}]")
    ax[0].legend(loc="best", fontsize=8)
    info = m.get("step_info", {}).get("pose", {})
    txt = "; ".join(f"{k}: rise {v.get('RiseTime', np.nan) * 1e3:.0f} ms, settle {v.get('SettlingTime', np.nan) * 1e3:.0f} ms,"
                    f" overshoot {v.get('Overshoot', np.nan):.1f} %" for k, v in info.items() if "RiseTime" in v)
    ax[0].set_title(f"{out.scenario.name}: {res.controller['type']}\n{txt}", fontsize=9)
    jscale, junit = (1e3, "mm") if facts.joint_unit == "m" else (1e3, "mrad")
    e = (res["qref"] - res["q_true"]) * jscale
    for j in range(e.shape[1]):
        ax[1].plot(t, e[:, j], label=f"e{j + 1}")
    pred = m.get("steady_state", {}).get("predicted_joint_error_equilibrium") or \
        m.get("steady_state", {}).get("predicted_joint_error")
    if pred is not None:
        for j, p in enumerate(pred):
            ax[1].axhline(p * jscale, color=f"C{j}", ls=":", lw=0.8)
    ax[1].set_ylabel(f"joint error qref - q [{junit}]\n(dotted: predicted e_ss)")
    lim = np.max(np.abs(e[len(e) // 3:])) if len(e) > 3 else 1.0
    ax[1].set_ylim(-3 * lim - 1e-6, 3 * lim + 1e-6)
    ax[1].legend(ncol=6, fontsize=7)
    _effort_panel(ax[2], res)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def _effort_panel(ax, res) -> None:
    """The applied effort of every joint over time, on ``ax``."""
    for j in range(res["tau_applied"].shape[1]):
        ax.plot(res["time"], res["tau_applied"][:, j], label=f"tau{j + 1}")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"effort [{res.units['tau_applied']}]")
    ax.legend(ncol=6, fontsize=7)


def tracking_figure(out, path) -> Path:
    """The traced path (reference vs actual pen point), the pen error over time, efforts."""
    from .trajectories import pen_point

    plt = _plt()
    res, m = out.result, out.metrics
    tool = m["tracking"]["tool_offset"]
    pen, ref = pen_point(res.robot, res["x"], tool), pen_point(res.robot, res["xref"], tool)
    err = np.linalg.norm(pen - ref, axis=1)
    fig = plt.figure(figsize=(10, 8))
    a0 = fig.add_subplot(2, 2, 1)
    a0.plot(ref[:, 0] * 1e3, ref[:, 1] * 1e3, "k--", lw=1, label="reference")
    a0.plot(pen[:, 0] * 1e3, pen[:, 1] * 1e3, lw=1.5, alpha=0.8, label="pen point")
    a0.set_aspect("equal")
    a0.set_xlabel("x [mm]")
    a0.set_ylabel("y [mm]")
    a0.legend(fontsize=8)
    a0.set_title(f"{out.scenario.name}: {res.controller['type']}", fontsize=9)
    a1 = fig.add_subplot(2, 2, 2)
    a1.semilogy(res["time"], np.maximum(err, 1e-12) * 1e6)
    a1.set_xlabel("time [s]")
    a1.set_ylabel("pen error [um]")
    a1.set_title(f"RMS {m['tracking']['pen_error_rms'] * 1e6:.3g} um, max {m['tracking']['pen_error_max'] * 1e6:.3g} um",
                 fontsize=9)
    _effort_panel(fig.add_subplot(2, 1, 2), res)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)


def pose_set_figure(out, path) -> Path:
    """Pose coordinates over the campaign (held poses shaded) and the error at each hold."""
    plt = _plt()
    res, m = out.result, out.metrics
    t = res["time"]
    fig, ax = plt.subplots(2, 1, figsize=(9, 7))
    for i, nm in enumerate(["x", "y", "z"][: res["x"].shape[1]]):
        ax[0].plot(t, res["pose"][:, i] * 1e3, lw=0.8, label=f"{nm} (tracker)")
    for p in m["poses"]:
        ax[0].axvspan(p["t_start"], p["t_end"], color="0.9")
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("position [mm]")
    ax[0].legend(fontsize=8)
    ax[0].set_title(f"{out.scenario.name}: {len(m['poses'])} held poses", fontsize=9)
    labels = [p["label"] for p in m["poses"]]
    ax[1].bar(labels, [p["position_error"] * 1e6 for p in m["poses"]])
    ax[1].set_xlabel("held pose")
    ax[1].set_ylabel("position error at hold [um]")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return Path(path)
