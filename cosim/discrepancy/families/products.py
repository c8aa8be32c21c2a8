"""Products and couplings: candidate terms of the discovery step built from the core's joint
force (``<j>[i].force_*``, ``pkm.h``; ``c_core/src/dynamics/joint_force.cpp`` evaluates them,
nothing here restates a force).  With z = q - force_qc, s = tanh(qd / v_c) (v_c = force_cv,
0: the drive's sharp v_eps) and tau the effort the drive applies:

=========== ======================================= ===========================================
term        force                                   grid (options per joint)
=========== ======================================= ===========================================
load        force_cload |tau| s                     sharp, and the fading friction's 3 scales
effortpos   (force_eq z + force_eg) tau             one (z about the recording's mean: the
                                                    centre of the truth shifts force_eg)
posrate     force_qv z qd                           one
stroke_1    force_cq1 z s                           one (sharp)
stroke_2    force_cq2 z^2 s                         one (sharp)
zone        force_czone s (1 + tanh((q - q_z) /     5 positions (20-80 % quantiles) x the two
            w_z)) / 2                               sides, w_z a tenth of the travel; the
                                                    selected one's q_z and w_z then fitted
cross_q     force_xk1 (q_k - force_xqc)             each other joint k (force_xj = k)
cross_v     force_xv qd_k                           each other joint k
=========== ======================================= ===========================================

Every option of every term is one candidate of the look-elsewhere count (``Search.n_tried``
counts the columns the search holds): the families add 4 + 1 + 1 + 1 + 1 + 10 + 2 (n - 1)
candidates per joint of an n-joint robot (28 on the 6-PUS).  The core's force_ceff (tau s, a
loss that differs between driving and being driven) is not searched: where the effort keeps one
sign it is the load term, and on the Clavel delta's held-out rotor-inertia case it kept, on top
of a drive dead zone, the dead zone the added inertias otherwise withdraw.  Terms that share a shape parameter of the core on one joint (the Coulomb levels'
velocity scale force_cv, the other joint force_xj, the centre force_qc) enter together only
where their values agree (:func:`clash`): the core holds one value per joint.

Families (the unit the bench leaves out of the search, :func:`without`): ``load``, ``stroke`` (zone, stroke_1, stroke_2), ``cross`` (cross_q, cross_v),
``effortpos``, ``posrate``.
"""
from __future__ import annotations

import contextlib
import math
import weakref

import numpy as np

#: term -> (core keys of its coefficients, scale of its basis function, shape parameters, words);
#: scales beyond discovery's: "E" (the joint's RMS effort), "TE" (travel x effort), "TV" (travel x rate)
TERMS = {
    "load": (("force_cload",), ("E",), ("force_cv",), "Coulomb friction growing with the load, |tau| s"),
    "effortpos": (("force_eq", "force_eg"), ("TE", "E"), ("force_qc",),
                  "a force in proportion to the applied effort, linear in the position (a ratio or efficiency "
                  "over the stroke)"),
    "posrate": (("force_qv",), ("TV",), ("force_qc",), "a damping that changes over the stroke, (q - qc) qd"),
    "stroke_1": (("force_cq1",), ("T",), ("force_qc", "force_cv"), "a Coulomb level changing linearly over the stroke"),
    "stroke_2": (("force_cq2",), ("T2",), ("force_qc", "force_cv"),
                 "a Coulomb level changing quadratically over the stroke"),
    "zone": (("force_czone",), ("1",), ("force_czone_q", "force_czone_w", "force_cv"),
             "a Coulomb level over part of the stroke (a friction zone)"),
    "cross_q": (("force_xk1",), ("T",), ("force_xj", "force_xqc"), "a force in proportion to another joint's position"),
    "cross_v": (("force_xv",), ("V",), ("force_xj",), "a force in proportion to another joint's rate"),
}
#: the families: what a leave-one-family-out run removes from the search
FAMILIES = {"load": ("load",), "stroke": ("zone", "stroke_1", "stroke_2"),
            "cross": ("cross_q", "cross_v"), "effortpos": ("effortpos",), "posrate": ("posrate",)}
#: terms whose columns carry the noise of the measured rates (instruments, as discovery's)
RATE_TERMS = ("load", "posrate", "stroke_1", "stroke_2", "zone", "cross_v")
#: coefficients with the sign of their physics: a friction growing with the load never negative
SIGNED = ("force_cload",)
#: the existing terms through the velocity's sign s and the velocity scale they hold (0: sharp)
SIGN_TERMS = {"coulomb_pos": 0, "coulomb_neg": 0, "coulomb_both": 0}

