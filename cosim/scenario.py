"""Declarative co-simulation scenarios (TOML): load, run, measure, export.

A scenario file names the robot, the parameter overrides of the model the controller
believes in (``[parameters]``) and of the plant that plays the real robot
(``[plant_parameters]`` values, ``[plant_scale]`` factors, ``[plant_offset]`` additive
errors, all on top of the nominal), the controller and its gains, the
reference, the duration and communication step, the sensor noise and the outputs.
``run_scenario`` runs it against the Co-Simulation FMU or the core (``plant``), then
writes beside each other in the output directory:

* ``<name>.csv`` + ``<name>.json``: the run in ``pkm-recording/1`` (joint readings,
  efforts, ``qref``, the tracker's pose, a ``label`` column tagging held poses);
* ``<name>_metrics.json``: step metrics, steady-state errors and their prediction,
  tracking errors, per-pose results, the plant's true parameters;
* ``<name>.png``: the figure.

The format is documented with examples in ``docs/scenarios.md``; the scenarios shipped
with the project are in ``scenarios/``.

Example
-------
>>> from cosim.scenario import load_scenario, run_scenario
>>> sc = load_scenario("scenarios/6pus_step_pdg.toml")
>>> out = run_scenario(sc, out_dir="results/pdg", figures=False)
>>> out.metrics["steady_state"]["joint_error_max"]      # [m]
"""
from __future__ import annotations

import copy
import json
import subprocess
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import controllers as ctl
from . import trajectories as tr
from .jsonable import jsonable
from .closed_loop import LoopInterrupted
from .master import CoreDrive, CorePlant, FMUPlant, MasterError, make_reference, run
from .errors import InputError

REPO = Path(__file__).resolve().parent.parent

_TOP_KEYS = {"name", "description", "robot", "param_set", "plant", "duration", "step", "seed", "parameters",
             "plant_parameters", "plant_scale", "plant_offset", "integrator", "controller", "reference", "initial", "noise",
             "output", "fmu", "tracker"}


class ScenarioError(InputError):
    """A scenario file that cannot be run; names the file and the key."""


@dataclass
class Scenario:
    """A parsed scenario; ``spec`` is the TOML content, ``path`` where it came from."""

    spec: dict
    path: Path | None = None

    @property
    def name(self) -> str:
        return self.spec["name"]

    def get(self, section, key=None, default=None):
        s = self.spec.get(section, {})
        return s if key is None else s.get(key, default)

    def with_overrides(self, **top) -> "Scenario":
        """A copy with top-level keys replaced (``plant="fmu"``, ``duration=0.5``...)."""
        spec = copy.deepcopy(self.spec)
        for k, v in top.items():
            if v is not None:
                spec[k] = v
        return Scenario(_check(spec, self.path), self.path)


@dataclass
class ScenarioResult:
    """What :func:`run_scenario` produced: the run, its metrics and the files written."""

    scenario: Scenario
    result: object          # cosim.run_record.RunRecord
    metrics: dict
    files: dict = field(default_factory=dict)


# ------------------------------------------------------------------- loading

def load_scenario(path) -> Scenario:
    """Read and check a scenario TOML file.

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (format: docs/scenarios.md).

    Raises
    ------
    ScenarioError
        Naming the file and the offending key (unknown key, missing section, wrong
        type or length).
    """
    path = Path(path)
    if not path.exists():
        raise ScenarioError(f"{path}: scenario file not found")
    try:
        spec = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(f"{path}: not valid TOML: {e}") from None
    spec.setdefault("name", path.stem)
    return Scenario(_check(spec, path), path)


def scenario_from_dict(spec: dict, name: str = "scenario") -> Scenario:
    """A scenario from an in-memory dict with the layout of the TOML file.

    Parameters
    ----------
    spec : dict
        Content with the layout of the TOML file.
    name : str
        Name if ``spec`` has none.
    """
    spec = copy.deepcopy(spec)
    spec.setdefault("name", name)
    return Scenario(_check(spec, None), None)


