"""Running the FMU binaries of every platform through the tests' own FMI 2.0 host
(tests/fmu/host/fmi2_host.c): natively for linux64, under Wine for win64 and under QEMU for
aarch64-linux.  Used by tests/fmu/test_platforms.py (two robots) and bench/fmu_platforms.py
(every FMU).

The scenario is a closed loop of a robot's plant and controller FMUs: a PD step to a pose
a few millimetres (or a few hundredths of a radian) from home, the FMU states saved,
serialised and restored, and a refused non-finite input with its message.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np

from cosim import controllers as ctl
from cosim import fmu, ssp
from cosim.core import Model

H = 1e-3
PLATFORMS = ("linux64", "win64", "aarch64-linux")
AARCH64_SYSROOT = "/usr/aarch64-linux-gnu"


def host_command(platform: str) -> list[str]:
    """The command that runs the host program built for ``platform`` on this machine."""
    exe = fmu.build_dir() / "fmu" / "hosts" / platform / ("fmi2_host.exe" if platform == "win64" else "fmi2_host")
    if not exe.exists():
        raise FileNotFoundError(f"{exe} is not built (scripts/bootstrap.sh builds every platform's host)")
    if platform == "win64":
        return [shutil.which("wine") or "wine", str(exe)]
    if platform == "aarch64-linux":
        return [shutil.which("qemu-aarch64") or "qemu-aarch64", "-L", AARCH64_SYSROOT, str(exe)]
    return [str(exe)]


def _native_path(platform: str, p: Path) -> str:
    return "Z:" + str(p).replace("/", "\\") if platform == "win64" else str(p)


def _uri(platform: str, p: Path) -> str:
    return "file:///Z:" + str(p) if platform == "win64" else "file://" + str(p)


class Unpacked:
    """An FMU unzipped into ``folder``: its model description, GUID and value references."""

    def __init__(self, path: Path, folder: Path):
        from fmpy import read_model_description

        folder.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(path) as z:
            z.extractall(folder)
        self.folder = folder
        self.md = read_model_description(str(folder))
        self.ident = self.md.coSimulation.modelIdentifier
        self.guid = self.md.guid
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.integer = {v.name for v in self.md.modelVariables if v.type == "Integer"}

    def library(self, platform: str) -> Path:
        ext = ".dll" if platform == "win64" else ".so"
        return self.folder / "binaries" / platform / (self.ident + ext)

    def load_line(self, name: str, platform: str, model_exchange: bool = False) -> str:
        kind = "me" if model_exchange else "fmu"
        nx = f" {len(self.md.derivatives)}" if model_exchange else ""
        return (f"{kind} {name} {_native_path(platform, self.library(platform))} {self.guid} "
                f"{_uri(platform, self.folder / 'resources')}{nx}")

    def set_lines(self, name: str, values: dict) -> list[str]:
        return [f"{'int' if k in self.integer else 'real'} {name} {self.vr[k]} "
                f"{int(v) if k in self.integer else repr(float(v))}" for k, v in values.items()]

    def vrs(self, names) -> str:
        return " ".join(str(self.vr[n]) for n in names)


def loop_setup(robot: str):
    """The PD step of ``robot``: (model, controller start values, plant start values, printed names).

    The gains put every joint's loop at 8 Hz, 0.7 damping on the joint-space mass at home
    (controllers.joint_mass); the target is 2 mm along each translation and 0.01 rad about
    each rotation of the robot's pose from home."""
    m = Model(robot)
    nd = m.ndof
    x0 = m.home()
    mass = np.diag(ctl.joint_mass(m, x0))
    wn = 2 * np.pi * 8.0
    c = ctl.pd(ndof=nd, kp=mass * wn**2, kd=2 * 0.7 * mass * wn, joint=m.joint_unit)
    step = np.array([0.002 if u == "m" else 0.01 for u in m.facts.pose_units])
    qref = m.ik(x0 + step)
    cparams = ssp.controller_parameters(c, ndof=nd, dt=H, lti_states=0)
    cparams.update({f"qref[{i + 1}]": qref[i] for i in range(nd)})
    pparams = {"solver.rtol": 1e-10, "solver.atol": 1e-12}
    joints = [f"q[{i}]" for i in range(1, nd + 1)]
    rates = [f"qd[{i}]" for i in range(1, nd + 1)]
    efforts = [f"tau[{i}]" for i in range(1, nd + 1)]
    return m, cparams, pparams, (list(m.facts.pose_names), joints, rates, efforts)


