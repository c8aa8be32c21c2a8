"""The plant FMUs (FMI 2.0, Model Exchange + Co-Simulation) built by ``fmu/``.

The FMUs wrap the reference core: they contain no physics of their own.  This module
finds the built ``.fmu``, validates and simulates it with fmpy, and offers
:class:`FMUInstance`, a small stepping wrapper over ``fmpy.fmi2.FMU2Slave`` /
``FMU2Model`` that addresses variables by name.  See ``docs/fmu.md``.

Units are SI: time [s], pose [m, rad], efforts [N or N m].

Example
-------
>>> from cosim import fmu
>>> path = fmu.fmu_path("6pus")              # build/fmu/PKM_6PUS.fmu
>>> fmu.validate(path)
[]
>>> res = fmu.simulate(path, stop_time=0.1, tau=[1.0] * 6, outputs=["z", "q[1]"])
>>> res["z"][-1]
"""
from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np

from . import _fmu_build
from ._fmu_build import PLATFORMS
from .errors import FMUError, InputError

__all__ = ["FMU_IDS", "PLATFORMS", "fmu_id", "fmu_path", "build", "package", "validate", "variable_names", "simulate", "restore_fmpy_logger",
           "FMUInstance", "FMUError"]

REPO = Path(__file__).resolve().parent.parent


def _is_file(robot: str) -> bool:
    return robot.endswith(".toml") or "/" in robot or os.sep in robot


def fmu_id(robot: str) -> str:
    """Model identifier (and .fmu file name) of a robot's plant FMU: ``PKM_<ROBOT>``, the
    name fmu_gen gives a model folder's FMU (a robot without a folder has none); for a
    description file, its name without ``.toml`` (``my_stewart.toml`` -> ``PKM_MY_STEWART``).
    An identifier given as such (``"PKM_6PUS"``) is returned unchanged."""
    if robot.startswith("PKM_"):
        return robot
    if _is_file(robot):
        robot = Path(robot).name.removesuffix(".toml")
    return "PKM_" + "".join(c if c.isalnum() else "_" for c in robot.upper())


class _FmuIds(dict):
    """Deprecated alias of :func:`fmu_id` (one release): ``FMU_IDS[robot]``."""

    def __missing__(self, robot):
        return fmu_id(robot)

    def get(self, robot, default=None):
        return fmu_id(robot)


FMU_IDS = _FmuIds()


def build_dir() -> Path:
    """The CMake build directory: ``$PKM_BUILD_DIR`` or ``<repo>/build``."""
    return Path(os.environ.get("PKM_BUILD_DIR", REPO / "build"))


def fmu_path(robot: str = "6pus", build: str | Path | None = None, fmi: int = 2) -> Path:
    """Path of a robot's built FMU, ``<build>/fmu/<ID>.fmu`` (FMI 2.0) or
    ``<build>/fmu/fmi3/<ID>.fmu`` (``fmi=3``); raises if it is not built.
    A description file's FMU is built on demand by :func:`build` (``cosim fmu PATH.toml``)."""
    ident = fmu_id(robot)
    if fmi not in (2, 3):
        raise InputError(f"FMI {fmi}: the FMUs are FMI 2.0 or 3.0 (fmi=2 or 3)")
    folder = Path(build or build_dir()) / "fmu"
    p = folder / f"{ident}.fmu" if fmi == 2 else folder / "fmi3" / f"{ident}.fmu"
    if not p.exists():
        target = f"{ident}_fmu" if fmi == 2 else f"{ident}_fmu3"
        how = (f"cosim fmu {robot} --out DIR (or cosim.fmu.build({robot!r}))" if _is_file(robot) else
               f"./scripts/bootstrap.sh (or cmake --build {folder.parent} --target {target})")
        raise FileNotFoundError(f"{p} is not built: run {how}")
    return p


# The binaries/ folder of each platform in an FMI 3.0 FMU (the platform tuples).
FMI3_PLATFORMS = {"linux64": "x86_64-linux", "win64": "x86_64-windows", "aarch64-linux": "aarch64-linux"}


