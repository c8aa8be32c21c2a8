"""Interactive, self-contained HTML reports (plotly, its JavaScript inlined: no network).

* :func:`mechanism_figure`: the robot drawn from the core's own geometry (6-PUS rails,
  sliders, legs and platform from ``Model.leg_points``; Quattro motor axes, arms, forearms
  and platform from ``cosim.quattro.points``) and animated over a recording, with a time
  slider and play/pause buttons.
* :func:`write_html`: one page of titled sections (figures and text) in one file.
* :func:`view`: the animation of a recording alone (``cosim view rec.csv``).

A page opened with ``#frame=K`` in its address starts at frame K (used by the browser test
to draw two different times).

Example
-------
>>> from cosim.report import view
>>> path = view("results/6pus_step_pd/6pus_step_pd.csv", out="out/step_view.html")
"""
from __future__ import annotations

import html as _html
from pathlib import Path

import numpy as np

from ..errors import ReportError

__all__ = ["mechanism_figure", "write_html", "view", "ReportError"]


def _segments(model, x):
    """Line segments (list of (3, 2) arrays [m]) and labelled point sets of the robot at pose x:
    each leg's chain as the core gives it (``Model.chain_points``: base joint, moving joint,
    platform joint), whatever the robot."""
    from ..errors import UnsupportedError

    try:
        c = model.chain_points(x)
    except UnsupportedError:
        raise ReportError(f"the report cannot draw robot {model.robot!r}: the core gives no chain points for it "
                          "(every robot but the four-bar has them)") from None
    segs = {"links": [np.array([c[i, 0], c[i, 1]]) for i in range(len(c))],
            "legs": [np.array([c[i, 1], c[i, 2]]) for i in range(len(c))],
            "platform": [np.vstack([c[:, 2], c[:1, 2]])]}
    if model.ndof == 1 and model.joint_unit == "rad":
        segs.update(_rotary_axis(model, x, c[0]))
    return segs, {"base joints": c[:, 0], "joints": c[:, 1]}


#: length of a rotary axis's drawn shaft and pointer when its bodies give none [m]
_POINTER = 0.1


def _rotary_axis(model, x, chain):
    """A revolute axis drawn so that its turning shows: its shaft (a line along the axis
    through the axis point) and a pointer from the axis point, fixed in the platform,
    perpendicular to the axis (its direction at q = 0 turned by the platform's rotation,
    from ``Model.platform_pose``), as long as the platform is far from the axis (at least
    100 mm)."""
    from scipy.spatial.transform import Rotation

    k = np.array([model.param(f"axis[1].k{c}") for c in "xyz"])
    X = model.platform_pose(np.atleast_1d(np.asarray(x, float)))[0]
    o, A = X[:3], chain[0]
    size = max(np.linalg.norm(o - A), _POINTER)
    u = np.cross(k, np.eye(3)[int(np.argmin(np.abs(k)))])
    u /= np.linalg.norm(u)
    R = Rotation.from_euler("XYZ", X[3:]).as_matrix()  # R = Rx(rx) Ry(ry) Rz(rz), docs/robots.md
    return {"shaft": [np.array([A - 0.5 * size * k, A + 0.5 * size * k])],
            "pointer": [np.array([A, A + size * (R @ u)])]}


_COLORS = {"shaft": "#555555", "pointer": "#ff7f0e", "links": "#888888", "rails": "#888888", "legs": "#1f77b4", "platform": "#d62728", "arms": "#1f77b4", "forearms": "#2ca02c"}