def _check(spec, path):
    where = str(path) if path else "scenario"

    def fail(key, msg):
        raise ScenarioError(f"{where}: {key}: {msg}")

    unknown = set(spec) - _TOP_KEYS
    if unknown:
        fail(sorted(unknown)[0], f"unknown key (known: {', '.join(sorted(_TOP_KEYS))})")
    spec.setdefault("robot", "6pus")
    spec.setdefault("plant", "core")
    spec.setdefault("step", 1e-3)
    spec.setdefault("seed", 0)
    if spec["plant"] not in ("core", "fmu"):
        fail("plant", f"must be 'core' or 'fmu', got {spec['plant']!r}")
    for key in ("duration", "step"):
        if key not in spec:
            fail(key, "missing")
        v = spec[key]
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not v > 0:
            fail(key, f"must be a positive number of seconds, got {v!r}")
    for sec in ("controller", "reference"):
        if not isinstance(spec.get(sec), dict):
            fail(sec, "missing section")
    for sec in ("parameters", "plant_parameters", "plant_scale", "plant_offset", "integrator", "initial", "noise",
                "output", "fmu"):
        if not isinstance(spec.setdefault(sec, {}), dict):
            fail(sec, "must be a table")
    for sec in ("parameters", "plant_parameters", "plant_scale", "plant_offset"):
        for k, v in spec[sec].items():
            if not isinstance(v, (int, float)) or isinstance(v, bool):
                fail(f"{sec}.{k}", f"must be a number, got {v!r}")
    c = spec["controller"]
    if c.get("kind") == "discrete" or c.get("type") == "discrete":
        from .controllers import ControllerError, discrete

        try:
            discrete(c, ndof=1 if not isinstance(c.get("kp"), list) else len(c["kp"]))
        except ControllerError as e:
            field, _, why = str(e).partition(": ")
            fail(field, why)
        c.setdefault("type", "discrete")
    elif c.get("type") not in ("pd", "pd_gravity", "computed_torque", "pid"):
        fail("controller.type", f"must be 'pd', 'pd_gravity', 'computed_torque', 'pid' or 'discrete' (kind = "
             f"\"discrete\"), got {c.get('type')!r}")
    if c["type"] == "discrete":
        pass
    elif c["type"] == "pid":
        if "ki" not in c:
            fail("controller.ki", "missing: a PID needs its integral gain [N/(m s) or N m/(rad s)]")
        for k in ("deriv_filter",):
            if k in c and not (isinstance(c[k], (int, float)) and not isinstance(c[k], bool) and c[k] >= 0):
                fail(f"controller.{k}", f"must be a number >= 0 [s], got {c[k]!r}")
    elif "ki" in c or "deriv_filter" in c:
        fail("controller.ki" if "ki" in c else "controller.deriv_filter", f"only a 'pid' controller takes it "
             f"(this one is {c['type']!r})")
    has_gains = "kp" in c or "kd" in c
    has_design = "bandwidth_hz" in c
    if c["type"] == "discrete":
        pass
    elif has_gains == has_design or (has_gains and not ("kp" in c and "kd" in c)):
        fail("controller", "give either kp and kd, or bandwidth_hz (and optionally damping)")
    r = spec["reference"]
    if r.get("type") not in ("step", "letter_m", "poses", "excitation"):
        fail("reference.type", f"must be 'step', 'letter_m', 'poses' or 'excitation', got {r.get('type')!r}")
    if r.get("angle_unit", "rad") not in ("rad", "deg"):
        fail("reference.angle_unit", "must be 'rad' or 'deg'")
    if r["type"] == "step":
        for k in ("from", "to"):
            if k not in r:
                fail(f"reference.{k}", "missing (the pose before and after the step)")
    if r["type"] == "poses" and not r.get("poses"):
        fail("reference.poses", "missing (a list of poses)")
    for key in ("kp", "kd", "bandwidth_hz", "damping", "saturation"):
        v = c.get(key)
        if c["type"] != "discrete" and v is not None and not _numbers(v):
            fail(f"controller.{key}", f"must be a number or a list of numbers, got {v!r}")
    _check_pose_units(spec, fail)
    _check_tracker(spec, fail)
    return spec


