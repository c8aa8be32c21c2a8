"""The diagnosis as a Markdown report with figures (matplotlib, Agg backend).

``report.md`` answers the three questions in order: where (localisation), why
(attribution, look-alikes, what the recording cannot show), how much better (held-out
fit before/after, replay), then the method settings.  Figures:

* ``residuals.png``: every residual channel against time, nominal and fitted model,
  the noise band and the localised windows, the held-out part marked;
* ``velocity.png``: effort residual against the joint rate, coloured by motion phase
  (the signature of friction: a step for Coulomb, a slope for viscous, a bump at low
  speed for Stribeck);
* ``workspace.png``: the poses of the recording coloured by the residual;
* ``heldout.png``: held-out overlay of the recorded and modelled effort/readings;
* ``replay.png``: closed-loop replay of the held-out part (when it was run).
"""
from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

PHASE_COLOURS = ["#7f7f7f", "#d62728", "#ff7f0e", "#2ca02c", "#1f77b4"]


def write_report(d, eng, sel, out: Path, figures: bool = True) -> dict:
    """Write ``report.md``, ``diagnosis.json`` (the diagnosis with these files) and the figures
    into ``out``; returns the files {name: path}.  ``d`` is left as it is."""
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    if figures:
        import matplotlib

        matplotlib.use("Agg")
        files["residuals"] = _fig_residuals(d, eng, sel, out / "residuals.png")
        files["velocity"] = _fig_velocity(d, eng, out / "velocity.png")
        files["workspace"] = _fig_workspace(d, eng, out / "workspace.png")
        files["heldout"] = _fig_heldout(d, eng, sel, out / "heldout.png")
        if d.replay and d.replay.get("runs") and d.replay.get("kind") != "open loop":
            files["replay"] = _fig_replay(d, eng, out / "replay.png")
        for t in d.discovered:
            files[f"discovered{t.joint}"] = _fig_discovered(t, eng, out / f"discovered{t.joint}.png")
        if getattr(d, "drifts", None):
            from .drift import figure

            files["drifts"] = figure(d.drifts, out / "drifts.png")
        if getattr(d, "flexible", None):
            from .flexible import figure as flexible_figure

            if flexible_figure(d.flexible, out / "flexible.png"):
                files["flexible"] = str(out / "flexible.png")
    files["json"] = str(out / "diagnosis.json")
    md = out / "report.md"
    files["report"] = str(md)
    (out / "diagnosis.json").write_text(_strip_arrays(dataclasses.replace(d, files=files)))
    md.write_text(markdown(d, files))
    return files


def _strip_arrays(d) -> str:
    dd = d.to_dict()
    dd["discovered"] = [{k: v for k, v in vars(t).items() if k != "curve"} for t in d.discovered]
    if dd.get("replay") and dd["replay"].get("runs"):
        dd["replay"] = {**dd["replay"], "runs": {k: {kk: vv for kk, vv in v.items() if kk not in ("time", "q", "tau")}
                                                 for k, v in dd["replay"]["runs"].items()}}
    from ..jsonable import finite, jsonable

    return json.dumps(finite(dd), indent=2, allow_nan=False, default=jsonable)  # JSON has no NaN: null


