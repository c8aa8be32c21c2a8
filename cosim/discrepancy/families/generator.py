"""Physics drawn at random from the term families of :mod:`.products`: hidden forces for the
blind cases (``blind.simulate_case`` hides them as it hides the library's effects) and the
answer key's checks of what the discovery step found.

Sizes are relative to the joint's RMS feed-forward effort E, position spread T and RMS rate V
along the case's reference, each force's typical size ``size * E`` with ``size`` drawn
log-uniform over [SIZE_LO, 10 SIZE_LO] (a decade from about the detection limit up).
"""
from __future__ import annotations

import math

import numpy as np

#: kind -> (family of products.FAMILIES, what it is)
KINDS = {
    "load_friction": ("load", "Coulomb friction growing with the applied effort, mu |tau| sign(qd), on one joint"),
    "friction_zone": ("stroke", "a Coulomb level over one side of the stroke on one joint (a friction zone)"),
    "stroke_friction": ("stroke", "a Coulomb level changing linearly over the stroke on one joint"),
    "cable_link": ("cross", "a force on one joint in proportion to another joint's position (a cable carrier)"),
    "cross_damper": ("cross", "a force on one joint in proportion to another joint's rate"),
    "pair_damper": ("cross", "a damper between two joints: c (qd_j - qd_k) against joint j, c (qd_k - qd_j) "
                    "against joint k"),
    "pair_spring": ("cross", "a spring between two joints: k (q_j - q_k - L) against joint j, its opposite against "
                    "joint k"),
    "cable_taut": ("cross", "a cable carrier between two joints that pulls once taut: k w softplus((q_j - q_k - s) / w) "
                   "against joint j, its opposite against joint k"),
    "effort_position": ("effortpos", "a force in proportion to the applied effort and the position on one joint"),
    "position_damper": ("posrate", "a damping that changes linearly over the stroke on one joint"),
}
#: the coefficient (core key) each kind must be found with
NEEDS = {"load_friction": "force_cload", "friction_zone": "force_czone", "stroke_friction": "force_cq1",
         "cable_link": "force_xk1", "cross_damper": "force_xv", "pair_damper": "force_xv",
         "pair_spring": "force_xk1", "cable_taut": "force_taut",
         "effort_position": "force_eq",
         "position_damper": "force_qv"}
#: the smallest typical force drawn, per RMS effort (see the module's docstring)
SIZE_LO = 0.02