def _check_tracker(spec, fail):
    """``[tracker] pose = "full"``: a 6-DOF tracker that measures x y z rx ry rz (for a robot
    that declares fewer: the parasitic motion of a 3-PRS or 3-RPS head too), ``noise`` its
    standard deviation per component [m, m, m, rad, rad, rad] (default 0)."""
    t = spec.setdefault("tracker", {})
    if not isinstance(t, dict):
        fail("tracker", "must be a table")
    for k in t:
        if k not in ("pose", "noise"):
            fail(f"tracker.{k}", "unknown key (known: pose, noise)")
    if t.get("pose", "declared") not in ("declared", "full"):
        fail("tracker.pose", f"must be 'declared' (the robot's coordinates) or 'full' (x y z rx ry rz), got "
                             f"{t['pose']!r}")
    if t.get("pose") == "full":
        from .core.model import robot_facts
        from .recording import full_pose_allowed

        if not full_pose_allowed(robot_facts(spec["robot"])):
            fail("tracker.pose", f"'full' is for a robot that declares some of x y z rx ry rz; {spec['robot']} "
                                 f"declares {' '.join(robot_facts(spec['robot']).pose_names)}")
    nz = t.get("noise", [0.0] * 6)
    if not (isinstance(nz, list) and len(nz) == 6 and _numbers(nz) and all(v >= 0 for v in nz)):
        fail("tracker.noise", f"must be 6 non-negative numbers (x y z [m], rx ry rz [rad]), got {nz!r}")


def _numbers(v) -> bool:
    vals = v if isinstance(v, list) else [v]
    return bool(vals) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in vals)


def _check_pose_units(spec, fail):
    """A reference pose whose lengths or angles are far outside any robot's range is
    almost always a unit slip: say which (mm for m, degrees for rad) instead of letting
    the inverse kinematics report an unreachable pose."""
    from .errors import PkmError
    from .core.model import robot_facts

    try:  # a robot name, or a description file (its own errors name their line)
        robot_facts(spec["robot"])
    except PkmError as e:
        fail("robot", str(e))
    units = robot_facts(spec["robot"]).pose_units
    names = robot_facts(spec["robot"]).pose_names
    r = spec["reference"]
    deg = r.get("angle_unit", "rad") == "deg"
    poses = [(k, r[k]) for k in ("from", "to", "start") if k in r]
    poses += [(f"poses[{i}]", p) for i, p in enumerate(r.get("poses") or [])]
    for key, pose in poses:
        if not _numbers(pose):
            fail(f"reference.{key}", f"must be a list of {len(units)} numbers, got {pose!r}")
        for name, unit, v in zip(names, units, pose):
            if unit == "m" and abs(v) > 2.0:
                fail(f"reference.{key}", f"{name} = {v:g} m is beyond any reach of the robot: was it given in mm? "
                                         f"(lengths are in m: {v / 1000:g})")
            if unit == "rad" and not deg and abs(v) > 2 * 3.141592653589793:
                fail(f"reference.{key}", f"{name} = {v:g} rad is more than a turn: was it given in degrees? "
                                         f"(set reference.angle_unit = \"deg\" or give radians)")


# ------------------------------------------------------------------ building

def _angles(pose, unit, units=None):
    """The pose(s) in radians: with ``unit = "deg"`` the coordinates whose unit is ``"rad"``
    (``units``: the robot's pose units from the core; default the 6-PUS layout x y z rx ry rz)
    are converted."""
    p = np.array(pose, dtype=float)
    if unit != "deg":
        return p
    if units is None:
        if p.shape[-1] == 6:
            p[..., 3:] = np.radians(p[..., 3:])
        return p
    if p.shape[-1] == len(units):
        rad = [i for i, u in enumerate(units) if u == "rad"]
        p[..., rad] = np.radians(p[..., rad])
    return p


def build_models(sc: Scenario):
    """The controller's (nominal) model and the plant's ("true") model."""
    from .core.model import Model

    robot, pset = sc.spec["robot"], sc.spec.get("param_set")
    nominal = Model(robot, pset, sc.spec["parameters"] or None)
    true = Model(robot, pset, sc.spec["parameters"] or None)
    truth = dict(sc.spec["plant_parameters"])
    for k, f in sc.spec["plant_scale"].items():
        truth[k] = nominal.param(k) * f
    for k, d in sc.spec["plant_offset"].items():
        truth[k] = truth.get(k, nominal.param(k)) + d
    if truth:
        true.set_params(truth)
    return nominal, true, truth


def _letter_m(r, unit, model):
    return tr.letter_m(center=tuple(r.get("center", (0.0, 0.0))), z=float(r.get("z", 0.075)),
                       width=float(r.get("width", 0.03)), height=float(r.get("height", 0.03)),
                       segment_time=float(r.get("segment_time", 0.4)),
                       hold_time=float(r.get("hold_time", 0.1)),
                       middle_depth=float(r.get("middle_depth", 0.5)),
                       orientation=_angles([0, 0, 0, *r.get("orientation", (0, 0, 0))], unit)[3:],
                       coordinates=model.facts.pose_names)


