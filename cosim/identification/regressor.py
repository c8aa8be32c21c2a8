"""The inverse-dynamics regressor of a serial arm, built from the core by linearity.

A serial arm's inverse dynamics is linear in each link's ten standard inertial parameters
(Khalil & Dombre 2002, sec. 12.3; Atkeson, An & Hollerbach 1986): the mass ``m`` [kg], the
first moments ``mx, my, mz`` = m c [kg m] and the inertia about the joint frame's origin
``XX, XY, XZ, YY, YZ, ZZ`` [kg m2], all in joint i's frame; and in the drive layer's rotor
inertia, viscous and Coulomb friction and effort offset of each joint.  So column k of the
regressor W (tau = W phi + tau_rest) is the change of the core's inverse dynamics per unit
of phi_k: here two evaluations of :meth:`cosim.core.Model.inverse_dynamics`, the parameter
set through the model's parameter API.  No equation of motion is written in Python; the
conversion between the core's link parameters (m, centre, inertia about the centre) and the
standard ones is the parallel-axis theorem.

Example
-------
>>> import numpy as np
>>> from cosim.core import Model
>>> from cosim.identification.regressor import regressor
>>> m = Model("robots/urdf/ur5.urdf")
>>> q = np.tile(m.home(), (3, 1))
>>> W, names, rest = regressor(m, q, 0 * q, 0 * q)
>>> W.shape, names[:2]
((18, 84), ['link[1].m', 'link[1].mx'])
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

LINK = ("m", "mx", "my", "mz", "XX", "XY", "XZ", "YY", "YZ", "ZZ")
DRIVE = ("rotor_inertia", "viscous", "coulomb", "offset")
_STEP = 0.25  # the perturbation of each standard parameter about the unit body (keeps it a rigid body's)


def link_to_standard(m: float, c, inertia) -> np.ndarray:
    """The ten standard parameters of a link from its mass [kg], centre ``c`` (3,) [m] and
    inertia about the centre ``(ixx, ixy, ixz, iyy, iyz, izz)`` [kg m2] (parallel axes)."""
    c = np.asarray(c, dtype=float)
    ixx, ixy, ixz, iyy, iyz, izz = inertia
    Ic = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    Io = Ic + m * (c @ c * np.eye(3) - np.outer(c, c))
    return np.array([m, *(m * c), Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2], Io[2, 2]])


def standard_to_link(phi) -> tuple[float, np.ndarray, np.ndarray]:
    """Inverse of :func:`link_to_standard`: (m, c, inertia about the centre as ixx, ixy,
    ixz, iyy, iyz, izz) from the ten standard parameters (m must be positive)."""
    m, h = float(phi[0]), np.asarray(phi[1:4], dtype=float)
    c = h / m
    XX, XY, XZ, YY, YZ, ZZ = phi[4:10]
    Io = np.array([[XX, XY, XZ], [XY, YY, YZ], [XZ, YZ, ZZ]])
    Ic = Io - m * (c @ c * np.eye(3) - np.outer(c, c))
    return m, c, np.array([Ic[0, 0], Ic[0, 1], Ic[0, 2], Ic[1, 1], Ic[1, 2], Ic[2, 2]])


def link_params(i: int, phi) -> dict:
    """The core's parameters of link ``i`` (from 1) for standard parameters ``phi`` (10,)."""
    m, c, ic = standard_to_link(phi)
    names = ("cx", "cy", "cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")
    return {f"link[{i}].m": m, **{f"link[{i}].{n}": float(v) for n, v in zip(names, [*c, *ic])}}


def standard_names(nd: int, drive=DRIVE, extra=()) -> list[str]:
    """Names of the standard parameters: ``link[i].m ... link[i].ZZ`` for each link, then
    ``joint[i].<drive term>`` for each joint and each name in ``drive``, then ``extra``."""
    return [f"link[{i}].{p}" for i in range(1, nd + 1) for p in LINK] + \
        [f"joint[{i}].{p}" for i in range(1, nd + 1) for p in drive] + list(extra)