MECHANISMS = {
    "load": "friction that grows with the load: a ball screw, nut, guide or gear whose contact force is the "
            "transmitted load (Coulomb's law, mu times the normal force)",
    "effortpos": "an effort that changes over the stroke in proportion to itself: a lever ratio, screw lead or "
                 "belt transmission whose ratio or efficiency varies with the position",
    "posrate": "a damper or seal whose damping changes over the stroke (a dashpot engaging, lubricant spread "
               "unevenly)",
    "stroke": "friction that changes over the stroke: a guide worn or misaligned over part of its length, a "
              "preload that varies along a screw, a seal or wiper in a zone, a dirty or dry section",
    "zone": "friction in a zone of the stroke: a guide worn or misaligned over part of its length, a wiper or "
            "seal engaging, a dirty or dry section",
    "cross": "a coupling between two axes: a cable carrier, hose or belt linking two carriages, a shared "
             "counterweight, crosstalk of the drives' current measurement",
}

_EXCLUDED: set = set()


#: the stack of :func:`searched` blocks: the families are searched unless the innermost block
#: turned them off (``diagnose(families=False)``, ``cosim diagnose --no-families``)
_SEARCHED: list = []

#: per search (gone with it): the terms clashing with each term per joint (:func:`clash`) and the terms' full shapes
_CLASHES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def excluded() -> frozenset:
    """Terms left out of the search (see :func:`without`), and every term of the families
    where the innermost :func:`searched` block turned them off."""
    return frozenset(_EXCLUDED | (set(TERMS) if _SEARCHED and not _SEARCHED[-1] else set()))


@contextlib.contextmanager
def searched(on: bool = True):
    """Search the families' terms (``on``, the default outside any block) or leave them all out
    while the block runs.

    Examples
    --------
    >>> from cosim.discrepancy.families import searched
    >>> with searched(False):
    ...     pass  # diagnose(...) here searches the library of one joint's position and rate only
    """
    _SEARCHED.append(bool(on))
    try:
        yield
    finally:
        _SEARCHED.pop()


@contextlib.contextmanager
def without(*families):
    """Leave the terms of ``families`` (keys of :data:`FAMILIES`, or any term name of the
    search, e.g. ``"fading"``) out of the discovery step while the block runs (the
    leave-one-family-out protocol of ``bench/unnamed_bench.py``).

    Examples
    --------
    >>> from cosim.discrepancy.families import without
    >>> with without("load"):
    ...     pass  # diagnose(...) here searches no load-dependent friction
    """
    terms = {t for f in families for t in FAMILIES.get(f, (f,))}
    added = terms - _EXCLUDED
    _EXCLUDED.update(added)
    try:
        yield
    finally:
        _EXCLUDED.difference_update(added)


# ------------------------------------------------------------------------- the grid

def grids(search) -> dict:
    """Per term, its options: a list of {core key: values per joint} (the shapes tried)."""
    nd, qc = search.nd, search.q_centre
    sharp = {"force_cv": np.zeros(nd)}
    signs = [sharp] + [{"force_cv": np.asarray(v, float)} for v in search.fades]
    q = search.pipe.q_s[search.pipe.idx][search.eng.train]
    qs = np.quantile(q, np.linspace(0.2, 0.8, 5), axis=0)
    w = 0.1 * search.travel
    zones = [{"force_czone_q": qs[i], "force_czone_w": side * w, "force_cv": np.zeros(nd)}
             for side in (1.0, -1.0) for i in range(len(qs))]
    centre = {"force_qc": np.asarray(qc, float)}
    others = [np.array([(j + o + 1) % nd for j in range(nd)]) for o in range(max(nd - 1, 0))]
    cross_q = [{"force_xj": k + 1.0, "force_xqc": np.asarray(qc, float)[k]} for k in others]
    cross_v = [{"force_xj": k + 1.0} for k in others]
    return {"load": signs, "effortpos": [centre], "posrate": [centre],
            "stroke_1": [dict(centre, **sharp)], "stroke_2": [dict(centre, **sharp)], "zone": zones,
            "cross_q": cross_q, "cross_v": cross_v}