def build_trajectory(sc: Scenario, model):
    """The pose reference of the scenario."""
    r = sc.spec["reference"]
    unit = r.get("angle_unit", "rad")
    kind = r["type"]
    nd = model.ndof
    if kind == "step":
        units = model.facts.pose_units
        x0, x1 = _angles(r["from"], unit, units), _angles(r["to"], unit, units)
        for k, v in (("from", x0), ("to", x1)):
            if v.shape != (nd,):
                raise ScenarioError(f"{sc.path or 'scenario'}: reference.{k}: needs {nd} pose coordinates")
        return tr.step(x0, x1, t_step=float(r.get("t_step", 0.0)), name="step")
    if kind == "excitation":
        # the discrepancy engine's exciting trajectory (any robot: amplitudes from the core's reach)
        from .discrepancy.excitation import excitation

        lead_in = float(r.get("lead_in", 0.5))
        return excitation(model, float(sc.spec["duration"]) - lead_in, seed=int(r.get("seed", sc.spec.get("seed", 0))),
                          scale=float(r.get("scale", 1.0)), lead_in=lead_in)
    if kind == "letter_m":
        try:
            return _letter_m(r, unit, model)
        except ValueError as e:
            raise ScenarioError(f"{sc.path or 'scenario'}: reference.type = 'letter_m': {e}") from None
    units = model.facts.pose_units
    poses = _angles(r["poses"], unit, units)
    if poses.ndim != 2 or poses.shape[1] != nd:
        raise ScenarioError(f"{sc.path or 'scenario'}: reference.poses: each pose needs {nd} coordinates")
    start = _angles(r["start"], unit, units) if "start" in r else None
    return tr.pose_set(poses, move_time=float(r.get("move_time", 0.5)), hold_time=float(r.get("hold_time", 0.5)),
                       start=start, name="pose set")


def _start_pose(traj):
    """Where the robot starts: a piecewise trajectory's first knot (before a step at t = 0),
    else the pose at t = 0."""
    knots = getattr(traj, "knots", None)
    return knots[0] if knots is not None else traj.evaluate(0.0)[0][0]


def build_controller(sc: Scenario, model, x0):
    """The controller of the scenario, with gains given or designed with python-control.

    With ``bandwidth_hz`` the gains come from :func:`cosim.controllers.design_pd` on the
    decoupled joint double integrator: the effective mass is the largest diagonal entry
    of the joint-space mass matrix at ``x0`` for PD/PD+G, 1 for computed torque (whose
    gains are the outer-loop ``wn^2`` and ``2 zeta wn``).
    """
    c = sc.spec["controller"]
    kind = c["type"]
    design = None
    if kind == "discrete":
        return ctl.discrete({k: v for k, v in c.items() if k != "type"}, ndof=model.ndof, model=model), None
    if "bandwidth_hz" in c:
        mass = 1.0 if kind == "computed_torque" else float(np.max(np.diag(ctl.joint_mass(model, x0))))
        design = ctl.design_pd(mass=mass, bandwidth_hz=float(c["bandwidth_hz"]), damping=float(c.get("damping", 1.0)),
                               dt=float(sc.spec["step"]))
        kp, kd = design.kp, design.kd
    else:
        kp, kd = c["kp"], c["kd"]
    sat = c.get("saturation")
    if kind == "pd":
        ctrl = ctl.pd(ndof=model.ndof, kp=kp, kd=kd, saturation=sat, joint=ctl._joint_of(model))
    elif kind == "pd_gravity":
        ctrl = ctl.pd_gravity(model, kp=kp, kd=kd, saturation=sat, gravity=c.get("gravity", "measured"))
    elif kind == "pid":
        ctrl = ctl.pid(model, kp=kp, ki=c["ki"], kd=kd, dt=float(sc.spec["step"]),
                       deriv_filter=float(c.get("deriv_filter", 0.0)), saturation=sat,
                       gravity_feedforward=bool(c.get("gravity_feedforward", False)))
    else:
        ctrl = ctl.computed_torque(model, kp=kp, kd=kd, saturation=sat)
    if design is not None:
        ctrl.info["design"] = design.as_dict()
    return ctrl, design


def fmu_path(sc: Scenario) -> Path:
    """The .fmu of the scenario: ``[fmu] path``, else the one the build produced."""
    p = sc.spec["fmu"].get("path")
    if p:
        p = Path(p)
        return p if p.is_absolute() else REPO / p
    return built_fmu(sc.spec["robot"])


