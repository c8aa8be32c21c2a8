"""The diagnosis' last steps: the discovery step on what the library leaves (library effects
on trial, :mod:`.discovery`) and the closed-loop replay of the held-out part with the
nominal, the fitted and the compared plants (:mod:`.diagnosis`).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..._native import PkmError
from .answer import _withdrawn_sentence
from ..residuals import DiagnosisError


def _discover(eng, sel, threshold):
    """The discovery step (:mod:`.discovery`): library effects put on trial against
    discovered terms, then the terms found on every effort channel of what is left.
    Returns (terms, withdrawn groups, parameters: library kept + discovered, the groups tied
    with discovered terms)."""
    from ..discovery import judge_library
    from ..discovery.pair import paired
    from ..discovery.taut import taut_pairs

    theta, withdrawn, ties, search, base = judge_library(eng, sel, threshold)
    found = [t for t in base.values() if t is not None]  # the terms on what the library keeps
    withdrawn = withdrawn + _offsets_refitted_away(sel, found, {w["group"] for w in withdrawn})
    found = [replace(t, instead_of=[_withdrawn_sentence(w) for w in withdrawn if t.channel in w["replaced_by"]])
             for t in found]
    theta = dict(theta)
    for t in found:
        theta.update(t.params())
    found, withdrawn, theta = paired(eng, search, sel, theta, found, withdrawn, threshold)
    found, withdrawn, theta = taut_pairs(eng, search, sel, theta, found, withdrawn, threshold)
    R_all = eng.R(theta) if found else None
    return [replace(t, curve=_curve(eng, theta, R_all, t)) for t in found], withdrawn, theta, ties


def _curve(eng, theta, R_all, t) -> dict:
    """For the report's figure of discovered term ``t``: its joint's position or rate (``key``)
    and its channel's residual without and with the term (``before``, ``after``), at the
    decimated samples; ``theta`` holds every parameter fitted, ``R_all`` is its residual."""
    pipe, c = eng.pipe, t.joint - 1
    without = eng.R({k: v for k, v in theta.items() if k not in t.params()})[:, c]
    key = {"position": pipe.q_s, "velocity": pipe.qd_s, "acceleration": pipe.qdd_s}[t.key_variable][pipe.idx, c]
    return {"key": key, "before": without, "after": R_all[:, c]}


def _offsets_refitted_away(sel, found, gone) -> list:
    """The library's offsets that a discovered term refitted to zero on its joint (its value with
    the term within its 95 % interval of zero): it stood in for the term, and is withdrawn (the
    plant's parameters hold the refitted value)."""
    out = []
    for t in found:
        for a in sel.selected:
            g = a.group
            c = t.coefficients.get(g.params[0]) if g.key == "offset" else None
            if c is None or g.label in gone or c.base == 0 or abs(c.value) > c.ci95:
                continue
            out.append({"group": g.label, "effect": g.effect.name, "title": g.title,
                        "params": {g.params[0]: float(sel.theta.get(g.params[0], float("nan")))},
                        "replaced_by": [t.channel], "refitted": {"value": c.value, "ci95": c.ci95, "unit": c.unit}})
    return out


def _compared(rec, mdl, compare) -> dict:
    """The plants ``compare`` names for the replay: {name: Model}."""
    from ...core.model import Model

    if not compare:
        return {}
    out = {}
    for name, spec in (compare.items() if isinstance(compare, dict) else ((c, None) for c in compare)):
        try:
            if spec is None:
                out[name] = Model(rec.robot, name)
            else:
                out[name] = mdl.copy()
                out[name].set_params(spec)
        except PkmError as e:
            raise DiagnosisError(f"compare: {name}: {e}") from None
    return out


def black_box_for_plant(eng, R, fits, rows: int) -> np.ndarray:
    """The explained flexible models as the replay's black-box force (rows, joints), for the
    fitted plant, which carries every fitted term (:func:`.flexible.black_box_force`).  A partial
    term's channel is fitted on the residual before the term (``FlexibleFit.target``): its model
    predicts that, evaluated on the inputs it was fitted on; what the plant leaves is that less
    the term's part (``target`` less the residual ``R`` after the fitted model, interpolated as
    the force), else the plant and the black box would both carry the term's force."""
    from ..flexible import black_box_force

    R = np.asarray(R, float)
    R_fitted = R.copy()  # the stage's residual: each fitted channel's target
    for f in fits:
        if f.target is not None:
            R_fitted[:, f.joint - 1] = f.target
    out = black_box_force(eng, R_fitted, fits, rows)
    t, t_rows = eng.pipe.t[eng.pipe.idx], eng.pipe.t[:rows]
    for f in fits:
        if f.explained and f.target is not None:
            out[:, f.joint - 1] += np.interp(t_rows, t, R_fitted[:, f.joint - 1] - R[:, f.joint - 1],
                                             left=0.0, right=0.0)
    return out


def _replay(rec, eng, sel, compared=None, theta=None, black_box=None, drifts=()):
    """Closed-loop replay of the held-out part: the core plant (nominal, then fitted, then,
    with a fitted gap or compliance, the fitted plant with those drives as two bodies,
    :mod:`.drive_bodies`, then the ``compared`` ones) driven by the recorded controller and
    reference, against the recorded motion.  Each run starts from the recorded state at the
    first held-out sample, its controller primed with the recorded readings and reference of
    every sample before it (filters, differences, integrators and computation delay as the
    rig's controller had them: started at rest, a rig's controller with a delay outputs
    nothing at first and sees no velocity, a kick of hundreds of newtons on a real drive).
    Per run the RMS differences and the relative error of the efforts, norm of the
    difference over the norm of the recorded effort.  ``black_box`` (rows x joints, the
    flexible model's force, :func:`black_box_for_plant`): one more run, "fitted + black
    box", the fitted plant with that force as a known external effort.  ``drifts`` (:mod:`.drift`,
    :func:`.drift.for_plant`): the fitted plant carries those with a course as its parameters'
    time courses, and one more run, "fitted, mean", holds every parameter at the constant fitted."""
    from ..drive_bodies import drive_joints, fit_two_body, fitting_window
    from ..runs import closed_loop, controller_from, reference_from_recording

    from ..open_loop import declared_open_loop, heldout_replay

    if rec.qref is None or declared_open_loop(rec):  # an open-loop experiment, or declared: open loop
        return heldout_replay(rec, eng, sel.theta if theta is None else theta, compared, drifts)
    mdl = eng.model
    pipe = eng.pipe
    test = eng.test
    k0 = int(pipe.idx[test][0]) if test.any() else None
    if k0 is None:
        return {"skipped": "no held-out samples"}
    # on a working set of blocks the runs stay inside one block: the held-out one from k0,
    # the two-body fit in the block of the last fitted sample
    rec = rec.slice(0, pipe.segment_of(k0)[1])
    fit_from, fit_to = int(pipe.idx[0]), k0
    if len(pipe.segments) > 1 and (pipe.idx < k0).any():
        a, b = pipe.segment_of(int(pipe.idx[pipe.idx < k0][-1]))
        fit_from, fit_to = int(pipe.idx[pipe.idx >= a][0]), min(k0, b)
    try:
        ref = reference_from_recording(rec, mdl)
    except Exception as e:  # noqa: BLE001 - reported, not fatal
        return {"skipped": f"the reference could not be mapped to poses: {e}"}
    ctrl, why = controller_from(rec.controller, mdl)
    if ctrl is None:
        return {"skipped": why}
    from ...injection import from_recording

    injected = from_recording(rec)  # a test signal the rig added into its loop, replayed at its point

    def run(plant, ref, start, extra=None):
        ctrl, _ = controller_from(rec.controller, mdl)  # a fresh controller (its own state) per run
        f_ext = getattr(rec, "f_ext", None)
        if extra is not None:
            f_ext = extra[: len(rec.time)] + (0.0 if f_ext is None else f_ext)
        return closed_loop(plant, ctrl, ref, x0=pipe.x_f[start], xd0=pipe.xd_f[start], start=start,
                           rtol=1e-8, atol=1e-10, f_ext=f_ext,  # a known input, replayed
                           history=(rec.q[:start], rec.qd[:start]) if start > 0 else None, inject=injected)

    out = {"start": float(rec.time[k0]), "runs": {}}
    theta = sel.theta if theta is None else theta
    plants = {"nominal": mdl.copy(), "fitted": mdl.copy()}
    if theta:
        plants["fitted"].set_params(theta)
    if any(d.course is not None for d in drifts):
        from ..drift import apply

        plants["fitted, mean"] = plants["fitted"].copy()
        apply(plants["fitted"], drifts)
    joints = drive_joints(theta, mdl)
    if joints:
        k_fit, n_fit = fitting_window(pipe, joints, fit_from, fit_to)
        extra, rows = fit_two_body(rec, pipe, plants["fitted"], joints, run, ref, k_fit, n_fit)
        if extra is None:
            out["two_body"] = {"skipped": rows}
        else:
            plants["fitted, two bodies"] = plants["fitted"].copy()
            plants["fitted, two bodies"].set_params(extra)
            # score: the two bodies' differences on the window over the reading model's (< 1: closer)
            out["two_body"] = {"params": extra, "joints": [i for _, i, _, _ in joints],
                               "window": [float(rec.time[k_fit]), float(rec.time[k_fit + n_fit])],
                               "score": min(r["score"] for r in rows if "score" in r), "grid": rows}
    plants.update(compared or {})
    if black_box is not None:
        plants["fitted + black box"] = plants["fitted"]
    for name, plant in plants.items():
        try:
            res = run(plant, ref, k0, black_box if name == "fitted + black box" else None)
        except Exception as e:  # noqa: BLE001 - a failing replay is reported
            out["runs"][name] = {"error": str(e)}
            continue
        s = slice(k0, k0 + len(res.time))
        dq = res.q - rec.q[s]
        dt_ = res.tau_logged - rec.tau[s]
        out["runs"][name] = {"rms_q": np.sqrt(np.mean(dq**2, axis=0)).tolist(),
                             "rms_tau": np.sqrt(np.mean(dt_**2, axis=0)).tolist(),
                             "rel_tau": (np.linalg.norm(dt_, axis=0)
                                         / np.maximum(np.linalg.norm(rec.tau[s], axis=0), 1e-300)).tolist(),
                             "time": res.time, "q": res.q, "tau": res.tau_logged}
    return out
