"""The diagnosis' checks: a recording that contradicts the model's conventions (joint or effort
sign and units), a motion that cannot separate the effects, and the held-out fit of a model
(:mod:`.diagnosis`).
"""
from __future__ import annotations

import math

import numpy as np

from ..residuals import DiagnosisError

_DECLARE = ('Declare it in the sidecar ("joint_convention": {"sign": [...], "offset": [...]}, recorded = sign * '
            'model + offset)')


def convention_contradictions(pipe, mdl) -> list:
    """Joints the recording measures in another convention than the model's, one
    sentence each: from the pose columns when there are any (:func:`joint_contradictions`),
    then from the efforts (:func:`effort_contradictions`) for the joints not named yet."""
    out = joint_contradictions(pipe, mdl)
    named = {w.split(":")[0] for w in out}
    return out + [w for w in effort_contradictions(pipe, mdl) if w.split(":")[0] not in named]


def joint_contradictions(pipe, mdl) -> list:
    """Joints whose recorded reading runs against the inverse kinematics of the recorded
    pose (slope below 0 of the reading on it: a reversed joint coordinate) or sits far
    from it (by more than 5 cm or 0.5 rad: an offset no encoder error explains); [] without
    pose columns.  The library's reading effects (offset, backlash, compliance) stay far
    inside both bounds."""
    if pipe.pose is None or list(mdl.facts.pose_names) != list(pipe.rec.pose_columns):
        return []
    q_ik, status = mdl.ik(pipe.pose[pipe.idx], errors="status")
    ok = status == 0
    if ok.sum() < 10:
        return []
    q_rec, q_ik = pipe.q[pipe.idx][ok], q_ik[ok]
    noun, out = mdl.facts.joint_noun, []
    for i in range(q_rec.shape[1]):
        a, b = q_rec[:, i] - q_rec[:, i].mean(), q_ik[:, i] - q_ik[:, i].mean()
        spread = float(b @ b)
        slope = float(a @ b) / spread if spread > 0 else 1.0
        gap = float(np.median(q_rec[:, i] - q_ik[:, i]))
        unit = mdl.joint_unit
        far = abs(gap) > (0.5 if unit == "rad" else 0.05)
        if slope < 0:
            out.append(f"{noun} {i + 1}: the recorded reading q{i + 1} runs against the inverse kinematics of the "
                       f"recorded pose (slope {slope:.2f}): a joint coordinate running the other way? {_DECLARE}")
        elif far:
            out.append(f"{noun} {i + 1}: the recorded reading q{i + 1} is {gap:.4g} {unit} from the inverse "
                       f"kinematics of the recorded pose: another zero of the joint coordinate? {_DECLARE}")
    return out


#: how many times more residual the model plus a constant effort offset must leave than a
#: scale (a gear ratio, a unit, a sign) before the check blames the recording's convention
SURE = 3.0


def effort_contradictions(pipe, mdl) -> list:
    """Joints whose recorded effort runs against the model's, one sentence each.

    The nominal inverse dynamics along the measured motion is compared with the
    recorded effort joint by joint (smoothed, decimated samples): a cosine below -0.5
    (gravity load of the wrong sign, a reversed rail coordinate) or, where they agree in
    shape (cosine above 0.9), a scale outside 0.5-2 (a gear ratio, a unit) is no missing
    physics the library can name: it is a convention the recording does not share with
    the model.  A constant effort offset (a cable carrier, an unbalanced mass, a force
    on the joint) also changes the cosine and the scale of a one-signed effort, and it is
    physics: the convention is blamed only if it is sure, that is if a scale (with a
    constant) explains the recorded effort and the model plus a constant offset leaves
    at least ``SURE`` times more residual; the sentence gives both residuals.
    """
    tau_m = pipe.S(mdl.inverse_dynamics(pipe.x_f, pipe.xd_f, pipe.xdd_f))[pipe.idx]
    tau_r = pipe.tau_s[pipe.idx]
    noun, unit = mdl.facts.joint_noun, mdl.facts.effort_unit
    out = []
    for i in range(tau_r.shape[1]):
        a, b = tau_r[:, i], tau_m[:, i]
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        if not (na > 0 and nb > 0):
            continue
        cos, scale = float(a @ b) / (na * nb), float(a @ b) / (nb * nb)
        col = f"tau{i + 1}"
        against = cos < -0.5
        if not (against or (cos > 0.9 and not 0.5 < scale < 2.0)):
            continue
        # The two explanations: the model times a scale plus a constant, the model plus a
        # constant offset (physics the library names).
        (s, c), *_ = np.linalg.lstsq(np.column_stack([b, np.ones_like(b)]), a, rcond=None)
        r_scale = float(np.sqrt(np.mean((a - s * b - c) ** 2)))
        r_offset = float(np.std(a - b))
        if (0.5 < s < 2.0) or r_offset < SURE * r_scale:
            continue
        sure = (f"the model times {s:.3g} plus {c:.3g} {unit} leaves {r_scale:.3g} {unit} RMS, the model plus a "
                f"constant offset {r_offset:.3g} {unit}, {r_offset / max(r_scale, 1e-300):.0f} times more")
        if against:
            out.append(f"{noun} {i + 1}: the recorded effort runs against the model's (cosine {cos:.2f}; {sure}): "
                       f"was it recorded in another joint convention or with the opposite sign of {col}? {_DECLARE}")
        else:
            out.append(f"{noun} {i + 1}: the recorded effort is the model's times {s:.3g} (cosine {cos:.2f}; "
                       f"{sure}): a gear ratio or a unit in {col}? Convert the column to the joint's effort")
    return out


