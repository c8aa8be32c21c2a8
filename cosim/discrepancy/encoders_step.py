"""The diagnosis' encoder step: a recording with a link-side encoder on a joint (columns
``q_link<i>``, docs/importing.md) beside its motor-side reading (``q<i>``, the motor angle in joint
units) has the gear's elasticity and backlash measured from the two encoders' difference
(:func:`cosim.identification.encoders.drive_elasticity`), reported as the two-body drive's core
parameters ``<joint>[i].compliance`` (and its stiffness, 1 / compliance) and ``<joint>[i].backlash``
with 95 % intervals.

The effort is referred to the link side: the recording's ``tau`` is the motor's effort in joint
units (gear ratio x motor torque, N m or N at the joint); the transmitted one is that less the
drive layer's share of the model diagnosed against (rotor inertia, friction, offset at the motor
side's motion). The encoders are taken as recorded (no low-pass). The 95 % intervals allow for the
residual's serial correlation: the least-squares standard errors times sqrt((1 + r) / (1 - r)), r
the residual's lag-1 autocorrelation (the AR(1) variance inflation, Wilks 2011, sec. 5.2.4; for
regressors as smooth as the residual it is the factor of the coefficients too).  The engine's HAC
covariance (:mod:`.intervals`) is not used here: its AR(1) plug-in bandwidth is bounded at r = 0.97,
and the residual of this fit is mostly the core's backlash model (a jump of the reading at the
effort's sign change, where a real gear drifts through its gap), correlated over whole crossings
(r near 1): measured on the two-mass drive of tests/discrepancy/test_link_encoders.py, the HAC
interval of the backlash was 2.8e-6 rad for an error of 3.3e-6, this one 1.2e-5.

Example
-------
>>> from cosim.discrepancy.encoders_step import encoder_findings
>>> found = encoder_findings(rec, model)  # doctest: +SKIP
>>> found[0]["params"]["joint[2].compliance"].value  # doctest: +SKIP
"""
from __future__ import annotations

import re

import numpy as np

from .results import ParamEstimate

#: the link-side encoder column of joint i
LINK_COLUMN = re.compile(r"^q_link([1-9][0-9]*)$")
#: which side the effort of a recording is referred to, as the report says it
EFFORT_SIDE = ("link side: the recording's tau is the motor's effort times the gear ratio (at the joint); the "
               "transmitted effort is that less the nominal drive's rotor inertia, friction and offset")


def _inflation(res: np.ndarray) -> float:
    """sqrt((1 + r) / (1 - r)), r the lag-1 autocorrelation of ``res`` in [0, 0.999]."""
    r = 0.0
    if res.size > 3 and np.std(res) > 0:
        r = float(np.clip(np.corrcoef(res[:-1], res[1:])[0, 1], 0.0, 0.999))
    return float(np.sqrt((1 + r) / (1 - r)))


def _bound(x) -> str:
    return "inf" if x is None else f"{x:.4g}"


def link_joints(rec) -> list[int]:
    """The joints (from 1) of ``rec`` with a link-side encoder column, in order."""
    return sorted(int(m.group(1)) for k in rec.extra if (m := LINK_COLUMN.match(k)))


