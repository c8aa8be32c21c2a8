"""The flexible stage's part of the report (:mod:`.flexible`): each channel's statement, the
conclusion's clause, the partial-dependence figure and the Markdown section of the fits a report
states."""
from __future__ import annotations

import numpy as np

from . import periodic

#: the statement warns of extrapolation when the named inputs leave the fitted range in their
#: held-out block at more than this share of the samples
OUTSIDE_WARN = 0.1


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
        ins = _inputs_cell(f)
        L.append(f"| {f.channel} | {100 * f.share:.0f} %{'' if f.explained else ' (not claimed)'} | {f.z:.0f} | "
                 f"{f.rms_left:.3g} {f.unit} | {f.noise:.3g} {f.unit} | {ins} |")
    L += [""] + [f"- {f.statement}" for f in fits] + [""]
    if files.get("flexible"):
        L += ["![Partial dependence of the flexible model](flexible.png)", ""]
    return L


def _inputs_cell(fit) -> str:
    """The table's inputs of a fit: each named group once (:attr:`~.stage.FlexibleFit.named`) with
    the importance of each of its curves; a folded fit's own rate the direction's, then the level's."""
    imp = {}
    for d in fit.inputs:
        said = "direction " if d.feature == "direction of motion" else ("level " if d.group in imp else "")
        imp.setdefault(d.group, []).append(f"{said}{100 * d.importance:.0f} %")
    return ", ".join(f"{g} ({', '.join(imp[g])})" for g in fit.named) or "-"


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


def family_says(fit, discovered, effects) -> str:
    """A found discovered term or library effect of the channel's joint keyed on an input the
    flexible model depends on, in words; "" if none."""
    key_of = {"position": "position", "velocity": "rate", "acceleration": "acceleration"}
    own = {d.quantity for d in fit.inputs if d.joint == fit.joint}
    for t in discovered:
        if t.joint == fit.joint and key_of.get(t.key_variable) in own:
            return f"the discovered term ({t.equation}) is keyed on the same input and leaves this part"
    for e in effects:
        if e["joint"] == fit.joint:
            return f"{e['name']} on this joint was fitted and leaves this part"
    return ""


def _at_value(feature, x, unit) -> str:
    """Where a partial dependence peaks, in words: for a direction (a sign, smoothed as the efforts
    are), the direction of motion; the smoothed sign overshoots +-1 after a reversal, which the
    value beside says."""
    if not feature.startswith("sign("):
        return f"{feature} = {x:.3g} {unit}".rstrip()
    said = f"motion in the {'negative' if x < 0 else 'positive'} direction"
    return said + (f" ({feature} = {x:.3g}: the smoothed sign overshoots +-1 after a reversal)" if abs(x) > 1 else "")


def statement(fit, noun: str) -> str:
    """The report's sentence for one channel, with the inputs a rule reading the channels side by
    side left out of its fit and why (:mod:`.across`: ``left_out``)."""
    said = _statement(fit, noun)
    return f"{said}; {fit.left_out}" if fit.left_out else said


def _statement(fit, noun: str) -> str:
    if not fit.explained and not fit.beyond_noise:
        return (f"{fit.channel}: whether what is left is explainable cannot be judged: it holds nothing beyond "
                f"its own noise (RMS {fit.rms_left:.3g} {fit.unit} against a noise of {fit.noise:.3g} {fit.unit})")
    if not fit.explained:
        return (f"{fit.channel}: the structure left is not explainable from the recorded inputs "
                f"(share out of fold {100 * fit.share:.0f} %, chi-square {fit.z:.0f}, not significant)")
    if not fit.inputs:
        s = (f"{fit.channel}: {100 * fit.share:.0f} % of what is left is explainable, on no single input "
             f"(out of fold)")
        if fit.screened:
            s += (f"; the inputs that stood out ({', '.join(fit.screened[0])}) alone: share out of fold "
                  f"{100 * fit.screened[1]:.0f} %, not significant")
        return s
    parts, head = [], f"a force on {noun} {fit.joint} that depends on "
    ins = fit.inputs
    if fit.folded:  # sigma g: the direction, then what its level depends on
        head = (f"a force on {noun} {fit.joint} that switches with its direction of motion (importance "
                f"{100 * ins[0].importance:.0f} %), its level depending on ")
        ins = ins[1:]
    for d in ins:
        size = max(abs(min(d.curve)), abs(max(d.curve)))
        k = int(np.argmax(np.abs(np.asarray(d.curve))))
        at = _at_value(d.feature, d.grid[k], d.unit)
        if d.feature.startswith(periodic.LINE):  # the force's phase: its curve is the line's amplitude
            hz = d.feature[len(periodic.LINE):].split(" Hz")[0].strip()
            parts.append(f"the time (a line at {hz} Hz; up to {size:.3g} {fit.unit}; "
                         f"importance {100 * d.importance:.0f} %)")
            continue
        if d.feature.startswith(periodic.COMB):  # a pulse train's phase: its curve is the comb's amplitude
            hz = d.feature[len(periodic.COMB):].split(" Hz")[0].strip()
            parts.append(f"the time (a force repeating at {hz} Hz, its harmonics beside; up to {size:.3g} "
                         f"{fit.unit}; importance {100 * d.importance:.0f} %)")
            continue
        parts.append(f"the {d.group.replace(f'{noun} {fit.joint}', f'{noun}')} ({d.feature}"
                     f"{', ' + d.where if d.where else ''}; up to {size:.3g} {fit.unit} at {at}; "
                     f"importance {100 * d.importance:.0f} %)")
    only = " and on nothing else" if len(parts) == 1 else ""
    beside = f", with the fitted {', '.join(fit.readjusted)} re-adjusted beside it" if fit.readjusted else ""
    s = (head + (" and on ".join(parts) if parts else "nothing else recorded") + only
         + f": {100 * fit.share:.0f} % of what is left (out of fold, flexible model{beside})")
    if fit.outside > OUTSIDE_WARN:
        s += (f"; at {100 * fit.outside:.0f} % of the samples these inputs lay outside the range the trees were "
              f"fitted on without them (extrapolated flat: the share is a lower bound there)")
    return s + (f"; {fit.family}" if fit.family else "; no found family is keyed on these inputs")


def sentence(fits: list) -> str:
    """The conclusion's clause: the explained channels' statements."""
    told = [f.statement for f in fits if f.explained]
    return "where no equation was found: " + "; ".join(told) if told else ""