def _check_motion(pipe):
    """A recording that does not move cannot excite any dynamic effect: say so."""
    if np.all(np.abs(pipe.qd_s[pipe.idx]) < 1e-9):
        raise DiagnosisError(f"{pipe.where}: the joints do not move (all rates below 1e-9): a standstill "
                             f"recording cannot excite friction, inertia, delays or any other dynamic effect; "
                             f"record a motion with accelerations, constant-velocity phases and reversals")


def heldout_fit(eng, sel, theta: dict | None = None, R_after=None) -> dict:
    """Residuals on the held-out samples before (nominal) and after (fitted) modelling.

    RMS over the samples each channel uses (a joint's rest phases, where its friction
    and backlash depend on a rate below the reading noise, are left out, as in the
    fit); ``rms_all_*`` over every held-out sample.  ``R_after`` (every row of ``eng``): the
    fitted residual when it is not ``eng.R(theta)`` (the plant carries drifts, :func:`.drift.residual`)."""
    test = eng.test
    theta = sel.theta if theta is None else theta
    Rb = eng.R({})[test]
    Ra = (eng.R(theta) if R_after is None else R_after)[test] if theta else Rb
    use = eng.use[test] > 0
    pipe = eng.pipe
    chans = pipe.channels
    nd = pipe.nd
    scale = np.concatenate([np.sqrt(np.mean(pipe.tau_s[pipe.idx[test]] ** 2, axis=0)),
                            np.std(pipe.q[pipe.idx[test]], axis=0)])[: len(chans)]
    # A scale at the rounding level of the channel's own values (a joint held still reads
    # a spread of 1e-16 m) is no scale: the joint did not move, the NRMSE is n/a.
    size = np.concatenate([np.max(np.abs(pipe.tau_s), axis=0), np.max(np.abs(pipe.q), axis=0)])[: len(chans)]
    scale = np.where(scale > 1024 * np.finfo(float).eps * size, scale, 0.0)

    def rms(a):
        return np.sqrt(np.sum(a**2 * use, axis=0) / np.maximum(use.sum(axis=0), 1))

    rb, ra = rms(Rb), rms(Ra)
    sig = sel.sigma
    # Channels the fitted effects act on: their contribution exceeds twice the noise on
    # at least 2 % of the held-out samples (a Stribeck term acts at reversals only).
    acts = (np.abs(Rb - Ra) > 2.0 * sig) & use
    affected = [i for i in range(len(chans)) if acts[:, i].mean() >= 0.02]
    pick = affected or list(range(len(chans)))
    gain = float(np.sqrt(np.sum((rb[pick] / sig[pick]) ** 2) / max(np.sum((ra[pick] / sig[pick]) ** 2), 1e-300)))
    # The same ratio over the held-out samples where the nominal residual leaves its
    # noise band (the localised windows): an effect that acts in a few phases (Stribeck
    # at slow reversals) is diluted by the noise of the other samples in the RMS above.
    band = (np.abs(Rb) > 3.0 * sig) & use
    num = sum(np.sum((Rb[band[:, i], i] / sig[i]) ** 2) for i in pick)
    den = sum(np.sum((Ra[band[:, i], i] / sig[i]) ** 2) for i in pick)
    gain_w = float(np.sqrt(num / den)) if den > 0 else float("nan")
    note_w = None if den > 0 else ("no held-out sample of the affected channels leaves the nominal residual's "
                                   "3-sigma noise band: no window to measure a gain on")
    rb_all, ra_all = np.sqrt(np.mean(Rb**2, axis=0)), np.sqrt(np.mean(Ra**2, axis=0))
    per = {c: {"rms_before": float(rb[i]), "rms_after": float(ra[i]),
               **_nrmse(rb[i], ra[i], scale[i], i < nd), "noise": float(sig[i]),
               "rms_all_before": float(rb_all[i]), "rms_all_after": float(ra_all[i]),
               "unit": _unit(pipe, i)} for i, c in enumerate(chans)}
    tt = pipe.t[pipe.idx[test]]
    fitted = bool(theta)
    note = None
    if fitted and not affected:
        # The fitted effects change nothing on the held-out part beyond the noise (a
        # saturation never reached there): no gain can be measured.
        gain = gain_w = float("nan")
        note = note_w = ("the fitted effects change no held-out channel by more than twice the noise on 2 % "
                         "of its samples: no gain can be measured")
    # A gain that cannot be measured is NaN here and null in diagnosis.json, with its reason.
    return {"channels": per, "gain": gain if fitted else 1.0,
            "gain_windows": gain_w if fitted else 1.0,
            "gain_note": note if fitted else None, "gain_windows_note": note_w if fitted else None,
            "window_fraction": float(band[:, pick].mean()) if pick else 0.0,
            "affected": [chans[i] for i in affected],
            "samples": int(test.sum()), "start": float(tt[0]) if test.any() else None,
            "end": float(tt[-1]) if test.any() else None, "nd": nd}


def _nrmse(rms_before, rms_after, scale, effort: bool) -> dict:
    """The held-out RMS over the channel's own scale (RMS effort, or the joint's spread), or,
    where that scale is zero (a joint that did not move over the held-out part, an effort
    that stayed zero), ``None`` with the reason in ``nrmse_na``: no ratio, never a NaN."""
    if scale > 0 and math.isfinite(scale):
        return {"nrmse_before": float(rms_before / scale), "nrmse_after": float(rms_after / scale), "nrmse_na": None}
    why = "no effort on the joint" if effort else "joint did not move"
    return {"nrmse_before": None, "nrmse_after": None, "nrmse_na": f"{why} over the held-out part: n/a"}


def _unit(pipe, i):
    # the core's units of the robot's joints and efforts (RobotFacts), not a robot-name test
    facts = pipe.model.facts
    return facts.effort_unit if i < pipe.nd else facts.joint_unit
