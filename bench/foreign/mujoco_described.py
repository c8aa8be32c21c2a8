"""The core's dynamics of a described robot checked against MuJoCo built from the same file.

    .venv/bin/python bench/foreign/mujoco_described.py ROBOT_OR_FILE [ROBOT_OR_FILE ...]
        [--seconds 4] [--seed 1] [--timestep 1e-4] [--integrator RK4] [--solref 0.0005]
        [--solimp "0.9999 0.9999 0.001 0.5 2"] [--pd-hz 15] [--blind] [--verbose]
    .venv/bin/python bench/foreign/mujoco_described.py tripod_3prs tripod_3rps --closure 200
    .venv/bin/python bench/foreign/mujoco_described.py tripod_3rps tripod_3prs fivebar --exact-efforts 400

ROBOT_OR_FILE is a description name (robots/NAME.toml, as ``Model(NAME)`` takes it) or a
path to a description file; ``all`` stands for every name of robots/robots.list.  ``--blind``
also runs the check on bench/foreign/mujoco_blind.py's clean 6-PUS model (the hand-written
core model "6pus": free platform, capsule legs), for comparison.

Independence.  This script reads the TOML itself (``tomllib``), expands ``copies`` itself,
applies the file's ``[defaults]`` by parameter name itself, solves every leg's inverse
kinematics in closed form itself and lays MuJoCo's model out at the home pose from that.
MuJoCo (PyPI ``mujoco``) then does all the dynamics: nothing of the geometry, the masses or
the motion comes from the core.  The core is asked only, at the end, for ``ik(home)`` and for
``inverse_dynamics`` along the platform motion MuJoCo produced.

The MuJoCo model (MJCF, SI units, no geoms, no contacts):
  * the platform: one body, with a joint per *declared* coordinate only (slides x, y, z along
    the world axes, then hinges rx, ry, rz about the body's own axes in that order, so that
    R = Rx(rx) Ry(ry) Rz(rz) as in the description; the undeclared coordinates are not joints,
    so they are held at 0), its mass and principal inertias at the frame origin, a payload
    point body;
  * a single axis (P, R): no legs; the platform body itself on one slide joint along the rail
    (through S0 - p at q = 0) or one hinge about the axis (through A), named by the declared
    coordinate: its qpos is q, the platform's coordinate;
  * every other leg its own chain from the world, the actuated joint's ``ref`` being its home value
    (so qpos of that joint *is* the description's q):
      - rail (PUS, PSS, P(SS)2, PRR): a slide joint along the rail carrying the slider (point
        mass at S), then the rod: a ball joint at S, a uniform slender rod of mass m between S
        and P (inertia m L^2/12 across, ``AXIAL`` times that along);
      - arm (RUS, RSS, R(SS)2, RRR): a hinge about k through A carrying the arm (its mass at
        arm_com along the arm, arm_inertia about its centre of mass, isotropic: only the part
        about k ever moves), then the rod on a ball joint at the elbow B, as above;
      - strut (UPS, SPS): a ball joint at B carrying the cylinder (uniform slender tube of
        cylinder_length from B), a slide joint along it carrying the piston (uniform slender
        rod of piston_length ending at P);
    a parallelogram (P(SS)2, R(SS)2) is one rod of the pair's mass on the centre line: the
    platform joints hold the orientation the parallelograms hold;
  * each leg closed at its platform point by a ``connect`` equality between a site at the
    rod's (piston's) end and a site on the platform, stiff (``--solref``, solimp 0.9999);
  * motors (gear 1) on the actuated joints; the drive layer's rotor inertia and viscous
    friction from ``[defaults]`` as the joint's ``armature`` and ``damping`` (any other drive
    parameter is set to 0 in the core for the comparison, and said so).
The joints are driven by a PD written here (no feed-forward), gains from MuJoCo's own
joint-space inertia at home (probed: unit efforts in, accelerations out), tracking the joint
trajectory of a platform trajectory around home (three sines per declared coordinate,
0.5-3 Hz, faded in over 0.5 s, sized to a few mm / degrees and kept inside the strokes).
Every 1 ms: ``mj_forward`` at the current state, then the platform coordinates (qpos), their
rates (qvel) and accelerations (qacc) and the applied efforts (actuator_force) are recorded.

Integrator.  RK4 by default.  ``implicitfast`` (and Euler) integrate joint damping
implicitly while the constraint forces are those of the plain mass matrix; the mismatch
leaves each step a constraint-velocity error that the connect's stabilisation (-b v - k r)
removes as a spurious acceleration worth timestep x damping x qdd of effort: a residual of
exactly h c qdd on a joint with viscous friction c (found by regression on a 6-SPS with
viscous drives: 1e-2 % of the effort at h = 0.1 ms; 1e-5 % with RK4).  Without damping,
implicitfast gives about 1e-3 % (proportional to the timestep), RK4 1e-5 to 1e-4 %.

``--closure N`` compares kinematics only: for a robot with dependent coordinates (PRS, RPS
legs), the same MJCF as an open tree, its loops closed by Gauss-Newton on MuJoCo's own site
positions and Jacobians (``closure_pose``), against the core's ``platform_pose`` at N poses.

``--exact-efforts N`` compares efforts with no soft closure: the same open tree, closed
exactly at N samples of a smooth excitation, its rates and accelerations from the closure,
its inverse dynamics mapped onto the actuated joints by virtual work
(``closed_loop_efforts``), against the core's ``inverse_dynamics`` along the same motion.

Compared: the core's ``inverse_dynamics(x, xd, xdd)`` along that record against MuJoCo's
efforts (RMS of effort, of the residual, their ratio; also over the inertial part, effort
minus the core's gravity load), the connect closure error, the home joints (this script's
IK, which MuJoCo's model is laid out with and whose closure MuJoCo confirms) against
``m.ik(home)``, and MuJoCo's actuated joints against ``m.ik`` of MuJoCo's platform poses.
"""
from __future__ import annotations

import argparse
import math
import os
import sys
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO))

COORDS = ("x", "y", "z", "rx", "ry", "rz")
RAIL, ARM, STRUT = "rail", "arm", "strut"
SLIDE_AXIS, HINGE_AXIS = "slide axis", "hinge axis"   # single axes: the joint carries the platform
LEG_JOINT = {"PUS": RAIL, "PSS": RAIL, "P(SS)2": RAIL, "PRR": RAIL, "PRS": RAIL,
             "RUS": ARM, "RSS": ARM, "R(SS)2": ARM, "RRR": ARM,
             "UPS": STRUT, "SPS": STRUT, "RPS": STRUT, "P": SLIDE_AXIS, "R": HINGE_AXIS}
PASSIVE_REVOLUTE = ("PRS", "RPS")  # a hinge of axis revolute_axis in place of the rod's (strut's) first ball
AXES = (SLIDE_AXIS, HINGE_AXIS)
DRIVE_PREFIXES = ("rail", "arm", "strut", "axis")
AXIAL = 1e-4        # a slender rod's inertia about its own axis, as a fraction of m L^2/12
TINY = 1e-12        # floor of masses and inertias MuJoCo must see as positive
COUNTER = 1.0       # inertia of an articulated platform's counter-turning attachment bodies [kg m2]: they do
                    # not turn (the equality holds them at -rz against the articulation), so it adds no
                    # energy; a large one keeps them from turning while the soft equality takes up its load
DT_REC = 1e-3       # recording period [s]
RAMP = 0.5          # fade-in of the excitation [s]; also what the "late" columns drop


# ------------------------------------------------------------------ the description

@dataclass
class Leg:
    type: str
    joint: str
    p: np.ndarray                  # platform point, platform frame [m]
    stroke: tuple
    L: float = 0.0                 # rod length (rail, arm)
    m_rod: float = 0.0
    branch: float = 1.0
    base: np.ndarray = None        # rail origin S0 / axis point A / strut base B
    dir: np.ndarray = None         # rail direction s / motor axis k
    u: np.ndarray = None           # arm direction at q = 0
    m_body: float = 0.0            # slider or arm mass
    r: float = 0.0                 # arm length
    rc: float = 0.0                # arm centre of mass distance
    I_arm: float = 0.0
    m_cyl: float = 0.0
    l_cyl: float = 0.0
    m_pis: float = 0.0
    l_pis: float = 0.0
    f: np.ndarray = field(default_factory=lambda: np.zeros(3))  # articulated: fixed offset of p [m]
    com_angle: float = 0.0         # arm: its centre of mass's angle from the arm line [rad]
    lumped: bool = False           # rod mass half at each joint instead of uniform
    rev: np.ndarray = None         # PRS, RPS: the passive revolute axis (the leg's plane normal)