def standard_values(model, drive=DRIVE, extra=()) -> np.ndarray:
    """The model's standard parameters, in the order of :func:`standard_names`."""
    p, nd = model.params(), model.ndof
    out = []
    for i in range(1, nd + 1):
        c = [p[f"link[{i}].c{a}"] for a in "xyz"]
        out.extend(link_to_standard(p[f"link[{i}].m"], c, [p[f"link[{i}].I{a}"] for a in
                                                            ("xx", "xy", "xz", "yy", "yz", "zz")]))
    out.extend(p[f"joint[{i}].{d}"] for i in range(1, nd + 1) for d in drive)
    out.extend(p[n] for n in extra)
    return np.array(out)


def _check_serial(model) -> None:
    if "link[1].Ixx" not in model.params():
        raise InputError(f"{model.robot}: base-parameter identification takes a serial arm (kind = \"serial\", "
                         "docs/robots.md, Serial arms); this robot has no link[i].m ... Izz")


def regressor(model, q, qd, qdd, drive=DRIVE, extra=()) -> tuple[np.ndarray, list[str], np.ndarray]:
    """The regressor of a serial arm's inverse dynamics at the states (q, qd, qdd).

    Parameters
    ----------
    model : cosim.core.Model
        A serial arm; only a working copy of it is changed.
    q, qd, qdd : array_like, shape (n, nd)
        Joint positions [rad or m], rates [rad/s or m/s] and accelerations [rad/s2 or m/s2].
    drive : sequence of str
        The drive layer's terms identified per joint (default rotor inertia, viscous and
        Coulomb friction, effort offset; any parameter ``joint[i].<name>`` the effort is
        linear in, e.g. ``force_k1`` for a position-proportional force).
    extra : sequence of str
        Further parameters the efforts are linear in, by full name (``joint[2].force_k1``).

    Returns
    -------
    W : ndarray, shape (n * nd, p)
        Rows sample by sample, joint by joint (row k nd + j: sample k, joint j+1), one column
        per name of :func:`standard_names` [N m per unit of the parameter].
    names : list of str
        The standard parameters' names.
    rest : ndarray, shape (n * nd,)
        The efforts no identified parameter makes (a payload, the other drive terms) [N m]:
        ``model.inverse_dynamics`` = ``W @ standard_values(model) + rest``.
    """
    _check_serial(model)
    work = model.copy()
    nd = work.ndof
    q, qd, qdd = (np.ascontiguousarray(np.reshape(a, (-1, nd)), dtype=float) for a in (q, qd, qdd))
    names = standard_names(nd, drive, extra)
    known = set(work.param_names())
    for n in names[10 * nd:]:
        if n not in known:
            raise InputError(f"{model.robot} has no parameter {n!r} to identify")
    W = np.empty((q.shape[0] * nd, len(names)))
    unit = np.array([1.0, 0, 0, 0, 1.0, 0, 0, 1.0, 0, 1.0])  # 1 kg, centre at the origin, inertia 1 kg m2
    work.set_params({k: v for i in range(1, nd + 1) for k, v in link_params(i, unit).items()})
    base = work.inverse_dynamics(q, qd, qdd).ravel()
    for i in range(1, nd + 1):
        for k in range(10):
            phi = unit.copy()
            phi[k] += _STEP
            work.set_params_unchecked(link_params(i, phi))
            W[:, (i - 1) * 10 + k] = (work.inverse_dynamics(q, qd, qdd).ravel() - base) / _STEP
        work.set_params_unchecked(link_params(i, unit))
    for k, name in enumerate(names[10 * nd:], start=10 * nd):
        v0 = work.param(name)
        work.set_params_unchecked({name: v0 + 1.0})
        W[:, k] = work.inverse_dynamics(q, qd, qdd).ravel() - base
        work.set_params_unchecked({name: v0})
    rest = model.inverse_dynamics(q, qd, qdd).ravel() - W @ standard_values(model, drive, extra)
    return W, names, rest