def n_options(search, term) -> int:
    return len(search.fam[term])


def shape(search, term, j, option) -> dict:
    """The core shape parameters of ``term`` on joint j (0-based) in ``option``."""
    return {search.name(j, k): float(v[j]) for k, v in search.fam[term][option].items()}


def add_option(search, term, c, values: dict) -> tuple:
    """``(search, option)``: the search with a new option of ``term``, the grid's first with joint
    c's shape set to ``values`` ({core key: value}); its columns taken again on joint c
    (``Search.with_family_option``)."""
    opt = {k: np.array(v, float).copy() for k, v in search.fam[term][0].items()}
    for k, v in values.items():
        opt[k][c] = v
    return search.with_family_option(term, c, opt)


def scale(search, s: str, j: int) -> float:
    """The size of a basis function of scale ``s`` on joint j (see :data:`TERMS`): a
    coefficient step of 5 % of the RMS effort over it; for the effort terms a smaller one
    (the core solves them implicitly: the column stays linear within 0.25 %)."""
    E = max(float(search.effort[j]), 1e-12)
    return {"E": 20.0 * E, "TE": 20.0 * search.travel[j] * E, "TV": search.travel[j] * search.rate[j]}[s]


def _full_shape(search, c, term, option):
    sh = dict(search.shape(term, c, option))
    if term in SIGN_TERMS:
        sh.setdefault(search.name(c, "force_cv"), float(SIGN_TERMS[term]))
    return sh


#: the library's frictions beside which no friction zone is tried on their joint: fitted before the
#: discovery step and not refitted with its terms, a friction there has taken a share of any
#: friction the recording holds, and a zone on top of it fits that friction's misfit (a viscous
#: friction standing in for a Coulomb one left a zone beside it that beat the Coulomb pair)
ZONE_NOT_BESIDE = ("coulomb", "viscous", "stribeck")


def _shape_kept(search, c, term):
    """:func:`_full_shape` of ``term`` on joint c, kept per search (:data:`_CLASHES`)."""
    shapes = _kept(search)[1]
    sh = shapes.get((c, term))
    if sh is None:
        sh = shapes[(c, term)] = _full_shape(search, c, *term)
    return sh


def _kept(search) -> tuple:
    """What :data:`_CLASHES` keeps for ``search``: ``({(c, term): clashing terms}, {(c, term): shape})``."""
    return _CLASHES.get(search) or _CLASHES.setdefault(search, ({}, {}))


def _zone_not_here(search, c, held) -> bool:
    """Does the model ``held`` hold a library friction on joint c (:data:`ZONE_NOT_BESIDE`)?"""
    return bool(held) and any(search.name(c, k) in held for k in ZONE_NOT_BESIDE)


def _clashing_with(search, c, t) -> frozenset:
    """The terms of the search that set a shape parameter of joint c to another value than
    ``t`` does, kept per search (a Search is a value: its shapes fixed) and (c, t)."""
    kept = _kept(search)[0]
    out = kept.get((c, t))
    if out is None:
        b = _shape_kept(search, c, t)
        out = kept[(c, t)] = frozenset(u for u in search.cols if _differ(_shape_kept(search, c, u), b))
    return out


def _differ(a, b) -> bool:
    """Does the shape ``a`` set a shape parameter that ``b`` sets to another value?"""
    return any(k in b and b[k] != v for k, v in a.items())


def clashing(search, c, chosen, held=None):
    """The candidates of :func:`clash` beside ``chosen`` on joint c, as a set: ``cand in
    clashing(...)`` is ``clash(..., cand, held)`` for every term of the search (a zone beside a
    library friction of ``held`` is marked by ``"zone"``: see :func:`clashes`)."""
    out = set()
    for t in chosen:
        out |= _clashing_with(search, c, t)
    if _zone_not_here(search, c, held):
        out.add("zone")
    return out


def clashes(clashing_set, cand) -> bool:
    """Is ``cand`` in the set :func:`clashing` made (a zone where it marks zones)?"""
    return cand in clashing_set or (cand[0] == "zone" and "zone" in clashing_set)