@dataclass
class Robot:
    name: str
    file: Path
    coords: list                   # pose indices, sorted
    home: np.ndarray               # per declared coordinate, in the order of coords
    gravity: np.ndarray
    m_platform: float
    I_platform: np.ndarray
    m_payload: float
    c_payload: np.ndarray
    legs: list
    drive: dict = field(default_factory=dict)   # [defaults] of the drive layer, by name
    articulated: bool = False      # two translating end bars, their axis turned by rz
    rz0: float = 0.0               # articulated: axis direction at rz = 0 [rad]
    ends: float = 0.0              # articulated: end bars' distance from the centre [m]
    c_platform: np.ndarray = field(default_factory=lambda: np.zeros(3))  # centre, axis frame [m]
    dependent: list = field(default_factory=list)  # pose indices the PRS/RPS legs' planes decide

    @property
    def n(self) -> int:
        return len(self.coords)

    @property
    def kind(self) -> str:
        return "+".join(sorted({l.type for l in self.legs}))


def resolve(name_or_file: str) -> Path:
    """The description file a name or path stands for (as the core: a path if it has a '/' or
    ends in .toml, else NAME.toml in PKM_ROBOT_PATH's folders, then robots/)."""
    if "/" in name_or_file or name_or_file.endswith(".toml"):
        p = Path(name_or_file)
        return p if p.is_absolute() else (Path.cwd() / p)
    dirs = [Path(d) for d in os.environ.get("PKM_ROBOT_PATH", "").split(os.pathsep) if d] + [REPO / "robots"]
    for d in dirs:
        if (d / f"{name_or_file}.toml").is_file():
            return d / f"{name_or_file}.toml"
    raise SystemExit(f"no description {name_or_file}.toml in {', '.join(map(str, dirs))}")


def listed_robots() -> list[str]:
    """The names of robots/robots.list (comments and blank lines skipped)."""
    f = REPO / "robots" / "robots.list"
    if not f.is_file():
        return []
    return [s.split("#")[0].strip() for s in f.read_text().splitlines() if s.split("#")[0].strip()]


def _rz(v, a):
    c, s = math.cos(a), math.sin(a)
    v = np.asarray(v, float)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1], v[2]])


def read(path: Path) -> Robot:
    """The robot a description file declares, read here (not by the core)."""
    doc = tomllib.loads(path.read_text())
    rob = doc["robot"]
    names = list(rob["coordinates"])
    home_by = dict(zip(names, rob["home"]))
    coords = sorted(COORDS.index(c) for c in names)
    # flat parameter table named as the format's [defaults] names them (docs: parameter names)
    P: dict[str, float] = {}
    types: list[str] = []
    lumped: dict[int, bool] = {}
    k = 0
    for t in doc["leg"]:
        copies = int(t.get("copies", 1))
        for c in range(copies):
            a = 2 * math.pi * c / copies
            i = k + 1
            k += 1
            typ = t["type"]
            types.append(typ)
            joint = LEG_JOINT[typ]
            for key, pre in (("platform_point", f"leg[{i}].p"),):  # legs meeting at a point: none, 0
                for ax, v in zip("xyz", _rz(t.get(key, [0.0, 0.0, 0.0]), a)):
                    P[pre + ax] = v
            if typ in PASSIVE_REVOLUTE:
                for ax, v in zip("xyz", _rz(t["revolute_axis"], a)):
                    P[f"leg[{i}].a{ax}"] = v
            for ax, v in zip("xyz", t.get("platform_offset", [0.0, 0.0, 0.0])):
                P[f"leg[{i}].f{ax}"] = v
            lumped[i] = t.get("rod_model", "uniform") == "lumped"
            lo, hi = t["stroke"]
            if joint == SLIDE_AXIS:
                for key, pre in (("rail_origin", "S0"), ("rail_direction", "s")):
                    for ax, v in zip("xyz", _rz(t[key], a)):
                        P[f"rail[{i}].{pre}{ax}"] = v
                P[f"rail[{i}].qmin"], P[f"rail[{i}].qmax"] = lo, hi
            elif joint == HINGE_AXIS:
                for key, pre in (("axis_point", "A"), ("axis", "k")):
                    for ax, v in zip("xyz", _rz(t[key], a)):
                        P[f"axis[{i}].{pre}{ax}"] = v
                P[f"axis[{i}].qmin"], P[f"axis[{i}].qmax"] = lo, hi
            if joint in (RAIL, ARM):
                P[f"leg[{i}].L"] = t["rod_length"]
                P[f"leg[{i}].m"] = t["rod_mass"]
                P[f"leg[{i}].branch"] = float(t.get("branch", 1))
            if joint == RAIL:
                for ax, v in zip("xyz", _rz(t["rail_origin"], a)):
                    P[f"rail[{i}].S0{ax}"] = v
                for ax, v in zip("xyz", _rz(t["rail_direction"], a)):
                    P[f"rail[{i}].s{ax}"] = v
                P[f"rail[{i}].qmin"], P[f"rail[{i}].qmax"] = lo, hi
                P[f"slider[{i}].m"] = t["slider_mass"]
            elif joint == ARM:
                for key, pre in (("axis_point", "A"), ("axis", "k"), ("arm_direction", "u")):
                    for ax, v in zip("xyz", _rz(t[key], a)):
                        P[f"arm[{i}].{pre}{ax}"] = v
                P[f"arm[{i}].r"] = t["arm_length"]
                P[f"arm[{i}].mass"] = t["arm_mass"]
                P[f"arm[{i}].rc"] = t["arm_com"]
                P[f"arm[{i}].I"] = t["arm_inertia"]
                P[f"arm[{i}].com_angle"] = t.get("arm_com_angle", 0.0)
                P[f"arm[{i}].qmin"], P[f"arm[{i}].qmax"] = lo, hi
            elif joint == STRUT:
                for ax, v in zip("xyz", _rz(t["base_point"], a)):
                    P[f"leg[{i}].b{ax}"] = v
                P[f"strut[{i}].qmin"], P[f"strut[{i}].qmax"] = lo, hi
                P[f"cylinder[{i}].m"], P[f"cylinder[{i}].l"] = t["cylinder_mass"], t["cylinder_length"]
                P[f"piston[{i}].m"], P[f"piston[{i}].l"] = t["piston_mass"], t["piston_length"]
    plat = doc["platform"]
    P["platform.m"] = plat["mass"]
    P["platform.Ixx"], P["platform.Iyy"], P["platform.Izz"] = plat.get("inertia", [0.0, 0.0, 0.0])
    articulated = plat.get("kind", "rigid") == "articulated"
    if articulated:
        P["platform.axis_angle"], P["platform.ends"] = plat["axis_angle"], plat["ends"]
        P["platform.cx"], P["platform.cy"], P["platform.cz"] = plat["centre"]
    pay = doc.get("payload", {})
    P["payload.m"] = pay.get("mass", 0.0)
    P["payload.x"], P["payload.y"], P["payload.z"] = pay.get("position", [0.0, 0.0, 0.0])
    P["gravity.x"], P["gravity.y"], P["gravity.z"] = doc.get("gravity", {}).get("vector", [0.0, 0.0, -9.81])
    drive = {}
    for key, v in doc.get("defaults", {}).items():
        if key in P:
            P[key] = float(v)
        else:
            drive[key] = float(v)  # the drive layer's (friction, rotor inertia, ...): handled in build()
    legs = []
    for i, typ in enumerate(types, 1):
        joint = LEG_JOINT[typ]
        v3 = lambda pre: np.array([P[pre + ax] for ax in "xyz"])  # noqa: E731
        if joint == RAIL:
            leg = Leg(typ, joint, v3(f"leg[{i}].p"), (P[f"rail[{i}].qmin"], P[f"rail[{i}].qmax"]),
                      L=P[f"leg[{i}].L"], m_rod=P[f"leg[{i}].m"], branch=P[f"leg[{i}].branch"],
                      base=v3(f"rail[{i}].S0"), dir=v3(f"rail[{i}].s"), m_body=P[f"slider[{i}].m"])
        elif joint in AXES:
            pre = "rail" if joint == SLIDE_AXIS else "axis"
            leg = Leg(typ, joint, v3(f"leg[{i}].p"), (P[f"{pre}[{i}].qmin"], P[f"{pre}[{i}].qmax"]),
                      base=v3(f"{pre}[{i}].{'S0' if joint == SLIDE_AXIS else 'A'}"),
                      dir=v3(f"{pre}[{i}].{'s' if joint == SLIDE_AXIS else 'k'}"))
        elif joint == ARM:
            leg = Leg(typ, joint, v3(f"leg[{i}].p"), (P[f"arm[{i}].qmin"], P[f"arm[{i}].qmax"]),
                      L=P[f"leg[{i}].L"], m_rod=P[f"leg[{i}].m"], branch=P[f"leg[{i}].branch"],
                      base=v3(f"arm[{i}].A"), dir=v3(f"arm[{i}].k"), u=v3(f"arm[{i}].u"),
                      m_body=P[f"arm[{i}].mass"], r=P[f"arm[{i}].r"], rc=P[f"arm[{i}].rc"], I_arm=P[f"arm[{i}].I"],
                      com_angle=P[f"arm[{i}].com_angle"])
        else:
            leg = Leg(typ, joint, v3(f"leg[{i}].p"), (P[f"strut[{i}].qmin"], P[f"strut[{i}].qmax"]),
                      base=v3(f"leg[{i}].b"), m_cyl=P[f"cylinder[{i}].m"], l_cyl=P[f"cylinder[{i}].l"],
                      m_pis=P[f"piston[{i}].m"], l_pis=P[f"piston[{i}].l"])
        leg.f = v3(f"leg[{i}].f")
        leg.lumped = lumped[i]
        if typ in PASSIVE_REVOLUTE:
            leg.rev = v3(f"leg[{i}].a")
        legs.append(leg)
    art = dict(articulated=True, rz0=P["platform.axis_angle"], ends=P["platform.ends"],
               c_platform=np.array([P["platform.cx"], P["platform.cy"], P["platform.cz"]])) if articulated else {}
    dependent = [k for k in range(6) if k not in coords] if any(l.rev is not None for l in legs) else []
    return Robot(rob["name"], path, coords, np.array([home_by[COORDS[c]] for c in coords], float),
                 np.array([P["gravity.x"], P["gravity.y"], P["gravity.z"]]), P["platform.m"],
                 np.array([P["platform.Ixx"], P["platform.Iyy"], P["platform.Izz"]]), P["payload.m"],
                 np.array([P["payload.x"], P["payload.y"], P["payload.z"]]), legs, drive, **art,
                 dependent=dependent)