def sample(kind, rng, motion, name, nd):
    """``(params, joints)`` of one force of ``kind`` (:data:`KINDS`): core parameters
    (``name(i, key)`` the core name of joint i's key) and the 0-based joints it acts on;
    ``motion`` as for ``blind.sample_unlisted`` (``q``: the joints' reference positions, samples x
    joints, for the one-sided spring's slack)."""
    E, T, V, span, home = (np.asarray(motion[k], float) for k in ("E", "T", "V", "span", "home"))
    j = int(rng.integers(0, nd))
    size = SIZE_LO * 10.0 ** float(rng.uniform(0.0, 1.0))
    if kind == "load_friction":
        p = {name(j, "force_cload"): size}
    elif kind == "friction_zone":
        side = float(rng.choice([-1.0, 1.0]))
        lo, hi = home[j] - 0.5 * span[j], home[j] + 0.5 * span[j]
        q = float(lo + rng.uniform(0.35, 0.65) * (hi - lo))
        p = {name(j, "force_czone"): 2.0 * size * E[j], name(j, "force_czone_q"): q,
             name(j, "force_czone_w"): side * float(rng.uniform(0.05, 0.2)) * T[j]}
    elif kind == "stroke_friction":
        p = {name(j, "force_qc"): float(home[j]), name(j, "force_cq1"): float(rng.choice([-1, 1])) * size * E[j] / T[j]}
    elif kind in ("cable_link", "cross_damper"):
        k = int((j + rng.integers(1, nd)) % nd)
        p = {name(j, "force_xj"): float(k + 1)}
        sign = float(rng.choice([-1, 1]))
        if kind == "cable_link":
            p.update({name(j, "force_xqc"): float(home[k]), name(j, "force_xk1"): sign * 1.5 * size * E[j] / T[k]})
        else:
            p[name(j, "force_xv")] = sign * 1.5 * size * E[j] / V[k]
    elif kind == "pair_damper":  # the core's viscous levels and the other joint's rate, equal and opposite
        k = int((j + rng.integers(1, nd)) % nd)
        c = 1.5 * size * E[j] / V[j]
        p = {name(a, key): v for a, b in ((j, k), (k, j))
             for key, v in (("force_xj", float(b + 1)), ("force_vpos", c), ("force_vneg", c), ("force_xv", -c))}
        return p, [j, k]
    elif kind == "pair_spring":  # the core's springs and the other joint's position, equal and opposite
        k = int((j + rng.integers(1, nd)) % nd)
        stiff = 1.5 * size * E[j] / T[j]
        rest = float(home[j] - home[k] + rng.uniform(-0.5, 0.5) * T[j])  # the rest difference L
        p = {name(a, key): v for a, b, sign in ((j, k, 1.0), (k, j, -1.0))
             for key, v in (("force_xj", float(b + 1)), ("force_k1", stiff), ("force_xk1", -stiff),
                            ("force_qc", float(home[a])), ("force_xqc", float(home[a]) - sign * rest))}
        return p, [j, k]
    elif kind == "cable_taut":  # the core's one-sided spring on q_j - q_k, its reaction on k
        k = int((j + rng.integers(1, nd)) % nd)
        d = np.asarray(motion["q"], float)[:, j] - np.asarray(motion["q"], float)[:, k]  # along the reference
        slack = float(np.quantile(d, rng.uniform(0.6, 0.85)))  # taut over the last 15-40 % of the difference
        width = float(rng.uniform(0.03, 0.1)) * float(np.ptp(d))
        # its typical force past the slack size * E (the hinge's RMS sizes it)
        stiff = 1.5 * size * E[j] / max(float(np.sqrt(np.mean(np.maximum(d - slack, 0.0) ** 2))), 1e-12)
        p = {name(a, key): v for a, b, sign in ((j, k, 1.0), (k, j, -1.0))
             for key, v in (("force_xj", float(b + 1)), ("force_taut", stiff), ("force_taut_q", sign * slack),
                            ("force_taut_w", sign * width))}
        return p, [j, k]
    elif kind == "effort_position":
        p = {name(j, "force_qc"): float(home[j]), name(j, "force_eq"): float(rng.choice([-1, 1])) * 1.5 * size / T[j]}
    elif kind == "position_damper":
        p = {name(j, "force_qc"): float(home[j]),
             name(j, "force_qv"): float(rng.choice([-1, 1])) * 1.5 * size * E[j] / (T[j] * V[j])}
    else:
        raise KeyError(kind)
    return {k: float(v) for k, v in p.items()}, [j]


def _coef(params, suffix):
    return next((v for k, v in params.items() if k.endswith("." + suffix)), None)


def structure_ok(kind, term, truth) -> bool:
    """The discovered term holds the hidden force's coefficient (for a cross term, read from
    the right other joint)."""
    need = NEEDS[kind]
    if not any(k.endswith("." + need) for k in term.coefficients):
        return False
    if kind in ("cable_link", "cross_damper"):
        return _coef(term.shape, "force_xj") == _coef(truth["params"], "force_xj")
    return True


def coefficient_error(kind, term, truth) -> float:
    """Relative error of the discovered coefficient against the hidden one (inf: not found)."""
    need = NEEDS[kind]
    got = next((c.value for k, c in term.coefficients.items() if k.endswith("." + need)), None)
    want = _coef(truth["params"], need)
    if got is None or not want:
        return math.inf
    return abs(got / want - 1.0)