def markdown(d, files: dict) -> str:
    L = [f"# Discrepancy diagnosis: {Path(d.recording).name}", ""]
    L += [f"**{d.conclusion}**", ""] + ([f"Details: {d.details}", ""] if d.details else [])
    s = d.settings
    L += [f"Robot `{d.robot}`, {s['samples']} samples at {1 / s['dt']:.4g} Hz "
          f"({s['samples'] * s['dt']:.3g} s); residuals smoothed over {s['smoothing_samples']} samples "
          f"({s['window'] * 1e3:.0f} ms), decimated by {s['decimation']}; the last "
          f"{(1 - s['train_fraction']) * 100:.0f} % of the recording is held out of the fit.", ""]
    from .working_set import sentence

    if sentence(s.get("working_set")):
        L += [sentence(s["working_set"])[0].upper() + sentence(s["working_set"])[1:] + " (docs/discrepancy.md, "
              "Long recordings).", ""]

    if getattr(d, "unexplained", None):
        L += ["## Structure left unexplained", "",
              "After the fit these residual channels still follow the motion (tested against the residual's own "
              "high-frequency noise, not the noise model the structure would inflate):", ""]
        L += [f"- `{e['channel']}`: keyed on {e['keyed_on']}, rms {e['rms']:.3g} against noise {e['noise']:.3g} "
              f"(chi-square {e['chi2']:.0f}); the library effects of that kind: {', '.join(e['closest'])}"
              for e in d.unexplained]
        L += [""]
    L += _where_section(d, files)
    L += _why_section(d, files)
    L += _discovery_section(d, files)
    if getattr(d, "flexible", None):
        from .flexible import markdown as flexible_markdown

        L += flexible_markdown(d.flexible, files)

    if getattr(d, "platform_force", None) is not None:
        from .platform_force import markdown as platform_markdown

        L += platform_markdown(d.platform_force)
    if getattr(d, "drifts", None):
        from .drift import markdown as drift_markdown

        L += drift_markdown(d.drifts, files)
    from .encoders_step import markdown as encoder_markdown

    L += encoder_markdown(getattr(d, "encoders", []))
    L += _heldout_section(d, files)
    L += _replay_section(d, files)
    L += ["## Method", "",
          "Residuals: effort = recorded command (zero-order hold, smoothed) minus the core's inverse dynamics of "
          "the recorded motion (smoothed identically); readings = recorded joints minus the core's sensor model at "
          "the tracker pose.  Every regressor is a finite difference of these residuals over a core parameter.  "
          f"Selection: forward BIC over effect groups with N_eff = {d.noise['n_eff']:.0f} effectively independent "
          "samples; intervals from the final Jacobian.  See docs/discrepancy.md.", ""]
    t = d.timings
    L.append("Timings [s]: " + ", ".join(f"{k} {v:.2f}" for k, v in t.items()))
    return "\n".join(L) + "\n"


def _where_section(d, files: dict) -> list:
    """The section where the model goes wrong: the localisation's summary, its table per channel and the figures."""
    L = ["## Where the model goes wrong", ""]
    loc = d.localisation
    if loc["summary"]:
        L += [f"- {x}" for x in loc["summary"]]
    else:
        L += ["- every residual channel stays inside its noise band (3 sigma)"]
    L += ["", "| channel | RMS | noise (1 sigma) | out of band | windows (start-end s, main phase) |",
          "| --- | --- | --- | --- | --- |"]
    for name, c in loc["channels"].items():
        w = c["windows"]
        ws = "; ".join(f"{x['start']:.2f}-{x['end']:.2f} ({max(x['phases'], key=x['phases'].get)})" for x in w[:4])
        if len(w) > 4:
            ws += f"; ... ({len(w)} windows)"
        L.append(f"| {name} | {c['rms']:.3g} | {c['noise']:.3g} | {c['out_of_band'] * 100:.0f} % | {ws or '-'} |")
    L.append("")
    for key, title in (("residuals", "Residual channels"), ("velocity", "Effort residual against joint rate"),
                       ("workspace", "Residual over the workspace")):
        if key in files:
            L += [f"![{title}]({Path(files[key]).name})", ""]
    return L