def built_fmu(robot: str) -> Path:
    """The Co-Simulation FMU of ``robot`` from the CMake build (``cosim.fmu`` knows where)."""
    from .fmu import build, fmu_path as fmu_file

    try:
        try:
            return Path(fmu_file(robot))
        except FileNotFoundError:
            if not (robot.endswith(".toml") or "/" in robot):
                raise
            return Path(build(robot))  # a description file's FMU: made by the build, on demand
    except (FileNotFoundError, subprocess.CalledProcessError) as e:
        raise ScenarioError(f"the FMU of robot {robot} is not built ({e}): build the project "
                            f"(./scripts/bootstrap.sh) or give [fmu] path in the scenario") from None


def build_plant(sc: Scenario, true_model, truth: dict):
    integ = sc.spec["integrator"]
    rtol, atol = float(integ.get("rtol", 1e-10)), float(integ.get("atol", 1e-12))
    from .simulate import METHOD_CODES, default_options

    method = integ.get("method", default_options()["method"])
    if method not in METHOD_CODES:
        raise ScenarioError(f"[integrator] method = {method!r}: use one of {sorted(METHOD_CODES)}")
    if sc.spec["plant"] == "core":
        return CorePlant(true_model, rtol=rtol, atol=atol, method=method)
    # the FMU's solver.method is the core's method code (pkm.h pkm_lmm)
    params = {"solver.method": METHOD_CODES[method], **sc.spec["parameters"], **truth}
    # the FMU outputs the joints of its current time; the master delays the readings (CoreDrive)
    params.pop("sensor.delay", None)
    return FMUPlant(fmu_path(sc), parameters=params, rtol=rtol, atol=atol, names=sc.spec["fmu"].get("names"),
                    robot=None if sc.spec["fmu"].get("path") else sc.spec["robot"])


# ------------------------------------------------------------------- running

def run_scenario(sc, *, plant: str | None = None, duration: float | None = None, out_dir=None,
                 figures: bool | None = None, export: bool = True, progress: bool | None = None,
                 started=None) -> ScenarioResult:
    """Run a scenario and write its recording, metrics and figure.

    Parameters
    ----------
    sc : Scenario or str or Path
        The scenario (or its TOML file).
    plant : {"core", "fmu"}, optional
        Override the scenario's plant.
    duration : float, optional
        Override the duration [s].
    out_dir : str or Path, optional
        Where to write (default: ``[output] dir`` or ``results/<name>``).
    figures : bool, optional
        Write the figure (default: ``[output] figures``, true).
    export : bool
        Write the recording and the metrics.
    progress : bool, optional
        Progress bar (default: shown on runs longer than two seconds).
    started : callable, optional
        ``started()``, called once when the set-up is done, right before the first step.
    """
    if not isinstance(sc, Scenario):
        sc = load_scenario(sc)
    sc = sc.with_overrides(plant=plant, duration=duration)
    nominal, true, truth = build_models(sc)
    traj = build_trajectory(sc, nominal)
    step, dur = float(sc.spec["step"]), float(sc.spec["duration"])
    ref = make_reference(nominal, traj, step=step, duration=dur)
    init = sc.spec["initial"]
    # start at rest where the reference starts (before a step at t = 0, not after it)
    x0 = (_angles(init["pose"], sc.spec["reference"].get("angle_unit", "rad"), nominal.facts.pose_units)
          if "pose" in init else _start_pose(traj))
    ctrl, design = build_controller(sc, nominal, x0)
    noise = sc.spec["noise"]
    p = build_plant(sc, true, truth)
    out_cfg = sc.spec["output"]
    d = Path(out_dir or out_cfg.get("dir") or f"results/{sc.name}")
    if not d.is_absolute() and out_dir is None and out_cfg.get("dir"):
        d = Path.cwd() / d
    try:
        res = run(p, ctrl, ref, x0=x0, q_noise=noise.get("q", 0.0), qd_noise=noise.get("qd", 0.0),
                  pose_noise=noise.get("pose", 0.0), seed=sc.spec["seed"], drive=CoreDrive(true),
                  progress=progress, started=started)
    except LoopInterrupted as e:  # the caller may keep the samples: export_partial(e.scenario, e, e.out_dir)
        e.scenario, e.out_dir = sc, d
        raise
    finally:
        p.close()
    metrics = compute_metrics(sc, res, nominal, traj, ctrl, design)
    metrics["plant_parameters"] = {**sc.spec["parameters"], **truth}
    out = ScenarioResult(sc, res, metrics)
    if figures is None:
        figures = bool(out_cfg.get("figures", True))
    if export or figures:
        d.mkdir(parents=True, exist_ok=True)
        if export:
            out.files.update(export_run(out, d))
        if figures:
            from .plots import scenario_figure

            out.files["figure"] = scenario_figure(out, d / f"{sc.name}.png")
    return out