# ------------------------------------------------------------------ kinematics (this script's own)

def full_pose(rob: Robot, x: np.ndarray) -> np.ndarray:
    """(N, 6) poses from (N, n) declared coordinates: the others 0, or, with PRS/RPS legs,
    solved here so that every platform point lies in its leg's plane (a . (P - o) = 0, o the
    rail origin or base joint) by Newton from 0 with a finite-difference Jacobian."""
    x = np.atleast_2d(x)
    X = np.zeros((len(x), 6))
    X[:, rob.coords] = x
    if not rob.dependent:
        return X
    legs = [l for l in rob.legs if l.rev is not None]
    a = np.array([l.rev for l in legs])
    o = np.array([l.base for l in legs])
    p = np.array([l.p for l in legs])
    dep = rob.dependent

    def residual(X):
        P = X[:, None, :3] + np.einsum("nij,lj->nli", rotation(X), p)
        return np.einsum("lj,nlj->nl", a, P - o[None])

    h = 1e-7
    for _ in range(30):
        r = residual(X)
        if np.max(np.abs(r)) < 1e-15:
            break
        J = np.empty((len(X), len(dep), len(dep)))
        for k, c in enumerate(dep):
            Xp, Xm = X.copy(), X.copy()
            Xp[:, c] += h
            Xm[:, c] -= h
            J[:, :, k] = (residual(Xp) - residual(Xm)) / (2 * h)
        X[:, dep] -= np.linalg.solve(J, r[..., None])[..., 0]
    if np.max(np.abs(residual(X))) > 1e-13:
        raise SystemExit(f"{rob.name}: this script's solve of the dependent coordinates did not converge")
    return X


def rotation(X: np.ndarray) -> np.ndarray:
    """R = Rx(rx) Ry(ry) Rz(rz), (N, 3, 3)."""
    def rot(axis, a):
        c, s = np.cos(a), np.sin(a)
        R = np.zeros((len(a), 3, 3))
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        R[:, axis, axis] = 1
        R[:, i, i], R[:, j, j], R[:, i, j], R[:, j, i] = c, c, -s, s
        return R
    return rot(0, X[:, 3]) @ rot(1, X[:, 4]) @ rot(2, X[:, 5])


def leg_ik(leg: Leg, P: np.ndarray) -> np.ndarray:
    """Joint values of one leg whose platform point is at P (N, 3); NaN where unreachable."""
    d = P - leg.base
    if leg.joint == RAIL:
        # |d - q s| = L, s unit; branch +1 puts the slider on the -s side of P: the smaller root
        b = d @ leg.dir
        disc = b * b - (np.einsum("ij,ij->i", d, d) - leg.L ** 2)
        with np.errstate(invalid="ignore"):
            return b - leg.branch * np.sqrt(disc)
    if leg.joint == ARM:
        # |d - r (cos q u + sin q w)| = L: alpha cos q + beta sin q = K; branch picks the root
        # as the description format defines it (q = atan2(beta, alpha) + branch acos(K / rho))
        w = np.cross(leg.dir, leg.u)
        al, be = d @ leg.u, d @ w
        K = (np.einsum("ij,ij->i", d, d) + leg.r ** 2 - leg.L ** 2) / (2 * leg.r)
        with np.errstate(invalid="ignore"):
            return np.arctan2(be, al) + leg.branch * np.arccos(K / np.hypot(al, be))
    return np.linalg.norm(d, axis=1)


def platform_points(rob: Robot, x: np.ndarray) -> np.ndarray:
    """(N, legs, 3) world platform points at declared coordinates x (N, n)."""
    X = full_pose(rob, x)
    X[:, 5] += rob.rz0  # an articulated platform's axis direction at rz = 0 (else 0)
    R = rotation(X)
    p = np.array([l.p for l in rob.legs])
    f = np.array([l.f for l in rob.legs])
    return X[:, None, :3] + np.einsum("nij,lj->nli", R, p) + f[None]


def platform_joints(rob: Robot) -> list:
    """The pose components the platform has a MuJoCo joint for: the declared ones, and the
    dependent ones (the legs' planes hold those)."""
    return sorted(rob.coords + rob.dependent)


def single_axis(rob: Robot) -> bool:
    """One P or R leg: the joint carries the platform, its coordinate is the joint's."""
    return rob.legs[0].joint in AXES


def actuated_joint(rob: Robot, i: int) -> str:
    """The MuJoCo name of leg i's actuated joint (a single axis: the platform's own joint)."""
    return COORDS[rob.coords[0]] if single_axis(rob) else f"q{i}"


def ik(rob: Robot, x) -> np.ndarray:
    """(N, n) joints of poses x (N, n)."""
    if single_axis(rob):  # the format defines the coordinate as the joint's
        return np.atleast_2d(np.asarray(x, float)).copy()
    P = platform_points(rob, np.atleast_2d(x))
    return np.column_stack([leg_ik(l, P[:, i]) for i, l in enumerate(rob.legs)])


def elbow(leg: Leg, q: float) -> np.ndarray:
    w = np.cross(leg.dir, leg.u)
    return leg.base + leg.r * (math.cos(q) * leg.u + math.sin(q) * w)


# ------------------------------------------------------------------ MJCF

def _v(a) -> str:
    return " ".join(f"{float(c):.17g}" for c in a)


def _rod_inertia(m: float, n: np.ndarray, length: float, lumped: bool = False) -> str:
    """fullinertia of a uniform slender rod of mass m and length along unit n, about its centre
    (lumped: half the mass at each end)."""
    It = max(m * length ** 2 / (4 if lumped else 12), TINY)
    I = It * (np.eye(3) - np.outer(n, n)) + AXIAL * It * np.outer(n, n)
    return f'mass="{max(m, TINY):.17g}" fullinertia="{_v([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"'