def build(robot: str = "6pus", build: str | Path | None = None, jobs: int = 2, platforms=None) -> Path:
    """Build (or bring up to date) a robot's FMUs (plant, controller, source-code; FMI 2.0 and
    3.0) with CMake and return the FMI 2.0 plant's path.

    A robot the toolkit lists: its targets in the build directory, with the platforms it was
    configured for (``platforms`` is not used).  A description file anywhere
    (``"my_stewart.toml"``): its FMUs in a build tree of their own,
    ``<build>/fmu_descriptions/<ID>/`` (nothing in the checkout changes), made from the build
    directory's fmu_gen and core of every platform (only their FMU layer compiles), then copied
    to ``<build>/fmu`` beside the listed robots' FMUs; ``platforms`` (names of ``PLATFORMS``,
    each one the build directory makes; None: all it makes) are the binaries to make.  The
    build directory is never configured again: no other FMU is removed or replaced meanwhile,
    and two description files build at once.

    Example
    -------
    >>> from cosim import fmu
    >>> fmu.build("my_stewart.toml", platforms=["linux64"])   # build/fmu/PKM_MY_STEWART.fmu
    """
    ident = fmu_id(robot)
    b = Path(build or build_dir())
    if _is_file(robot):
        desc = Path(robot).resolve()
        if not desc.is_file():
            raise FileNotFoundError(f"{robot}: no such description file")
        from .core import Model

        Model(str(desc))  # a mistake in the file: its line, in one InputError, before any build
        _fmu_build.build_description(desc, ident, b, jobs, platforms)
    else:
        _fmu_build.build_listed(ident, b, jobs)
    return fmu_path(robot, b)


_build_fmus = build  # for package(), whose ``build`` argument is the folder


def package(robot: str, *, out: str | Path, platforms=("linux64",), source: bool = False, fmi: int = 2,
            build: str | Path | None = None) -> list[Path]:
    """Write a robot's FMUs for the platforms a user asks for into ``out``.

    Parameters
    ----------
    robot : str
        A robot the toolkit lists (``"6pus"``, ``"quattro"``) or a description file.
    out : str or Path
        Folder to write to (created): ``<ID>.fmu`` (plant) and ``<ID>_CTRL.fmu`` (controller),
        each with the binaries of ``platforms``; with ``source``, ``<ID>_sources.fmu`` and
        ``<ID>_CTRL_sources.fmu`` too (source-code FMUs, docs/fmu.md).
    platforms : sequence of str
        Any of ``PLATFORMS``: ``linux64``, ``win64``, ``aarch64-linux``.
    source : bool
        Also the source-code FMUs.
    fmi : int
        FMI version: 2 or 3 (FMI 3.0: the same binaries under the FMI 3.0 platform tuples,
        ``x86_64-linux``, ``x86_64-windows``, ``aarch64-linux``; no source-code FMU).

    Returns
    -------
    list of Path
        The files written.

    Example
    -------
    >>> from cosim import fmu
    >>> fmu.package("6pus", out="out/fmus", platforms=["linux64", "win64"], source=True)
    >>> fmu.package("6pus", out="out/fmi3", platforms=["linux64", "aarch64-linux"], fmi=3)
    """
    import zipfile

    if fmi not in (2, 3):
        raise InputError(f"FMI {fmi}: this build makes FMI 2.0 and FMI 3.0 FMUs (--fmi 2 or 3)")
    if fmi == 3 and source:
        raise InputError("FMI 3: the source-code FMUs are FMI 2.0 only (drop --source or use --fmi 2)")
    bad = [p for p in platforms if p not in PLATFORMS]
    if bad:
        raise InputError(f"unknown platform {bad[0]!r}: use {', '.join(PLATFORMS)}")
    b = Path(build or build_dir())
    ident = fmu_id(robot)
    folder = b / "fmu" if fmi == 2 else b / "fmu" / "fmi3"
    made = [folder / f"{i}.fmu" for i in (ident, ident + "_CTRL")]
    asked = list(platforms)
    platforms = [p if fmi == 2 else FMI3_PLATFORMS[p] for p in platforms]
    if _is_file(robot) or not all(p.exists() for p in made):
        _build_fmus(robot, b, platforms=asked)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for src in made:
        with zipfile.ZipFile(src) as z:
            names = z.namelist()
            have = {n.split("/")[1] for n in names if n.startswith("binaries/") and n.count("/") == 2
                    and not n.endswith("/")}
            missing = [p for p in platforms if p not in have]
            if missing:
                raise FileNotFoundError(f"{src} has no {missing[0]} binary: its cross compiler was not installed "
                                        f"when the build ran (scripts/bootstrap.sh installs them)")
            dst = out / src.name
            with zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as w:
                for n in names:
                    parts = n.split("/")
                    if parts[0] == "binaries" and len(parts) > 1 and parts[1] not in platforms:
                        continue
                    w.writestr(z.getinfo(n), z.read(n))
        written.append(dst)
        if source:
            s = b / "fmu" / "source" / src.name
            if not s.exists():
                raise FileNotFoundError(f"{s} is not built (cmake --build {b} --target {src.stem}_source_fmu)")
            dst = out / f"{src.stem}_sources.fmu"
            shutil.copyfile(s, dst)
            written.append(dst)
    return written


