"""The flexible stage's part of the report (:mod:`.flexible`): the partial-dependence figure
and the Markdown section of the fits a report states."""
from __future__ import annotations

import numpy as np


def figure(fits: list, path):
    """Partial-dependence figure of the explained channels (one panel per named input): the
    flexible model's force against the input, in their units.  Returns the path, or None when
    no channel is explained."""
    panels = [(f, d) for f in fits if f.explained for d in f.inputs]
    if not panels:
        return None
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(4.2 * len(panels), 3.4), squeeze=False)
    for ax, (f, d) in zip(axes[0], panels):
        ax.plot(d.grid, d.curve, color="#d62728")
        ax.set_xlabel(f"{d.feature} [{d.unit}]" if d.unit else d.feature)
        ax.set_ylabel(f"{f.channel}: partial dependence [{f.unit}]")
        ax.set_title(f"{d.group}\n{100 * d.importance:.0f} % importance, {100 * f.share:.0f} % explained", fontsize=9)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def reported(fits: list) -> list:
    """The fits a report states: every one but a weak channel's where no force was found (a
    weak channel with nothing found says nothing a clean channel would not)."""
    return [f for f in fits if f.explained or not f.weak]


def markdown(fits: list, files: dict) -> list:
    """The report's section (Markdown lines) on the :func:`reported` fits."""
    fits = reported(fits)
    if not fits:
        return []
    L = ["## Where no equation was found: a flexible model and its dependence", "",
         "Boosted trees (scikit-learn HistGradientBoostingRegressor) on each channel that keeps structure, on "
         "every joint's position, rate (and commanded rate), acceleration and model effort, their low-passed "
         "|rate|, effort and power, the pose and time; judged out of fold over blocks in time spread through "
         "the recording.  The inputs are those whose permutation costs the most out of fold; the curves are "
         "partial dependences.  A black box: it says what the force depends on, not its equation.", "",
         "| channel | explained (out of fold) | chi-square | RMS left | own noise | inputs (importance) |",
         "| --- | --- | --- | --- | --- | --- |"]
    for f in fits:
        ins = ", ".join(f"{d.group} ({100 * d.importance:.0f} %)" for d in f.inputs) or "-"
        L.append(f"| {f.channel} | {100 * f.share:.0f} %{'' if f.explained else ' (not claimed)'} | {f.z:.0f} | "
                 f"{f.rms_left:.3g} {f.unit} | {f.noise:.3g} {f.unit} | {ins} |")
    L += [""] + [f"- {f.statement}" for f in fits] + [""]
    if files.get("flexible"):
        L += ["![Partial dependence of the flexible model](flexible.png)", ""]
    return L


def _where(grid, curve, unit) -> str:
    """Where the partial dependence acts, in words: "above x" / "below x" when it is flat
    (within a tenth of its span) over at least a quarter of the range at one end only, "from
    x0 to x1" when at both (a step), else "over x0 to x1"."""
    span = float(np.max(curve) - np.min(curve))
    n = len(grid)
    if not span > 0 or n < 4:
        return ""
    tol = 0.1 * span
    near_lo = np.abs(np.asarray(curve) - curve[0]) <= tol
    near_hi = np.abs(np.asarray(curve) - curve[-1]) <= tol
    a = int(np.argmin(near_lo))            # first point off the low end's level
    b = n - 1 - int(np.argmin(near_hi[::-1]))  # last point off the high end's level
    lo, hi = a >= 0.25 * n, (n - 1 - b) >= 0.25 * n

    def x(i):
        return f"{grid[i]:.3g}"
    if lo and hi:
        return f"a change from {x(a - 1)} to {x(b + 1)} {unit}".rstrip()
    if lo:
        return f"above {x(a - 1)} {unit}".rstrip()
    if hi:
        return f"below {x(b + 1)} {unit}".rstrip()
    return f"over {x(0)} to {x(n - 1)} {unit}".rstrip()
