"""Running the FMU binaries of every platform through the tests' own FMI 2.0 and FMI 3.0
hosts (tests/fmu/host/fmi_host.c, built as fmi2_host and fmi3_host): natively for linux64,
under Wine for win64 and under QEMU for aarch64-linux.  Used by tests/fmu/test_platforms.py
(two robots), tests/fmu/test_fmi3_host.py (the FMI 3.0 FMUs) and bench/fmu_platforms.py
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


def host_command(platform: str, fmi: int = 2) -> list[str]:
    """The command that runs the FMI ``fmi`` host program built for ``platform`` on this machine."""
    name = f"fmi{fmi}_host"
    exe = fmu.build_dir() / "fmu" / "hosts" / platform / (name + ".exe" if platform == "win64" else name)
    if not exe.exists():
        raise FileNotFoundError(f"{exe} is not built (scripts/bootstrap.sh builds every platform's host)")
    if platform == "win64":
        _wine_server()
        return [shutil.which("wine") or "wine", str(exe)]
    if platform == "aarch64-linux":
        return [shutil.which("qemu-aarch64") or "qemu-aarch64", "-L", AARCH64_SYSROOT, str(exe)]
    return [str(exe)]


_WINE_SERVER_UP = []


def _wine_server() -> None:
    """One wineserver for every Wine run of the tests, kept 60 s after its last client: a wine
    started while the previous run's server shuts down can exit 1 without a word (a full suite
    run once did so), which is Wine's start-up, not the FMU."""
    if not _WINE_SERVER_UP:
        env = dict(os.environ, WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
        env.pop("DISPLAY", None)
        # not captured: the server it starts keeps the pipes it was given open
        subprocess.run([shutil.which("wineserver") or "wineserver", "-p60"], stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, env=env, timeout=60)
        # nor Wine's own processes (services, devices), started by the first program a new server
        # runs: a captured first run would wait about 60 s for them to close its pipes
        subprocess.run([shutil.which("wine") or "wine", "cmd", "/c", "exit"], stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, env=env, timeout=120)
        _WINE_SERVER_UP.append(True)


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
        nx = f" {self.md.numberOfContinuousStates}" if model_exchange else ""
        return (f"{kind} {name} {_native_path(platform, self.library(platform))} {self.guid} "
                f"{_uri(platform, self.folder / 'resources')}{nx}")

    def set_lines(self, name: str, values: dict) -> list[str]:
        return [f"{'int' if k in self.integer else 'real'} {name} {self.vr[k]} "
                f"{int(v) if k in self.integer else repr(float(v))}" for k, v in values.items()]

    def vrs(self, names) -> str:
        return " ".join(str(self.vr[n]) for n in names)


class Unpacked3(Unpacked):
    """An FMI 3.0 FMU unzipped into ``folder``, addressed by the names of its FMI 2.0 twin
    (``fmu2``: the FMI 2.0 ``.fmu`` of the same table): each FMI 2.0 variable is an element
    of an FMI 3.0 variable, in order (tests/fmu/test_fmi3.py checks that), so the scripts of
    the FMI 2.0 host serve the FMI 3.0 host with whole arrays (``VR:N``)."""

    fmi = 3

    def __init__(self, path: Path, folder: Path, fmu2: Path):
        from fmpy import read_model_description

        super().__init__(path, folder)
        md2 = read_model_description(str(fmu2))
        self.vars3 = [v for v in self.md.modelVariables if v.causality not in ("independent", "local")]
        self.size = {v.name: int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1
                     for v in self.vars3}
        self.element = {}  # FMI 2.0 name -> (FMI 3.0 variable, index)
        self.start = {}    # FMI 3.0 name -> its start values (FMI 2.0's)
        rows = iter(md2.modelVariables)
        for v in self.vars3:
            starts = []
            for k in range(self.size[v.name]):
                r = next(rows)
                self.element[r.name] = (v, k)
                starts.append(r.start)
            self.start[v.name] = starts
        self.integer = {v.name for v in self.vars3 if v.type == "Int32"}

    def library(self, platform: str) -> Path:
        ext = ".dll" if platform == "win64" else ".so"
        return self.folder / "binaries" / fmu.FMI3_PLATFORMS[platform] / (self.ident + ext)

    def set_lines(self, name: str, values: dict) -> list[str]:
        """One line per FMI 3.0 variable touched: all its values, the ones not given at their start."""
        arrays = {}
        for k, x in values.items():
            v, i = self.element[k]
            arrays.setdefault(v.name, (v, list(self.start[v.name])))[1][i] = x
        lines = []
        for n, (v, vals) in arrays.items():
            txt = [str(int(x)) if n in self.integer else repr(float(x)) for x in vals]
            lines.append(f"{'int' if n in self.integer else 'real'} {name} {v.valueReference}:{len(vals)} "
                         + " ".join(txt))
        return lines

    def vrs(self, names) -> str:
        """Names that make whole FMI 3.0 variables, in order, as ``VR:N`` words."""
        words, k = [], 0
        names = list(names)
        while k < len(names):
            v, i = self.element[names[k]]
            n = self.size[v.name]
            got = [self.element[m] for m in names[k:k + n]]
            assert i == 0 and got == [(v, j) for j in range(n)], f"{names[k:k + n]} is not the whole of {v.name}"
            words.append(f"{v.valueReference}:{n}")
            k += n
        return " ".join(words)


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
        plant.set_lines("plant", {"tau[1]": float("nan")})[0],
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
        plant.set_lines("plant", {"tau[1]": float("nan")})[0],
        "",
    ])