def validate(path: str | Path) -> list[str]:
    """fmpy's validation of the FMU (schema, names, model structure, units): a list of problems."""
    from fmpy.validation import validate_fmu

    return validate_fmu(str(path))


def variable_names(path_or_md) -> dict[str, list[str]]:
    """Names of the plant's vector variables, found from the model structure.

    Returns a dict with ``tau`` (inputs), ``x`` and ``xd`` (the continuous states: pose
    and pose rate, in state order), ``xdd`` (their second derivatives), ``x0`` and ``xd0``
    (the initial-state parameters: state name + ``0``), ``q`` and ``qd``.
    """
    from fmpy import read_model_description

    md = path_or_md if hasattr(path_or_md, "modelVariables") else read_model_description(str(path_or_md))
    nx = len(md.derivatives) // 2
    der = [u.variable for u in md.derivatives]
    names = {
        "tau": [v.name for v in md.modelVariables if v.causality == "input"],
        "x": [d.derivative.name for d in der[:nx]],
        "xd": [d.name for d in der[:nx]],
        "xdd": [d.name for d in der[nx:]],
    }
    names["x0"] = [n + "0" for n in names["x"]]
    names["xd0"] = [n + "0" for n in names["xd"]]
    names["q"] = [f"q[{i}]" for i in range(1, nx + 1)]
    names["qd"] = [f"qd[{i}]" for i in range(1, nx + 1)]
    return names


def simulate(path, fmi_type: str = "CoSimulation", stop_time: float = 1.0, step: float = 1e-3,
             tau=None, params: dict | None = None, x0=None, xd0=None, rtol: float | None = None,
             outputs: list[str] | None = None, logger=None):
    """Simulate the FMU with ``fmpy.simulate_fmu`` under a constant actuator effort.

    Parameters
    ----------
    path : str or Path
        The ``.fmu`` (see :func:`fmu_path`).
    fmi_type : {"CoSimulation", "ModelExchange"}
        CS integrates inside the FMU (the core's integrator, ``solver.method``: RK 5(4) by default); ME with fmpy's own CVode.
    stop_time, step : float
        End time and communication (output) step [s].
    tau : array_like, optional
        Constant actuator efforts [N or N m], one per actuator (default 0).
    params : dict, optional
        Start values by FMU variable name (robot parameters, ``solver.*``...).
    x0, xd0 : array_like, optional
        Initial pose [m, rad] and pose rate (default: home pose at rest).
    rtol : float, optional
        Relative tolerance: fmpy's CVode (ME), or passed to the FMU by
        fmi2SetupExperiment (CS, replaces ``solver.rtol``).
    outputs : list of str, optional
        Variables to record (default: the pose).

    Returns
    -------
    numpy structured array with a ``time`` field and one field per output.
    """
    from fmpy import simulate_fmu

    names = variable_names(path)
    start = dict(params or {})
    if tau is not None:
        start.update(zip(names["tau"], np.broadcast_to(np.asarray(tau, float), (len(names["tau"]),)).tolist()))
    if x0 is not None:
        start.update(zip(names["x0"], np.asarray(x0, float).tolist()))
    if xd0 is not None:
        start.update(zip(names["xd0"], np.asarray(xd0, float).tolist()))
    if logger is None:
        return simulate_fmu(str(path), fmi_type=fmi_type, stop_time=stop_time, output_interval=step,
                            start_values=start, relative_tolerance=rtol, output=outputs or names["x"])
    try:
        return simulate_fmu(str(path), fmi_type=fmi_type, stop_time=stop_time, output_interval=step,
                            start_values=start, relative_tolerance=rtol, output=outputs or names["x"],
                            logger=logger)
    finally:
        restore_fmpy_logger()


# fmpy formats an FMU's printf-style log messages in a native proxy that forwards to ONE
# process-wide Python callback; ``simulate_fmu(logger=...)`` points that proxy at a ctypes
# callback freed when the call returns, so every later FMU instantiated with fmpy's default
# callbacks would log through freed memory (a crash, or messages silently lost).  The
# callback kept here lives as long as the process.
_FMPY_DEFAULT_LOGGER = None


