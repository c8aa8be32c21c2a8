"""Plants: what the closed loop steps, behind one interface (:class:`Plant`).

* :class:`CorePlant`: the core integrated directly (:class:`cosim.simulate.Simulator`,
  explicit Runge-Kutta 5(4) by default), the reference plant;
* :class:`FMUPlant`: a robot's Co-Simulation FMU driven through fmpy's ``FMU2Slave``,
  inputs and outputs addressed by variable name.

:class:`CoreDrive` is the plant's drive and sensor model from the core (the effort applied,
the joint readings).  :class:`cosim.closed_loop.ClosedLoop` steps a plant under a controller;
:func:`cosim.master.run` runs it over a reference (``from cosim.master import CorePlant``
works too: the master's interface names its plants).

Example
-------
>>> from cosim.core import Model
>>> from cosim.plants import CorePlant
>>> m = Model("6pus")
>>> p = CorePlant(m)
>>> p.initialize(0.0, m.home())
>>> p.set_input(m.gravity_load(m.home()))
>>> p.do_step(0.0, 1e-3)
>>> p.outputs().q.shape
(6,)
"""
from __future__ import annotations

import shutil
from dataclasses import dataclass

import numpy as np

from .errors import MasterError


def _facts(robot):
    """The core's facts of a robot, or None for a name the core does not know (an FMU of
    another origin)."""
    from ._native import PkmError
    from .core.model import robot_facts

    try:
        return robot_facts(robot)
    except PkmError:
        return None


@dataclass
class PlantOutputs:
    """What a plant shows at a communication point (true values, before sensor noise)."""

    q: np.ndarray    # joints [m or rad]
    qd: np.ndarray   # joint rates
    x: np.ndarray    # pose [m, rad]
    xd: np.ndarray   # pose rate
    drive: tuple | None = None  # (theta, theta_d) of the drive bodies (drive.two_body), else None


class Plant:
    """Interface of a plant the master can step."""

    robot: str
    ndof: int
    kind: str = "plant"

    def initialize(self, t0: float, x0, xd0=None) -> None:
        raise NotImplementedError

    def set_input(self, tau) -> None:
        raise NotImplementedError

    def do_step(self, t: float, h: float) -> None:
        """Advance from ``t`` to ``t + h`` with the input held [s]."""
        raise NotImplementedError

    def outputs(self) -> PlantOutputs:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def describe(self) -> dict:
        return {"kind": self.kind}

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class CorePlant(Plant):
    """The core integrated directly (pkm_sim): the reference plant.

    Parameters
    ----------
    model : cosim.core.Model
        The plant's model (its parameters are the "true" robot).
    rtol, atol : float
        Integrator tolerances (relative; absolute on the task-space state [m, rad, m/s, rad/s]).
    method : {"erk", "erk23", "bdf", "adams"}
        Integration method (:class:`cosim.simulate.Simulator`): explicit Runge-Kutta 5(4)
        (default), 3(2) (throughput at rtol ~1e-6), or CVODE's BDF / Adams.
    max_step : float
        Largest internal step [s] (0: unlimited).
    """

    kind = "core"

    def __init__(self, model, rtol: float = 1e-10, atol: float = 1e-12, method: str = "erk",
                 max_step: float = 0.0):
        from .simulate import Simulator

        self.model = model
        self.robot = model.robot
        self.ndof = model.ndof
        self.options = {"rtol": rtol, "atol": atol, "method": method, "max_step": max_step}
        self.sim = Simulator(model, rtol=rtol, atol=atol, method=method, max_step=max_step)
        self._t = None

    def initialize(self, t0, x0, xd0=None):
        x0 = np.asarray(x0, float)
        xd0 = np.zeros(self.ndof) if xd0 is None else np.asarray(xd0, float)
        self.sim.set_input(np.zeros(self.ndof))  # a run starts with nothing commanded
        self.sim.set_external(np.zeros(self.ndof))  # and no external effort
        self.sim.reset(t0, x0, xd0)

    def set_input(self, tau):
        self.sim.set_input(np.asarray(tau, float))

    def set_external(self, f):
        """Hold a known external effort per joint [N or N m], positive along +q (added to the
        actuator effort)."""
        self.sim.set_external(np.asarray(f, float))

    def applied_effort(self):
        """Effort acting on the mechanism now [N or N m]: the held command after the drive's
        saturation, or with ``actuator.delay`` the one issued that much earlier (the core's
        delay line, ``pkm_sim_applied_effort``)."""
        return self.sim.applied_effort

    def do_step(self, t, h):
        self.sim.advance(t + h)

    def outputs(self):
        t, x, xd = self.sim.state
        q = self.model.ik(x)
        qd = self.model.joint_velocity(x, xd)
        drive = self.sim.drive_state if self.model.two_body_joints() else None
        return PlantOutputs(q, qd, x, xd, drive)

    def describe(self):
        return {"kind": "core", **self.options}


