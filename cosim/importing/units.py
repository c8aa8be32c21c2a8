"""Units a map may give a source variable in, and their factor to the recording's SI unit.

Only linear conversions (a factor, no offset) between units of one kind; anything else is
refused by name, never guessed.
"""
from __future__ import annotations

import math

from ..errors import InputError

#: unit -> (kind, factor to the SI unit of that kind)
UNITS = {
    # length [m]
    "m": ("length", 1.0), "mm": ("length", 1e-3), "cm": ("length", 1e-2), "um": ("length", 1e-6),
    "µm": ("length", 1e-6), "nm": ("length", 1e-9), "in": ("length", 0.0254),
    # angle [rad]
    "rad": ("angle", 1.0), "mrad": ("angle", 1e-3), "urad": ("angle", 1e-6), "deg": ("angle", math.pi / 180),
    "rev": ("angle", 2 * math.pi),
    # time [s]
    "s": ("time", 1.0), "ms": ("time", 1e-3), "us": ("time", 1e-6), "µs": ("time", 1e-6), "ns": ("time", 1e-9),
    "min": ("time", 60.0), "h": ("time", 3600.0),
    # linear velocity [m/s]
    "m/s": ("linear velocity", 1.0), "mm/s": ("linear velocity", 1e-3), "cm/s": ("linear velocity", 1e-2),
    "um/s": ("linear velocity", 1e-6), "m/min": ("linear velocity", 1 / 60), "mm/min": ("linear velocity", 1e-3 / 60),
    # angular velocity [rad/s]
    "rad/s": ("angular velocity", 1.0), "mrad/s": ("angular velocity", 1e-3),
    "deg/s": ("angular velocity", math.pi / 180), "rpm": ("angular velocity", 2 * math.pi / 60),
    "rev/s": ("angular velocity", 2 * math.pi),
    # force [N]
    "N": ("force", 1.0), "mN": ("force", 1e-3), "kN": ("force", 1e3), "daN": ("force", 10.0),
    # torque [N m]
    "N m": ("torque", 1.0), "mN m": ("torque", 1e-3), "kN m": ("torque", 1e3), "N mm": ("torque", 1e-3),
}

#: the SI unit of each kind (what a pkm-recording holds)
SI = {"length": "m", "angle": "rad", "time": "s", "linear velocity": "m/s", "angular velocity": "rad/s",
      "force": "N", "torque": "N m"}


def canonical(unit: str) -> str:
    """One spelling per unit: ``"Nm"``, ``"N*m"``, ``"N.m"``, ``"N·m"`` are ``"N m"``;
    ``"degree"``/``"degrees"`` are ``"deg"``; surrounding spaces ignored."""
    u = " ".join(unit.strip().split())
    for sep in ("*", "·", "."):
        u = u.replace(f"N{sep}m", "N m")
    u = {"Nm": "N m", "mNm": "mN m", "kNm": "kN m", "Nmm": "N mm", "degree": "deg", "degrees": "deg",
         "radian": "rad", "radians": "rad", "sec": "s", "msec": "ms", "°": "deg", "°/s": "deg/s",
         "r/min": "rpm"}.get(u, u)
    return u


def kind_of(si_unit: str) -> str:
    """The kind of quantity a recording column's SI unit measures (``"m/s"`` -> linear velocity)."""
    return UNITS[si_unit][0]


def factor(unit: str, si_unit: str) -> float:
    """The factor taking values in ``unit`` to ``si_unit`` (both of one kind).

    Raises
    ------
    ValueError
        ``unit`` is unknown, or of another kind than ``si_unit`` (the message says which
        units that kind accepts).

    Example
    -------
    >>> factor("mm", "m")
    0.001
    >>> round(factor("deg/s", "rad/s"), 6)
    0.017453
    """
    want = kind_of(si_unit)
    u = canonical(unit)
    same = ", ".join(k for k, (kind, _) in UNITS.items() if kind == want)
    if u not in UNITS:
        raise InputError(f"unknown unit {unit!r} ({_a(want)} is in one of: {same})")
    kind, f = UNITS[u]
    if kind != want:
        raise InputError(f"unit {unit!r} is {_a(kind)}, the column is {_a(want)} in {si_unit} (one of: {same})")
    return f / UNITS[si_unit][1]


def _a(kind: str) -> str:
    return f"an {kind}" if kind[0] in "aeiou" else f"a {kind}"
