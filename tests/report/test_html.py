"""The interactive HTML pages: self-contained (plotly inlined, nothing fetched), the 3D view
of the robot drawn in a real headless browser (Chromium from Debian, installed by
scripts/bootstrap.sh), no console error, and the slider moving the robot (screenshots at
two times differ in the 3D view)."""
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from cosim.master import CorePlant, make_reference, run
from cosim import controllers as ctl
from cosim import trajectories as tr
from cosim.core import Model
from cosim.recording import write_recording
from cosim.report import ReportError, view, write_html

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("rec")
    m = Model("6pus")
    h = m.home()
    ref = make_reference(m, tr.waypoints([h, h + [0.01, 0, 0.012, 0, 0, 0.05]], move_time=0.4), duration=0.6)
    res = run(CorePlant(m), ctl.pd_gravity(m, kp=300, kd=30), ref)
    path = d / "lift.csv"
    write_recording(path, res.to_recording(parameters=m.params()))
    return path


def test_the_page_is_self_contained(recording, tmp_path):
    page = view(recording, out=tmp_path / "v.html")
    text = page.read_text()
    assert "Plotly" in text and "scatter3d" in text
    assert not re.search(r"<script[^>]+src=", text)           # no script fetched
    assert not re.search(r"<link[^>]+href=[\"']https?:", text)  # no stylesheet fetched


def _shot(page, frame, out):
    p = subprocess.run([CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                        "--use-angle=swiftshader", "--enable-logging=stderr", "--log-level=0", "--window-size=1000,900",
                        "--virtual-time-budget=8000", f"--screenshot={out}", f"file://{page}#frame={frame}"],
                       capture_output=True, text=True, timeout=120)
    console = [ln for ln in p.stderr.splitlines() if "CONSOLE" in ln]
    return p.returncode, console


def test_the_browser_draws_the_robot_and_the_slider_moves_it(recording, tmp_path):
    from PIL import Image

    assert CHROMIUM is not None, "chromium is not installed: ./scripts/bootstrap.sh installs it"

    page = view(recording, out=tmp_path / "v.html", max_frames=40).resolve()
    shots = []
    for frame in (0, 39):
        png = tmp_path / f"f{frame}.png"
        rc, console = _shot(page, frame, png)
        assert rc == 0 and png.exists()
        errors = [ln for ln in console if re.search(r"Uncaught|Error|Failed to load|net::ERR", ln)
                  and "GL Driver Message" not in ln]
        assert not errors, errors
        shots.append(np.asarray(Image.open(png).convert("L"), float))
    # the 3D view: below the headings, above the slider
    a, b = (s[150:650, 0:900] for s in shots)
    assert a.std() > 5 and b.std() > 5                 # something is drawn, not a blank canvas
    assert np.mean(np.abs(a - b)) > 0.5, np.mean(np.abs(a - b))  # the robot moved between the two times


def test_run_calibration_and_diagnosis_pages(recording, tmp_path):
    from cosim.calibration import calibrate
    from cosim.discrepancy import diagnose
    from cosim.report.pages import calibration_page, diagnosis_page

    root = Path(__file__).resolve().parents[2]
    res = calibrate(root / "scenarios" / "calibration_6pus_campaign.csv", holdout=0.25)
    p1 = calibration_page(res, tmp_path / "cal.html")
    assert "accuracy" in p1.read_text() and "estimate - nominal" in p1.read_text()
    d = diagnose(recording, figures=False, replay=False)
    p2 = diagnosis_page(d, tmp_path / "diag.html")
    text = p2.read_text()
    assert "held-out residual RMS" in text and "scatter3d" in text and d.conclusion in text
    assert "replay: readings" not in text  # no replay run, no replay section
    d = diagnose(recording, figures=False, replay=True)
    text = diagnosis_page(d, tmp_path / "diag2.html").read_text()
    assert "replay: readings" in text and "fitted plant" in text
    with pytest.raises(ReportError, match="section 'bad'"):
        write_html(tmp_path / "x.html", "t", [("bad", 3)])


TURNTABLE = """
[robot]
name = "turntable_on_axis"
coordinates = ["rz"]
home = [0.0]
[gravity]
vector = [0.0, 0.0, -9.81]
[platform]
mass = 2.0
inertia = [0.01, 0.01, 0.02]
[[leg]]
type = "R"
platform_point = [0.0, 0.0, 0.0]
axis_point = [0.0, 0.0, 0.0]
axis = [0.0, 0.0, 1.0]
continuous = true
"""


def test_a_rotary_axis_whose_points_lie_on_it_is_drawn_turning(tmp_path):
    """A turntable with every chain point on its axis (no extent at all: the box once had a
    size of 0 and plotly an aspect ratio of NaN) is drawn, with a shaft and a pointer that
    turns with q: the pointer's end at q = pi/2 is the one at q = 0 turned by pi/2 about z."""
    import json

    from cosim.report import mechanism_figure

    (tmp_path / "turntable_on_axis.toml").write_text(TURNTABLE)
    m = Model(str(tmp_path / "turntable_on_axis.toml"))
    t = np.linspace(0.0, 1.0, 5)
    fig = mechanism_figure(m, t, (np.pi / 2 * 4 * t)[:, None])  # q = 0, pi/2, pi, 3 pi/2, 2 pi
    ar = fig.layout.scene.aspectratio
    assert all(np.isfinite([ar.x, ar.y, ar.z])) and min(ar.x, ar.y, ar.z) > 0, ar
    ends = []
    for fr in fig.frames[:2]:
        (ptr,) = [d for d in fr.data if d.name == "pointer"]
        ends.append(np.array([ptr.x[1] - ptr.x[0], ptr.y[1] - ptr.y[0], ptr.z[1] - ptr.z[0]]))
    assert np.linalg.norm(ends[0]) > 0
    turned = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1]]) @ ends[0]  # Rz(pi/2)
    np.testing.assert_allclose(ends[1], turned, atol=1e-9)
    assert any(d.name == "shaft" for d in fig.frames[0].data)
    out = write_html(tmp_path / "t.html", "turntable", [("the turntable", fig)])
    assert "NaN" not in json.dumps(fig.layout.scene.to_plotly_json()) and out.exists()
