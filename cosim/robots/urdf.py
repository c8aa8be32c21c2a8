"""URDF in: a serial arm's URDF file read into a robot description (docs/robots.md, URDF).

The URDF's links and joints become the description's ``[[joint]]`` tables, base to tool:

* revolute, continuous and prismatic joints are the arm's joints, each with its ``<origin>``,
  ``<axis>`` (normalised) and ``<limit lower upper>`` (continuous joints have none);
* the link a joint moves brings its ``<inertial>`` (mass, centre of mass, inertia turned
  into the link's axes);
* fixed joints are merged: a link fixed to another adds its inertial to that link's (masses
  summed, inertias moved to the common centre of mass), and the joints below it are placed
  through it; links fixed to the base add nothing (the base does not move);
* the tool frame is the link at the end of the fixed joints below the last moving joint
  (``tip`` chooses another link of that group).

The chain must be serial: one moving joint after another, at most six. Every mistake
raises :class:`URDFError` naming the element and its line ("arm.urdf:12: <joint
name="elbow">: ...").

Example
-------
>>> from cosim.robots.urdf import urdf_description
>>> text = urdf_description("robots/urdf/ur5.urdf")   # doctest: +SKIP
>>> print(text.splitlines()[1])                        # doctest: +SKIP
name = "ur5"
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

from ..errors import URDFError

MAX_JOINTS = 6  # the core's serial arms (the drive layer's joints)
MOVING = ("revolute", "continuous", "prismatic")
NOT_READ = ("floating", "planar")


@dataclass
class _Inertial:
    m: float = 0.0
    c: np.ndarray = field(default_factory=lambda: np.zeros(3))  # [m], in the link frame
    I: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))  # about c, link axes [kg m2]


@dataclass
class _Joint:
    name: str
    type: str
    parent: str
    child: str
    T: np.ndarray  # origin, 4x4 in the parent link frame
    axis: np.ndarray
    limits: tuple | None
    line: int


def _rpy(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _rpy_of(R):
    """URDF's roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    angles = (math.atan2(R[2, 1], R[2, 2]), math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0])),
              math.atan2(R[1, 0], R[0, 0]))
    return tuple(a + 0.0 for a in angles)  # no -0.0 in the text


class _Reader:
    """Attribute and element reading with the file and line in every message."""

    def __init__(self, path):
        self.path = path

    def fail(self, el, what):
        raise URDFError(f"{self.path}:{getattr(el, 'line', '?')}: {self.tag(el)}: {what}")

    @staticmethod
    def tag(el):
        name = el.get("name")
        return f'<{el.tag} name="{name}">' if name is not None else f"<{el.tag}>"

    def numbers(self, el, attr, n, default=None):
        text = el.get(attr) if el is not None else None
        if text is None:
            if default is None:
                self.fail(el, f"attribute {attr} is missing ({n} numbers)")
            return np.array(default, dtype=float)
        try:
            v = np.array([float(t) for t in text.split()], dtype=float)
        except ValueError:
            self.fail(el, f'{attr}="{text}" is not {n} numbers')
        if v.size != n or not np.all(np.isfinite(v)):
            self.fail(el, f'{attr}="{text}" must be {n} finite numbers')
        return v

    def origin(self, parent):
        o = parent.find("origin")
        T = np.eye(4)
        if o is not None:
            T[:3, :3] = _rpy(*self.numbers(o, "rpy", 3, (0, 0, 0)))
            T[:3, 3] = self.numbers(o, "xyz", 3, (0, 0, 0))
        return T


class _Element(ET.Element):
    """An element that can carry its line."""

    line = "?"


def _parse(path):
    """The XML tree, each element with the line it starts on (``el.line``)."""
    import xml.parsers.expat

    builder = ET.TreeBuilder(element_factory=_Element)
    p = xml.parsers.expat.ParserCreate()

    def start(tag, attrs):
        el = builder.start(tag, attrs)
        el.line = p.CurrentLineNumber

    p.StartElementHandler = start
    p.EndElementHandler = builder.end
    p.CharacterDataHandler = builder.data
    try:
        with open(path, "rb") as f:
            p.Parse(f.read(), True)
    except xml.parsers.expat.ExpatError as e:
        raise URDFError(f"{path}:{e.lineno}: not well-formed XML ({xml.parsers.expat.ErrorString(e.code)})") from None
    return builder.close()


