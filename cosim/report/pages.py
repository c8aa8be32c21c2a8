"""The interactive pages of ``cosim run``, ``cosim calibrate`` and ``cosim diagnose`` (``--html``)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from . import ReportError, _recording_poses, mechanism_figure, write_html

__all__ = ["run_page", "calibration_page", "diagnosis_page"]


def _series(time, Y, names, unit, title, windows=None):
    import plotly.graph_objects as go

    fig = go.Figure()
    for j, name in enumerate(names):
        fig.add_trace(go.Scatter(x=time, y=Y[:, j], mode="lines", name=name))
    for a, b in windows or []:
        fig.add_vrect(x0=a, x1=b, fillcolor="orange", opacity=0.15, line_width=0)
    fig.update_layout(title=title, xaxis_title="time [s]", yaxis_title=unit, height=360,
                      margin=dict(l=60, r=20, t=50, b=40))
    return fig


def _by_unit(rows, title, ytitle, kind="bar", log=False, height=300):
    """One figure with a panel per unit: ``rows`` is a list of ``(series, label, unit,
    value[, error])``; every panel's axis says its unit (``ytitle`` with ``{unit}``), so
    that quantities of different units never share an axis."""
    import plotly.graph_objects as go
    from plotly.subplots import make_subplots

    units = list(dict.fromkeys(r[2] for r in rows))
    fig = make_subplots(rows=len(units), cols=1, vertical_spacing=0.25 / max(1, len(units)),
                        subplot_titles=[f"[{u}]" for u in units])
    series = list(dict.fromkeys(r[0] for r in rows))
    colours = ["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728"]
    for i, u in enumerate(units, start=1):
        for j, name in enumerate(series):
            mine = [r for r in rows if r[2] == u and r[0] == name]
            if not mine:
                continue
            style = dict(name=name, legendgroup=name, showlegend=i == 1, marker_color=colours[j % len(colours)])
            if kind == "bar":
                fig.add_trace(go.Bar(x=[r[1] for r in mine], y=[r[3] for r in mine], **style), row=i, col=1)
            else:
                fig.add_trace(go.Scatter(x=[r[1] for r in mine], y=[r[3] for r in mine], mode="markers",
                                         error_y=dict(type="data", array=[r[4] for r in mine]), **style),
                              row=i, col=1)
        fig.update_yaxes(title_text=ytitle.format(unit=u), type="log" if log else None, row=i, col=1)
    fig.update_layout(title=title, barmode="group", height=120 + height * len(units),
                      margin=dict(l=80, r=20, t=70, b=40))
    return fig


def run_page(out, path) -> Path:
    """A scenario run (:class:`cosim.scenario.ScenarioResult`): the robot in motion, the joints
    against their reference, the efforts, the metrics."""
    import json

    from ..core.model import Model, robot_facts

    res = out.result
    facts = robot_facts(res.robot)
    model = Model(res.robot)
    J = [f"q{i + 1}" for i in range(facts.ndof)]
    err = (res["qref"] - res["q_true"]) * (1e3 if facts.joint_unit == "m" else 1e3)
    try:
        view = mechanism_figure(model, res.time, res["x"], title=f"{out.scenario.name}: {res.robot}")
    except ReportError as e:  # a robot the report cannot draw: the page goes on without the 3D view
        view = f"no 3D view: {e}"
    sections = [
        ("the robot in motion (true pose)", view),
        ("joint errors", _series(res.time, err, [f"e{i + 1}" for i in range(facts.ndof)],
                                 f"qref - q [{'mm' if facts.joint_unit == 'm' else 'mrad'}]", "tracking error")),
        ("efforts", _series(res.time, res["tau"], [f"tau{i + 1}" for i in range(facts.ndof)],
                            f"effort [{facts.effort_unit}]", "applied efforts")),
        ("metrics", json.dumps(out.metrics, indent=1, default=str)[:20000]),
    ]
    del J
    return write_html(path, f"scenario {out.scenario.name}", sections)


def calibration_page(res, path) -> Path:
    """A calibration (:class:`cosim.calibration.CalibrationResult`): accuracy per pose before
    and after, the estimates with 3 standard errors (and the truth when known), the report."""
    import plotly.graph_objects as go

    from ..calibration.plots import _truth

    acc = res.holdout_accuracy or res.calibration_accuracy
    which = "held-out" if res.holdout_accuracy else "calibration"
    k = np.arange(acc.n)
    f1 = go.Figure([go.Bar(x=k, y=acc.per_pose[:, 0] * 1e6, name="nominal"),
                    go.Bar(x=k, y=acc.per_pose[:, 1] * 1e6, name="calibrated")])
    f1.update_layout(barmode="group", title=f"accuracy on the {which} poses: gain {acc.gain:.3g}x",
                     xaxis_title=f"{which} pose", yaxis_title="error [um]", yaxis_type="log", height=380)
    s = res.solution
    idx = np.flatnonzero(s.free)
    units = list(getattr(res.problem, "units", [""] * len(s.names)))
    truth = _truth(res)
    f2 = go.Figure()
    for u, scale, label in (("m", 1e3, "mm"), ("1", 1e3, "1e-3")):
        js = [j for j in idx if units[j] == u]
        if not js:
            continue
        names = [s.names[j] for j in js]
        f2.add_trace(go.Scatter(x=names, y=s.dp[js] * scale, mode="markers", name=f"estimate [{label}]",
                                error_y=dict(type="data", array=3 * s.se[js] * scale)))
        if truth:
            f2.add_trace(go.Scatter(x=names, y=[(truth.get(n, np.nan) - s.p0[j]) * scale for n, j in zip(names, js)],
                                    mode="markers", marker_symbol="x", name=f"truth [{label}]"))
    f2.update_layout(title="estimate - nominal, +-3 standard errors", height=420)
    return write_html(path, f"calibration of {res.robot} from {Path(str(res.source)).name}",
                      [("accuracy", f1), ("estimates", f2), ("report", res.text())])


def diagnosis_page(d, path, model=None) -> Path:
    """A diagnosis (:class:`cosim.discrepancy.Diagnosis`): the recording in 3D, the efforts
    with the windows where the model is wrong, the effects with their 95 % intervals, the
    held-out fit before and after, the conclusion."""

    import plotly.graph_objects as go

    from ..core.model import Model
    from ..recording import read_recording

    rec = read_recording(d.recording)
    model = model or Model(rec.robot)
    sections = [("conclusion", d.conclusion + ("\n\n" + "\n".join(d.localisation.get("summary", []))))]
    try:
        sections.append(("the robot in motion", mechanism_figure(model, rec.time, _recording_poses(rec, model),
                                                                 title=f"{Path(d.recording).name}")))
    except ReportError:
        pass
    chans = d.localisation["channels"]
    r = d.residual
    for c, name in enumerate(d.channels):
        wins = [(w["start"], w["end"]) for w in chans.get(name, {}).get("windows", [])]
        unit = d.heldout["channels"].get(name, {}).get("unit", "")
        if r:
            Y = np.column_stack([r["before"][:, c], r["after"][:, c]])
            fig = _series(r["time"], Y, ["nominal model", "fitted model"], unit,
                          f"{name}: residual (recording - model); shaded where the nominal model is out of its "
                          f"noise band", wins)
        else:
            fig = _series(rec.time, rec.tau[:, [min(c, rec.tau.shape[1] - 1)]], [name], unit, name, wins)
        sections.append((f"{name}", fig))
    if d.effects:
        # one panel per unit: a friction in N and a mass in kg have no common axis
        rows = [("fitted change", k, v["unit"], v["value"] - (v.get("nominal") or 0.0), v["ci95"])
                for e in d.effects for k, v in e["params"].items()]
        sections.append(("effects", _by_unit(rows, "fitted effects: change from the nominal value, 95 % intervals",
                                             "change [{unit}]", kind="markers")))
    for t in getattr(d, "discovered", []):
        cv = t.curve
        if not cv:
            continue
        key, before, after = (np.asarray(cv[k]) for k in ("key", "before", "after"))
        order = np.argsort(key)
        f = go.Figure([go.Scattergl(x=key, y=before, mode="markers", marker=dict(size=3, color="#7f7f7f"),
                                    name="residual without the term (before)"),
                       go.Scattergl(x=key, y=after, mode="markers", marker=dict(size=3, color="#1f77b4"),
                                    name="residual with the term (after)"),
                       go.Scatter(x=key[order], y=(before - after)[order], mode="lines", line=dict(color="#d62728"),
                                  name="fitted term")])
        f.update_layout(title=t.equation + (" (a partial fit, not the physics)" if getattr(t, "partial", "") else ""),
                        height=380, xaxis_title=f"{t.key_variable} of joint {t.joint}",
                        yaxis_title=t.channel)
        sections.append((f"discovered: {t.channel}", f))
    for fl in getattr(d, "flexible", []):
        for dep in fl.inputs:  # the flexible model's partial dependence on each input it names
            f = go.Figure([go.Scatter(x=list(dep.grid), y=list(dep.curve), mode="lines", line=dict(color="#d62728"),
                                      name="partial dependence")])
            f.update_layout(title=fl.statement, height=380, xaxis_title=f"{dep.feature} [{dep.unit}]",
                            yaxis_title=f"{fl.channel} [{fl.unit}]")
            sections.append((f"flexible model: {fl.channel} on {dep.group}", f))
    hc = d.heldout["channels"]
    rows = [(label, c, hc[c]["unit"], hc[c][key]) for label, key in (("nominal model", "rms_before"),
                                                                      ("fitted model", "rms_after")) for c in hc]
    sections.append(("before / after on the held-out part",
                     _by_unit(rows, f"held-out residual RMS per channel (gain {d.heldout['gain']:.1f}x)",
                              "residual RMS [{unit}]", log=True)))
    runs = {k: v for k, v in ((d.replay or {}).get("runs") or {}).items() if "rms_tau" in v}
    if runs:
        # the closed-loop replay: per plant, the RMS difference to the recording of every
        # effort and reading channel (a two-body replay of a fitted gap shows on the readings)
        nd = len(next(iter(runs.values()))["rms_tau"])
        for what, key, sym, unit in (("efforts", "rms_tau", "tau", model.facts.effort_unit),
                                     ("readings", "rms_q", "q", model.facts.joint_unit)):
            rows = [(f"{name} plant", f"{sym}{i + 1}", unit, run[key][i]) for name, run in runs.items()
                    for i in range(nd)]
            sections.append((f"replay: {what}", _by_unit(
                rows, f"closed-loop replay of the held-out part: RMS difference to the recorded {what}",
                "RMS difference [{unit}]", log=True)))
    return write_html(path, f"diagnosis of {Path(d.recording).name}", sections)