def _why_section(d, files: dict) -> list:
    """The section of the missing physics: the effects' table, their look-alikes, the plant parameters, the
    selection's steps and what was not excited, not tested or refused."""
    L = ["## Why: the missing physics", ""]
    if d.effects:
        L += ["| rank | effect | core parameter | fitted value | 95 % interval | unit | delta BIC | importance |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        for r, e in enumerate(d.effects, 1):
            for k, (p, v) in enumerate(e["params"].items()):
                L.append(f"| {r if k == 0 else ''} | {e['title'] if k == 0 else ''} | `{p}` | {v['value']:.5g} | "
                         f"+- {v['ci95']:.2g} | {v['unit']} | {e['delta_bic']:.1f} | {e['importance']:.1f} |")
        L.append("")
        for e in d.effects:
            if e["derived"]:
                L.append(f"- {e['title']}: " + ", ".join(f"{k} = {_fmt(v)}" for k, v in e["derived"].items()))
            for a in e["lookalikes"]:
                L.append(f"- {e['title']} vs {a['statement']}")
        L += ["", "Plant parameters that put the fitted effects into the model (core / FMU names):", "",
              "```json", json.dumps(d.theta, indent=2), "```", ""]
    else:
        threshold = d.settings["threshold"]
        L += ["No effect of the library is supported by the data "
              f"(an effect must lower the BIC by more than {threshold:g})." if "cannot" not in d.conclusion
              else "Nothing could be tested.", ""]
    if d.steps:
        L += ["Forward selection: " + " -> ".join(f"{x['group']} ({x['delta_bic']:.0f})" for x in d.steps), ""]
    if d.not_excited:
        L += ["Not excited by this recording:", ""] + [f"- {x}" for x in d.not_excited] + [""]
    if d.unavailable:
        L += ["Not tested:", ""] + [f"- {x}" for x in d.unavailable] + [""]
    if d.refused:
        L += ["Refused although the residual pointed at them:", ""] + [f"- {x}" for x in d.refused] + [""]
    return L


def _pair_coefficients(t) -> str:
    """The coefficients a pair between two joints fits, in words."""
    if "taut" in t.terms:
        return "three coefficients (k, slack, width)"
    return "two coefficients (k, L)" if "spring" in t.terms else "one coefficient"


def _discovery_section(d, files: dict) -> list:
    """The discovery step's section (none when it found and withdrew nothing): each term, why it was kept, what
    it replaces."""
    L = []
    if d.discovered or d.withdrawn:
        L += ["## Missing physics no library effect names (discovery)", "",
              "Searched on every effort channel after the library: a constant, a spring and its quadratic and cubic "
              "terms, quadratic drag, viscous and Coulomb friction by direction, Coulomb friction that fades below a "
              "velocity scale, a ripple in position (period from the residual's spectrum over position), a smooth "
              "step, an added inertia; stepwise BIC with the look-elsewhere cost of the "
              "search, kept when stable over block-bootstrap resamples and better on the held-out part.  The term is "
              "the core's joint force (`<j>[i].force_*`), so the fitted plant below carries it.", ""]
        for t in d.discovered:
            held = f"  - held-out residual of `{t.channel}`: RMS {t.heldout_before:.3g} -> {t.heldout_after:.3g}"
            if t.repeats_its_pair:
                L.append(held)
                continue
            L += [f"- **{t.equation}**", f"  - what makes such a term: {t.mechanisms}",
                  held + f" (chi-square {t.delta_chi2_heldout:.0f} lower{' over both channels' * bool(t.pair)}); "
                  + (f"{_pair_coefficients(t)} on {t.channel} "
                     f"and joint {t.pair}, kept against the two channels' separate terms (BIC, held-out part)"
                     if t.pair else "kept in "
                     + ", ".join(f"{100 * v:.0f} % ({k})" for k, v in t.stability.items())
                     + " of the bootstrap resamples")]
            L += [f"  - library effect it replaces: {x}" for x in t.instead_of]
            if t.partial:
                L.append(f"  - not named as the physics: {t.partial}")
            if f"discovered{t.joint}" in files:
                L += ["", f"![{t.channel} against its key variable](discovered{t.joint}.png)", ""]
        L.append("")
        if d.theta:
            L += ["Plant parameters with the discovered terms (core / FMU names):", "", "```json",
                  json.dumps(d.theta, indent=2), "```", ""]
    return L


def _heldout_section(d, files: dict) -> list:
    """The held-out fit's section: the gain and the table per channel before and after."""
    L = ["## How much better: held-out fit", ""]
    h = d.heldout
    if d.theta and h["affected"] and np.isfinite(h["gain"]):
        windows = (f", **{h['gain_windows']:.1f}x** in the windows where the nominal residual was out of band"
                   if np.isfinite(h["gain_windows"]) else "")
        L += [f"Held-out samples: t = {h['start']:.2f}-{h['end']:.2f} s. Gain (noise-normalised RMS, affected "
              f"channels {', '.join(h['affected'])}): **{h['gain']:.1f}x** over all samples{windows}.", ""]
    else:
        L += [f"Held-out samples: t = {h['start']:.2f}-{h['end']:.2f} s. "
              + ("Nothing fitted: the nominal model stands." if not d.theta else
                 "The fitted model changes no channel beyond its noise there."), ""]
    L += [
          "| channel | RMS before | RMS after | NRMSE before | NRMSE after | noise |", "| --- | --- | --- | --- | --- | --- |"]
    for name, c in h["channels"].items():
        if c.get("nrmse_na"):
            nb = na = f"n/a ({c['nrmse_na'].split(' over ')[0]})"
        else:
            nb, na = f"{c['nrmse_before'] * 100:.2f} %", f"{c['nrmse_after'] * 100:.2f} %"
        L.append(f"| {name} | {c['rms_before']:.3g} | {c['rms_after']:.3g} | {nb} | {na} | {c['noise']:.3g} {c['unit']} |")
    L.append("")
    if "heldout" in files:
        L += ["![Held-out overlay](heldout.png)", ""]
    return L


def _replay_section(d, files: dict) -> list:
    """The closed-loop (or open-loop) replay's part of the held-out section, empty without a replay."""
    L = []
    rp = d.replay
    if rp:
        if rp.get("skipped"):
            L += [f"Replay not run: {rp['skipped']}.", ""]
        elif rp.get("kind") == "open loop":  # an open-loop experiment (.open_loop): rates and readings
            from .open_loop import sentence

            L += [sentence(rp)[0].upper() + sentence(rp)[1:] + ".", ""]
        else:
            from ..core.model import robot_facts

            nd = len(_first_run(rp))
            facts = robot_facts(d.robot)
            L += [f"Closed-loop replay of the held-out part from t = {rp['start']:.2f} s (core plant, recorded "
                  f"controller and reference): RMS of the difference to the recording, efforts and readings", "",
                  "| plant | " + " | ".join(f"tau{i + 1} [{facts.effort_unit}]" for i in range(nd)) + " | "
                  + " | ".join(f"q{i + 1} [{facts.joint_unit}]" for i in range(nd)) + " |",
                  "| --- |" + " --- |" * (2 * nd)]
            for name, run in rp["runs"].items():
                if "error" in run:
                    L.append(f"| {name} | failed: {run['error']} |")
                else:
                    L.append(f"| {name} | " + " | ".join(f"{v:.3g}" for v in run["rms_tau"] + run["rms_q"]) + " |")
            L.append("")
            tb = rp.get("two_body") or {}
            if tb.get("params"):
                L += ["The fitted gap or compliance replayed as two bodies (drive body with the rotor inertia, "
                      "carriage, dead-band spring; docs/discrepancy.md), its damping and faces fitted by replays of "
                      f"{tb['window'][0]:.2f}-{tb['window'][1]:.2f} s: "
                      + ", ".join(f"`{k}` = {v:.4g}" for k, v in tb["params"].items() if k != "drive.two_body")
                      + f"; on that window their differences to the recording are {tb['score']:.2f} times the reading "
                      f"model's (the window is where the drive joints' efforts change sign most often).", ""]
            elif tb.get("skipped"):
                L += [f"No two-body replay: {tb['skipped']}.", ""]
            if "replay" in files:
                L += ["![Replay](replay.png)", ""]
    return L


def _first_run(rp):
    for run in rp["runs"].values():
        if "rms_tau" in run:
            return run["rms_tau"]
    return []


def _fmt(v):
    if isinstance(v, (list, tuple)):
        return "(" + ", ".join(f"{x:.3g}" for x in v) + ")"
    return f"{v:.3g}"


# -------------------------------------------------------------------- figures

def _fig_discovered(t, eng, path):
    """A discovered term: the channel's residual without it against its key variable, the
    fitted force, and the residual with it (before / after)."""
    import matplotlib.pyplot as plt

    facts = eng.model.facts
    cv = t.curve
    key, before, after = (np.asarray(cv[k]) for k in ("key", "before", "after"))
    order = np.argsort(key)
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6), sharey=True)
    sym, per = {"position": ("q", ""), "velocity": ("qd", "/s"), "acceleration": ("qdd", "/s2")}[t.key_variable]
    xl = f"{sym}{t.joint} [{facts.joint_unit}{per}]"
    ax[0].plot(key, before, ".", ms=2, color="#7f7f7f", label="residual without the term")
    ax[0].plot(key[order], (before - after)[order], "-", color="#d62728", lw=1.5, label="fitted term")
    ax[0].set_title("before", fontsize=9)
    ax[1].plot(key, after, ".", ms=2, color="#1f77b4", label="residual with the term")
    ax[1].set_title("after", fontsize=9)
    for a in ax:
        a.set_xlabel(xl)
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    ax[0].set_ylabel(f"{t.channel} [{facts.effort_unit}]")
    fig.suptitle(t.equation, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)