def _inertial(rd, link, moving=False):
    """The link's inertial (None for a massless frame); ``moving``: a moving joint's child."""
    el = link.find("inertial")
    if el is None:
        return None
    mass = el.find("mass")
    if mass is None:
        rd.fail(el, "<mass value=...> is missing")
    m = float(rd.numbers(mass, "value", 1)[0])
    if m < 0 or (moving and m == 0):
        rd.fail(mass, f"value={m:g} kg: the mass of a link a joint moves must be > 0" if moving else
                f"value={m:g} kg: a mass must be >= 0")
    iel = el.find("inertia")
    if iel is None:
        rd.fail(el, "<inertia ixx=... iyy=... izz=... ixy=... ixz=... iyz=...> is missing")
    v = {k: rd.numbers(iel, k, 1)[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
    Iin = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]], [v["ixz"], v["iyz"], v["izz"]]])
    e = np.linalg.eigvalsh(Iin)
    tol = 1e-12 * max(1.0, float(np.max(np.abs(e))))
    if e.min() < -tol or e[0] + e[1] < e[2] - tol:
        rd.fail(iel, f"principal moments {e[0]:.6g}, {e[1]:.6g}, {e[2]:.6g} kg m2 are not a rigid body's "
                     "(each >= 0 and at most the sum of the others)")
    if m == 0:
        if np.any(Iin != 0):
            rd.fail(iel, "a link of mass 0 (a frame) has no inertia")
        return None
    T = rd.origin(el)
    return _Inertial(m, T[:3, 3].copy(), T[:3, :3] @ Iin @ T[:3, :3].T)


def _merge(a: _Inertial | None, b: _Inertial | None, T):
    """a plus b, b given in a frame placed by T in a's frame."""
    if b is None:
        return a
    c_b = T[:3, :3] @ b.c + T[:3, 3]
    I_b = T[:3, :3] @ b.I @ T[:3, :3].T
    if a is None:
        return _Inertial(b.m, c_b, I_b)
    m = a.m + b.m
    c = (a.m * a.c + b.m * c_b) / m

    def shift(mass, ci, Ii):
        d = ci - c
        return Ii + mass * (d @ d * np.eye(3) - np.outer(d, d))

    return _Inertial(m, c, shift(a.m, a.c, a.I) + shift(b.m, c_b, I_b))


def _joints(rd, root, links):
    """The <joint> elements, checked one by one."""
    joints, child_of = [], {}
    for el in root.findall("joint"):
        name, jtype = el.get("name"), el.get("type")
        if not name:
            rd.fail(el, "attribute name is missing")
        if jtype is None:
            rd.fail(el, "attribute type is missing (revolute, continuous, prismatic or fixed)")
        if jtype in NOT_READ:
            rd.fail(el, f'type="{jtype}" is not read: a serial arm\'s joints are revolute, continuous, prismatic or fixed')
        if jtype not in MOVING + ("fixed",):
            rd.fail(el, f'type="{jtype}" is not a URDF joint type (revolute, continuous, prismatic, fixed, floating, '
                        "planar)")
        if el.find("mimic") is not None:
            rd.fail(el.find("mimic"), "mimic joints are not read: every joint of a serial arm is a coordinate")
        ends = {}
        for end in ("parent", "child"):
            e = el.find(end)
            if e is None:
                rd.fail(el, f"<{end} link=...> is missing: a joint joins a parent link to a child link")
            ln = e.get("link")
            if ln not in links:
                rd.fail(e, f'link="{ln}" is not a <link> of this robot' if ln else "attribute link is missing")
            ends[end] = ln
        if ends["child"] in child_of:
            other = child_of[ends["child"]]
            rd.fail(el, f'link "{ends["child"]}" is already the child of <joint name="{other.name}"> (line '
                        f"{other.line}): a link has one parent joint (closed loops are not URDF)")
        axis = rd.numbers(el.find("axis"), "xyz", 3, (1, 0, 0)) if el.find("axis") is not None else np.array([1.0, 0, 0])
        if jtype in MOVING:
            n = np.linalg.norm(axis)
            if not n > 1e-9:
                rd.fail(el.find("axis"), "xyz is zero: a moving joint needs an axis")
            axis = axis / n
        limits = None
        if jtype in ("revolute", "prismatic"):
            lim = el.find("limit")
            if lim is None:
                rd.fail(el, f"<limit lower=... upper=...> is missing (a {jtype} joint has limits; make it continuous "
                            "if it has none)")
            lo, hi = (rd.numbers(lim, k, 1)[0] for k in ("lower", "upper"))
            if not lo < hi:
                rd.fail(lim, f"lower={lo:g} must be below upper={hi:g}")
            limits = (lo, hi)
        j = _Joint(name, jtype, ends["parent"], ends["child"], rd.origin(el), axis, limits, el.line)
        child_of[j.child] = j
        joints.append(j)
    return joints, child_of


