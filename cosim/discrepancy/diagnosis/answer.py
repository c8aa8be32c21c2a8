"""The diagnosis' answer in words: the effects found with their statements, the gaps and
effects the recording could not show (detection limits), and the conclusion
(:mod:`.diagnosis`).
"""
from __future__ import annotations

import math

import numpy as np

from ..effects import BY_KEY, separating_motion
from ..results import Alternative, FoundEffect, ParamEstimate
from ..ties import TIE_MARGIN, UNEXPLAINED, tied


def _open_statement(items) -> str:
    chans = ", ".join(s["channel"] for s in items)
    keyed = "; ".join(dict.fromkeys(s["keyed_on"] for s in items))
    return f"structure remains unexplained on {chans} (keyed on {keyed})"


def _partial_sentence(left, joint: int) -> str:
    """For a discovered term on ``joint`` (1-based): "" when the recording keeps no structure
    (``left``, :func:`.structure.unexplained`), else why it is not named as the physics."""
    own = [s for s in left if s["joint"] == joint]  # its effort or its reading
    if own:
        return (_open_statement(own) + " with the term added: a partial fit that may stand in for what is "
                "missing, not the physics")
    if left:
        return (_open_statement(left) + ": the fit of the recording is incomplete and the term may take part of "
                "what is missing, so it is not named as the physics with confidence")
    return ""


def _partial_reason(partial: str) -> str:
    """The conclusion's short form of why a discovered term is a partial fit."""
    from ..flexible.rival import PARTIAL

    if partial.startswith(PARTIAL):
        return "a flexible model explains more"
    return "fitted beside a tied library effect" if partial.startswith("fitted beside") else "structure remains"


def _beside_tie_sentence(ties, gone, term) -> str:
    """For a discovered ``term``: why it is not named as the physics when a library effect kept
    on its channel is tied with terms discovered in its place (the two fit as well; fitted
    beside it, the term shares what the effect explains), else "".  An effect whose parameters
    the term refits itself (the drive's offset beside a spring: the spring's rest position) is
    part of the term, not beside it."""
    beside = [t["title"] for t in ties if term.channel in t.get("channels", ()) and t["group"] not in gone
              and not set(t.get("params", ())) & set(term.coefficients)]
    if not beside:
        return ""
    return (f"fitted beside {', '.join(dict.fromkeys(beside))}, which terms discovered in its place fit as well: "
            "the two share what they explain, so the term is not named as the physics with confidence")


def _units(mdl):
    return {p.name: p.unit for p in mdl.param_info()}