class CoreDrive:
    """The plant's drive and sensor model from the core, applied by the master.

    The plants integrate the mechanics and clip the effort at ``effort_max`` inside;
    what the robot's own controller logs is computed here from the plant's parameters,
    the same way for the FMU and the core plant: the effort actually applied
    (``pkm_actuator_effort``: saturation) and the joint readings
    (``pkm_measure_joints``: encoder offset, backlash, transmission compliance).

    Parameters
    ----------
    model : cosim.core.Model
        The plant's ("true") model.
    """

    def __init__(self, model):
        self.model = model
        self.ndof = model.ndof
        self._line = None  # the readings' delay line (sensor.delay): the core's

    def delayed(self, t, q, qd):
        """The readings the sensors deliver at time t [s] (``sensor.delay``): the readings
        recorded at t, interpolated linearly between the samples around t - delay (the first
        sample's before it), by the core's delay line (``pkm_reading_delay``, the line of
        its compiled loop); :meth:`reset_delay` empties it."""
        if self._line is None:
            self.reset_delay()
        return self._line.read(t, q, qd)

    def reset_delay(self):
        """A new, empty delay line, of the model's ``sensor.delay`` now."""
        from .core.reading_delay import ReadingDelay

        self._line = ReadingDelay(self.model)

    def applied(self, tau_cmd):
        """Effort reaching the mechanism [N or N m] for the commanded one."""
        return self.model.actuator_effort(np.asarray(tau_cmd, float))

    def measure(self, x, xd, tau):
        """Encoder readings [m or rad] at (x, xd) under the applied effort tau."""
        return self.model.measure_joints(np.asarray(x, float), np.asarray(xd, float), np.asarray(tau, float))

    def read(self, y, tau):
        """Encoder readings and rates from a plant's outputs ``y`` under the applied effort:
        the reading model, and on a two-body joint its drive body (``y.drive``; the core's
        ``pkm_sensor_readings``)."""
        if y.drive is None or not self.model.two_body_joints():
            return self.measure(y.x, y.xd, tau), y.qd
        return self.model.sensor_readings(y.x, y.xd, tau, y.drive)