@dataclass
class _Group:
    """Links held rigidly together by fixed joints: their inertial and frames, in the
    frame of its first link, and the moving joints that leave it."""
    inertial: _Inertial | None = None
    frames: dict = field(default_factory=dict)  # link name -> 4x4 in the group's frame
    leaves: list = field(default_factory=list)  # links with no fixed joint below them
    moving: list = field(default_factory=list)  # (joint, 4x4 origin in the group's frame)


def _group(rd, link, below, links, out=None, T=None, first_moving=False):
    """The group of ``link`` (``first_moving``: a moving joint's child)."""
    out = _Group() if out is None else out
    T = np.eye(4) if T is None else T
    out.inertial = _merge(out.inertial, _inertial(rd, links[link], moving=first_moving), T)
    out.frames[link] = T
    fixed = [j for j in below.get(link, []) if j.type == "fixed"]
    for j in below.get(link, []):
        if j.type == "fixed":
            _group(rd, j.child, below, links, out, T @ j.T)
        else:
            out.moving.append((j, T @ j.T))
    if not fixed:
        out.leaves.append(link)
    return out


def _chain(rd, root, tip):
    """(robot name, [(joint, origin 4x4, _Inertial)], tool 4x4) of the serial arm."""
    if root.tag != "robot":
        rd.fail(root, "the root element must be <robot>")
    links = {}
    for el in root.findall("link"):
        if not el.get("name"):
            rd.fail(el, "attribute name is missing")
        if el.get("name") in links:
            rd.fail(el, f"a second link named \"{el.get('name')}\" (the first is on line {links[el.get('name')].line})")
        links[el.get("name")] = el
    if not links:
        rd.fail(root, "no <link>: a robot is links joined by joints")
    joints, child_of = _joints(rd, root, links)
    bases = [n for n in links if n not in child_of]
    if not bases:
        rd.fail(root.find("joint"), "every link is a joint's child: the joints close a loop (a URDF is a tree)")
    if len(bases) > 1:
        rd.fail(links[bases[1]], f'links "{bases[0]}" and "{bases[1]}" both have no parent joint: a URDF is one tree '
                                 "(join them with a joint)")
    below = {}
    for j in joints:
        below.setdefault(j.parent, []).append(j)
    chain, group, seen = [], _group(rd, bases[0], below, links), set()
    while True:
        seen |= set(group.frames)
        if len(group.moving) > 1:
            (a, _), (b, _) = group.moving[:2]
            rd.fail(root.find(f"joint[@name='{b.name}']"),
                    f'the arm branches: <joint name="{a.name}"> (line {a.line}) and this joint both move from link '
                    f'"{a.parent}"\'s rigid group; a serial arm is one chain (trees are not read)')
        if not group.moving:
            break
        j, T = group.moving[0]
        if links[j.child].find("inertial") is None:
            rd.fail(links[j.child], f'<inertial> is missing: the link <joint name="{j.name}"> (line {j.line}) moves '
                                    "needs its mass, centre of mass and inertia")
        group = _group(rd, j.child, below, links, first_moving=True)
        chain.append((j, T, group.inertial))
        if len(chain) > MAX_JOINTS:
            rd.fail(root.find(f"joint[@name='{j.name}']"), f"a seventh moving joint: the toolkit's serial arms have at "
                                                            f"most {MAX_JOINTS} joints")
    unreached = [j for j in joints if j.parent not in seen]
    if unreached:
        rd.fail(root.find(f"joint[@name='{unreached[0].name}']"), f'link "{unreached[0].parent}" is not reached from the '
                f'base link "{bases[0]}": these joints close a loop')
    if not chain:
        rd.fail(root, "no revolute, continuous or prismatic joint: nothing moves")
    if tip is None:
        tip = group.leaves[0] if len(group.leaves) == 1 else chain[-1][0].child
    elif tip not in group.frames:
        raise URDFError(f"{rd.path}: tip link \"{tip}\" is not fixed to the last moving link (links there: "
                        f"{', '.join(group.frames)})")
    return root.get("name") or "urdf_arm", chain, group.frames[tip]