def _traces(model, x):
    import plotly.graph_objects as go

    segs, pts = _segments(model, x)
    traces = []
    for name, lines in segs.items():
        xs, ys, zs = [], [], []
        for ln in lines:
            xs += list(ln[:, 0] * 1e3) + [None]
            ys += list(ln[:, 1] * 1e3) + [None]
            zs += list(ln[:, 2] * 1e3) + [None]
        traces.append(go.Scatter3d(x=xs, y=ys, z=zs, mode="lines", name=name,
                                   line=dict(width=6 if name != "rails" else 3, color=_COLORS.get(name, "#444"))))
    for name, P in pts.items():
        traces.append(go.Scatter3d(x=P[:, 0] * 1e3, y=P[:, 1] * 1e3, z=P[:, 2] * 1e3, mode="markers", name=name,
                                   marker=dict(size=3, color="#333")))
    if model.ndof == 1:
        # a single axis has no platform polygon: its carriage (the platform point) is drawn as a block
        c = segs["platform"][0][0] * 1e3
        name = "platform" if model.joint_unit == "rad" else "carriage"
        traces.append(go.Scatter3d(x=[c[0]], y=[c[1]], z=[c[2]], mode="markers", name=name,
                                   marker=dict(size=14, symbol="square", color=_COLORS["platform"])))
    return traces