def mjcf(rob: Robot, timestep: float, integrator: str, solref: float, solimp: str) -> tuple[str, np.ndarray]:
    """The MJCF of the robot at home, and the home joints (this script's IK) it is laid out with."""
    q0 = ik(rob, rob.home[None])[0]
    if not np.all(np.isfinite(q0)):
        bad = np.where(~np.isfinite(q0))[0] + 1
        raise SystemExit(f"{rob.name}: home is unreachable by this script's IK (legs {bad})")
    P0 = platform_points(rob, rob.home[None])[0]
    armature = {j: rob.drive.get(f"{pre}[{j + 1}].rotor_inertia", 0.0) for j in range(rob.n)
                for pre in DRIVE_PREFIXES if f"{pre}[{j + 1}].rotor_inertia" in rob.drive}
    damping = {j: rob.drive.get(f"{pre}[{j + 1}].viscous", 0.0) for j in range(rob.n)
               for pre in DRIVE_PREFIXES if f"{pre}[{j + 1}].viscous" in rob.drive}

    def extra(j):
        s = ""
        if armature.get(j):
            s += f' armature="{armature[j]:.17g}"'
        if damping.get(j):
            s += f' damping="{damping[j]:.17g}"'
        return s

    def first_joint(i, l):
        """The rod's (strut's) joint at the slider (base): a ball, or PRS/RPS the passive hinge."""
        if l.rev is not None:
            return f'<joint name="s{i}" type="hinge" axis="{_v(l.rev)}"/>'
        return f'<joint name="s{i}" type="ball"/>'

    if single_axis(rob):
        return _single_axis(rob, extra(0), timestep, integrator), q0
    legs = []
    for i, (l, q, P) in enumerate(zip(rob.legs, q0, P0)):
        if l.joint == RAIL:
            S = l.base + q * l.dir
            a = P - S
            legs.append(f"""
    <body name="slider{i}" pos="{_v(S)}">
      <joint name="q{i}" type="slide" axis="{_v(l.dir)}" ref="{q:.17g}"{extra(i)}/>
      <inertial pos="0 0 0" mass="{max(l.m_body, TINY):.17g}" diaginertia="{TINY} {TINY} {TINY}"/>
      <body name="rod{i}">
        {first_joint(i, l)}
        <inertial pos="{_v(a / 2)}" {_rod_inertia(l.m_rod, a / np.linalg.norm(a), l.L, l.lumped)}/>
        <site name="end{i}" pos="{_v(a)}"/>
      </body>
    </body>""")
        elif l.joint == ARM:
            B = elbow(l, q)
            e = (B - l.base) / l.r
            e = math.cos(l.com_angle) * e + math.sin(l.com_angle) * np.cross(l.dir, e)  # towards the centre of mass
            a = P - B
            Ia = max(l.I_arm, TINY)
            legs.append(f"""
    <body name="arm{i}" pos="{_v(l.base)}">
      <joint name="q{i}" type="hinge" axis="{_v(l.dir)}" ref="{q:.17g}"{extra(i)}/>
      <inertial pos="{_v(l.rc * e)}" mass="{max(l.m_body, TINY):.17g}" diaginertia="{Ia:.17g} {Ia:.17g} {Ia:.17g}"/>
      <body name="rod{i}" pos="{_v(B - l.base)}">
        <joint name="s{i}" type="ball"/>
        <inertial pos="{_v(a / 2)}" {_rod_inertia(l.m_rod, a / np.linalg.norm(a), l.L, l.lumped)}/>
        <site name="end{i}" pos="{_v(a)}"/>
      </body>
    </body>""")
        else:
            n = (P - l.base) / q
            legs.append(f"""
    <body name="cylinder{i}" pos="{_v(l.base)}">
      {first_joint(i, l)}
      <inertial pos="{_v(n * l.l_cyl / 2)}" {_rod_inertia(l.m_cyl, n, l.l_cyl)}/>
      <body name="piston{i}">
        <joint name="q{i}" type="slide" axis="{_v(n)}" ref="{q:.17g}"{extra(i)}/>
        <inertial pos="{_v(n * (q - l.l_pis / 2))}" {_rod_inertia(l.m_pis, n, l.l_pis)}/>
        <site name="end{i}" pos="{_v(n * q)}"/>
      </body>
    </body>""")
    axes = {0: "1 0 0", 1: "0 1 0", 2: "0 0 1"}
    pj = "".join(f'\n      <joint name="{COORDS[c]}" type="{"slide" if c < 3 else "hinge"}" axis="{axes[c % 3]}"/>'
                 for c in platform_joints(rob))  # slides first (world axes), then rx, ry, rz: R = Rx Ry Rz
    # inertias about axes the platform cannot turn about play no part: raised (to the sum of the
    # others) so that MuJoCo's triangle inequality holds whatever the file gives for them
    Ip = np.maximum(rob.I_platform, TINY)
    for a in range(3):
        if 3 + a not in platform_joints(rob):
            Ip[a] = max(Ip[a], Ip.sum() - Ip[a])
    sites = "".join(f'\n      <site name="p{i}" pos="{_v(l.p)}"/>' for i, l in enumerate(rob.legs))
    payload = ""
    if rob.m_payload > 0:
        payload = (f'\n      <body name="payload" pos="{_v(rob.c_payload)}"><inertial pos="0 0 0" '
                   f'mass="{rob.m_payload:.17g}" diaginertia="{TINY} {TINY} {TINY}"/></body>')
    eq = "".join(f'\n    <connect site1="end{i}" site2="p{i}" solref="{solref:.17g} 1" solimp="{solimp}"/>'
                 for i in range(rob.n))
    if rob.articulated:
        platform, more_eq = _articulated_platform(rob, Ip, payload, solref, solimp)
        eq += more_eq
    else:
        platform = f"""
    <body name="platform" pos="0 0 0">{pj}
      <inertial pos="0 0 0" mass="{max(rob.m_platform, TINY):.17g}" diaginertia="{_v(Ip)}"/>{sites}{payload}
    </body>"""
    act = "".join(f'\n    <motor name="m{i}" joint="q{i}" gear="1"/>' for i in range(rob.n))
    xml = f"""<mujoco model="{rob.name}">
  <compiler angle="radian" inertiafromgeom="false" balanceinertia="false"/>
  <option timestep="{timestep:.17g}" integrator="{integrator}" gravity="{_v(rob.gravity)}"
          tolerance="1e-12" iterations="200">
    <flag contact="disable"/>
  </option>
  <worldbody>{''.join(legs)}{platform}
  </worldbody>
  <equality>{eq}
  </equality>
  <actuator>{act}
  </actuator>
</mujoco>"""
    return xml, q0


def _single_axis(rob: Robot, extra: str, timestep: float, integrator: str) -> str:
    """A single axis: the platform body on one slide joint along the rail, laid out at q = 0
    with its platform point at the rail origin, or on one hinge about the axis through the axis
    point, the platform point on it; qpos is q.  The sites end0 and p0 (the closure the other
    robots check) are the platform point itself."""
    l = rob.legs[0]
    c = rob.coords[0]
    Ip = np.maximum(rob.I_platform, TINY)
    if l.joint == SLIDE_AXIS:  # the carriage does not turn: inertias play no part, made valid for MuJoCo
        Ip[:] = Ip.max()
        pos, com, jtype = l.base - l.p, np.zeros(3), "slide"
    else:  # the body frame at the axis point, turning about it; the platform origin at -p from it
        pos, com, jtype = l.base, -l.p, "hinge"
    payload = ""
    if rob.m_payload > 0:
        payload = (f'\n      <body name="payload" pos="{_v(com + rob.c_payload)}"><inertial pos="0 0 0" '
                   f'mass="{rob.m_payload:.17g}" diaginertia="{TINY} {TINY} {TINY}"/></body>')
    site = _v(com + l.p)
    return f"""<mujoco model="{rob.name}">
  <compiler angle="radian" inertiafromgeom="false" balanceinertia="false"/>
  <option timestep="{timestep:.17g}" integrator="{integrator}" gravity="{_v(rob.gravity)}">
    <flag contact="disable"/>
  </option>
  <worldbody>
    <body name="platform" pos="{_v(pos)}">
      <joint name="{COORDS[c]}" type="{jtype}" axis="{_v(l.dir)}" pos="0 0 0"{extra}/>
      <inertial pos="{_v(com)}" mass="{max(rob.m_platform, TINY):.17g}" diaginertia="{_v(Ip)}"/>{payload}
      <site name="p0" pos="{site}"/>
      <site name="end0" pos="{site}"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="m0" joint="{COORDS[c]}" gear="1"/>
  </actuator>
</mujoco>"""


def _articulated_platform(rob: Robot, Ip, payload: str, solref: float, solimp: str) -> tuple[str, str]:
    """An articulated platform as MuJoCo bodies: a translating frame at the pose point (slides
    x, y, z), in it the articulation body turned by the hinge rz (from rz0) carrying the end
    bars' point masses, the payload and the platform inertia; each leg's attachment on a body
    at its turning point that a hinge turns back by -rz (a joint equality), so that its fixed
    offset keeps its direction: p_i = pose + Rz(rz0 + rz) a_i + f_i."""
    ends = "".join(f"""
        <body name="end{k}" pos="{_v(rob.c_platform + np.array([sgn * rob.ends, 0.0, 0.0]))}">
          <inertial pos="0 0 0" mass="{max(0.5 * rob.m_platform, TINY):.17g}" diaginertia="{TINY} {TINY} {TINY}"/>
        </body>""" for k, sgn in enumerate((1.0, -1.0)))
    attach = "".join(f"""
        <body name="attach{i}" pos="{_v(l.p)}" euler="0 0 {-rob.rz0:.17g}">
          <joint name="c{i}" type="hinge" axis="0 0 1"/>
          <inertial pos="0 0 0" mass="{TINY}" diaginertia="{COUNTER} {COUNTER} {COUNTER}"/>
          <site name="p{i}" pos="{_v(l.f)}"/>
        </body>""" for i, l in enumerate(rob.legs))
    xml = f"""
    <body name="platform" pos="0 0 0">
      <joint name="x" type="slide" axis="1 0 0"/>
      <joint name="y" type="slide" axis="0 1 0"/>
      <joint name="z" type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{TINY}" diaginertia="{TINY} {TINY} {TINY}"/>
      <body name="articulation" euler="0 0 {rob.rz0:.17g}">
        <joint name="rz" type="hinge" axis="0 0 1"/>
        <inertial pos="0 0 0" mass="{TINY}" diaginertia="{_v(Ip)}"/>{ends}{attach}{payload}
      </body>
    </body>"""
    eq = "".join(f'\n    <joint joint1="c{i}" joint2="rz" polycoef="0 -1 0 0 0" solref="{solref:.17g} 1" solimp="{solimp}"/>'
                 for i in range(rob.n))
    return xml, eq