def export_run(out: ScenarioResult, d: Path) -> dict:
    """Write the recording (``pkm-recording/1``) and the metrics JSON into ``d``."""
    from .recording import write_recording

    sc = out.scenario
    notes = (f"scenario {sc.name} ({sc.spec.get('description', '').strip()}); plant {sc.spec['plant']}; "
             f"step {sc.spec['step']} s; pose columns are the external tracker's measurement "
             f"(noise {out.result.noise['pose']}); label = index of the held pose (0 while moving)")
    rec = out.result.to_recording(parameters=sc.spec["parameters"], notes=notes)
    tracker = sc.spec.get("tracker", {})
    if tracker.get("pose") == "full":
        rec.set_full_pose(full_pose_measured(sc, out.result["x"]))
        rec.notes = notes.replace("the external tracker's measurement", "a 6-DOF tracker's measurement of x y z rx "
                                  "ry rz") .replace(f"(noise {out.result.noise['pose']})",
                                                    f"(noise {tracker.get('noise', [0.0] * 6)})")
    csv_path, side = write_recording(d / f"{sc.name}.csv", rec)
    mpath = d / f"{sc.name}_metrics.json"
    mpath.write_text(json.dumps(out.metrics, indent=2, default=jsonable))
    return {"recording": csv_path, "sidecar": side, "metrics": mpath}


def full_pose_measured(sc: Scenario, x) -> np.ndarray:
    """What a 6-DOF tracker reads of the plant at true poses x (n, nd): the plant's full pose
    x y z rx ry rz (its undeclared components as the core holds or solves them, the parasitic
    motion) plus the ``[tracker] noise`` (seeded from the scenario's seed)."""
    _, true, _ = build_models(sc)
    X = np.asarray(true.platform_pose(np.asarray(x, float))[0], float).reshape(-1, 6)
    sd = np.asarray(sc.spec.get("tracker", {}).get("noise", [0.0] * 6), float)
    rng = np.random.default_rng([int(sc.spec.get("seed") or 0), 6])
    return X + rng.normal(0.0, 1.0, X.shape) * sd


def export_partial(sc: Scenario, stop: LoopInterrupted, d: Path) -> dict:
    """The recording of an interrupted run (:func:`run_scenario` raised ``stop``, a
    KeyboardInterrupt carrying the samples taken), up to the interruption, in ``d``; the
    metrics and figure of an earlier complete run there are removed (they would not match
    it).  Nothing is written when fewer than two samples were taken."""
    from .recording import write_recording

    for old in (d / f"{sc.name}_metrics.json", d / f"{sc.name}.png"):
        old.unlink(missing_ok=True)
    if len(stop.partial) < 2:
        return {}
    d.mkdir(parents=True, exist_ok=True)
    notes = (f"scenario {sc.name}: interrupted at t = {stop.partial.time[-1]:.6g} s of {sc.spec['duration']:g} s "
             f"(ctrl-C); plant {sc.spec['plant']}; step {sc.spec['step']} s")
    rec = stop.partial.to_recording(parameters=sc.spec["parameters"], notes=notes)
    if sc.spec.get("tracker", {}).get("pose") == "full":
        rec.set_full_pose(full_pose_measured(sc, stop.partial["x"]))
    csv_path, side = write_recording(d / f"{sc.name}.csv", rec)
    return {"recording": csv_path, "sidecar": side}


# ------------------------------------------------------------------- metrics

def _window(res, sc):
    """Rows of the settling window at the end of the run."""
    w = float(sc.spec["output"].get("settle_window", max(0.1 * sc.spec["duration"], 0.05)))
    return res["time"] >= res["time"][-1] - w + 1e-12


