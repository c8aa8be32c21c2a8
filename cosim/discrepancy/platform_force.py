"""Platform forces: one force on the platform for the whole robot, not six joint terms.

A load on the moving platform itself (a cable or umbilical to a fixed anchor, a weight, an air
flow) reaches every joint through the robot's Jacobian; searched per joint it comes out as a
string of stand-ins (a platform mass error, a gravity tilt, offsets on several rails).  This
stage searches it once for the whole robot, in the core's platform force
(``wrench.*``, ``cable.*``, ``platform_drag.*``, ``pkm.h``; world frame):

- ``force``: a constant force (f_x, f_y, f_z) at the platform's reference point;
- ``wrench``: a constant force and moment;
- ``cable``: a cable of constant tension T from the platform's reference point to a fixed
  anchor A, f = T (A - p) / |A - p|, the anchor found by a search and T fitted with it;
- ``drag``: a drag -c v on the platform's velocity;

and a static family together with the drag.  Each column is the core's: the efforts the
drive spends on a unit force (or moment, or drag coefficient) along the recorded motion
(``mechanism_inverse_dynamics`` of the model with that parameter set, smoothed as the residual
pipeline smooths efforts).  A cable's efforts at a candidate anchor are those columns weighted,
sample by sample, by the cable's direction (the efforts are linear in the force at each pose);
the chosen anchor and tension are then evaluated by the core's residual pipeline itself.

An option enters if its BIC decrease on the fitted part exceeds the library's threshold plus
the look-elsewhere cost ``2 ln M`` (M: the options tried, each anchor search counted as one per
start) and its drag and tension have the sign of their physics (a drag dissipates, a cable
pulls: :func:`physical`).  When the option alone describes the fitted part at least as well as the library's whole
selection (BIC), the library's selection is made again with the platform force in the model
(``reselect``), and the platform force is kept only if it and that selection fit the
held-out part better than the library's selection alone by more than the threshold: then the
library effects that stood in for it are gone and the report names a platform force with its
equation in the world frame.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

FORCE = ("wrench.fx", "wrench.fy", "wrench.fz")
MOMENT = ("wrench.mx", "wrench.my", "wrench.mz")
DRAG = ("platform_drag.linear",)
ANCHOR = ("cable.anchor_x", "cable.anchor_y", "cable.anchor_z")
#: the parameters whose unit values' columns :func:`search` fits
UNIT_KEYS = FORCE + MOMENT + DRAG
#: distances of the anchor searches' starts from the mean platform position, along the fitted
#: constant force [m]
ANCHOR_STARTS = (0.1, 0.3, 1.0, 3.0)
#: what each option is, in words
WORDS = {"force": "a constant force on the platform", "wrench": "a constant force and moment on the platform",
         "cable": "a cable of constant tension from the platform to a fixed anchor",
         "drag": "a drag on the platform's velocity"}
MECHANISMS = {"force": "a weight or a spring preloaded far from its rest hung on the platform, an umbilical or "
                       "hose pulling one way",
              "wrench": "a weight off the platform's centre, an umbilical or hose pulling and twisting the platform",
              "cable": "a cable, umbilical, hose or spring tied to the platform and to a fixed point",
              "drag": "air or fluid drag on the platform, a damper or seal between the platform and the frame"}


@dataclass
class PlatformForce:
    """A force on the platform found for the whole robot.

    Attributes
    ----------
    family : str
        ``force``, ``wrench``, ``cable``, ``drag`` or a static family with ``+drag``.
    params : dict
        Core parameter -> value (the plant's overrides that model it).
    ci95 : dict
        Core parameter -> half-width of its 95 % interval.
    units : dict
        Core parameter -> unit.
    equation : str
        The force in the world frame, with its intervals.
    delta_bic : float
        BIC decrease on the fitted part (against the nominal model).
    bar : float
        What it had to beat: the threshold plus the look-elsewhere cost ``2 ln M``.
    tried : int
        Options tried (M).
    heldout : dict
        Held-out chi-squares: ``library`` (the library's selection alone), ``platform`` (the
        platform force and the library's selection made again with it), ``gain``.
    instead_of : list of str
        The library effects of the first selection that the platform force replaces.
    mechanisms : str
        What produces such a force.
    """

    family: str
    params: dict
    ci95: dict
    units: dict
    equation: str
    delta_bic: float
    bar: float
    tried: int
    heldout: dict = field(default_factory=dict)
    instead_of: list = field(default_factory=list)
    mechanisms: str = ""

    def __getitem__(self, k):
        return getattr(self, k)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("family", "params", "ci95", "units", "equation", "delta_bic", "bar",
                                               "tried", "heldout", "instead_of", "mechanisms")}


def has_platform_force(model) -> bool:
    """The core declares the platform force for this robot (a robot with a platform)."""
    return "wrench.fx" in model.params()


def unit_columns(eng, keys) -> dict:
    """Residual columns (m, C) of a unit value of each core parameter in ``keys`` along the
    recorded motion, and the per-sample efforts (n, nd) of the unit forces before smoothing
    (``raw``): the core's mechanism inverse dynamics with the parameter set, less without.
    The model with the parameter set is the pipeline's scratch model (:meth:`.residuals.Pipeline.model_for`):
    a copy of the model per parameter costs more than its inverse dynamics over a 10 s recording."""
    pipe = eng.pipe
    motion = (pipe.x_f, pipe.xd_f, pipe.xdd_f)
    base = pipe.model.mechanism_inverse_dynamics(*motion)
    cols, raw = {}, {}
    for k in keys:
        raw[k] = pipe.model_for({k: pipe.nominal[k] + 1.0}).mechanism_inverse_dynamics(*motion) - base
        cols[k] = _residual_column(eng, raw[k])
    return cols, raw


def _residual_column(eng, efforts):
    """The residual's change (m, C) for model efforts (n, nd) added along the recorded motion:
    smoothed as the pipeline smooths them, taken at its samples, with the sign of a residual
    (recorded less modelled); no change on the reading channels."""
    pipe = eng.pipe
    out = np.zeros_like(eng.R0)
    out[:, :pipe.nd] = -pipe.S_rows(efforts, pipe.idx)
    return out


@dataclass
class _Option:
    family: str
    keys: tuple
    coef: np.ndarray
    cov: np.ndarray
    chi2: float
    k: int
    anchor: np.ndarray | None = None
    anchor_cov: np.ndarray | None = None


def _fit(eng, y, cols, mask=None):
    """Weighted least squares of ``y`` on the columns (m, C, k): coefficients, their covariance
    (scaled by the misfit when it exceeds the noise) and the chi-square left."""
    X = eng.vec_cols(cols, mask)
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    r = y - X @ coef
    chi2 = float(r @ r)
    dof = max(len(y) - X.shape[1], 1)
    cov = np.linalg.pinv(X.T @ X) * max(1.0, chi2 / dof)
    return coef, cov, chi2


def _platform_positions(eng):
    """The platform's reference point (m, 3) at the residual's samples (the core's full pose)."""
    pipe = eng.pipe
    X, _ = pipe.model.platform_pose(pipe.x_f[pipe.idx])
    return np.asarray(X)[:, :3]


def _cable_column(cols, P, A):
    """Residual column (m, C, 1) of a unit tension towards the anchor A: the unit forces' columns
    weighted by the cable's direction at each sample (the direction turns slowly against the
    smoothing window; the chosen cable is then evaluated by the core, :func:`_exact`)."""
    d = A[None, :] - P
    u = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    return sum(u[:, i:i + 1] * cols[k] for i, k in enumerate(FORCE))[:, :, None]


def _search_anchor(eng, y, cols, P, f0, extra):
    """The anchor (3,) and tension of the best cable, by Gauss-Newton on the anchor with the
    tension (and the ``extra`` columns) fitted linearly at each anchor; from starts along the
    constant force ``f0`` at the distances :data:`ANCHOR_STARTS`.  Returns (anchor, coef, cov of
    (anchor, coef), chi2) or None."""
    from scipy.optimize import least_squares

    p_mean = np.nanmean(P, axis=0)
    u0 = f0 / max(np.linalg.norm(f0), 1e-300)

    def design(A):
        c = _cable_column(cols, P, A)
        return np.concatenate([c, extra], axis=2) if extra is not None else c

    def resid(A):
        X = eng.vec_cols(design(A))
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        return y - X @ coef

    best = None
    for d in ANCHOR_STARTS:
        try:
            sol = least_squares(resid, p_mean + d * u0, x_scale=d, max_nfev=60, method="lm")
        except (ValueError, np.linalg.LinAlgError):
            continue
        chi2 = float(sol.fun @ sol.fun)
        if best is None or chi2 < best[1]:
            best = (sol.x, chi2)
    if best is None:
        return None
    A = best[0]
    Xl = eng.vec_cols(design(A))
    coef, *_ = np.linalg.lstsq(Xl, y, rcond=None)
    # covariance of (anchor, linear coefficients) from the full Jacobian at the optimum
    h = 1e-4 * max(np.linalg.norm(A - p_mean), 1e-3)
    Ja = np.stack([(Xl @ coef - eng.vec_cols(design(A + h * e)) @ coef) / h for e in np.eye(3)], axis=1)
    Jfull = np.concatenate([-Ja, Xl], axis=1)
    dof = max(len(y) - Jfull.shape[1], 1)
    cov = np.linalg.pinv(Jfull.T @ Jfull) * max(1.0, best[1] / dof)
    return A, coef, cov, best[1]


def search(eng, threshold: float, theta=None, tried0: int = 0, drag_cable: bool = True, cols=None):
    """The best platform-force option on the residual of the nominal model (with the parameters
    ``theta``, default none), or None when no option passes the threshold plus its look-elsewhere
    cost (``tried0`` options tried before count too; ``drag_cable`` False: no anchor search for a
    cable with a drag; ``cols``: the unit forces' columns, :func:`unit_columns` of
    :data:`UNIT_KEYS`, when already made).  Returns ``(option, delta_bic, bar, M)``."""
    y = -eng.vec(eng.R(theta) if theta else eng.R0)  # what the parameters' columns must cancel
    chi0 = float(y @ y)
    cols = unit_columns(eng, UNIT_KEYS)[0] if cols is None else cols
    stack = {k: cols[k][:, :, None] for k in cols}
    logn = math.log(eng.n_eff)
    options = []
    for fam, keys in (("force", FORCE), ("wrench", FORCE + MOMENT), ("drag", DRAG), ("force+drag", FORCE + DRAG),
                      ("wrench+drag", FORCE + MOMENT + DRAG)):
        coef, cov, chi2 = _fit(eng, y, np.concatenate([stack[k] for k in keys], axis=2))
        options.append(_Option(fam, keys, coef, cov, chi2, len(keys)))
    tried = tried0 + len(options)
    f0 = options[0].coef
    P = _platform_positions(eng)
    for fam, extra in (("cable", None), ("cable+drag", stack[DRAG[0]]))[:2 if drag_cable else 1]:
        found = _search_anchor(eng, y, cols, P, f0, extra)
        tried += len(ANCHOR_STARTS)
        if found is None:
            continue
        A, coef, cov, chi2 = found
        keys = ("cable.tension",) + (DRAG if extra is not None else ())
        options.append(_exact(eng, y, _Option(fam, keys, coef, cov[3:, 3:], chi2, 3 + len(keys), A, cov[:3, :3]),
                              cols))
    bar = threshold + 2.0 * math.log(tried)
    best, best_bic = None, 0.0
    for o in options:
        dbic = chi0 - o.chi2 - o.k * logn
        if dbic > bar and dbic > best_bic and physical(o):
            best, best_bic = o, dbic
    return (best, best_bic, bar, tried) if best is not None else None


#: coefficients with the sign of their physics: a drag dissipates (f = -c v, c >= 0), a cable pulls
#: (T >= 0); an option fitting the other sign is a force the mechanism cannot make, not it
SIGNED = ("platform_drag.linear", "cable.tension")


def physical(o: _Option) -> bool:
    """Whether an option's drag and tension have the sign of their physics (:data:`SIGNED`).
    A negative drag (a force along the platform's velocity, feeding energy in) stood for a fast
    periodic force on the platform that the noise model partly takes for noise
    (bench/foreign/mujoco_unlisted.py, fan_unbalance: c = -6.0 N s/m named with confidence)."""
    return all(float(c) >= 0.0 for k, c in zip(o.keys, o.coef) if k in SIGNED)


def _exact(eng, y, o: _Option, cols) -> _Option:
    """A cable option refitted with the core's own column of the tension at its anchor (the
    residual pipeline's difference over ``cable.tension``): its coefficients and chi-square."""
    anchor = {k: float(v) for k, v in zip(ANCHOR, o.anchor)}
    col = eng.R(dict(anchor, **{"cable.tension": 1.0})) - eng.R(anchor)
    X = np.concatenate([col[:, :, None]] + [cols[k][:, :, None] for k in o.keys[1:]], axis=2)
    coef, cov, chi2 = _fit(eng, y, X)
    return _Option(o.family, o.keys, coef, cov, chi2, o.k, o.anchor, o.anchor_cov)


def params_of(o: _Option) -> dict:
    """Core parameters of an option (the model's nominal ones are 0: the robot's table)."""
    out = {k: float(v) for k, v in zip(o.keys, o.coef)}
    if o.anchor is not None:
        out.update({k: float(v) for k, v in zip(ANCHOR, o.anchor)})
    return out


def _ci(o: _Option) -> dict:
    ci = {k: 1.96 * float(np.sqrt(max(o.cov[i, i], 0.0))) for i, k in enumerate(o.keys)}
    if o.anchor is not None:
        ci.update({k: 1.96 * float(np.sqrt(max(o.anchor_cov[i, i], 0.0))) for i, k in enumerate(ANCHOR)})
    return ci


def equation(params: dict, ci: dict) -> str:
    """The platform force in the world frame, with its 95 % intervals."""
    def pm(k, unit, d=3):
        return f"{params[k]:.{d}g} ± {ci.get(k, 0.0):.2g} {unit}"
    parts = []
    if "wrench.fx" in params:
        parts.append("f = (" + ", ".join(pm(k, "N") for k in FORCE) + ")")
    if "wrench.mx" in params:
        parts.append("m = (" + ", ".join(pm(k, "N m") for k in MOMENT) + ") about p")
    if "cable.tension" in params:
        parts.append(f"f = T (A - p)/|A - p|, T = {pm('cable.tension', 'N')}, A = ("
                     + ", ".join(pm(k, "m") for k in ANCHOR) + ")")
    if "platform_drag.linear" in params:
        parts.append(f"f = -c v, c = {pm('platform_drag.linear', 'N s/m')}")
    return "; ".join(parts) + " (world frame; p, v: the platform's reference point and its velocity)"


UNITS = {**{k: "N" for k in FORCE}, **{k: "N m" for k in MOMENT}, **{k: "m" for k in ANCHOR},
         "cable.tension": "N", "platform_drag.linear": "N s/m"}


#: library effects a force on the platform cannot make (a friction or a rotor inertia of one joint):
#: the platform force is searched again beside them when it does not fit alone and the selection
#: holds its stand-ins (:func:`_stand_ins`; a cable beside a large viscous friction on one rail,
#: ``tests/discrepancy/test_two_effects.py``, was named a gravity tilt, a platform mass error and
#: offsets on four rails)
BESIDE = ("coulomb", "viscous", "stribeck", "smooth_coulomb", "rotor_inertia")
def _stand_ins(sel) -> bool:
    """Does the library's selection hold what a force on the platform is named as when it is
    missing: a gravity tilt, or offsets on two joints or more?"""
    keys = [a.group.effect.key for a in sel.selected]
    return "gravity_tilt" in keys or keys.count("offset") >= 2


#: options tried by :func:`search` (5 fixed, 2 anchor searches of len(ANCHOR_STARTS) starts)
_TRIED = 5 + 2 * len(ANCHOR_STARTS)


def platform_stage(eng, sel, threshold: float, reselect):
    """The platform-force stage of a diagnosis: search, the library's selection made again with
    the force in the model (``reselect(params) -> (eng2, sel2)``), and the held-out comparison.

    Returns ``(PlatformForce or None, eng2, sel2)``: with a platform force, the selection made
    with it (its parameters relative to the model with the force); else ``eng, sel``."""
    from .._native import PkmError

    if not has_platform_force(eng.model):
        return None, eng, sel
    try:
        cols = unit_columns(eng, UNIT_KEYS)[0]  # the same for both searches: the residual's change, not the residual
        found = search(eng, threshold, cols=cols)
    except (PkmError, np.linalg.LinAlgError):  # a pose the core refuses (a dependent pose not solved): no stage
        return None, eng, sel
    # only a force that alone (or with the library's joint frictions and rotor inertias beside it:
    # no force on the platform makes those) describes the fitted part at least as well as the
    # library's whole selection (BIC) is worth the library's selection made again with it
    logn = math.log(eng.n_eff)
    lib_bic = (eng.chi2(sel.theta) if sel.theta else float(eng.vec(eng.R0) @ eng.vec(eng.R0))) + len(sel.theta) * logn
    if found is None or found[0].chi2 + found[0].k * logn >= lib_bic:
        joint = {k: v for a in sel.selected if a.group.effect.key in BESIDE for k, v in sel.theta.items()
                 if k in a.group.params}
        if not joint or not _stand_ins(sel):
            return None, eng, sel
        try:
            # (the cable with a drag not searched again: half the time of a second search)
            found = search(eng, threshold, joint, tried0=found[3] if found else _TRIED, drag_cable=False, cols=cols)
        except (PkmError, np.linalg.LinAlgError):
            return None, eng, sel
        if found is None or found[0].chi2 + (found[0].k + len(joint)) * logn >= lib_bic:
            return None, eng, sel
    o, dbic, bar, tried = found
    params = params_of(o)
    # the anchor search's column is the cable's direction applied per sample; the core's own
    # evaluation of the cable gives the chi-square compared below
    eng2, sel2 = reselect(params)
    both = dict(params, **sel2.theta)
    R_lib = eng.R(sel.theta) if sel.theta else eng.R0
    R_pf = eng.R(both)
    chi_lib, chi_pf = _heldout_chi2(eng, R_lib), _heldout_chi2(eng, R_pf)
    if not chi_lib - chi_pf > bar:
        return None, eng, sel
    kept = {a.group.label for a in sel2.selected}
    pf = PlatformForce(o.family, params, _ci(o), {k: UNITS[k] for k in params}, equation(params, _ci(o)),
                       float(dbic), float(bar), int(tried),
                       {"library": chi_lib, "platform": chi_pf, "gain": math.sqrt(chi_lib / max(chi_pf, 1e-300))},
                       [f"{a.group.title}" for a in sel.selected if a.group.label not in kept],
                       "; ".join(MECHANISMS[f] for f in o.family.split("+")))
    return pf, eng2, sel2


def diagnosis_stage(eng, sel, rec, model, groups, pipeline_kw: dict, prepare_kw: dict):
    """:func:`platform_stage` in a diagnosis: the second selection is the diagnosis's own
    (:func:`.engine.prepare` and :func:`.engine.attribute` with ``prepare_kw``) on the recording's
    residual pipeline (``pipeline_kw``) for the model with the platform force."""
    from .engine import attribute, prepare
    from .residuals import Pipeline

    def reselect(params):
        m2 = model.copy()
        m2.set_params(params)
        # the first pipeline's kinematics are taken (a force on the platform moves no joint)
        return attribute(prepare(Pipeline(rec, m2, kinematics=eng.pipe, **pipeline_kw), groups, **prepare_kw))
    return platform_stage(eng, sel, prepare_kw["threshold"], reselect)


def _heldout_chi2(eng, R) -> float:
    y = eng.vec(R, eng.test)
    return float(y @ y)


def short_name(pf: PlatformForce) -> str:
    """The force in a few words, for the conclusion's first paragraph."""
    return WORDS[pf.family.split("+")[0]] + (" and a drag on its velocity" if pf.family.endswith("+drag") else "")


def sentence(pf: PlatformForce, conclusion: str) -> str:
    """The diagnosis's conclusion with the platform force first."""
    head = f"missing physics on the platform: {short_name(pf)}, {pf.equation} ({pf.mechanisms})"
    if pf.instead_of:
        head += "; instead of the library's " + ", ".join(pf.instead_of)
    if conclusion.startswith("no missing physics"):
        return head
    rest = conclusion.split(": ", 1)[1] if conclusion.startswith("missing physics") else conclusion
    return head + "; and " + rest


def markdown(pf: PlatformForce) -> list:
    """The report's section on a platform force (lines of Markdown)."""
    h = pf.heldout
    L = ["## A force on the platform", "",
         "Searched once for the whole robot (a constant force or wrench, a cable to a fixed anchor, a drag on the "
         "platform's velocity), mapped to the joints through the robot's Jacobian by the core "
         "(`wrench.*`, `cable.*`, `platform_drag.*`).", "",
         f"- **{pf.equation}**",
         f"  - what makes such a force: {pf.mechanisms}",
         f"  - BIC decrease {pf.delta_bic:.0f} against a bar of {pf.bar:.1f} (threshold + 2 ln {pf.tried} options "
         f"tried)",
         f"  - held-out chi-square: {h['library']:.0f} with the library's selection alone, {h['platform']:.0f} with "
         f"the platform force and the library's selection made again with it (gain {h['gain']:.2f})"]
    L += [f"  - library effect it replaces: {x}" for x in pf.instead_of]
    return L + [""]