# ------------------------------------------------------------------ the run

def excitation(rob: Robot, t: np.ndarray, seed: int, scale: float = 1.0) -> np.ndarray:
    """Platform coordinates (N, n) around home: three sines per coordinate (0.5-3 Hz, random
    phases), faded in over RAMP; total amplitude per coordinate ``scale`` x (3 % of the mean
    leg span at home, base joint to platform point, for a translation; 4 deg for a rotation)."""
    ramp = np.where(t < RAMP, 0.5 * (1 - np.cos(np.pi * np.clip(t / RAMP, 0, 1))), 1.0)
    x = np.tile(rob.home, (len(t), 1))
    for j, (w, f, ph) in enumerate(_sines(rob, seed, scale)):
        x[:, j] += ramp * (w[None] * np.sin(2 * np.pi * f[None] * t[:, None] + ph[None])).sum(axis=1)
    return x


def _sines(rob: Robot, seed: int, scale: float) -> list:
    """Per declared coordinate, the excitation's three sines: amplitudes, frequencies [Hz] and
    phases [rad]."""
    rng = np.random.default_rng(seed)
    size = leg_span(rob)
    out = []
    for c in rob.coords:
        amp = scale * (0.03 * size if c < 3 else math.radians(4.0))
        w = rng.uniform(0.5, 1.0, 3)
        w *= amp / w.sum()
        f = rng.uniform(0.5, 3.0, 3)
        ph = rng.uniform(0, 2 * np.pi, 3)
        out.append((w, f, ph))
    return out


def smooth_excitation(rob: Robot, t: np.ndarray, seed: int) -> tuple:
    """The excitation's sines without the fade-in: platform coordinates (N, n) and their exact
    first and second time derivatives, scaled down (x0.7 a step) until every joint stays 10 %
    of its stroke inside its limits along it.  Returns x, xd, xdd, scale."""
    scale = 1.0
    for _ in range(30):
        x, xd, xdd = (np.tile(rob.home, (len(t), 1)), np.zeros((len(t), rob.n)), np.zeros((len(t), rob.n)))
        for j, (w, f, ph) in enumerate(_sines(rob, seed, scale)):
            om = 2 * np.pi * f[None]
            arg = om * t[:, None] + ph[None]
            x[:, j] += (w * np.sin(arg)).sum(axis=1)
            xd[:, j] = (w * om * np.cos(arg)).sum(axis=1)
            xdd[:, j] = -(w * om ** 2 * np.sin(arg)).sum(axis=1)
        if _inside_strokes(rob, ik(rob, x)):
            return x, xd, xdd, scale
        scale *= 0.7
    raise SystemExit(f"{rob.name}: no excitation around home stays inside the strokes")


def leg_span(rob: Robot) -> float:
    """Mean distance from a leg's first joint at home (the slider, the arm's axis point, the
    strut's base) to its platform point [m]: the robot's size."""
    if single_axis(rob):  # no rod: the stroke's span for a rail (the excitation's size)
        return float(rob.legs[0].stroke[1] - rob.legs[0].stroke[0])
    q0 = ik(rob, rob.home[None])[0]
    P0 = platform_points(rob, rob.home[None])[0]
    d = []
    for l, q, P in zip(rob.legs, q0, P0):
        base = l.base + q * l.dir if l.joint == RAIL else l.base
        d.append(np.linalg.norm(P - base))
    return float(np.mean(d))


def _inside_strokes(rob: Robot, q: np.ndarray) -> bool:
    """Every joint of q (N, n) reachable and 10 % of its stroke inside its limits."""
    lo = np.array([l.stroke[0] for l in rob.legs])
    hi = np.array([l.stroke[1] for l in rob.legs])
    margin = 0.1 * (hi - lo)
    return bool(np.all(np.isfinite(q)) and np.all(q >= lo + margin) and np.all(q <= hi - margin))


def fitted_excitation(rob: Robot, t, seed):
    """The excitation scaled down until every joint stays 10 % of its stroke inside its limits
    (and every leg reachable) along it."""
    scale = 1.0
    for _ in range(30):
        x = excitation(rob, t, seed, scale)
        q = ik(rob, x)
        if _inside_strokes(rob, q):
            return x, q, scale
        scale *= 0.7
    raise SystemExit(f"{rob.name}: no excitation around home stays inside the strokes")


@dataclass
class Result:
    robot: str
    kind: str
    n: int
    unit: str
    seconds: float
    scale: float
    t: np.ndarray
    x: np.ndarray
    xd: np.ndarray
    xdd: np.ndarray
    tau: np.ndarray          # MuJoCo's applied efforts
    tau_core: np.ndarray     # the core's inverse dynamics along x, xd, xdd
    tau_grav: np.ndarray     # the core's gravity load along x
    closure: np.ndarray      # max connect gap per record [m]
    q: np.ndarray            # MuJoCo's actuated joints
    q_core: np.ndarray       # the core's ik(x)
    qd: np.ndarray           # MuJoCo's actuated joint rates
    qd_core: np.ndarray      # the core's J(x) xd
    home_q: np.ndarray       # this script's IK at home (MuJoCo's layout)
    home_q_core: np.ndarray
    home_closure: float
    wall: float
    notes: list
    dependent_err: float = 0.0       # PRS/RPS: max |core's dependent components - MuJoCo's| along the run
    dependent_home_err: float = 0.0  # ... and against this script's own solve at home

    def figures(self, t0: float = 0.0) -> dict:
        k = self.t >= t0 - 1e-12
        e, r = self.tau[k], self.tau[k] - self.tau_core[k]
        dyn = self.tau[k] - self.tau_grav[k]
        rms = lambda a: float(np.sqrt(np.mean(a ** 2)))  # noqa: E731
        per = np.sqrt(np.mean(r ** 2, axis=0)) / np.sqrt(np.mean(e ** 2, axis=0))
        return {"effort": rms(e), "residual": rms(r), "pct": 100 * rms(r) / rms(e),
                "worst_joint_pct": 100 * float(per.max()), "inertial": rms(dyn),
                "pct_inertial": 100 * rms(r) / max(rms(dyn), 1e-300),
                "closure": float(self.closure[k].max()),
                "q_err": float(np.abs(self.q[k] - self.q_core[k]).max()),
                "qd_err": float(np.abs(self.qd[k] - self.qd_core[k]).max())}


def _gains(model, data, av, f_pd: float):
    """PD gains (matrices) from MuJoCo's joint-space inertia at the current state, Mq = (d qdd /
    d tau)^-1 probed with unit efforts: Kp = Mq wn^2, Kd = Mq 2 zeta wn (zeta 0.9)."""
    import mujoco

    n = len(av)
    data.ctrl[:] = 0
    mujoco.mj_forward(model, data)
    a0 = data.qacc[av].copy()
    G = np.empty((n, n))
    for j in range(n):
        data.ctrl[:] = 0
        data.ctrl[j] = 1.0
        mujoco.mj_forward(model, data)
        G[:, j] = data.qacc[av] - a0
    data.ctrl[:] = 0
    Mq = np.linalg.inv(G)
    Mq = 0.5 * (Mq + Mq.T)
    wn = 2 * np.pi * f_pd
    return Mq * wn ** 2, Mq * 2 * 0.9 * wn


def _drive(model, data, q_of, av, pose_of, gap, qref, qdref, Kp, Kd, nrec: int, sub: int, name: str) -> dict:
    """The PD (every MuJoCo step, no feed-forward) along qref; every ``sub`` steps mj_forward at
    the state and a record: platform (x, xd, xdd) by ``pose_of()``, efforts, joints, closure."""
    import mujoco

    n = len(av)
    rec = {k: np.empty((nrec, n)) for k in ("x", "xd", "xdd", "tau", "q", "qd")}
    closure = np.empty(nrec)
    step = 0
    for k in range(nrec):
        for _ in range(sub if k else 0):
            data.ctrl[:] = Kp @ (qref[step] - q_of()) + Kd @ (qdref[step] - data.qvel[av])
            mujoco.mj_step(model, data)
            step += 1
        # the effort of this instant, then the state's accelerations under it
        data.ctrl[:] = Kp @ (qref[step] - q_of()) + Kd @ (qdref[step] - data.qvel[av])
        mujoco.mj_forward(model, data)
        rec["x"][k], rec["xd"][k], rec["xdd"][k] = pose_of()
        rec["tau"][k] = data.actuator_force
        rec["q"][k], rec["qd"][k] = q_of(), data.qvel[av]
        closure[k] = gap()
        if not np.all(np.isfinite(data.qpos)):
            raise SystemExit(f"{name}: MuJoCo diverged at t = {k * DT_REC:.3f} s")
    rec["closure"] = closure
    return rec