def compute_metrics(sc: Scenario, res, model, traj, ctrl, design=None) -> dict:
    """Metrics of a run, by reference type (see docs/scenarios.md)."""
    m = {"scenario": sc.name, "robot": sc.spec["robot"], "plant": res.plant, "controller": res.controller,
         "step": res.step, "duration": float(res["time"][-1] - res["time"][0]), "wall_time": res.wall_time,
         "saturated_samples": int(res.saturated), "units": {"length": "m", "angle": "rad", "time": "s"}}
    kind = sc.spec["reference"]["type"]
    if kind == "step":
        m.update(step_response_metrics(sc, res, model, traj, ctrl))
    elif kind == "letter_m":
        m.update(tracking_metrics(sc, res))
    elif kind == "excitation":
        e = res["xref"] - res["x"]
        m["excitation"] = {"pose_error_rms": np.sqrt(np.mean(e ** 2, axis=0)).tolist(),
                           "effort_max": np.max(np.abs(res["tau_applied"]), axis=0).tolist()}
    else:
        m.update(pose_set_metrics(sc, res))
    return m


def step_response_metrics(sc, res, model, traj, ctrl) -> dict:
    """Step metrics (python-control ``step_info``), steady-state error and its prediction."""
    x0, x1 = traj.knots[0], traj.knots[-1]
    t_step = traj.times[0]
    after = res["time"] >= t_step
    win = _window(res, sc)
    t = res["time"][after]
    e_joint = (res["qref"] - res["q_true"])[win]
    e_pose = (res["xref"] - res["x"])[win]
    ess = e_joint.mean(axis=0)
    out = {"steady_state": {
        "window": [float(res["time"][win][0]), float(res["time"][-1])],
        "joint_error": ess.tolist(),
        "joint_error_max": float(np.max(np.abs(ess))),
        "joint_error_spread": float(np.max(np.ptp(e_joint, axis=0))),
        "pose_error": e_pose.mean(axis=0).tolist(),
        "joint_speed_max": float(np.max(np.abs(res["qd_true"][win]))),
    }}
    kind = ctrl.kind
    kp = ctrl.kp
    if kind == "pd":
        pred = ctl.predicted_steady_state_error(model, x1, kp)
        pred_eq = predicted_equilibrium_error(model, x1, kp)
        denom = np.max(np.abs(pred_eq))
        out["steady_state"]["predicted_joint_error"] = pred.tolist()
        out["steady_state"]["predicted_joint_error_equilibrium"] = pred_eq.tolist()
        out["steady_state"]["prediction_absolute_error"] = float(np.max(np.abs(ess - pred_eq)))
        # relative to the predicted error; undefined (None) where gravity loads no joint
        # (a planar robot in a horizontal plane: the prediction is 0, the absolute error tells)
        out["steady_state"]["prediction_relative_error"] = (float(np.max(np.abs(ess - pred_eq)) / denom)
                                                            if denom > 0 else None)
        out["steady_state"]["prediction_relative_error_first_order"] = (float(np.max(np.abs(ess - pred)) / denom)
                                                                        if denom > 0 else None)
    elif kind in ("pd_gravity", "pid"):  # gravity fed forward, or integrated away
        out["steady_state"]["predicted_joint_error"] = [0.0] * model.ndof
    # python-control step metrics on the moved pose coordinates and on each joint
    moved = np.flatnonzero(np.abs(x1 - x0) > 0)
    names = model.facts.pose_names
    pose_info = {}
    for i in moved:
        y = res["x"][after, i]
        try:
            pose_info[names[i]] = ctl.step_metrics(t, y, y0=x0[i])
        except ctl.ControllerError as e:
            pose_info[names[i]] = {"error": str(e)}
    joint_info = []
    q0, q1 = model.ik(x0), res["qref"][-1]
    qstart = res["q_true"][0]
    for j in range(model.ndof):
        if abs(q1[j] - q0[j]) < 1e-9:
            joint_info.append(None)
            continue
        joint_info.append(ctl.step_metrics(t, res["q_true"][after, j], y0=qstart[j]))
    out["step_info"] = {"pose": pose_info, "joints": joint_info, "amplitude_pose": (x1 - x0).tolist(),
                        "amplitude_joints": (q1 - q0).tolist()}
    # what python-control predicts on the decoupled joint with its effective mass
    if kind in ("pd", "pd_gravity"):
        mq = np.diag(ctl.joint_mass(model, x1))
        out["predicted_step_info"] = [ctl.analyse_pd(mass=float(mq[j]), kp=float(kp[j, j]), kd=float(ctrl.kd[j, j]),
                                                     dt=res.step) for j in range(model.ndof)]
    return out