def solver_script(plant: Unpacked, platform: str, method: int) -> str:
    """Instantiate and initialise the plant with ``solver.method = method``, one step."""
    return "\n".join([plant.load_line("plant", platform), *plant.set_lines("plant", {"solver.method": method}),
                      "init plant", f"step 1 {H!r}", ""])


def run(platform: str, script: str, folder: Path, timeout: float = 300, fmi: int = 2) -> dict:
    """Run a host script on ``platform`` with the FMI ``fmi`` host; the output split into values,
    statuses and log lines."""
    path = folder / f"script_{platform}_fmi{fmi}.txt"
    path.write_text(script)
    env = dict(os.environ, WINEDEBUG="-all", WINEDLLOVERRIDES="mscoree,mshtml=")
    env.pop("DISPLAY", None)
    r = subprocess.run(host_command(platform, fmi) + [_native_path(platform, path)], capture_output=True, text=True,
                       timeout=timeout, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"fmi{fmi}_host ({platform}) exited {r.returncode}: {r.stderr.strip()[-2000:]}"
                           f" (stdout: {r.stdout.strip()[-1000:]!r})")
    out = {"values": [], "lines": []}
    for line in r.stdout.splitlines():
        if line.startswith("values "):
            out["values"].append(np.array([float(v) for v in line.split()[1:]]))
        elif line.startswith(("status ", "log ", "saved ", "restored ")):
            out["lines"].append(line)
    return out


def fmu_pair(robot: str, folder: Path, fmi: int = 2) -> tuple[Unpacked, Unpacked]:
    """The robot's plant and controller FMUs (FMI ``fmi``), unzipped under ``folder``."""
    out = []
    for name, ident in (("plant", robot), ("ctrl", fmu.fmu_id(robot) + "_CTRL")):
        if fmi == 2:
            out.append(Unpacked(fmu.fmu_path(ident), folder / name))
        else:
            out.append(Unpacked3(fmu.fmu_path(ident, fmi=3), folder / f"{name}3", fmu.fmu_path(ident)))
    return out[0], out[1]


# The FMI 2.0 function named in a message, and its FMI 3.0 counterpart.
FMI3_NAME = {"fmi2SetReal": "fmi3SetFloat64", "fmi2SetInteger": "fmi3SetInt32", "fmi2GetReal": "fmi3GetFloat64",
             "fmi2DoStep": "fmi3DoStep", "fmi2ExitInitializationMode": "fmi3ExitInitializationMode",
             "fmi2GetDerivatives": "fmi3GetContinuousStateDerivatives",
             "fmi2CompletedIntegratorStep": "fmi3CompletedIntegratorStep"}


def as_fmi3(lines: list[str]) -> list[str]:
    """An FMI 2.0 run's output lines as the FMI 3.0 FMU says them (its function names)."""
    out = []
    for ln in lines:
        for a, b in FMI3_NAME.items():
            ln = ln.replace(a + ":", b + ":")
        out.append(ln)
    return out


def largest_difference(a: dict, b: dict) -> float:
    """The largest difference between two runs' printed values (relative where |v| > 1)."""
    assert len(a["values"]) == len(b["values"]), (a, b)
    d = 0.0
    for u, v in zip(a["values"], b["values"]):
        d = max(d, float(np.max(np.abs(u - v) / np.maximum(1.0, np.abs(u)))))
    return d