def _compare(m, rec, name, kind, seconds, scale, home_q, home_q_core, home_closure, wall, notes) -> Result:
    """The core along MuJoCo's record."""
    nrec = len(rec["x"])
    tau_core = m.inverse_dynamics(rec["x"], rec["xd"], rec["xdd"])
    tau_grav = m.gravity_load(rec["x"])
    q_core = m.ik(rec["x"])
    qd_core = np.einsum("nij,nj->ni", m.jacobian(rec["x"]), rec["xd"])
    return Result(name, kind, m.ndof, m.facts.effort_unit, seconds, scale, np.arange(nrec) * DT_REC, rec["x"],
                  rec["xd"], rec["xdd"], rec["tau"], tau_core, tau_grav, rec["closure"], rec["q"], q_core, rec["qd"],
                  qd_core, home_q, home_q_core, home_closure, time.perf_counter() - wall, notes)


def _reference(rob: Robot, seconds: float, seed: int, timestep: float):
    """Joint reference at every MuJoCo step from the platform excitation (this script's IK)."""
    sub = int(round(DT_REC / timestep))
    nrec = int(round(seconds / DT_REC)) + 1
    ts = np.arange((nrec - 1) * sub + 2) * timestep
    _, qref, scale = fitted_excitation(rob, ts, seed)
    return qref, np.gradient(qref, timestep, axis=0), scale, nrec, sub


def run(robot: str, seconds: float = 4.0, seed: int = 1, timestep: float = 1e-4, integrator: str = "RK4",
        solref: float = 5e-4, solimp: str = "0.9999 0.9999 0.001 0.5 2", f_pd: float = 15.0) -> Result:
    """One run: MuJoCo from the description, the core's inverse dynamics along its motion."""
    import mujoco

    wall = time.perf_counter()
    path = resolve(robot)
    rob = read(path)
    notes = []
    xml, q0 = mjcf(rob, timestep, integrator, solref, solimp)
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    pq = [model.joint(COORDS[c]).qposadr[0] for c in rob.coords]
    pv = [model.joint(COORDS[c]).dofadr[0] for c in rob.coords]
    aq = [model.joint(actuated_joint(rob, i)).qposadr[0] for i in range(rob.n)]
    av = [model.joint(actuated_joint(rob, i)).dofadr[0] for i in range(rob.n)]
    ends = [model.site(f"end{i}").id for i in range(rob.n)]
    plats = [model.site(f"p{i}").id for i in range(rob.n)]
    data.qpos[pq] = rob.home
    dq = [model.joint(COORDS[c]).qposadr[0] for c in rob.dependent]
    if dq:  # the dependent components at home, from this script's own solve
        data.qpos[dq] = full_pose(rob, rob.home[None])[0, rob.dependent]
    mujoco.mj_forward(model, data)
    gap = lambda: float(np.max(np.linalg.norm(data.site_xpos[ends] - data.site_xpos[plats], axis=1)))  # noqa: E731
    home_closure = gap()
    home_q = data.qpos[aq].copy()

    # the core: the same file, asked only for ik(home) and the inverse dynamics; the drive
    # layer's sensor and actuator effects are not dynamics
    m = core_model(robot, rob, notes)
    home_q_core = m.ik(m.home())
    if np.max(np.abs(m.home() - rob.home)) > 1e-12:
        notes.append(f"home differs: core {m.home()} vs file {rob.home}")

    Kp, Kd = _gains(model, data, av, f_pd)
    qref, qdref, scale, nrec, sub = _reference(rob, seconds, seed, timestep)
    if scale < 1:
        notes.append(f"excitation scaled by {scale:.3g} to keep the strokes")
    dependent = []  # MuJoCo's dependent components at each record

    def pose_of():
        dependent.append(data.qpos[dq].copy())
        return data.qpos[pq], data.qvel[pv], data.qacc[pv]

    rec = _drive(model, data, lambda: data.qpos[aq], av, pose_of, gap, qref, qdref, Kp, Kd, nrec, sub, rob.name)
    res = _compare(m, rec, rob.name, rob.kind, seconds, scale, home_q, home_q_core, home_closure, wall, notes)
    if dq:  # the core's dependent components of MuJoCo's declared ones, against MuJoCo's
        res.dependent_err = float(np.abs(m.platform_pose(rec["x"])[0][:, rob.dependent] - np.array(dependent)).max())
        res.dependent_home_err = float(np.abs(m.platform_pose(rob.home)[0][rob.dependent]
                                              - full_pose(rob, rob.home[None])[0, rob.dependent]).max())
    return res


class _OpenTree:
    """The MJCF of :func:`mjcf` as an open tree: its constraints (the connects) disabled, so
    that MuJoCo's kinematics and dynamics are those of the tree alone.  ``close(x)`` moves
    every joint but the declared platform joints (the dependent platform joints, each leg's
    actuated and passive joints) by Gauss-Newton until the end site of every leg meets its
    platform site: MuJoCo computes the sites' positions (``mj_kinematics``) and their
    Jacobians (``mj_jacSite``), this class only solves.  A ball joint (the five-bar's elbow)
    moves by ``mj_integratePos``; its spin about the rod, which no closure decides, is left
    where it is (minimum-norm steps)."""

    def __init__(self, rob: Robot):
        import mujoco

        xml, _ = mjcf(rob, 1e-4, "RK4", 5e-4, "0.9999 0.9999 0.001 0.5 2")
        self.rob = rob
        self.model = model = mujoco.MjModel.from_xml_string(xml)
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
        self.data = data = mujoco.MjData(model)
        self.plat = platform_joints(rob)
        self.pq = [model.joint(COORDS[c]).qposadr[0] for c in rob.coords]
        self.allq = [model.joint(COORDS[c]).qposadr[0] for c in self.plat]
        self.decl = [model.joint(COORDS[c]).dofadr[0] for c in rob.coords]
        self.free = [j for j in range(model.nv) if j not in set(self.decl)]
        self.act = [model.joint(actuated_joint(rob, i)).dofadr[0] for i in range(rob.n)]
        self.ends = [model.site(f"end{i}").id for i in range(rob.n)]
        self.plats = [model.site(f"p{i}").id for i in range(rob.n)]
        data.qpos[:] = model.qpos0
        data.qpos[[model.joint(COORDS[c]).qposadr[0] for c in rob.dependent]] = \
            full_pose(rob, rob.home[None])[0, rob.dependent]  # the layout's pose (mjcf laid it out there)
        data.qpos[self.pq] = rob.home

    def gap_and_jacobian(self):
        """The closure gaps (3 n) end site minus platform site [m] and their Jacobian (3 n, nv)."""
        import mujoco

        model, data, n = self.model, self.data, self.rob.n
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        r = (data.site_xpos[self.ends] - data.site_xpos[self.plats]).ravel()
        jp, jr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        J = np.zeros((3 * n, model.nv))
        for i, (e, p) in enumerate(zip(self.ends, self.plats)):
            mujoco.mj_jacSite(model, data, jp, jr, e)
            J[3 * i:3 * i + 3] = jp
            mujoco.mj_jacSite(model, data, jp, jr, p)
            J[3 * i:3 * i + 3] -= jp
        return r, J

    def close(self, xk, tol: float = 1e-15, max_iter: int = 30):
        """Close the loops at declared coordinates xk; returns the last gap (3 n) and Jacobian."""
        import mujoco

        self.data.qpos[self.pq] = xk
        for _ in range(max_iter):
            r, J = self.gap_and_jacobian()
            if np.max(np.abs(r)) <= tol:
                break
            dv = np.zeros(self.model.nv)
            dv[self.free] = np.linalg.lstsq(J[:, self.free], -r, rcond=None)[0]
            mujoco.mj_integratePos(self.model, self.data.qpos, dv, 1.0)
        return r, J


def closure_pose(rob: Robot, x, tol: float = 1e-15, max_iter: int = 30) -> tuple[np.ndarray, float]:
    """The full platform poses (N, 6) at declared coordinates x (N, n), solved on MuJoCo's
    kinematics alone (:class:`_OpenTree`'s ``close``: nothing from the core).  Each pose starts
    from the previous solution (the first from the home layout).  Returns the poses and the
    largest closure gap met [m]."""
    tree = _OpenTree(rob)
    out, worst = np.zeros((len(np.atleast_2d(x)), 6)), 0.0
    for k, xk in enumerate(np.atleast_2d(np.asarray(x, float))):
        r, _ = tree.close(xk, tol, max_iter)
        worst = max(worst, float(np.max(np.abs(r))))
        out[k, tree.plat] = tree.data.qpos[tree.allq]
    return out, worst


