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


def run_page(out, path) -> Path:
    """A scenario run (:class:`cosim.scenario.ScenarioResult`): the robot in motion, the joints
    against their reference, the efforts, the metrics."""
    import json

    from ..core import Model, robot_facts

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

    from ..core import Model
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
        labels, vals, errs = [], [], []
        for e in d.effects:
            for k, v in e["params"].items():
                labels.append(f"{k} [{v['unit']}]")
                vals.append(v["value"] - (v.get("nominal") or 0.0))
                errs.append(v["ci95"])
        f = go.Figure(go.Scatter(x=labels, y=vals, mode="markers", error_y=dict(type="data", array=errs)))
        f.update_layout(title="fitted effects: change from the nominal value, 95 % intervals", height=400)
        sections.append(("effects", f))
    ch = list(d.heldout["channels"])
    f = go.Figure([go.Bar(x=ch, y=[d.heldout["channels"][c]["rms_before"] for c in ch], name="nominal model"),
                   go.Bar(x=ch, y=[d.heldout["channels"][c]["rms_after"] for c in ch], name="fitted model")])
    f.update_layout(barmode="group", yaxis_type="log", height=380,
                    title=f"held-out residual RMS per channel (gain {d.heldout['gain']:.1f}x)")
    sections.append(("before / after on the held-out part", f))
    runs = {k: v for k, v in ((d.replay or {}).get("runs") or {}).items() if "rms_tau" in v}
    if runs:
        # the closed-loop replay: per plant, the RMS difference to the recording of every
        # effort and reading channel (a two-body replay of a fitted gap shows on the readings)
        nd = len(next(iter(runs.values()))["rms_tau"])
        for what, key in (("efforts", "rms_tau"), ("readings", "rms_q")):
            names = [f"{'tau' if key == 'rms_tau' else 'q'}{i + 1}" for i in range(nd)]
            f = go.Figure([go.Bar(x=names, y=run[key], name=f"{name} plant") for name, run in runs.items()])
            f.update_layout(barmode="group", yaxis_type="log", height=360,
                            title=f"closed-loop replay of the held-out part: RMS difference to the recorded {what}")
            sections.append((f"replay: {what}", f))
    return write_html(path, f"diagnosis of {Path(d.recording).name}", sections)