def restore_fmpy_logger() -> None:
    """Point fmpy's native log proxy back at fmpy's own printing logger.

    Call after ``fmpy.simulate_fmu(..., logger=f)`` returns (:func:`simulate` does):
    fmpy leaves its process-wide proxy pointing at ``f``'s ctypes wrapper, which is freed
    with the call, and the next FMU instantiated with fmpy's default callbacks would log
    through it.
    """
    global _FMPY_DEFAULT_LOGGER
    from ctypes import byref

    from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, printLogMessage
    from fmpy.logging import addLoggerProxy

    if _FMPY_DEFAULT_LOGGER is None:
        _FMPY_DEFAULT_LOGGER = fmi2CallbackLoggerTYPE(printLogMessage)
    cb = fmi2CallbackFunctions()
    cb.logger = _FMPY_DEFAULT_LOGGER
    addLoggerProxy(byref(cb))


class FMUInstance:
    """One instance of a plant FMU, stepped by hand (Co-Simulation or Model Exchange).

    Variables are addressed by name (``"tau[1]"``, ``"z"``, ``"leg[1].L"``...) with
    :meth:`get` / :meth:`set`, whole vectors by the keys of :func:`variable_names`
    (``"x"``, ``"tau"``...) with :meth:`vector` / :meth:`set_vector`.  Every log
    line of the instance is kept in :attr:`log` (``"<status> [<category>] <message>"``),
    and a failing call raises :class:`FMUError` carrying them.

    Parameters
    ----------
    path : str or Path
        The ``.fmu``.
    kind : {"CoSimulation", "ModelExchange"}
    name : str
        Instance name (shows in the log).
    params : dict, optional
        Start values by name, set before initialization.
    start_time : float
        Initial time [s].
    initialize : bool
        Run setupExperiment / initialization now (default); with False, call
        :meth:`initialize` after setting values.
    """

    def __init__(self, path, kind: str = "CoSimulation", name: str = "plant", params: dict | None = None,
                 start_time: float = 0.0, initialize: bool = True, tolerance: float | None = None,
                 unzip_dir: str | None = None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Model, FMU2Slave

        self.path = str(path)
        self.md = read_model_description(self.path)
        self.kind = kind
        self.names = variable_names(self.md)
        self.vars = {v.name: v for v in self.md.modelVariables}
        self._own_unzip = unzip_dir is None
        self._unzip = unzip_dir or extract(self.path)
        self.log: list[str] = []
        cls, ident = ((FMU2Slave, self.md.coSimulation.modelIdentifier) if kind == "CoSimulation"
                      else (FMU2Model, self.md.modelExchange.modelIdentifier))
        self.fmu = cls(guid=self.md.guid, unzipDirectory=self._unzip, modelIdentifier=ident, instanceName=name)
        self._alive = False
        try:
            self.fmu.instantiate(loggingOn=False, callbacks=self._callbacks())
        except Exception as e:
            raise FMUError(f"fmi2Instantiate of {self.path} failed: "
                           f"{self.log[-1] if self.log else e}", self.log) from e
        self.time = start_time
        self._tolerance = tolerance
        self._alive = True
        for k, v in (params or {}).items():
            self.set(k, v)
        if initialize:
            self.initialize()

    # the log ---------------------------------------------------------------
    def _callbacks(self):
        # The FMU copies the callbacks at instantiation: the logger must be ours from the
        # start.  Lines are kept (not printed) so callers and tests can read them.
        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

        def logger(env, instance, status, category, message):
            st = ["OK", "Warning", "Discard", "Error", "Fatal", "Pending"][status] if 0 <= status <= 5 else str(status)
            # The message is a printf format without arguments (the PKM FMUs pre-format and
            # escape '%'); fmpy's formatting proxy is process-global, so it is not used here.
            self.log.append(f"{st} [{category.decode()}] {message.decode().replace('%%', '%')}")

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb  # keep the callbacks alive as long as the instance
        return cb

    def _call(self, what, fn, *args):
        from fmpy.fmi1 import FMICallException

        try:
            return fn(*args)
        except FMICallException as e:
            last = self.log[-1] if self.log else "(no log line)"
            raise FMUError(f"{what} failed (status {e.status}): {last}", self.log) from e

    # values ----------------------------------------------------------------
    def _var(self, name):
        if name not in self.vars:
            raise KeyError(f"{self.path}: no variable {name!r}")
        return self.vars[name]

    def set(self, name: str, value):
        """Set one variable by name (an Integer variable takes int(value))."""
        v = self._var(name)
        if v.type == "Integer":
            self._call(f"setInteger({v.name})", self.fmu.setInteger, [v.valueReference], [int(value)])
        else:
            self._call(f"setReal({v.name})", self.fmu.setReal, [v.valueReference], [float(value)])

    def get(self, name: str):
        """Value of one variable by name."""
        v = self._var(name)
        if v.type == "Integer":
            return self._call(f"getInteger({v.name})", self.fmu.getInteger, [v.valueReference])[0]
        return self._call(f"getReal({v.name})", self.fmu.getReal, [v.valueReference])[0]

    def set_vector(self, key: str, values):
        """Set a vector of :func:`variable_names` (``"tau"``, ``"x0"``...) in one call."""
        refs = [self._var(n).valueReference for n in self.names[key]]
        vals = np.broadcast_to(np.asarray(values, float), (len(refs),)).tolist()
        self._call(f"setReal({key})", self.fmu.setReal, refs, vals)

    def vector(self, key: str) -> np.ndarray:
        """A vector of :func:`variable_names` (``"x"``, ``"q"``...) as an array."""
        refs = [self._var(n).valueReference for n in self.names[key]]
        return np.array(self._call(f"getReal({key})", self.fmu.getReal, refs))

    # life cycle --------------------------------------------------------------
    def initialize(self):
        tol = self._tolerance
        self._call("setupExperiment", self.fmu.setupExperiment, tol, self.time)
        self._call("enterInitializationMode", self.fmu.enterInitializationMode)
        self._call("exitInitializationMode", self.fmu.exitInitializationMode)
        if self.kind == "ModelExchange":
            self.fmu.newDiscreteStates()
            self.fmu.enterContinuousTimeMode()

    def step(self, h: float, tau=None):
        """Co-Simulation: hold ``tau`` (if given) and advance by ``h`` [s]."""
        if tau is not None:
            self.set_vector("tau", tau)
        self._call(f"doStep(t={self.time!r}, h={h!r})", self.fmu.doStep, self.time, h)
        self.time += h

    def last_successful_time(self) -> float:
        from fmpy.fmi2 import fmi2LastSuccessfulTime

        return self.fmu.getRealStatus(fmi2LastSuccessfulTime)

    # FMU state ----------------------------------------------------------------
    def get_state(self):
        return self._call("getFMUstate", self.fmu.getFMUState)

    def set_state(self, state, time: float | None = None):
        self._call("setFMUstate", self.fmu.setFMUState, state)
        if time is not None:
            self.time = time

    def free_state(self, state):
        self.fmu.freeFMUState(state)

    def serialize(self, state) -> bytes:
        return bytes(self._call("serializeFMUstate", self.fmu.serializeFMUState, state))

    def deserialize(self, data: bytes):
        return self._call("deSerializeFMUstate", self.fmu.deSerializeFMUstate, bytes(data))

    # Model Exchange ----------------------------------------------------------------
    def _vec_call(self, what, fn, x):
        import ctypes

        return self._call(what, fn, x.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), x.size)

    def continuous_states(self) -> np.ndarray:
        """Model Exchange: the state vector (x, xd) [m, rad, m/s, rad/s]."""
        x = np.zeros(2 * len(self.names["x"]))
        self._vec_call("getContinuousStates", self.fmu.getContinuousStates, x)
        return x

    def set_continuous_states(self, x):
        x = np.ascontiguousarray(x, float)
        self._vec_call("setContinuousStates", self.fmu.setContinuousStates, x)

    def derivatives(self) -> np.ndarray:
        """Model Exchange: d(x, xd)/dt = (xd, xdd)."""
        dx = np.zeros(2 * len(self.names["x"]))
        self._vec_call("getDerivatives", self.fmu.getDerivatives, dx)
        return dx

    def close(self):
        if getattr(self, "_alive", False):
            try:
                self.fmu.terminate()
            except Exception:
                pass  # terminate is not allowed from every state; freeing always is
            self.fmu.freeInstance()
            self._alive = False
        if getattr(self, "_own_unzip", False) and getattr(self, "_unzip", None):
            shutil.rmtree(self._unzip, ignore_errors=True)
            self._unzip = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