def clash(search, c, chosen, cand, held=None) -> bool:
    """Is ``cand`` no candidate on joint c beside ``chosen``: it sets a shape parameter of the
    joint to another value than a term of ``chosen`` (the core holds one per joint), or it is a
    zone where the model ``held`` ({core parameter: value}) holds a library friction
    (:data:`ZONE_NOT_BESIDE`)?"""
    if cand[0] == "zone" and _zone_not_here(search, c, held):
        return True
    # the set of the search's terms clashing with each chosen term (the bootstrap's selections ask
    # about the same terms beside other chosen sets)
    if cand in search.cols:
        return any(cand in _clashing_with(search, c, t) for t in chosen)
    return any(_differ(_shape_kept(search, c, cand), _shape_kept(search, c, t)) for t in chosen)


def option_of(search, term_obj, name) -> int:
    """The option of term ``name`` whose shape on the discovered term's joint is its shape."""
    c = term_obj.joint - 1
    for o in range(len(search.fam[name])):
        sh = shape(search, name, c, o)
        if all(term_obj.shape.get(k) == v for k, v in sh.items()):
            return o
    return 0


def key_variable(names):
    """The report's key variable of a term holding these names, or None."""
    if "load" in names:
        return "velocity"
    if any(n in TERMS for n in names):
        return "position"
    return None


# ------------------------------------------------------------------------- the shape fit

#: the least share of the moving samples (faster than ZONE_SPEED times the joint's RMS rate: the
#: fading friction's largest grid scale, where a Coulomb level has built up) a friction zone
#: leaves off (else: a Coulomb friction)
ZONE_OFF, ZONE_SPEED = 0.1, 0.2


def fit_zone(search, c, y, terms, rows, ls_fit, heldout_gain):
    """``(search, terms)``: the zone of ``terms`` (if any) with its position and width fitted
    (Nelder-Mead on the fitted part's chi-square, the other terms refitted with it:
    ``ls_fit(search, terms) -> chi2``), the edge within the joint's range and its width within
    2-100 % of the position spread, and the search holding the zones tried.  The zone is a
    Coulomb friction over the whole stroke (the pair ``coulomb_both``, the simpler account)
    where it leaves hardly any moving samples off, or where the pair in its place does as well
    on the held-out part (``heldout_gain(search, terms)``: the held-out chi-square's drop)."""
    from scipy.optimize import minimize

    k = next((i for i, (t, _) in enumerate(terms) if t == "zone"), None)
    if k is None:
        return search, terms
    opt = search.fam["zone"][terms[k][1]]
    q0, w0 = float(opt["force_czone_q"][c]), float(opt["force_czone_w"][c])
    lo, hi = float(search.q_range[0][c]), float(search.q_range[1][c])
    T = float(search.travel[c])
    tried = {}

    def at(x):
        nonlocal search
        q, w = q0 + x[0] * abs(w0), w0 * math.exp(x[1])
        if not (lo <= q <= hi and 0.02 * T <= abs(w) <= T):
            return math.inf
        search, o = add_option(search, "zone", c, {"force_czone_q": q, "force_czone_w": w})
        tried[o] = ls_fit(search, terms[:k] + [("zone", o)] + terms[k + 1:])
        return tried[o]

    minimize(at, np.zeros(2), method="Nelder-Mead",
             options={"initial_simplex": [[0, 0], [0.7, 0], [0, 0.5]], "xatol": 0.01, "fatol": 0.1, "maxfev": 40})
    best = min(tried, key=tried.get, default=None)
    if best is not None and tried[best] < ls_fit(search, terms):
        terms = terms[:k] + [("zone", best)] + terms[k + 1:]
    # a zone whose off side holds hardly any of the moving samples is a Coulomb friction over
    # the whole stroke (its edge then cuts off the slow samples about the reversals nearest an
    # end of the stroke, where a sharp friction read at noisy rates misfits)
    opt = search.fam["zone"][terms[k][1]]
    qz, wz = float(opt["force_czone_q"][c]), float(opt["force_czone_w"][c])
    pipe = search.pipe
    moving = rows & (np.abs(pipe.qd_s[pipe.idx][:, c]) > ZONE_SPEED * search.rate[c])
    on = 0.5 * (1.0 + np.tanh((pipe.q_s[pipe.idx][moving, c] - qz) / wz))
    pair = terms[:k] + [("coulomb_both", 0)] + terms[k + 1:]
    if on.size and np.mean(on < 0.5) < ZONE_OFF:
        return search, pair
    if ("coulomb_both", 0) in search.cols and not any(clash(search, c, [u], ("coulomb_both", 0)) or
                                                      u[0].startswith("coulomb") for u in pair[:k] + pair[k + 1:]):
        if heldout_gain(search, pair) >= heldout_gain(search, terms):
            return search, pair
    return search, terms