def mechanism_figure(model, time, poses, *, max_frames: int = 120, title: str = ""):
    """A 3D plotly figure of the robot at ``poses`` (n, nd) [m, rad] over ``time`` (n,) [s],
    one animation frame per sample (decimated to ``max_frames``), with a time slider.

    The geometry is the core's: every drawn point comes from the model at that pose.
    """
    import plotly.graph_objects as go

    poses = np.asarray(poses, float)
    time = np.asarray(time, float)
    if poses.ndim != 2 or poses.shape[1] != model.ndof or len(time) != len(poses) or len(time) == 0:
        raise ReportError(f"poses must be (n, {model.ndof}) with one time each, got {poses.shape} and {time.shape}")
    keep = np.unique(np.linspace(0, len(time) - 1, min(max_frames, len(time))).round().astype(int))
    frames, steps = [], []
    for k in keep:
        frames.append(go.Frame(data=_traces(model, poses[k]), name=f"{k}"))
        steps.append(dict(method="animate", label=f"{time[k]:.2f}",
                          args=[[f"{k}"], dict(mode="immediate", frame=dict(duration=0, redraw=True),
                                               transition=dict(duration=0))]))
    # fixed axes covering the whole motion, so the robot moves and the view does not
    allp = np.concatenate([np.concatenate([np.vstack(v) for v in _segments(model, poses[k])[0].values()])
                           for k in keep[:: max(1, len(keep) // 10)]])
    lo, hi = allp.min(axis=0) * 1e3, allp.max(axis=0) * 1e3
    # a flat or straight robot (a planar one, a single axis) gets a depth of a quarter of its
    # size on its thin axes, so the view stays a box and the mechanism is seen, not a sliver
    # a robot with no extent at all (every point on one spot) gets a box of the pointer's size
    extent = max((hi - lo).max(), _POINTER * 1e3)
    mid, half = (lo + hi) / 2, np.maximum((hi - lo) / 2, 0.125 * extent)
    lo, hi = mid - half, mid + half
    pad = 0.05 * (hi - lo).max()
    scene = dict(xaxis=dict(title="x [mm]", range=[lo[0] - pad, hi[0] + pad]),
                 yaxis=dict(title="y [mm]", range=[lo[1] - pad, hi[1] + pad]),
                 zaxis=dict(title="z [mm]", range=[lo[2] - pad, hi[2] + pad]), aspectmode="manual",
                 # the box's proportions are the ranges' ("data" would take the traces', flat for a flat robot)
                 aspectratio=dict(zip("xyz", ((hi - lo + 2 * pad) / (hi - lo + 2 * pad).max()).tolist())))
    fig = go.Figure(data=_traces(model, poses[keep[0]]), frames=frames)
    fig.update_layout(
        title=title or f"{model.robot}: the recorded motion", scene=scene, height=640,
        margin=dict(l=0, r=0, t=40, b=0),
        updatemenus=[dict(type="buttons", x=0.02, y=0.02, xanchor="left", yanchor="bottom", buttons=[
            dict(label="play", method="animate",
                 args=[None, dict(frame=dict(duration=40, redraw=True), fromcurrent=True)]),
            dict(label="pause", method="animate",
                 args=[[None], dict(mode="immediate", frame=dict(duration=0, redraw=False))])])],
        sliders=[dict(active=0, currentvalue=dict(prefix="t = ", suffix=" s"), pad=dict(t=40), steps=steps)])
    return fig


_START_FRAME = """
<script>
// #frame=K in the address starts the animation at frame K (the browser test uses it)
(function () {
  var m = /frame=(\\d+)/.exec(window.location.hash);
  if (!m) return;
  var gd = document.querySelector('.plotly-graph-div');
  if (!gd || !gd._transitionData) { setTimeout(arguments.callee, 50); return; }
  var names = gd._transitionData._frames.map(function (f) { return f.name; });
  var k = Math.min(parseInt(m[1]), names.length - 1);
  Plotly.animate(gd, [names[k]], {mode: 'immediate', frame: {duration: 0, redraw: true}, transition: {duration: 0}});
})();
</script>
"""


def write_html(path, title: str, sections: list) -> Path:
    """One self-contained page: ``sections`` is a list of ``(heading, item)`` where an item
    is a plotly figure or a text (plain, paragraphs split at blank lines).  The plotly
    JavaScript is inlined once; nothing is fetched when the page is opened."""
    from plotly.offline import get_plotlyjs

    parts = [f"<!DOCTYPE html>\n<html><head><meta charset='utf-8'><title>{_html.escape(title)}</title>",
             "<style>body{font-family:sans-serif;margin:1.5em;max-width:1200px} pre{background:#f4f4f4;"
             "padding:0.6em;overflow-x:auto;white-space:pre-wrap;overflow-wrap:anywhere} h2{margin-top:1.6em}</style>",
             f"<script type='text/javascript'>{get_plotlyjs()}</script></head><body>",
             f"<h1>{_html.escape(title)}</h1>"]
    for heading, item in sections:
        parts.append(f"<h2>{_html.escape(heading)}</h2>")
        if isinstance(item, str):
            parts.append("<pre>" + _html.escape(item) + "</pre>")
        elif hasattr(item, "to_html"):
            parts.append(item.to_html(full_html=False, include_plotlyjs=False, auto_play=False))
        else:
            raise ReportError(f"section {heading!r}: a plotly figure or a text, not {type(item).__name__}")
    parts.append(_START_FRAME + "</body></html>")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text("\n".join(parts))
    return out


def _recording_poses(rec, model):
    """Poses of a recording: its tracker columns, or the core's forward kinematics of q."""
    if rec.pose is not None and rec.pose.shape[1] == model.ndof:
        return rec.pose
    x = np.empty((len(rec.time), model.ndof))
    guess = model.home()
    for k, q in enumerate(rec.q):
        guess = x[k] = model.fk(q, x_guess=guess)
    return x


def view(recording, *, out=None, model=None, max_frames: int = 120) -> Path:
    """The animated robot of a ``pkm-recording/1`` file as a self-contained HTML page.

    Parameters
    ----------
    recording : str or Path
        The recording (CSV with its JSON sidecar).
    out : str or Path, optional
        The page to write (default: beside the recording, ``<name>_view.html``).
    model : cosim.core.Model, optional
        The model to draw with (default: the robot of the recording with its sidecar's
        parameters).
    """
    from ..core.model import Model
    from ..recording import read_recording

    rec = read_recording(recording)
    if model is None:
        model = Model(rec.robot)
        params = {k: v for k, v in (rec.parameters or {}).items() if k in set(model.param_names())}
        if params:
            model.set_params(params)
    x = _recording_poses(rec, model)
    fig = mechanism_figure(model, rec.time, x, max_frames=max_frames,
                           title=f"{Path(recording).name}: {rec.robot}, {rec.time[-1] - rec.time[0]:.2f} s")
    out = Path(out) if out else Path(recording).with_name(Path(recording).stem + "_view.html")
    return write_html(out, f"{Path(recording).name}: the robot in motion", [("3D view", fig)])