def _fig_residuals(d, eng, sel, path):
    import matplotlib.pyplot as plt

    pipe = eng.pipe
    t = pipe.t[pipe.idx]
    R0 = eng.R0
    Rf = eng.R(sel.theta) if sel.theta else R0
    C = R0.shape[1]
    fig, axes = plt.subplots(C, 1, figsize=(11, 1.25 * C + 1), sharex=True, squeeze=False)
    split = t[eng.test][0] if eng.test.any() else None
    for c, ax in enumerate(axes[:, 0]):
        name = pipe.channels[c]
        s = sel.sigma[c]
        scale = 1e3 if c >= pipe.nd and pipe.model.joint_unit == "m" else 1.0  # readings of sliders in mm
        ax.plot(t, R0[:, c] * scale, color="0.6", lw=0.8, label="nominal model")
        if sel.theta:
            ax.plot(t, Rf[:, c] * scale, color="C0", lw=0.8, label="fitted model")
        ax.axhspan(-3 * s * scale, 3 * s * scale, color="C2", alpha=0.12, lw=0)
        for w in d.localisation["channels"][name]["windows"]:
            ax.axvspan(w["start"], w["end"], color="C1", alpha=0.18, lw=0)
        if split is not None:
            ax.axvline(split, color="k", ls="--", lw=0.8)
        unit = d.heldout["channels"][name]["unit"]
        ax.set_ylabel(f"{name}\n[{'mm' if scale == 1e3 else unit}]", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(loc="upper right", fontsize=7, ncol=2)
    axes[0, 0].set_title("residuals (green: +-3 sigma noise band, orange: windows out of band, dashed: start of "
                         "the held-out part)", fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)


def _fig_velocity(d, eng, path):
    import matplotlib.pyplot as plt

    from .localisation import PHASES, phases

    pipe = eng.pipe
    pos = pipe.idx
    qd, qdd = pipe.qd_s[pos], pipe.qdd_s[pos]
    ph = phases(qd, qdd)
    nd = pipe.nd
    cols = 3 if nd > 4 else 2
    rows = int(np.ceil(nd / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 3 * rows), squeeze=False)
    for j in range(rows * cols):
        ax = axes[j // cols, j % cols]
        if j >= nd:
            ax.axis("off")
            continue
        for k, name in enumerate(PHASES):
            m = ph[:, j] == k
            ax.scatter(qd[m, j], eng.R0[m, j], s=3, color=PHASE_COLOURS[k], label=name)
        ax.set_title(f"joint {j + 1}", fontsize=9)
        ax.set_xlabel("joint rate", fontsize=8)
        ax.set_ylabel(f"effort residual [{d.heldout['channels'][pipe.channels[j]]['unit']}]", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0, 0].legend(fontsize=6, markerscale=3)
    fig.suptitle("effort residual of the nominal model against the joint rate, by motion phase", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)


def _fig_workspace(d, eng, path):
    import matplotlib.pyplot as plt

    pipe = eng.pipe
    x = pipe.x_s[pipe.idx]
    sig = np.asarray([d.noise["sigma"][c] for c in pipe.channels])
    z = np.max(np.abs(eng.R0) / sig[None, :], axis=1)
    facts = eng.model.facts
    nd = x.shape[1]
    # the pose coordinates in mm / mrad; a one-coordinate robot is drawn against time
    scale = [1e3] * nd
    label = [f"{n} [{'mm' if u == 'm' else 'm' + u if u == 'rad' else u}]"
             for n, u in zip(facts.pose_names, facts.pose_units)]
    pairs = [(0, 1), (0, 2)] if nd >= 3 else [(0, 1)] if nd == 2 else [(None, 0)]
    fig, axes = plt.subplots(1, len(pairs), figsize=(5.5 * len(pairs), 4.2), layout="constrained", squeeze=False)
    axes = axes[0]
    order = np.argsort(z)
    for ax, (a, b) in zip(axes, pairs):
        xa = pipe.t[pipe.idx][order] if a is None else x[order, a] * scale[a]
        sc = ax.scatter(xa, x[order, b] * scale[b], c=z[order], s=4, cmap="viridis", vmin=0,
                        vmax=max(6, np.percentile(z, 99)))
        ax.set_xlabel("time [s]" if a is None else label[a])
        ax.set_ylabel(label[b])
    fig.colorbar(sc, ax=axes, label="largest |residual| / noise")
    fig.suptitle("where in the workspace the nominal model is wrong", fontsize=10)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)


def _fig_heldout(d, eng, sel, path):
    import matplotlib.pyplot as plt

    pipe = eng.pipe
    test = eng.test
    pos = pipe.idx[test]
    t = pipe.t[pos]
    Rb = eng.R0[test]
    Ra = eng.R(sel.theta)[test] if sel.theta else Rb
    # every affected channel (all joints of an effect on all joints), with its unit
    names = d.heldout["affected"] or pipe.channels[:1]
    fig, axes = plt.subplots(len(names), 2, figsize=(12, 1.9 * len(names) + 0.8), squeeze=False, sharex=True)
    for r, name in enumerate(names):
        c = pipe.channels.index(name)
        rec = pipe.tau_s[pos, c] if c < pipe.nd else pipe.q_s[pos, c - pipe.nd]
        ax = axes[r, 0]
        ax.plot(t, rec, color="k", lw=1.2, label="recorded (smoothed)")
        ax.plot(t, rec - Rb[:, c], color="0.6", lw=0.9, label="nominal model")
        ax.plot(t, rec - Ra[:, c], color="C0", lw=0.9, ls="--", label="fitted model")
        unit = d.heldout["channels"].get(name, {}).get("unit", "")
        ax.set_ylabel(f"{name} [{unit}]", fontsize=8)
        ax = axes[r, 1]
        ax.plot(t, Rb[:, c], color="0.6", lw=0.8, label="before")
        ax.plot(t, Ra[:, c], color="C0", lw=0.8, label="after")
        ax.set_ylabel(f"residual {name} [{unit}]", fontsize=8)
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].legend(fontsize=7)
    axes[0, 0].set_title("held-out part: recording and models", fontsize=9)
    axes[0, 1].set_title(f"held-out residual (gain {d.heldout['gain']:.1f}x)", fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    axes[-1, 1].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)