def closed_loop_efforts(rob: Robot, x, xd, xdd) -> dict:
    """The actuated joints' efforts (N, n) that move the declared platform coordinates along
    x, xd, xdd (N, n), from MuJoCo's open tree with its loops closed exactly (no soft closure,
    nothing from the core).  At each sample:

    * positions: :class:`_OpenTree`'s ``close`` (gap below 1e-15 m);
    * rates: the closure's Jacobian J (``mj_jacSite``) split into the declared platform joints
      (set to xd) and all the others, J_free qd_free = -J_decl xd;
    * accelerations: J qdd = -(the sites' relative acceleration at qdd = 0), that acceleration
      from MuJoCo (``mj_rnePostConstraint`` with qacc = 0, then ``mj_objectAcceleration``:
      the J-dot qd term, centripetal and Coriolis parts included);
    * generalized forces of the tree: ``mj_inverse`` (constraints disabled: mass matrix with
      the drives' armature, bias forces, joint damping);
    * efforts by virtual work over the loop's admissible motions: tau_tree = J^T lambda + B u,
      with B the actuated joints' columns and every other joint (the platform's, the passive
      ones) carrying no force: solved for the loop forces lambda and the efforts u.

    Returns ``tau`` (N, n), ``gap`` (largest closure gap [m]), ``vel_residual`` and
    ``acc_residual`` (largest |J qd|, |J qdd + bias|: what the spin of a ball joint leaves
    undecided must be zero), ``force_residual`` (largest |tau_tree - J^T lambda - B u|, relative
    to |tau_tree|: zero when the efforts balance the tree exactly)."""
    import mujoco

    tree = _OpenTree(rob)
    model, data = tree.model, tree.data
    nv, n = model.nv, rob.n
    B = np.zeros((nv, n))
    B[tree.act, range(n)] = 1.0
    acc = np.zeros(6)
    out = {"tau": np.zeros((len(x), n)), "gap": 0.0, "vel_residual": 0.0, "acc_residual": 0.0,
           "force_residual": 0.0}
    for k in range(len(x)):
        r, J = tree.close(x[k])
        out["gap"] = max(out["gap"], float(np.max(np.abs(r))))
        Jf, Jd = J[:, tree.free], J[:, tree.decl]
        qd = np.zeros(nv)
        qd[tree.decl] = xd[k]
        qd[tree.free] = np.linalg.lstsq(Jf, -Jd @ xd[k], rcond=None)[0]
        # the sites' relative acceleration with qacc = 0 (the gravity MuJoCo puts in as a
        # uniform acceleration of the world cancels in the difference)
        data.qvel[:] = qd
        data.qacc[:] = 0
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_comVel(model, data)
        mujoco.mj_rnePostConstraint(model, data)
        bias = np.zeros(3 * n)
        for i, (e, p) in enumerate(zip(tree.ends, tree.plats)):
            mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_SITE, e, acc, 0)
            bias[3 * i:3 * i + 3] = acc[3:]
            mujoco.mj_objectAcceleration(model, data, mujoco.mjtObj.mjOBJ_SITE, p, acc, 0)
            bias[3 * i:3 * i + 3] -= acc[3:]
        qdd = np.zeros(nv)
        qdd[tree.decl] = xdd[k]
        qdd[tree.free] = np.linalg.lstsq(Jf, -bias - Jd @ xdd[k], rcond=None)[0]
        out["vel_residual"] = max(out["vel_residual"], float(np.max(np.abs(J @ qd))))
        out["acc_residual"] = max(out["acc_residual"], float(np.max(np.abs(J @ qdd + bias))))
        data.qacc[:] = qdd
        mujoco.mj_inverse(model, data)
        f = data.qfrc_inverse.copy()
        A = np.hstack([J.T, B])
        sol = np.linalg.lstsq(A, f, rcond=None)[0]
        out["tau"][k] = sol[-n:]
        out["force_residual"] = max(out["force_residual"],
                                    float(np.max(np.abs(A @ sol - f)) / max(np.max(np.abs(f)), 1e-300)))
    return out


def core_model(name: str, rob: Robot, notes: list):
    """The core's model of the same file, the drive friction MuJoCo has no counterpart for
    (Coulomb, Stribeck) set to 0 and said so in notes."""
    from cosim.core import Model

    m = Model(name if not ("/" in name or name.endswith(".toml")) else str(resolve(name)))
    unmodelled = {k: v for k, v in rob.drive.items() if v != 0 and k.endswith((".coulomb", ".stribeck"))}
    if unmodelled:
        notes.append(f"drive friction not in MuJoCo, set to 0 in the core: {', '.join(sorted(unmodelled))}")
        m.set_params({k: 0.0 for k in unmodelled})
    return m


def exact_effort_check(name: str, seconds: float = 4.0, samples: int = 400, seed: int = 1) -> dict:
    """:func:`closed_loop_efforts` along :func:`smooth_excitation` against the core's
    ``inverse_dynamics`` along the same declared motion.  Returns the figures: effort RMS,
    residual RMS, their ratio, the worst joint's ratio, the same over the inertial part (effort
    minus the core's gravity load), and closed_loop_efforts' residuals."""
    rob = read(resolve(name))
    notes: list = []
    m = core_model(name, rob, notes)
    t = np.linspace(0.0, seconds, samples)
    x, xd, xdd, scale = smooth_excitation(rob, t, seed)
    mj = closed_loop_efforts(rob, x, xd, xdd)
    tau = m.inverse_dynamics(x, xd, xdd)
    rms = lambda a, axis=None: np.sqrt(np.mean(a ** 2, axis=axis))  # noqa: E731
    r = mj["tau"] - tau
    inertial = tau - m.gravity_load(x)
    return {"inertial": float(rms(inertial)), "rel_inertial": float(rms(r) / rms(inertial)), "robot": rob.name, "kind": rob.kind, "unit": m.facts.effort_unit, "samples": samples, "scale": scale,
            "effort": float(rms(tau)), "residual": float(rms(r)), "rel": float(rms(r) / rms(tau)),
            "worst_joint_rel": float((rms(r, 0) / rms(tau, 0)).max()), "gap": mj["gap"],
            "vel_residual": mj["vel_residual"], "acc_residual": mj["acc_residual"],
            "force_residual": mj["force_residual"], "notes": notes}


def exact_effort_report(names, seconds: float, samples: int, seed: int) -> int:
    """Print :func:`exact_effort_check`'s figures per robot."""
    print(f"{'robot':<14} {'samples':>7} {'effort RMS':>13} {'residual RMS':>13} {'relative':>9} "
          f"{'worst joint':>11} {'inertial RMS':>13} {'relative':>9} {'gap [m]':>8} {'|J qd|':>8} {'|J qdd+b|':>9} {'balance':>8}")
    for name in names:
        f = exact_effort_check(name, seconds, samples, seed)
        print(f"{f['robot']:<14} {f['samples']:>7} {f['effort']:>10.4g} {f['unit']:2s} {f['residual']:>10.3g} "
              f"{f['unit']:2s} {f['rel']:>9.2g} {f['worst_joint_rel']:>11.2g} "
              f"{f['inertial']:>10.4g} {f['unit']:2s} {f['rel_inertial']:>9.2g} {f['gap']:>8.1g} "
              f"{f['vel_residual']:>8.1g} {f['acc_residual']:>9.1g} {f['force_residual']:>8.1g}")
        for note in f["notes"]:
            print(f"  note: {note}")
    return 0


def closure_report(names, n: int, seed: int) -> int:
    """Print, per robot with dependent coordinates, the core's full pose against
    :func:`closure_pose` at n poses drawn about home (z +-1 cm, tilts +-0.3 rad)."""
    from cosim.core import Model

    print(f"{'robot':<14} {'poses':>5} {'closure gap [m]':>16} {'x [m]':>9} {'y [m]':>9} {'rz [rad]':>9}")
    for name in names:
        rob = read(resolve(name))
        if not rob.dependent:
            continue
        m = Model(name if not ("/" in name or name.endswith(".toml")) else str(resolve(name)))
        rng = np.random.default_rng(seed)
        span = np.array([0.01 if COORDS[c] in ("x", "y", "z") else 0.3 for c in rob.coords])
        X = rob.home + rng.uniform(-1, 1, (n, len(rob.coords))) * span
        full, gap = closure_pose(rob, X)
        err = np.abs(m.platform_pose(X)[0] - full).max(axis=0)
        print(f"{rob.name:<14} {n:>5} {gap:>16.2g} " + " ".join(f"{err[k]:>9.2g}" for k in rob.dependent))
    return 0