class FMUPlant(Plant):
    """A Co-Simulation FMU driven through fmpy (``fmpy.fmi2.FMU2Slave``).

    Variables are addressed by name, as in the FMU's ``modelDescription.xml``:
    ``tau[i]`` inputs, ``q[i]``/``qd[i]`` joint outputs, the pose coordinates
    (6-PUS ``x, y, z, rx, ry, rz``), their rates (``xd``...), the initial pose and rate
    parameters (``x0``..., ``xd0``...), see ``NAMES`` and ``POSE``.

    Parameters
    ----------
    fmu : str or Path
        The ``.fmu`` file.
    parameters : dict, optional
        Start values by variable name, set before initialization (the "true" robot).
    rtol, atol : float, optional
        The integrator's tolerances inside the FMU (parameters ``solver.rtol``, ``solver.atol``);
        the defaults are :class:`CorePlant`'s, so both plants integrate alike.  None
        keeps the FMU's own start values.
    names : dict, optional
        Overrides of the names of a channel (``"tau"``, ``"q"``, ``"qd"``, ``"x"``,
        ``"xd"``, ``"x0"``, ``"xd0"``): a format string of the 1-based index ``{i}`` or
        a list of nd names.
    instance_name : str
        The FMU instance's name.
    robot : str, optional
        The robot the FMU models (a name or a description file), for its pose names; by
        default the listed robot whose FMU identifier (``PKM_<ROBOT>``) the FMU has.
    """

    kind = "fmu"
    #: variable names of the joint channels: format strings of the 1-based joint index i
    NAMES = {"tau": "tau[{i}]", "q": "q[{i}]", "qd": "qd[{i}]", "rtol": "solver.rtol", "atol": "solver.atol"}
    # The pose coordinates are the core's (RobotFacts.pose_names); the FMU names the rate
    # "<c>d", the initial pose "<c>0" and the initial rate "<c>d0" (fmu/<robot>/variables.txt).

    def __init__(self, fmu, parameters: dict | None = None, rtol: float | None = 1e-10,
                 atol: float | None = 1e-12, names: dict | None = None, instance_name: str = "plant",
                 robot: str | None = None):
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self.path = str(fmu)
        self.md = read_model_description(self.path)
        if self.md.coSimulation is None:
            raise MasterError(f"{self.path}: the FMU has no Co-Simulation interface")
        self.vars = {v.name: v for v in self.md.modelVariables}
        self.ndof = sum(1 for v in self.md.modelVariables if v.causality == "input")
        if self.ndof == 0:
            raise MasterError(f"{self.path}: the FMU has no inputs (expected the actuator efforts)")
        self.robot = robot or self._robot()  # a description file's FMU is named after the file, not a listed robot
        facts = _facts(self.robot)
        pose = list(facts.pose_names) if facts else [f"x{i}" for i in range(1, self.ndof + 1)]
        self.names = {**self.NAMES, "x": pose, "xd": [c + "d" for c in pose], "x0": [c + "0" for c in pose],
                      "xd0": [c + "d0" for c in pose], **(names or {})}
        self.parameters = dict(parameters or {})
        self.rtol, self.atol = rtol, atol
        self.vr = {key: self._refs(key) for key in ("tau", "q", "qd", "x", "xd", "x0", "xd0")}
        # the drive bodies (drive.two_body), in FMUs that have them
        drive = [[f"{k}[{i}]" for i in range(1, self.ndof + 1)] for k in ("q_drive", "qd_drive")]
        self.vr_drive = ([[self.vars[n].valueReference for n in names] for names in drive]
                         if all(n in self.vars for names in drive for n in names) else None)
        self._unzip = extract(self.path)
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=self._unzip,
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=instance_name)
        self._instantiated = False

    def _robot(self):
        """The core robot the FMU packs: its model identifier is ``PKM_<ROBOT>`` (fmu_gen)."""
        from .core.facts import robots

        ident = self.md.coSimulation.modelIdentifier
        for r in robots():
            if ident.lower() == f"pkm_{r}":
                return r
        return "unknown"

    def _refs(self, key):
        spec = self.names[key]
        names = [spec.format(i=i) for i in range(1, self.ndof + 1)] if isinstance(spec, str) else list(spec)
        if len(names) != self.ndof:
            raise MasterError(f"{self.path}: {len(names)} names for {key}, the FMU has {self.ndof} inputs")
        refs = []
        for name in names:
            if name not in self.vars:
                raise MasterError(f"{self.path}: no variable {name!r} in the FMU "
                                  f"(expected for {key}; pass names={{'{key}': ...}} to map it)")
            refs.append(self.vars[name].valueReference)
        return refs

    def _set(self, name, value):
        if name not in self.vars:
            raise MasterError(f"{self.path}: no variable {name!r} in the FMU")
        v = self.vars[name]
        if v.type == "Integer":
            self.fmu.setInteger([v.valueReference], [int(value)])
        elif v.type == "Boolean":
            self.fmu.setBoolean([v.valueReference], [bool(value)])
        else:
            self.fmu.setReal([v.valueReference], [float(value)])

    def initialize(self, t0, x0, xd0=None):
        x0 = np.asarray(x0, float)
        xd0 = np.zeros(self.ndof) if xd0 is None else np.asarray(xd0, float)
        if self._instantiated:
            self.fmu.reset()
        else:
            self.fmu.instantiate(callbacks=self._callbacks())
            self._instantiated = True
        try:
            self.fmu.setupExperiment(startTime=t0)
            for name, value in self.parameters.items():
                self._set(name, value)
            if self.rtol is not None and self.names["rtol"] in self.vars:
                self._set(self.names["rtol"], self.rtol)
            if self.atol is not None and self.names["atol"] in self.vars:
                self._set(self.names["atol"], self.atol)
            self.fmu.setReal(self.vr["x0"], list(x0))
            self.fmu.setReal(self.vr["xd0"], list(xd0))
            self.fmu.enterInitializationMode()
            self.fmu.exitInitializationMode()
        except Exception as e:
            raise MasterError(f"{self.path}: initialization at t = {t0} s failed: {self._last_log(e)}") from e

    def _callbacks(self):
        # The FMU keeps the callbacks it was instantiated with: collect its log lines so an
        # error can say what the FMU said (which leg, which time), not only a status.
        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                               fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)

        self.log = []

        # The PKM FMUs pre-format their messages (a printf format without arguments, '%'
        # escaped): fmpy's native formatting proxy is not used, as it forwards to one
        # process-wide callback that would outlive this instance's.
        def logger(env, instance, status, category, message):
            self.log.append(message.decode(errors="replace").replace("%%", "%"))

        cb = fmi2CallbackFunctions()
        cb.logger = fmi2CallbackLoggerTYPE(logger)
        cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        self._cb = cb
        return cb

    def _last_log(self, e):
        return f"{e}: {self.log[-1]}" if getattr(self, "log", None) else str(e)

    def set_input(self, tau):
        self.fmu.setReal(self.vr["tau"], [float(v) for v in tau])

    def do_step(self, t, h):
        try:
            self.fmu.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        except Exception as e:
            raise MasterError(f"{self.path}: fmi2DoStep from t = {t:.9g} s (h = {h} s) failed: "
                              f"{self._last_log(e)}") from e

    def outputs(self):
        g = self.fmu.getReal
        # the drive side (its joints' own values unless a joint is two bodies)
        drive = None if self.vr_drive is None else (np.array(g(self.vr_drive[0])), np.array(g(self.vr_drive[1])))
        return PlantOutputs(np.array(g(self.vr["q"])), np.array(g(self.vr["qd"])), np.array(g(self.vr["x"])),
                            np.array(g(self.vr["xd"])), drive)

    def close(self):
        if getattr(self, "fmu", None) is not None and self._instantiated:
            try:
                self.fmu.terminate()
            except Exception:
                pass  # a failed run may leave the FMU in an error state; freeing is still allowed
            self.fmu.freeInstance()
            self._instantiated = False
        if getattr(self, "_unzip", None):
            shutil.rmtree(self._unzip, ignore_errors=True)
            self._unzip = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass

    def describe(self):
        d = {"kind": "fmu", "fmu": self.path, "model": self.md.modelName}
        if self.rtol is not None:
            d["rtol"] = self.rtol
        if self.atol is not None:
            d["atol"] = self.atol
        return d