def predicted_equilibrium_error(model, x_ref, kp, iterations: int = 20) -> np.ndarray:
    """``e`` solving ``Kp e = g(x(qref - e))``: the PD equilibrium, from the core's statics.

    :func:`cosim.controllers.predicted_steady_state_error` evaluates the gravity load at
    the reference pose; the robot settles ``e`` away from it, where the load differs a
    little.  This fixed point (forward kinematics of ``qref - e``, gravity load there)
    is the exact static prediction; it converges because ``Kp^-1 dg/dq`` is small.

    Parameters
    ----------
    model : cosim.core.Model
        The controller's model (kinematics and gravity load).
    x_ref : array_like, shape (nd,)
        Reference pose [m, rad]; ``qref = ik(x_ref)``.
    kp : float or array_like
        Proportional gain [N/m or N m/rad].
    iterations : int
        Largest number of fixed-point iterations.

    Returns
    -------
    ndarray, shape (nd,)
        ``qref - q`` at the equilibrium [m or rad].
    """
    nd = model.ndof
    K = ctl._gain(kp, nd, "kp", "N/m")
    qref = model.ik(x_ref)
    e = np.linalg.solve(K, model.gravity_load(x_ref))
    x = np.asarray(x_ref, float)
    for _ in range(iterations):
        x = model.fk(qref - e, x_guess=x)
        e_new = np.linalg.solve(K, model.gravity_load(x))
        if np.max(np.abs(e_new - e)) < 1e-15:
            e = e_new
            break
        e = e_new
    return e


def tracking_metrics(sc, res) -> dict:
    """Pen-point tracking error of a traced path (true pose vs reference pose)."""
    tool = sc.spec["output"].get("tool", [0.0, 0.0, 0.0])
    pen, pen_ref = tr.pen_point(res.robot, res["x"], tool), tr.pen_point(res.robot, res["xref"], tool)
    err = np.linalg.norm(pen - pen_ref, axis=1)
    ej = res["qref"] - res["q_true"]
    return {"tracking": {
        "tool_offset": list(tool),
        "pen_error_rms": float(np.sqrt(np.mean(err**2))),
        "pen_error_max": float(err.max()),
        "pen_error_max_time": float(res["time"][int(err.argmax())]),
        "joint_error_rms": float(np.sqrt(np.mean(ej**2))),
        "joint_error_max": float(np.max(np.abs(ej))),
        "effort_max": float(np.max(np.abs(res["tau_applied"]))),
    }}


def pose_set_metrics(sc, res) -> dict:
    """Per held pose: rows, final pose error (``position_error``: the norm over the pose
    coordinates in metres, as the core names their units), tracker scatter; over the whole
    run (``motion``): the joint and pose tracking errors and the largest effort."""
    from .core.model import robot_facts

    units = robot_facts(sc.spec["robot"]).pose_units
    lengths = [i for i, u in enumerate(units) if u == "m"]
    poses = []
    lab = res["label"]
    for k in sorted(set(lab.tolist()) - {0}):
        rows = np.flatnonzero(lab == k)
        last = rows[len(rows) // 2:]
        err = (res["xref"][last] - res["x"][last]).mean(axis=0)
        poses.append({"label": int(k), "rows": int(len(rows)), "t_start": float(res["time"][rows[0]]),
                      "t_end": float(res["time"][rows[-1]]), "pose_ref": res["xref"][rows[0]].tolist(),
                      "pose_error": err.tolist(), "position_error": float(np.linalg.norm(err[lengths])),
                      "tracker_std": res["pose"][last].std(axis=0).tolist(),
                      "joint_speed_max": float(np.max(np.abs(res["qd_true"][last])))})
    ej = res["qref"] - res["q_true"]
    ex = res["xref"] - res["x"]
    motion = {"joint_error_rms": np.sqrt(np.mean(ej ** 2, axis=0)).tolist(),
              "joint_error_max": float(np.max(np.abs(ej))),
              "joint_error_max_time": float(res["time"][int(np.argmax(np.max(np.abs(ej), axis=1)))]),
              "pose_error_rms": np.sqrt(np.mean(ex ** 2, axis=0)).tolist(),
              "effort_max": np.max(np.abs(res["tau_applied"]), axis=0).tolist()}
    return {"poses": poses, "held_poses": len(poses), "motion": motion}