def _effects(eng, sel, ties=(), left=()) -> list:
    """The selected groups as :class:`FoundEffect`, with their look-alikes: the library's,
    a discovered term tied with it (``ties``), and, when structure is ``left`` unexplained
    (:func:`.structure.unexplained`), the statement that the fit may stand in for what is
    missing (a tie: not named with confidence)."""
    units = _units(eng.model)
    out = []
    for a in sel.selected:
        g = a.group
        params = {p: ParamEstimate(float(a.values[p]), float(a.ci.get(p, float("nan"))), float(eng.nominal[p]),
                                   units.get(p, "")) for p in g.params}
        looks = []
        for c in a.lookalikes:
            if c.get("collinear"):
                st = (f"{c['name']} is the same column on this recording (partial correlation "
                      f"{c['correlation']:.3f}, variance inflation {1 / max(1 - c['correlation'] ** 2, 1e-12):.3g}): "
                      f"the two act as one "
                      f"force here and their split is no physics; neither is named with confidence; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            elif c["delta_bic"] < TIE_MARGIN:
                st = (f"{c['name']} explains the data as well (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): the two cannot be told apart with this data; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            elif c.get("delta_chi2", float("inf")) < TIE_MARGIN:
                st = (f"{c['name']} fits the data as well (chi-square {c['delta_chi2']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): the same physics on this recording; only its "
                      f"{c['extra_params']} extra parameter(s) cost it delta BIC {c['delta_bic']:+.1f}, which is no "
                      f"evidence against it; {separating_motion(g.key, c['effect'])} would separate them")
            elif c["delta_bic"] < eng.settings.lookalike_margin:
                st = (f"{c['name']} is a weaker alternative (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f}): not told apart with confidence; "
                      f"{separating_motion(g.key, c['effect'])} would separate them")
            else:
                st = (f"{c['name']} was ruled out (delta BIC {c['delta_bic']:+.1f}, correlation "
                      f"{c['correlation']:.2f})")
            looks.append(Alternative(**c, statement=st))
        for tie in ties:
            if tie["group"] == g.label:
                eq = "; ".join(tie["terms"])
                d2 = tie["heldout_chi2_discovered"] - tie["heldout_chi2_library"]
                looks.insert(0, Alternative(
                    "discovered", "discovered", f"a force no library effect names ({eq})", 0.0, d2,
                    tie["extra_params"], float("nan"), False,
                    f"a force no library effect names ({eq}) fits the held-out part as well (chi-square "
                    f"{d2:+.1f}): {g.effect.name} is not named with confidence on this recording"))
        if left:
            chans = ", ".join(s["channel"] for s in left)
            looks.insert(0, Alternative(
                UNEXPLAINED, UNEXPLAINED, f"structure left unexplained on {chans}", 0.0, 0.0, 0, float("nan"),
                False, f"{_open_statement(left)}: the fit may stand in for what is missing; "
                       f"{g.effect.name} is not named with confidence"))
        out.append(FoundEffect(g.key, g.effect.name, g.label, g.title, None if g.joint is None else g.joint + 1,
                               g.effect.family, params, a.delta_bic, a.importance,
                               g.effect.plant.replace("{j}", _prefix(eng.model)), looks, _derived(g, a.values, eng)))
    return out


def _prefix(model):
    from ..effects import joint_prefix

    return joint_prefix(model)


def _derived(g, values, eng) -> dict:
    """Quantities a reader wants besides the core parameters (tilt angle, ...)."""
    if g.key == "gravity_tilt":
        gx, gy = values.get("gravity.x", 0.0), values.get("gravity.y", 0.0)
        gz = eng.nominal.get("gravity.z", -9.81)
        return {"tilt_deg": math.degrees(math.atan2(math.hypot(gx, gy), abs(gz))),
                "azimuth_deg": math.degrees(math.atan2(gy, gx))}
    if g.key == "payload" and "payload.x" in values:
        return {"offset_mm": [1e3 * values[f"payload.{c}"] for c in "xyz"]}
    return {}


#: smallest share of a joint's samples on the minority side of its effort for a backlash gap
#: to be told from a constant offset (2 %: 0.18 s of a 9 s recording on the other face)
GAP_MINORITY = 0.02


def _drop_unseen_gaps(groups, pipe):
    """Backlash groups of joints whose effort keeps one sign: the carriage never leaves its
    face, the gap reads as a constant offset b/2 (the same physics on this recording), so its
    size cannot be measured.  Returns the remaining groups and the 'not excited' sentences."""
    tau = np.asarray(pipe.tau_c, float)
    neg = np.mean(tau < 0.0, axis=0)
    minority = np.minimum(neg, 1.0 - neg)
    keep, said = [], []
    for g in groups:
        if g.key == "backlash" and g.joint is not None and minority[g.joint] < GAP_MINORITY:
            said.append(f"{BY_KEY['backlash'].name} (joint {g.joint + 1}): its effort keeps one sign on "
                        f"{100 * (1 - minority[g.joint]):.1f} % of the samples, so a gap reads as a constant "
                        f"offset of half its size (the encoder offset covers it); it needs efforts of both signs "
                        f"on that joint")
            continue
        keep.append(g)
    return keep, said


def _not_excited(eng, sel) -> list:
    """Effects whose smallest detectable size exceeds their reference size."""
    chosen = {a.group.label for a in sel.selected}
    # a look-alike that fits as well as a named effect is the same physics on this recording
    # (said with that effect), not an effect the recording cannot reveal
    chosen |= {c["group"] for a in sel.selected for c in a.lookalikes
               if tied(c)}
    by_effect = {}
    same = {}
    for lab, (size, ref) in sel.detectability.items():
        g = eng.options[lab][0].group
        if lab in chosen or not np.isfinite(ref) or ref <= 0 or not (size > ref):
            continue
        if lab in sel.collinear:
            same.setdefault(g.key, []).append(g)
            continue
        by_effect.setdefault(g.key, []).append((g, size, ref))
    out = [f"{BY_KEY[key].name}{_where(gs)}: its signature on this recording is a combination of the effects "
           f"already fitted ({', '.join(a.group.title for a in sel.selected)}), so it cannot be told from them; it "
           f"needs {BY_KEY[key].requires}" for key, gs in same.items()]
    units = _units(eng.model)
    for key, items in by_effect.items():
        e = BY_KEY[key]
        unit = units.get(items[0][0].params[0], "")
        where = ", ".join(f"joint {g.joint + 1}" for g, _, _ in items if g.joint is not None)
        worst = max(items, key=lambda it: it[1] / it[2] if np.isfinite(it[1]) else math.inf)
        out.append(f"{e.name}{' (' + where + ')' if where else ''}: {detection_limit_text(worst[1], worst[2], unit)}"
                   f"; it needs {e.requires}")
    return out


#: a smallest detectable size this many times an effect's small size is no size at all: the
#: recording does not excite the effect (a limit of 6e300 kg says that, not a mass)
UNDETECTABLE_RATIO = 1e3


def detection_limit_text(size: float, ref: float, unit: str) -> str:
    """How small an effect this recording could reveal, in words: the limit and the effect's
    small size, or, when the limit is infinite, not a number or absurdly large
    (above :data:`UNDETECTABLE_RATIO` times the small size), that the recording does not
    show the effect at any size.

    Example
    -------
    >>> detection_limit_text(float("inf"), 0.05, "kg")
    'not detectable on this recording (it does not excite it: no size of it would show; a small one is 0.05 kg)'
    """
    if not (np.isfinite(size) and size <= UNDETECTABLE_RATIO * ref):
        return (f"not detectable on this recording (it does not excite it: no size of it would show; a small one "
                f"is {ref:.3g} {unit})")
    return f"this recording cannot reveal it below {size:.3g} {unit} (a small one is {ref:.3g} {unit})"


def _where(groups) -> str:
    joints = ", ".join(f"joint {g.joint + 1}" for g in groups if g.joint is not None)
    return f" ({joints})" if joints else ""


def _withdrawn_sentence(w) -> str:
    if w.get("pair"):
        return f"{w['title']}: part of the damper between two joints found in its place"
    if "refitted" in w:
        r = w["refitted"]
        return (f"{w['title']}: refitted with the discovered term to {r['value']:.3g} +- {r['ci95']:.2g} {r['unit']}, "
                f"zero within its interval (it stood in for the term)")
    a, b = w["heldout_chi2_library"], w["heldout_chi2_discovered"]
    if w.get("as_well"):  # put on trial with another effect: two effects where one force suffices
        return (f"{w['title']}: with {' and '.join(t for t in w['together'] if t != w['title'])}, fits the held-out "
                f"part as well as the one discovered force in their place (chi-square {a:.1f} with them, {b:.1f} "
                f"with it: {w['gain']:.1f} +- {w['se']:.1f}, bar {w['bar']:.1f}), with no fewer coefficients")
    return (f"{w['title']}: fits the held-out part worse (chi-square {a:.1f} with it, {b:.1f} with the discovered "
            f"term in its place: {w['gain']:.1f} +- {w['se']:.1f}, bar {w['bar']:.1f})")


def _conclusion(effects, not_excited, eng, sel, found=(), withdrawn=()) -> str:
    found = [t for t in found if not t.repeats_its_pair]
    if found:
        parts = [f"{t.equation} ({', '.join(t.terms)}; {t.mechanisms})"
                 + (f" [not named as the physics: {_partial_reason(t.partial)}]" if t.partial else "") for t in found]
        head = "missing physics no library effect names: " + "; ".join(parts)
        if withdrawn:
            worse = [w["title"] for w in withdrawn
                     if not w.get("as_well") and "refitted" not in w and not w.get("pair")]
            absorbed = [w["title"] for w in withdrawn if w.get("pair")]
            same = [w["title"] for w in withdrawn if w.get("as_well")]
            zero = [w["title"] for w in withdrawn if "refitted" in w]
            if worse:
                head += "; look-alike(s) of the library that fit the held-out part worse: " + ", ".join(worse)
            if zero:
                head += "; refitted to zero with the terms (they stood in for them): " + ", ".join(zero)
            if absorbed:
                head += "; part of the damper between two joints found in their place: " + ", ".join(absorbed)
            if same:
                head += ("; look-alike(s) of the library that fit the held-out part as well, two effects for one "
                         "force: " + ", ".join(same))
        if effects:
            head += "; and from the library: " + _conclusion(effects, not_excited, eng, sel)[len("missing physics: "):]
        return head
    if effects:
        parts = []
        for e in effects:
            vals = "; ".join(f"{p} = {v['value']:.4g} +- {v['ci95']:.2g} {v['unit']}" for p, v in e["params"].items())
            same = [a["name"] for a in e["lookalikes"] if tied(a) and a["group"] != UNEXPLAINED]
            parts.append(f"{e['title']} ({vals})" + (f" [tie: {', '.join(same)} fits as well]" if same else ""))
        open_ = any(a["group"] == UNEXPLAINED for e in effects for a in e["lookalikes"])
        return "missing physics: " + ", ".join(parts) + (
            " [none named with confidence: the fit leaves structure unexplained and may stand in for what is "
            "missing]" if open_ else "")
    excited = [lab for lab, (size, ref) in sel.detectability.items() if not (np.isfinite(ref) and size > ref)]
    if not excited:
        return "cannot diagnose: the recording excites none of the effects of the library (see 'not excited')"
    return "no missing physics found"


def _two_body_sentence(replay, unit) -> str:
    """What the two-body replay of a fitted gap or compliance showed on its joints' readings,
    for the conclusion ("" without one)."""
    runs = (replay or {}).get("runs", {})
    two, reading = runs.get("fitted, two bodies", {}), runs.get("fitted", {})
    if "rms_q" not in two or "rms_q" not in reading:
        return ""
    joints = replay["two_body"]["joints"]
    closer = all(two["rms_q"][i] < reading["rms_q"][i] for i in joints)
    parts = ", ".join(f"q{i + 1} {two['rms_q'][i]:.3g} {unit} against {reading['rms_q'][i]:.3g} {unit}" for i in joints)
    return (f"; replayed as two bodies (drive and carriage) the held-out readings come "
            f"{'closer to' if closer else 'no closer to'} the recording than with the reading model ({parts})")