def _fig_replay(d, eng, path):
    import matplotlib.pyplot as plt

    rec = eng.pipe.rec
    runs = {k: v for k, v in d.replay["runs"].items() if "tau" in v}
    if not runs:
        return None
    nd = eng.pipe.nd
    show = [eng.pipe.channels.index(c) for c in d.heldout["affected"] if eng.pipe.channels.index(c) < nd][:3] or [0]
    panels = [("tau", j) for j in show]
    # with two bodies: the readings of the first drive joint too (where the gap shows)
    drive = (d.replay.get("two_body") or {}).get("joints", [])
    if drive:
        panels.append(("q", drive[0]))
    fig, axes = plt.subplots(len(panels), 1, figsize=(11, 2.4 * len(panels)), squeeze=False)
    any_run = next(iter(runs.values()))
    k0 = int(np.searchsorted(rec.time, any_run["time"][0]))
    for r, (what, j) in enumerate(panels):
        ax = axes[r, 0]
        n = len(any_run["time"])
        recorded = getattr(rec, what)[k0:k0 + n, j]
        if what == "tau":
            ax.plot(rec.time[k0:k0 + n], recorded, color="k", lw=0.8, label="recorded")
        for (name, run), col in zip(runs.items(), ("0.6", "C0", "C3")):
            m = min(n, len(run["time"]))
            # readings: the replay less the recording (a gap is micrometres on a stroke of centimetres)
            y = run[what][:m, j] - (recorded[:m] if what == "q" else 0.0)
            ax.plot(run["time"][:m], y, color=col, lw=0.8, label=f"replay, {name} plant")
        ax.set_ylabel(f"{what}{j + 1}" + (" replay - recorded" if what == "q" else ""), fontsize=8)
    axes[0, 0].legend(fontsize=7)
    axes[0, 0].set_title("closed-loop replay of the held-out part: commanded effort"
                         + (" and the drive's readings" if drive else ""), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return str(path)