def euler_xyz(R):
    """(rx, ry, rz) with R = Rx(rx) Ry(ry) Rz(rz)."""
    ry = math.asin(max(-1.0, min(1.0, R[0, 2])))
    return np.array([math.atan2(-R[1, 2], R[2, 2]), ry, math.atan2(-R[0, 1], R[0, 0])])


def free_pose(qpos, qvel, qacc):
    """A free joint's state as the core's (x, y, z, rx, ry, rz), rates and accelerations: MuJoCo's
    linear parts are the world-frame origin's, its angular ones in the body frame."""
    import mujoco

    R = np.empty(9)
    mujoco.mju_quat2Mat(R, qpos[3:7])
    R = R.reshape(3, 3)
    r = euler_xyz(R)
    sx, cx, sy, cy = math.sin(r[0]), math.cos(r[0]), math.sin(r[1]), math.cos(r[1])
    E = np.array([[1, 0, sy], [0, cx, -sx * cy], [0, sx, cx * cy]])  # omega = E r_dot
    rd = np.linalg.solve(E, R @ qvel[3:6])
    ax, ay = rd[0], rd[1]
    Ed = np.array([[0, 0, cy * ay], [0, -sx * ax, -cx * cy * ax + sx * sy * ay],
                   [0, cx * ax, -sx * cy * ax - cx * sy * ay]])
    rdd = np.linalg.solve(E, R @ qacc[3:6] - Ed @ rd)  # alpha_world = R d(omega_body)/dt
    return np.r_[qpos[:3], r], np.r_[qvel[:3], rd], np.r_[qacc[:3], rdd]


def run_blind(seconds: float = 4.0, seed: int = 1, integrator: str | None = None, f_pd: float = 15.0) -> Result:
    """The same check on bench/foreign/mujoco_blind.py's clean MuJoCo 6-PUS (built from the
    6-PUS's parameters: free platform, capsule legs, connect at
    solref 0.0002, implicitfast at 0.1 ms), driven along the same excitation (that of
    robots/6pus.toml, the same robot) by the same PD."""
    import mujoco

    sys.path.insert(0, str(REPO / "bench"))
    sys.path.insert(0, str(REPO / "bench" / "foreign"))
    from mujoco_blind import case_xml

    from cosim.core import Model

    wall = time.perf_counter()
    m = Model("6pus")
    xml, _ = case_xml(m, [], np.random.default_rng(0))
    model = mujoco.MjModel.from_xml_string(xml)
    if integrator:
        model.opt.integrator = getattr(mujoco.mjtIntegrator, "mjINT_" + integrator.upper())
    data = mujoco.MjData(model)
    aq = [model.joint(f"rail{i}").qposadr[0] for i in range(6)]
    av = [model.joint(f"rail{i}").dofadr[0] for i in range(6)]
    ends = [model.site(f"end{i}").id for i in range(6)]
    plats = [model.site(f"p{i}").id for i in range(6)]
    fq = model.joint(model.body("platform").jntadr[0]).qposadr[0]
    fv = model.joint(model.body("platform").jntadr[0]).dofadr[0]
    q0 = m.ik(m.home())  # mujoco_blind's convention: its joints are zero at home
    mujoco.mj_forward(model, data)
    gap = lambda: float(np.max(np.linalg.norm(data.site_xpos[ends] - data.site_xpos[plats], axis=1)))  # noqa: E731
    home_closure = gap()
    rob = read(resolve("6pus"))
    Kp, Kd = _gains(model, data, av, f_pd)
    qref, qdref, scale, nrec, sub = _reference(rob, seconds, seed, model.opt.timestep)
    rec = _drive(model, data, lambda: q0 + data.qpos[aq], av,
                 lambda: free_pose(data.qpos[fq:fq + 7], data.qvel[fv:fv + 6], data.qacc[fv:fv + 6]), gap,
                 qref, qdref, Kp, Kd, nrec, sub, "mujoco_blind")
    integ = mujoco.mjtIntegrator(model.opt.integrator).name.removeprefix("mjINT_")
    notes = [f"mujoco_blind's MJCF: free platform, capsule legs, its solref/solimp, {integ} at "
             f"{model.opt.timestep:g} s"]
    return _compare(m, rec, "6pus (mujoco_blind model)", "PUS", seconds, scale, q0, q0, home_closure, wall, notes)


def report(res: Result, verbose: bool = False) -> None:
    a, b = res.figures(0.0), res.figures(RAMP)
    print(f"\n{res.robot} ({res.kind}, {res.n} legs, {res.seconds:g} s, excitation x{res.scale:.3g}, "
          f"{res.wall:.1f} s wall)")
    if "mujoco_blind" in res.robot:
        print(f"  home joints: mujoco_blind lays its model out with the core's ik(home) (closure "
              f"{res.home_closure:.1e} m)")
    else:
        print(f"  home joints: this script's IK (MuJoCo's layout, closure {res.home_closure:.1e} m) vs core "
              f"ik(home): max |diff| {np.max(np.abs(res.home_q - res.home_q_core)):.1e}")
    u = res.unit
    print(f"  {'':14s} {'effort RMS':>12s} {'residual RMS':>13s} {'resid/effort':>12s} {'worst joint':>11s} "
          f"{'inertial RMS':>12s} {'resid/inert':>11s} {'max closure':>11s} {'max |q - ik|':>12s} "
          f"{'max |qd - J xd|':>15s}")
    for label, f in (("whole run", a), (f"after {RAMP:g} s", b)):
        print(f"  {label:14s} {f['effort']:9.4g} {u:2s} {f['residual']:10.3g} {u:2s} {f['pct']:10.2e} % "
              f"{f['worst_joint_pct']:9.2e} % {f['inertial']:9.4g} {u:2s} {f['pct_inertial']:9.2e} % "
              f"{f['closure']:9.2e} m {f['q_err']:10.2e}   {f['qd_err']:12.2e}")
    for n in res.notes:
        print(f"  note: {n}")
    if verbose:
        k = res.t >= RAMP
        r = res.tau[k] - res.tau_core[k]
        print("  per joint: effort RMS, residual RMS, mean residual")
        for j in range(res.n):
            print(f"    {j + 1}: {np.sqrt(np.mean(res.tau[k, j] ** 2)):10.4g} {np.sqrt(np.mean(r[:, j] ** 2)):10.3g} "
                  f"{np.mean(r[:, j]):10.3g}")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("robots", nargs="*", help="description names or files; 'all' = robots/robots.list")
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--timestep", type=float, default=1e-4)
    ap.add_argument("--integrator", default="RK4", choices=["RK4", "implicitfast", "implicit", "Euler"],
                    help="MuJoCo's integrator (default RK4; see the docstring on implicitfast and joint damping)")
    ap.add_argument("--blind", action="store_true",
                    help="also run the check on mujoco_blind.py's clean 6-PUS model (hand-written core model '6pus')")
    ap.add_argument("--solref", type=float, default=5e-4, help="connect time constant [s] (default 5e-4)")
    ap.add_argument("--solimp", default="0.9999 0.9999 0.001 0.5 2")
    ap.add_argument("--pd-hz", type=float, default=15.0, help="PD bandwidth [Hz] (default 15)")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--closure", type=int, default=0, metavar="N",
                    help="robots with dependent coordinates: only compare the core's full pose with MuJoCo's "
                         "kinematics closed by closure_pose at N random poses (no simulation)")
    ap.add_argument("--exact-efforts", type=int, default=0, metavar="N",
                    help="no simulation: the efforts along a smooth excitation (--seconds long, N samples) from "
                         "MuJoCo's open tree with its loops closed exactly (closed_loop_efforts) against the "
                         "core's inverse dynamics")
    a = ap.parse_args(argv)
    names = [n for r in a.robots for n in (listed_robots() if r == "all" else [r])]
    import mujoco

    if a.closure:
        return closure_report(names, a.closure, a.seed)
    if a.exact_efforts:
        return exact_effort_report(names, a.seconds, a.exact_efforts, a.seed)

    print(f"MuJoCo {mujoco.__version__}, timestep {a.timestep:g} s, {a.integrator}, connect solref {a.solref:g} 1, "
          f"solimp {a.solimp}, seed {a.seed}")
    for name in names:
        report(run(name, a.seconds, a.seed, a.timestep, a.integrator, a.solref, a.solimp, a.pd_hz), a.verbose)
    if a.blind:  # its own integrator (implicitfast), then RK4
        report(run_blind(a.seconds, a.seed, None, a.pd_hz), a.verbose)
        report(run_blind(a.seconds, a.seed, "RK4", a.pd_hz), a.verbose)
    if not names and not a.blind:
        ap.error("name a robot (or 'all'), or give --blind")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