def loop_script(plant: Unpacked, ctrl: Unpacked, robot: str, platform: str, steps: int = 60) -> str:
    """The host script of the PD step: steps, state save / restore, then a NaN effort."""
    m, cparams, pparams, (pose, joints, rates, efforts) = loop_setup(robot)
    show = (f"print plant {plant.vrs(pose + joints + rates)}\n"
            f"print ctrl {ctrl.vrs(efforts)}\n")
    return "\n".join([
        ctrl.load_line("ctrl", platform),
        plant.load_line("plant", platform),
        *ctrl.set_lines("ctrl", cparams),
        *plant.set_lines("plant", pparams),
        "init ctrl", "init plant",
        f"connect plant {plant.vrs(joints + rates)} -> ctrl {ctrl.vrs(joints + rates)}",
        f"connect ctrl {ctrl.vrs(efforts)} -> plant {plant.vrs(efforts)}",
        f"step {steps} {H!r}", show,
        "save plant", "save ctrl",
        f"step {steps} {H!r}", show,
        "restore plant", "restore ctrl",
        f"step {steps} {H!r}", show,
        f"real plant {plant.vr['tau[1]']} nan",
        "",
    ])


def me_script(plant: Unpacked, robot: str, platform: str, steps: int = 100, h: float = 1e-4) -> str:
    """The plant as Model Exchange under efforts 2 % above its gravity load at home, stepped
    by the host's explicit Euler: steps, state save / restore, then a NaN effort."""
    m = Model(robot)
    tau = 1.02 * m.gravity_load(m.home())
    pose = list(m.facts.pose_names) + [p + "d" for p in m.facts.pose_names]
    show = f"print plant {plant.vrs(pose)}"
    return "\n".join([
        plant.load_line("plant", platform, model_exchange=True),
        *plant.set_lines("plant", {f"tau[{i + 1}]": v for i, v in enumerate(tau)}),
        "init plant",
        f"step {steps} {h!r}", show,
        "save plant",
        f"step {steps} {h!r}", show,
        "restore plant",
        f"step {steps} {h!r}", show,
        f"real plant {plant.vr['tau[1]']} nan",
        "",
    ])


def solver_script(plant: Unpacked, platform: str, method: int) -> str:
    """Instantiate and initialise the plant with ``solver.method = method``, one step."""
    return "\n".join([plant.load_line("plant", platform), f"int plant {plant.vr['solver.method']} {method}",
                      "init plant", f"step 1 {H!r}", ""])


def run(platform: str, script: str, folder: Path, timeout: float = 300) -> dict:
    """Run a host script on ``platform``; the output split into values, statuses and log lines."""
    path = folder / f"script_{platform}.txt"
    path.write_text(script)
    env = dict(os.environ, WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    env.pop("DISPLAY", None)
    r = subprocess.run(host_command(platform) + [_native_path(platform, path)], capture_output=True, text=True,
                       timeout=timeout, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"fmi2_host ({platform}) exited {r.returncode}: {r.stderr.strip()[-2000:]}")
    out = {"values": [], "lines": []}
    for line in r.stdout.splitlines():
        if line.startswith("values "):
            out["values"].append(np.array([float(v) for v in line.split()[1:]]))
        elif line.startswith(("status ", "log ", "saved ", "restored ")):
            out["lines"].append(line)
    return out


def fmu_pair(robot: str, folder: Path) -> tuple[Unpacked, Unpacked]:
    """The robot's plant and controller FMUs, unzipped under ``folder``."""
    plant = Unpacked(fmu.fmu_path(robot), folder / "plant")
    ctrl = Unpacked(fmu.fmu_path(fmu.fmu_id(robot) + "_CTRL"), folder / "ctrl")
    return plant, ctrl


def largest_difference(a: dict, b: dict) -> float:
    """The largest difference between two runs' printed values (relative where |v| > 1)."""
    assert len(a["values"]) == len(b["values"]), (a, b)
    d = 0.0
    for u, v in zip(a["values"], b["values"]):
        d = max(d, float(np.max(np.abs(u - v) / np.maximum(1.0, np.abs(u)))))
    return d