def _fmt(v):
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def urdf_description(path, *, tip: str | None = None, name: str | None = None) -> str:
    """A URDF file's serial arm as a description's text (TOML, docs/robots.md).

    Parameters
    ----------
    path : str
        The URDF file.
    tip : str, optional
        The link whose frame is the tool frame (default: the link at the end of the fixed
        joints below the last moving joint, or that joint's link if they branch).
    name : str, optional
        The robot's name (default: the URDF's ``<robot name>``).

    Returns
    -------
    str
        The description; its joints' parameters are ``joint[i].*`` and ``link[i].*`` (SI units).

    Raises
    ------
    URDFError
        A mistake of the file, naming its line and element.
    """
    rd = _Reader(str(path))
    robot_name, chain, tool = _chain(rd, _parse(str(path)), tip)
    robot_name = name or "".join(ch if ch.isalnum() or ch in "_-." else "_" for ch in robot_name)
    home = []
    for j, _, _ in chain:
        lo, hi = j.limits or (-math.inf, math.inf)
        home.append(0.0 if lo <= 0 <= hi else 0.5 * (lo + hi))
    out = [f"# Read from {path} by cosim (cosim/robots/urdf.py): a serial arm of {len(chain)} joints.",
           "[robot]", f'name = "{robot_name}"', 'kind = "serial"', f'title = "{robot_name}, read from a URDF"',
           f'source = "{path}"', f"home = {_fmt(home)}", ""]
    for j, T, ine in chain:
        I = ine.I
        out += ["[[joint]]", f'name = "{j.name}"', f'type = "{j.type}"', f"origin = {_fmt(T[:3, 3])}",
                f"rpy = {_fmt(_rpy_of(T[:3, :3]))}", f"axis = {_fmt(j.axis)}"]
        if j.limits:
            out.append(f"limits = {_fmt(j.limits)}")
        out += [f"mass = {float(ine.m)!r}", f"com = {_fmt(ine.c)}",
                f"inertia = {_fmt([I[0, 0], I[0, 1], I[0, 2], I[1, 1], I[1, 2], I[2, 2]])}", ""]
    out += ["[tool]", f"origin = {_fmt(tool[:3, 3])}", f"rpy = {_fmt(_rpy_of(tool[:3, :3]))}", ""]
    return "\n".join(out)


def register_urdf(path, *, tip: str | None = None, name: str | None = None) -> str:
    """Reads a URDF (:func:`urdf_description`) and gives its arm to the core; returns the
    robot's name, which ``Model`` then takes (``Model("arm.urdf")`` does this)."""
    from .._native import lib, raise_for
    from ..core._handles import _errbuf

    text = urdf_description(path, tip=tip, name=name)
    err = _errbuf()
    raise_for(lib.pkm_robot_register_description(text.encode(), f"{path} (read as a description)".encode(), err,
                                                 len(err)), err.value.decode())
    return text.split('name = "', 1)[1].split('"', 1)[0]
