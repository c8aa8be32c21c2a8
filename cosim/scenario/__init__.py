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

import json
import subprocess
from pathlib import Path

import numpy as np

from .. import controllers as ctl
from .. import trajectories as tr
from ..closed_loop import LoopInterrupted
from ..jsonable import jsonable
from ..master import CoreDrive, CorePlant, FMUPlant, make_reference, run
from .metrics import (compute_metrics, pose_set_metrics, predicted_equilibrium_error,  # noqa: F401
                               step_response_metrics, tracking_metrics)
from .spec import REPO, Scenario, ScenarioError, ScenarioResult, load_scenario, scenario_from_dict  # noqa: F401


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
    from ..core.model import Model

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
        from ..discrepancy.excitation import excitation

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
    from ..fmu import build, fmu_path as fmu_file

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
    from ..simulate import METHOD_CODES, default_options

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
            from ..plots import scenario_figure

            out.files["figure"] = scenario_figure(out, d / f"{sc.name}.png")
    return out


def export_run(out: ScenarioResult, d: Path) -> dict:
    """Write the recording (``pkm-recording/1``) and the metrics JSON into ``d``."""
    from ..recording import write_recording

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
    from ..recording import write_recording

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