def encoder_findings(rec, model) -> list[dict]:
    """Stiffness and backlash of each joint with a link-side encoder.

    Parameters
    ----------
    rec : cosim.recording.Recording
        With ``q_link<i>`` columns [rad or m] for some joints (none: ``[]``).
    model : cosim.core.Model
        The nominal model (its drive layer's share is taken off the recorded effort).

    Returns
    -------
    list of dict
        One per joint: ``joint``, ``name`` ("gear elasticity and backlash (two encoders)"),
        ``params`` ({``<joint>[i].compliance`` [rad/(N m) or m/N], ``<joint>[i].backlash`` [rad
        or m]: :class:`~cosim.discrepancy.results.ParamEstimate`}), ``stiffness`` [N m/rad or N/m]
        (None when the compliance is not positive) and ``stiffness_ci95`` (low, high; high None,
        unbounded, when the compliance's interval reaches zero; low None too when it is all below
        zero), ``rms_difference``, ``rms_residual`` [rad or m], ``effort_side``, ``statement``.
    """
    joints = [j for j in link_joints(rec) if j <= model.ndof]
    if not joints:
        return []
    from ..identification.encoders import drive_elasticity

    ql = np.array(rec.q, dtype=float)
    for j in joints:
        ql[:, j - 1] = rec.extra[f"q_link{j}"]
    # unfiltered: a low-pass of the difference and the effort biases the backlash (the sensor
    # model is not linear in the effort), measured on the two-mass drive of the test: 10 Hz gave
    # the stiffness 7 % and the backlash 29 % low, none 0.2 % and 0.5 %
    est = drive_elasticity(model, rec.time, rec.q, ql, rec.qd, rec.tau, joints=joints, effort="motor", design=True)
    pre, ju = model.facts.joint_prefix, model.joint_unit
    eu = model.facts.effort_unit
    nominal = model.params()
    out = []
    for e in est:
        j = e["joint"]
        f = _inflation(e["residual"])
        ci_c, ci_b = 1.96 * f * e["compliance_se"], 1.96 * f * e["backlash_se"]
        c = e["compliance"]
        lo = 1.0 / (c + ci_c) if c + ci_c > 0 else None  # None: no bound (JSON null, not Infinity)
        hi = 1.0 / (c - ci_c) if c - ci_c > 0 else None
        kc, kb = f"{pre}[{j}].compliance", f"{pre}[{j}].backlash"
        params = {kc: ParamEstimate(c, ci_c, float(nominal[kc]), f"{ju}/({eu})"),
                  kb: ParamEstimate(e["backlash"], ci_b, float(nominal[kb]), ju)}
        nid = "" if abs(e["backlash"]) > ci_b else " (its interval includes zero)"
        left = 100 * e["rms_residual"] / max(e["rms_difference"], 1e-300)
        stiff = (f"stiffness {e['stiffness']:.4g} {eu}/{ju} (95 %: {_bound(lo)} to {_bound(hi)})" if c > 0 else
                 f"no stiffness (compliance {c:.3g} +- {ci_c:.2g}, not positive)")
        out.append({"joint": j, "name": "gear elasticity and backlash (two encoders)", "params": params,
                    "stiffness": e["stiffness"] if c > 0 else None, "stiffness_ci95": (lo, hi),
                    "rms_difference": e["rms_difference"], "rms_residual": e["rms_residual"],
                    "effort_side": EFFORT_SIDE,
                    "statement": f"joint {j} (motor - link encoder, RMS {e['rms_difference']:.3g} {ju}, "
                                 f"{left:.0f} % left by the fit): "
                                 f"{stiff}, {kc} = {c:.4g} +- {ci_c:.2g}, {kb} = {e['backlash']:.4g} +- {ci_b:.2g} "
                                 f"{ju}{nid}"})
    return out


def sentence(found: list[dict]) -> str:
    """The conclusion's clause for the encoder findings ("" for none)."""
    if not found:
        return ""
    return ("gear elasticity and backlash from the motor and link encoders (effort referred to the link side): "
            + "; ".join(f["statement"] for f in found))


def markdown(found: list[dict]) -> list[str]:
    """The report's section (lines) for the encoder findings ([] for none)."""
    if not found:
        return []
    L = ["## Gear elasticity and backlash (motor and link encoders)", "",
         f"Effort referred to the {EFFORT_SIDE}.", "",
         "| joint | parameter | value | 95 % | nominal |", "| --- | --- | --- | --- | --- |"]
    for f in found:
        for k, p in f["params"].items():
            L.append(f"| {f['joint']} | `{k}` | {p.value:.4g} {p.unit} | +- {p.ci95:.2g} | {p.nominal:.4g} |")
        lo, hi = f["stiffness_ci95"]
        k = _bound(f["stiffness"])
        L.append(f"| {f['joint']} | stiffness (1 / compliance) | {k} | {_bound(lo)} to {_bound(hi)} | |")
    L += [""] + [f"- {f['statement']}" for f in found] + [""]
    return L