# ------------------------------------------------------------------------- the equation

def equation_parts(search, c, names, get, shape_of, pm) -> list:
    """The equation's parts of the family terms: ``get(key)`` a coefficient or None,
    ``shape_of(key)`` a shape parameter's value, ``pm(value, ci, unit)`` a figure."""
    F, Q = search.eng.model.facts.effort_unit, search.eng.model.facts.joint_unit

    def sgn():
        v = shape_of("force_cv")
        return "sign(qd)" if not v else f"tanh(qd / {v:.3g} {Q}/s)"

    parts = []
    z = f"(q - {shape_of('force_qc') or 0.0:.5g} {Q})" if shape_of("force_qc") is not None else "q"
    for key, fmt in (("force_cload", "|tau| {s}"), ("force_eq", "{z} tau"),
                     ("force_eg", "tau"),
                     ("force_qv", "{z} qd"), ("force_cq1", "{z} {s}"), ("force_cq2", "{z}^2 {s}")):
        e = get(key)
        if e is not None:
            parts.append(f"{pm(e.value, e.ci95, e.unit)} " + fmt.format(z=z, s=sgn() if "{s}" in fmt else ""))
    e = get("force_czone")
    if e is not None:
        parts.append(f"{pm(e.value, e.ci95, e.unit)} {sgn()} (1 + tanh((q - {shape_of('force_czone_q'):.5g} {Q}) / "
                     f"{shape_of('force_czone_w'):.3g} {Q})) / 2")
    k = shape_of("force_xj")
    for key, fmt in (("force_xk1", "(q{k} - {qc:.5g} {Q})"), ("force_xv", "qd{k}")):
        e = get(key)
        if e is not None:
            parts.append(f"{pm(e.value, e.ci95, e.unit)} " + fmt.format(k=int(k or 0), qc=shape_of("force_xqc") or 0.0,
                                                                         Q=Q))
    return parts


# ------------------------------------------------------------------------- effort terms refined

#: terms the core solves for implicitly (the applied effort): their columns are the core's
#: residual's slope at the model's effort, and a coefficient of a few per cent bends it (the
#: effort the plant applies differs from the model's by that much)
EFFORT_TERMS = ("load", "effortpos")


def refine_effort(search, c, terms, coef, held, rows, keys_of, iterations=2):
    """``coef`` (the coefficients of ``terms`` on joint c, as fitted to the columns taken at
    the model ``held``) refined by Gauss-Newton steps on the core's residual of channel c over
    ``rows`` where ``terms`` hold an effort term (:data:`EFFORT_TERMS`): each step takes every
    coefficient's column again at the current coefficients (``keys_of(term)``: its (core key,
    scale) pairs).  Returned unchanged otherwise, or where a step does not lower the chi-square
    (or makes the drive self-lock); None where ``coef`` itself makes it self-lock (the core
    refuses an effort term taking all of the applied effort: no plant holds them)."""
    from ...errors import ArgumentError

    if not any(t in EFFORT_TERMS for t, _ in terms):
        return coef
    eng = search.eng
    w = search.w[c] * eng.use[rows, c]
    shape, names, deltas, bases = {}, [], [], []
    for t, o in terms:
        shape.update(search.shape(t, c, o))
        for k, sc in keys_of(t):
            names.append(search.name(c, k))
            deltas.append(search._delta(sc, c))
            bases.append(float(held.get(search.name(c, k), 0.0)))
    base = dict(held, **shape)

    def at(x):
        return dict(base, **{n: b + v for n, b, v in zip(names, bases, x)})

    def r(x):
        return eng.R(at(x))[rows, c] * w

    x = np.array(coef, float)
    try:
        r0 = r(x)
    except ArgumentError:  # the drive self-locks at these coefficients
        return None
    for _ in range(iterations):
        try:
            J = np.column_stack([(r(x + d * np.eye(len(x))[i]) - r0) / d for i, d in enumerate(deltas)])
            step = -np.linalg.lstsq(J, r0, rcond=None)[0]
            r1 = r(x + step)
        except ArgumentError:
            break
        if not float(r1 @ r1) < float(r0 @ r0):
            break
        x, r0 = x + step, r1
    return x
