"""A scenario's file: read (:func:`load_scenario`, :func:`scenario_from_dict`) and checked key by
key (:class:`ScenarioError` names the key), the :class:`Scenario` and its
:class:`ScenarioResult` (:mod:`cosim.scenario`).
"""
from __future__ import annotations

import copy
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ScenarioError

REPO = Path(__file__).resolve().parents[2]

_TOP_KEYS = {"name", "description", "robot", "param_set", "plant", "duration", "step", "seed", "parameters",
             "plant_parameters", "plant_scale", "plant_offset", "integrator", "controller", "reference", "initial", "noise",
             "output", "fmu", "tracker"}


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
        from ..controllers import ControllerError, discrete

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
        from ..core.model import robot_facts
        from ..recording import full_pose_allowed

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
    from ..errors import PkmError
    from ..core.model import robot_facts

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
