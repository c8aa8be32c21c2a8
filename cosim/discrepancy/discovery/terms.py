"""The discovery's function library and its answer: the terms searched (:data:`TERMS`), their
mechanisms and the settings of the search, a discovered term (:class:`DiscoveredTerm`) with its
coefficients and its equation.  The step itself is described in :mod:`.discovery`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..families import products

#: term -> (core keys of its coefficients, scale of its basis function: "1", "T", "T2", "T3",
#: "V", "V2", "A" (the acceleration)), shape parameters it needs, what it is in words
TERMS = {
    "constant": (("offset",), ("1",), (), "a constant force (the drive's offset)"),
    "spring": (("force_k1",), ("T",), ("force_qc",), "a force proportional to the position (a spring)"),
    "quadratic": (("force_k2",), ("T2",), ("force_qc",), "a force quadratic in the position"),
    "cubic": (("force_k3",), ("T3",), ("force_qc",), "a force cubic in the position (a hardening spring)"),
    "drag": (("force_v2",), ("V2",), (), "quadratic drag, qd |qd|"),
    "viscous_pos": (("force_vpos",), ("V",), (), "viscous friction moving in the positive direction"),
    "viscous_neg": (("force_vneg",), ("V",), (), "viscous friction moving in the negative direction"),
    "coulomb_pos": (("force_cpos",), ("1",), (), "Coulomb friction moving in the positive direction"),
    "coulomb_neg": (("force_cneg",), ("1",), (), "Coulomb friction moving in the negative direction"),
    # both directions in one step: a greedy search of single terms would take a look-alike of
    # a friction acting both ways (quadratic drag for half of a viscous one) before either half
    "viscous_both": (("force_vpos", "force_vneg"), ("V", "V"), (), "viscous friction with a level for each direction"),
    "coulomb_both": (("force_cpos", "force_cneg"), ("1", "1"), (),
                     "Coulomb friction with a level for each direction"),
    # the same levels through tanh(qd / force_cv): a friction that builds up over a velocity
    # scale instead of at the smallest speed (one scale per joint in the core: the sharp and the
    # fading levels are one pair of coefficients, entered once)
    "fading": (("force_cpos", "force_cneg"), ("1", "1"), ("force_cv",),
               "Coulomb friction that fades below a velocity scale, a level for each direction"),
    "ripple": (("force_sin", "force_cos"), ("1", "1"), ("force_period",), "a ripple periodic in the position"),
    "step": (("force_step",), ("1",), ("force_step_q", "force_step_w"), "a smooth step in the position"),
    "inertia": (("force_inertia",), ("A",), (), "a force proportional to the acceleration (an inertia on the joint)"),
    # products of the velocity's sign with the load or the position, couplings between joints
    # (families/products.py)
    **products.TERMS,
}
#: coefficients of dissipative terms (friction, drag): the friction they make never negative
DISSIPATIVE = ("force_v2", "force_vpos", "force_vneg", "force_cpos", "force_cneg")
#: coefficients with a sign of their physics: friction and drag dissipate, and the joint's
#: inertia (the rotor's the model holds plus the added one) is no less than zero
SIGNED = DISSIPATIVE + ("force_inertia",) + products.SIGNED
#: the library's parameter whose column on its joint is the coefficient's own (the same physics):
#: where the model fits it, the coefficient is not searched
SAME_COLUMN = {"force_inertia": "rotor_inertia"}
#: the library's symmetric friction a direction-split coefficient adds to on its joint: on top
#: of it the split term is the friction's asymmetry, and the total (library level plus the
#: coefficient), not the coefficient, must not be negative
ADDS_TO = {"force_vpos": "viscous", "force_vneg": "viscous", "force_cpos": "coulomb", "force_cneg": "coulomb"}
#: terms whose columns carry the noise of the measured rates or accelerations: estimated with
#: instruments (an acceleration from the smoother is noisier than a rate: the library's rotor
#: inertia is instrumented for the same reason)
RATE_TERMS = ("drag", "viscous_pos", "viscous_neg", "coulomb_pos", "coulomb_neg", "viscous_both", "coulomb_both",
              "fading", "inertia") + products.RATE_TERMS

#: physical mechanisms that produce each kind of term (for the report's sentence)
MECHANISMS = {
    "constant": "a cable carrier or hose pulling one way, a counterweight or spring preloaded far from its rest, "
                "an offset in the drive's current or torque measurement",
    "spring": "a return spring, a cable carrier or hose bending with the stroke, a bellows or way cover, a gas spring",
    "quadratic": "a cable carrier whose bend changes with the stroke, a spring of changing rate, a stop approached",
    "cubic": "a hardening spring: a cable carrier or bellows stretched towards its ends, an elastic stop",
    "drag": "aerodynamic or fluid drag (a part moving through air, oil or coolant), turbulent flow in a seal or damper",
    "viscous": "a damper or seal that damps one direction more than the other (a check valve, asymmetric lubrication)",
    "coulomb": "friction that differs by direction: asymmetric wear of a guide, screw or nut, a preload on one flank, "
               "a seal lip that drags one way",
    "fading": "friction that builds up over a speed range instead of at once: a contact that deflects before it "
              "slides (pre-sliding, bristles of a seal or brush), a lubricated guide or screw, a belt or elastomer "
              "coupling that creeps, a drive whose friction compensation is smoothed",
    "ripple": "cogging of a motor (magnet pitch), ripple of a ball screw or gear (lead, tooth mesh), a bearing race "
              "or rack with a periodic defect",
    **products.MECHANISMS,
    "step": "a detent, a cable carrier reaching its bend, a seal, cover or limit spring engaging at one position",
    "inertia": "a mass or inertia the drive moves that the model leaves out: a motor rotor, coupling, pulley, belt or "
               "screw, a tool, clamp or cable carrier riding on the carriage",
}

#: standard errors a held-out chi-square gain must exceed to be significant (one-sided 95 %)
Z_ONE_SIDED = 1.645
#: a term is kept when the bootstrap selects it in at least this share of the resamples
STABILITY = 0.6
#: forward steps of the stepwise selection (a term may leave again in the backward pass)
MAX_STEPS = 8
#: bootstrap resamples, and the block length in decimated samples
N_BOOT, BLOCK = 30, 25


@dataclass
class Coefficient:
    """One fitted coefficient of a discovered term: core ``param``, ``value`` and ``ci95``
    (half width of the 95 % interval) in ``unit``, ``base`` the value the model held."""

    param: str
    value: float
    ci95: float
    unit: str
    #: the value the model held before (the library's offset refitted with the term): the
    #: term's force is ``value - base`` times the column on top of the model
    base: float = 0.0


@dataclass
class DiscoveredTerm:
    """The force found on one joint's effort channel.

    ``joint`` (1-based), ``channel``, ``terms`` (keys of :data:`TERMS`), ``equation`` (with
    units and intervals), ``coefficients`` ({core parameter: :class:`Coefficient`}),
    ``shape`` (core shape parameters: the polynomial's centre, the ripple's period, the step's
    position and width, the fading friction's velocity scale), ``mechanisms`` (a sentence),
    ``stability`` (share of bootstrap resamples that select each term), ``heldout_before`` /
    ``heldout_after`` (RMS of the channel's held-out residual without and with the term, in its
    unit), ``delta_chi2_heldout``, ``instead_of`` (library effects it replaced: look-alikes that
    fit worse, offsets it refitted to zero), ``partial`` (why it is not named as the physics:
    structure the recording keeps with it, a partial fit where its own joint keeps it, a tied
    library effect beside it; or "")."""

    joint: int
    channel: str
    terms: list
    equation: str
    coefficients: dict
    shape: dict
    mechanisms: str
    stability: dict
    heldout_before: float
    heldout_after: float
    delta_chi2_heldout: float
    key_variable: str
    instead_of: list = field(default_factory=list)
    #: "" when the recording keeps no structure with the term added; else the sentence saying so
    #: (a partial fit that may stand in for what is missing, not the physics)
    partial: str = ""
    #: 95 % half widths of the shape parameters the fit moves (a step's position and width, a
    #: ripple's period, a fading friction's velocity scale), {core parameter: half width}
    shape_ci95: dict = field(default_factory=dict)
    #: the other joint (1-based) of a damper between two joints found as one pair
    #: (:mod:`.pair`: the pair's equation on both channels, reported once), 0 for none
    pair: int = 0
    #: for the report's figure, on the decimated samples: ``key`` (the joint's position or
    #: rate), ``before`` / ``after`` (the channel's residual without / with the term)
    curve: dict = field(default_factory=dict, repr=False)

    def __getitem__(self, k):
        return getattr(self, k)

    @property
    def repeats_its_pair(self) -> bool:
        """True on the second joint of a pair between two joints: the pair is stated once, under
        its first joint (the lower index), and this term only carries it on its own channel."""
        return 0 < self.pair < self.joint

    def params(self) -> dict:
        """Core parameters that put the term into the plant (shape and coefficients)."""
        return {**self.shape, **{p: c.value for p, c in self.coefficients.items()}}


def _units(search):
    facts = search.eng.model.facts
    return facts.effort_unit, facts.joint_unit


def _term(search, c, terms, coef, half, stab, before, after, d_held, base=None, shape_ci95=None) -> DiscoveredTerm:
    """The :class:`DiscoveredTerm` of ``terms`` fitted on channel c; ``base``: {core parameter:
    the value the model held} of coefficients refitted with the terms (their coefficient is
    the held value plus the fitted step)."""
    base = base or {}
    F, Q = _units(search)
    units = {p.name: p.unit for p in search.eng.model.param_info()}
    coefs, shape = {}, {}
    i = 0
    for t, o in terms:
        shape.update(search.shape(t, c, o))
        for k in TERMS[t][0]:
            p = search.name(c, k)
            b = base.get(p, 0.0)
            coefs[p] = Coefficient(p, b + float(coef[i]), float(half[i]), units.get(p, ""), b)
            i += 1
    names = [t for t, _ in terms]
    eq = equation(names, coefs, shape, search, c, shape_ci95 or {})
    kinds = []
    # a constant beside a spring is the spring's rest position, no force of its own; a
    # refitted offset is the library's
    refitted = {search.name(c, "offset")} & set(base)
    for t in [n for n in names if not (n == "constant" and ("spring" in names or refitted))]:
        kind = t.split("_")[0]
        if kind not in kinds:
            kinds.append(kind)
    mech = "; ".join(" and ".join(TERMS[n][3] for n in names if n.split("_")[0] == k) + f": {MECHANISMS[k]}"
                     for k in kinds)
    key = _key_variable(names)
    noun = search.eng.model.facts.joint_noun
    return DiscoveredTerm(c + 1, search.pipe.channels[c], names, f"{noun} {c + 1}: {eq}", coefs, shape,
                          mech, {t: stab[(t, o)] for t, o in terms if (t, o) in stab}, before, after, d_held, key,
                          shape_ci95=dict(shape_ci95 or {}))


def _key_variable(names):
    fam = products.key_variable(names)
    if fam:
        return fam
    pos = {"spring", "quadratic", "cubic", "ripple", "step"}
    if any(n in pos for n in names):
        return "position"
    if "inertia" in names:
        return "acceleration"
    if names and all(n == "constant" for n in names):
        return "position"
    return "velocity"


def _pm(v, ci, unit, digits=3):
    u = f" {unit}" if unit else ""
    return f"({v:.{digits}g} +- {ci:.2g}){u}"


def equation(names, coefs, shape, search, c, shape_ci95=None) -> str:
    """F = ... with units and intervals; a spring with a constant as k (q - q0)."""
    F, Q = _units(search)
    shape_ci95 = shape_ci95 or {}

    def sh(key, digits, unit=Q):  # a shape parameter, with its interval when the fit moved it
        v, ci = shape[search.name(c, key)], shape_ci95.get(search.name(c, key))
        return f"{v:.{digits}g} {unit}" if ci is None else f"({v:.{digits}g} +- {ci:.2g}) {unit}"
    get = lambda k: coefs.get(search.name(c, k))  # noqa: E731
    parts = []
    qc = shape.get(search.name(c, "force_qc"))
    k1, c0 = get("force_k1"), get("offset")
    if k1 is not None and c0 is not None and k1.value != 0:
        q0 = qc - c0.value / k1.value
        # delta method, the two taken as independent (an upper bound when they are correlated)
        dq0 = math.hypot(c0.ci95 / abs(k1.value), abs(c0.value) * k1.ci95 / k1.value ** 2)
        parts.append(f"{_pm(k1.value, k1.ci95, k1.unit)} (q - ({q0:.5g} +- {dq0:.2g}) {Q})")
    else:
        if c0 is not None:
            parts.append(_pm(c0.value, c0.ci95, c0.unit))
        if k1 is not None:
            parts.append(f"{_pm(k1.value, k1.ci95, k1.unit)} (q - {qc:.5g} {Q})")
    signs = ("[qd > 0]", "(-[qd < 0])")
    if "fading" in names:  # the levels through tanh(qd / v)
        v = sh("force_cv", 3, f"{Q}/s")
        signs = (f"max(tanh(qd / {v}), 0)", f"min(tanh(qd / {v}), 0)")
    for key, fmt in (("force_k2", "(q - {qc:.5g} {Q})^2"), ("force_k3", "(q - {qc:.5g} {Q})^3"),
                     ("force_v2", "qd |qd|"), ("force_vpos", "max(qd, 0)"), ("force_vneg", "min(qd, 0)"),
                     ("force_cpos", signs[0]), ("force_cneg", signs[1]), ("force_inertia", "qdd")):
        e = get(key)
        if e is not None:
            parts.append(f"{_pm(e.value, e.ci95, e.unit)} " + fmt.format(qc=qc or 0.0, Q=Q))
    s, co = get("force_sin"), get("force_cos")
    if s is not None:
        amp = math.hypot(s.value, co.value)
        damp = math.hypot(s.ci95, co.ci95)
        phase = math.atan2(co.value, s.value)
        parts.append(f"({amp:.3g} +- {damp:.2g}) {F} sin(2 pi q / {sh('force_period', 4)} + {phase:.2f})")
    st = get("force_step")
    if st is not None:
        parts.append(f"{_pm(st.value, st.ci95, st.unit)} tanh((q - {sh('force_step_q', 5)}) / {sh('force_step_w', 3)})")
    parts += products.equation_parts(search, c, names, get, lambda k: shape.get(search.name(c, k)), _pm)
    return "F = " + " + ".join(parts)
