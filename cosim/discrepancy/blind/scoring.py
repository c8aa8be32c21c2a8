"""The blind benchmark: a diagnosis scored against its answer key (:func:`score`), the runs of
the plan's cases (:func:`benchmark`) and their summary (:func:`summarize`,
:func:`format_summary`; :mod:`.blind`).
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np

from .cases import load_config, make_case, plan
from ..diagnosis import UNEXPLAINED, tied


# ------------------------------------------------------------------- scoring

def _param_error(h: dict, values: dict) -> float:
    """Relative error of the estimated change of the hidden parameters (vector norm);
    for delays/saturation levels/... the parameter itself."""
    names = list(h["params"])
    true = np.array([h["params"][n] - h["nominal"].get(n, 0.0) for n in names])
    est = np.array([values.get(n, h["nominal"].get(n, 0.0)) - h["nominal"].get(n, 0.0) for n in names])
    if h["type"] in ("stribeck", "smooth_coulomb"):  # amplitude only; the velocity is reported apart
        true, est = true[:1], est[:1]
    if h["type"] in ("saturation", "dead_zone"):
        true = np.array([h["params"][n] for n in names])
        # a dead zone under a command of one sign is a constant offset of its width (the same
        # physics, which the engine declares a tie): its size then stands for the width
        est = np.array([values[n] if n in values else abs(values.get(n.replace(".dead_zone", ".offset"), 0.0))
                        if h["type"] == "dead_zone" else 0.0 for n in names])
    if h["type"] == "gravity_tilt":
        keep = [i for i, n in enumerate(names) if n != "gravity.z"]
        true, est = true[keep], est[keep]
    if h["type"] == "payload":
        true, est = true[:1], est[:1]
    nrm = np.linalg.norm(true)
    return float(np.linalg.norm(est - true) / nrm) if nrm > 0 else float("nan")


def stated_intervals(diag, shapes: bool = False) -> dict:
    """{core parameter: (value, 95 % half width)} of every parameter the diagnosis states: the
    library effects' and the discovered terms' coefficients, and with ``shapes`` the fitted
    shape parameters of the discovered terms (a step's position and width, a ripple's period)."""
    stated = {p: (v["value"], v["ci95"]) for e in diag.effects for p, v in e["params"].items()}
    for t in diag.discovered:
        stated.update({p: (c.value, c.ci95) for p, c in t.coefficients.items()})
        if shapes:
            stated.update({p: (t.shape[p], h) for p, h in t.shape_ci95.items()})
    return stated


def interval_holds(diag, truth: dict) -> list:
    """For every hidden parameter the diagnosis states a 95 % interval of (a library effect's
    or a discovered term's coefficient): does the interval contain the truth?"""
    stated = stated_intervals(diag)
    return [bool(abs(stated[p][0] - v) <= stated[p][1]) for p, v in truth.items()
            if p in stated and np.isfinite(stated[p][1])]


def score(diag, key: dict) -> dict:
    """Compare a diagnosis with the answer key of its case."""
    hidden = [h["type"] for h in key["effects"]]
    named = diag.named()
    values = diag.theta
    out = {"case": key["case"], "robot": key["robot"], "hidden": hidden, "named": named,
           "first": named[0] if named else "none"}
    if not hidden:
        out["clean_ok"] = not named
        return out
    out["first_ok"] = bool(named) and named[0] in hidden
    ties = diag.ties(named[0]) if named else []
    out["first_ok_or_tie"] = out["first_ok"] or any(t in hidden for t in ties)
    # named first with confidence: no tie among its look-alikes; "before" without the look-alike
    # that marks a fit leaving structure unexplained (what the rule costs)
    looks = diag.effects[0]["lookalikes"] if diag.effects else []
    out["first_confident"] = out["first_ok"] and not any(tied(a) for a in looks)
    out["first_confident_before"] = out["first_ok"] and not any(
        tied(a) for a in looks if a["group"] != UNEXPLAINED)
    out["all_found"] = all(t in named for t in hidden)
    errs = {}
    for h in key["effects"]:
        errs[h["type"]] = _param_error(h, values)
        if h["type"] == "payload" and "payload.x" in h["params"]:
            est = [values.get(f"payload.{c}", 0.0) for c in "xyz"]
            true = [h["params"][f"payload.{c}"] for c in "xyz"]
            out["payload_offset_error_mm"] = float(np.linalg.norm(np.subtract(est, true)) * 1e3)
    out["param_error"] = errs
    out["param_ok"] = all(e <= 0.15 for e in errs.values())
    out["holds"] = interval_holds(diag, {p: v for h in key["effects"] for p, v in h["params"].items()})
    out["gain"] = diag.heldout.get("gain", float("nan"))
    out["gain_windows"] = diag.heldout.get("gain_windows", float("nan"))
    # nan: the fitted effects do not act on the held-out part (nothing to measure)
    out["gain_ok"] = bool(out["gain"] >= 5.0)
    out["gain_windows_ok"] = bool(out["gain_windows"] >= 5.0)
    out["gain_measurable"] = bool(np.isfinite(out["gain"]))
    return out


#: held out together with a hidden type: a fading friction whose scale is below the rate
#: noise is the step friction itself (the generator's step is tanh(qd / drive.v_eps))
HOLD_OUT_WITH = {"coulomb": ("smooth_coulomb",)}


def same_physics_stand_in(kind: str, changes: dict, diag) -> bool:
    """With the type ``kind`` held out of the library, is the effect named first the same
    physics on this recording, at the size the truth implies?  Then no structure can
    remain and none is owed.  ``changes``: the hidden parameters' true changes from nominal.

    Three exact equivalences: a heavier platform is a payload at the platform's centre (its
    mass the platform's extra mass within 10 %, its offset under 1 cm); a gap on a joint whose
    effort keeps one sign (all but the engine's ``GAP_MINORITY`` of the samples) is an
    encoder offset of b/2 (within 10 %); a payload at the platform's centre is a heavier platform
    (its extra mass the payload's within 10 %)."""
    from ...recording import read_recording
    from ..diagnosis import GAP_MINORITY

    est, named = diag.plant_parameters(), diag.named()
    first = named[0] if named else None
    if kind == "platform_mass" and first == "payload":
        dm = changes["platform.m"]
        off = math.sqrt(sum(est.get(f"payload.{c}", 0.0) ** 2 for c in "xyz"))
        return abs(est.get("payload.m", 0.0) - dm) < 0.1 * abs(dm) and off < 0.01
    if kind == "payload" and first == "platform_mass":  # the same, the other way round
        dm = changes["payload.m"]
        off = math.sqrt(sum(changes.get(f"payload.{c}", 0.0) ** 2 for c in "xyz"))
        nominal = diag.effects[0]["params"]["platform.m"]["nominal"]
        return abs(est.get("platform.m", nominal) - nominal - dm) < 0.1 * abs(dm) and off < 0.01
    if kind == "backlash" and first == "encoder_offset" and len(changes) == 1:
        (name, b), = changes.items()
        joint = int(name.split("[")[1].split("]")[0])
        tau = np.asarray(read_recording(diag.recording).tau, float)[:, joint - 1]
        one_signed = min(np.mean(tau < 0), np.mean(tau > 0)) < GAP_MINORITY
        off = est.get(name.replace(".backlash", ".encoder_offset"), 0.0)
        return bool(one_signed and abs(abs(off) - b / 2) < 0.1 * b / 2)
    return False


def _run_one(args):
    spec, out_dir, key_dir, diag_kw, report, cfg, hold_out = args
    from .. import diagnose
    from ..effects import LIBRARY

    t0 = time.perf_counter()
    try:
        csv, kp = make_case(spec, out_dir, key_dir, cfg)
    except RuntimeError as e:  # the generator gave up on this case: reported, not scored
        return {"case": spec.case, "robot": spec.robot, "hidden": list(spec.hidden), "generation_failed": str(e)}
    t1 = time.perf_counter()
    key = json.loads(Path(kp).read_text())
    hidden = {h["type"] for h in key["effects"]}
    if hold_out and hidden:  # the hidden types taken out of the library: the structure must show
        out = hidden | {k for h in hidden for k in HOLD_OUT_WITH.get(h, ())}
        diag_kw = dict(diag_kw, effects=[e.key for e in LIBRARY if e.key not in out])
    try:
        d = diagnose(csv, out=(Path(out_dir) / f"{spec.case}_report") if report else None, **diag_kw)
    except Exception as e:  # noqa: BLE001 - a failed diagnosis is a failed case, not a stop
        return {"case": spec.case, "robot": spec.robot, "hidden": [h["type"] for h in key["effects"]],
                "diagnosis_failed": f"{type(e).__name__}: {e}"}
    t2 = time.perf_counter()
    s = score(d, key)
    s.update({"t_generate": t1 - t0, "t_diagnose": t2 - t1, "conclusion": d.conclusion,
              "held_out": bool(hold_out and hidden), "structure": [e["signature"] for e in d.unexplained]})
    if s["held_out"]:
        h = key["effects"][0]
        s["stand_in"] = (not s["structure"] and len(key["effects"]) == 1 and same_physics_stand_in(
            h["type"], {k: v - h["nominal"].get(k, 0.0) for k, v in h["params"].items()}, d))
    return s


def benchmark(n: int = 40, seed: int = 1, n_clean: int = 10, robots=("6pus",), out_dir="results/blind",
              jobs: int = 1, report: bool = False, progress=print, cfg: dict | None = None, hold_out: bool = False,
              **diag_kw) -> dict:
    """Generate and diagnose ``n`` effect cases and ``n_clean`` clean cases; score them.

    With ``hold_out``, each effect case is diagnosed with its hidden types taken out of
    the library, and the score is whether "structure left unexplained" is reported
    (``summary["structure_when_held_out"]``); the clean cases are diagnosed as usual.

    Returns a dict with the per-case scores (``cases``) and the summary figures; the
    recordings go to ``out_dir/cases``, the keys to ``out_dir/keys``.
    """
    out_dir = Path(out_dir)
    cfg = cfg or load_config()
    specs = plan(n, n_clean, seed, tuple(robots), cfg)
    args = [(s, out_dir / "cases", out_dir / "keys", diag_kw, report, cfg, hold_out) for s in specs]
    rows = []
    if jobs > 1:
        import multiprocessing as mp

        with mp.get_context("spawn").Pool(jobs) as pool:
            for r in pool.imap(_run_one, args):
                rows.append(r)
                progress(_line(r))
    else:
        for a in args:
            r = _run_one(a)
            rows.append(r)
            progress(_line(r))
    summary = summarize(rows)
    (out_dir / "benchmark.json").write_text(json.dumps({"cases": rows, "summary": summary}, indent=2,
                                                       default=float))
    return {"cases": rows, "summary": summary}


def _line(r):
    if "generation_failed" in r:
        return f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} NOT GENERATED: {r['generation_failed']}"
    if "diagnosis_failed" in r:
        return f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']) or 'clean':<28} DIAGNOSIS FAILED: " \
               f"{r['diagnosis_failed']}"
    if not r["hidden"]:
        return f"{r['case']:>9} {r['robot']:>7}  clean -> {','.join(r['named']) or 'none':<28} " \
               f"{'ok' if r['clean_ok'] else 'FALSE ALARM'}  ({r['t_diagnose']:.1f} s)"
    if r.get("held_out"):
        return (f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} held out -> "
                f"{','.join(r['named'][:3]) or 'none':<34} "
                f"{'structure: ' + ','.join(r['structure']) if r['structure'] else 'NO STRUCTURE'}"
                f"{' (its same-physics stand-in, at the right size)' if r.get('stand_in') else ''}  "
                f"({r['t_diagnose']:.1f} s)")
    errs = " ".join(f"{k}:{v * 100:.1f}%" for k, v in r["param_error"].items())
    return (f"{r['case']:>9} {r['robot']:>7}  {'+'.join(r['hidden']):<28} -> {','.join(r['named'][:3]) or 'none':<34}"
            f" {'ok' if r['first_ok'] else ('tie' if r['first_ok_or_tie'] else 'WRONG')}  err {errs}  "
            f"gain {r['gain']:.1f} (windows {r['gain_windows']:.1f})  ({r['t_diagnose']:.1f} s)")


def summarize(rows) -> dict:
    failed = [r for r in rows if "generation_failed" in r]
    rows = [r for r in rows if "generation_failed" not in r]
    # A diagnosis that raised counts as a wrong answer (nothing named, no gain).
    rows = [r if "diagnosis_failed" not in r else
            dict(r, named=[], first="failed", first_ok=False, first_ok_or_tie=False, all_found=False,
                 first_confident=False, first_confident_before=False,
                 clean_ok=False, param_error={h: float("inf") for h in r["hidden"]}, gain=float("nan"),
                 gain_windows=float("nan"), gain_ok=False, gain_windows_ok=False, gain_measurable=False,
                 t_diagnose=float("nan"), t_generate=float("nan")) for r in rows]
    eff = [r for r in rows if r["hidden"]]
    clean = [r for r in rows if not r["hidden"]]
    types = sorted({r["hidden"][0] for r in eff})
    confusion = {}
    for r in eff:
        # row: the hidden effect the first name matches (else the first hidden one)
        row = r["first"] if r["first"] in r["hidden"] else r["hidden"][0]
        confusion.setdefault(row, {}).setdefault(r["first"], 0)
        confusion[row][r["first"]] += 1
    per_type = {}
    for t in types:
        rs = [r for r in eff if r["hidden"][0] == t]
        errs = [r["param_error"][t] for r in rs]
        gains = [r["gain_windows"] for r in rs if np.isfinite(r["gain_windows"])]
        per_type[t] = {"cases": len(rs), "first_ok": sum(r["first_ok"] for r in rs),
                       "param_ok": sum(r["param_error"][t] <= 0.15 for r in rs),
                       "median_param_error": float(np.median(errs)),
                       "median_gain": float(np.median(gains)) if gains else float("nan")}
    held = [r for r in eff if r.get("held_out")]
    for t in types:
        rs = [r for r in held if r["hidden"][0] == t]
        if rs:
            per_type[t]["structure_when_held_out"] = sum(bool(r["structure"]) for r in rs)
            per_type[t]["stand_in"] = sum(bool(r.get("stand_in")) for r in rs)
    f = lambda k: (sum(bool(r[k]) for r in eff) / len(eff)) if eff else float("nan")  # noqa: E731
    meas = [r for r in eff if r.get("gain_measurable", True)]
    g = lambda k: (sum(bool(r[k]) for r in meas) / len(meas)) if meas else float("nan")  # noqa: E731
    return {
        "effect_cases": len(eff), "clean_cases": len(clean), "effect_types": len(types),
        "first_named_right": f("first_ok"), "first_named_right_or_tie": f("first_ok_or_tie"),
        "first_named_right_confident": f("first_confident"),
        "first_named_right_confident_before": f("first_confident_before"),
        "all_hidden_found": f("all_found"),
        "param_within_15pct": (sum(r["param_error"][r["hidden"][0]] <= 0.15 for r in eff) / len(eff)) if eff else
        float("nan"),
        "gain_measurable_cases": len(meas),
        "gain_at_least_5x": g("gain_ok"), "gain_windows_at_least_5x": g("gain_windows_ok"),
        "median_gain": float(np.median([r["gain"] for r in meas])) if meas else float("nan"),
        "median_gain_windows": float(np.median([r["gain_windows"] for r in meas])) if meas else float("nan"),
        "clean_no_missing_physics": (sum(r["clean_ok"] for r in clean) / len(clean)) if clean else float("nan"),
        "median_diagnose_s": float(np.nanmedian([r["t_diagnose"] for r in rows])) if rows else float("nan"),
        "max_diagnose_s": float(np.nanmax([r["t_diagnose"] for r in rows])) if rows else float("nan"),
        "diagnosis_failed": [r["case"] for r in rows if "diagnosis_failed" in r],
        "per_type": per_type, "confusion": confusion, "not_generated": [r["case"] for r in failed],
        "intervals_holding": [sum(sum(r.get("holds", [])) for r in eff), sum(len(r.get("holds", [])) for r in eff)],
        "structure_when_held_out": (sum(bool(r["structure"]) for r in held) / len(held)) if held else None,
        "stand_in_when_held_out": (sum(bool(r.get("stand_in")) for r in held) / len(held)) if held else None,
    }


def _coverage_line(holding) -> str:
    k, n = holding
    if not n:
        return "95 % intervals holding the truth:  none stated for a hidden parameter"
    p = k / n
    return (f"95 % intervals holding the truth:  {k}/{n} hidden parameters ({p * 100:.1f} % +- "
            f"{100 * math.sqrt(p * (1 - p) / n):.1f} %, binomial standard error)")


def format_summary(summary: dict) -> str:
    """The benchmark summary as text: rates, the confusion matrix, per-type figures."""
    s = summary
    if s.get("structure_when_held_out") is not None:
        lines = [f"effect cases: {s['effect_cases']} over {s['effect_types']} primary types, each diagnosed with "
                 f"its hidden types held out of the library; clean cases: {s['clean_cases']}",
                 f"structure left unexplained reported: {s['structure_when_held_out'] * 100:5.1f} %",
                 f"else its same-physics stand-in named at the right size: "
                 f"{s['stand_in_when_held_out'] * 100:.1f} %",
                 f"clean cases, no missing physics:     {s['clean_no_missing_physics'] * 100:5.1f} %"
                 if s["clean_cases"] else "clean cases, no missing physics:     none run",
                 f"diagnosis time:                      median {s['median_diagnose_s']:.2f} s, max "
                 f"{s['max_diagnose_s']:.2f} s", "",
                 "per primary hidden type: cases, structure reported, same-physics stand-in, named first instead"]
        for t, v in s["per_type"].items():
            firsts = sorted(s["confusion"].get(t, {}))  # held out: the row is the hidden type
            lines.append(f"  {t:<17} {v['cases']:>3} {v.get('structure_when_held_out', 0):>4} {v.get('stand_in', 0):>4}   "
                         f"{', '.join(firsts) or '-'}")
        return "\n".join(lines)
    lines = [
        f"effect cases: {s['effect_cases']} over {s['effect_types']} primary types; clean cases: {s['clean_cases']}"
        + (f"; not generated: {', '.join(s['not_generated'])}" if s.get("not_generated") else "")
        + (f"; diagnosis failed: {', '.join(s['diagnosis_failed'])}" if s.get("diagnosis_failed") else ""),
        f"right effect named first:          {s['first_named_right'] * 100:5.1f} %  "
        f"(counting declared ties: {s['first_named_right_or_tie'] * 100:.1f} %)",
        f"right and named with confidence:   {s['first_named_right_confident'] * 100:5.1f} %  (without the "
        f"structure rule: {s['first_named_right_confident_before'] * 100:.1f} %)",
        f"every hidden effect named:         {s['all_hidden_found'] * 100:5.1f} %",
        f"parameter within 15 %:             {s['param_within_15pct'] * 100:5.1f} %",
        f"held-out residual reduced >= 5x:   {s['gain_at_least_5x'] * 100:5.1f} % over all samples (median "
        f"{s['median_gain']:.1f}x), {s['gain_windows_at_least_5x'] * 100:.1f} % in the out-of-band windows (median "
        f"{s['median_gain_windows']:.1f}x); {s['effect_cases'] - s['gain_measurable_cases']} case(s) whose "
        f"effect does not act on the held-out part",
        f"clean cases, no missing physics:   {s['clean_no_missing_physics'] * 100:5.1f} %",
        _coverage_line(s.get("intervals_holding", [0, 0])),
        f"diagnosis time:                    median {s['median_diagnose_s']:.2f} s, max {s['max_diagnose_s']:.2f} s",
        "",
        "per primary hidden type: cases, named first, parameter within 15 %, median parameter error, median gain "
        "(out-of-band windows)",
    ]
    for t, v in s["per_type"].items():
        lines.append(f"  {t:<17} {v['cases']:>3} {v['first_ok']:>4} {v['param_ok']:>4}   "
                     f"{v['median_param_error'] * 100:7.1f} %  {v['median_gain']:7.1f}x")
    cols = sorted({c for row in s["confusion"].values() for c in row})
    lines += ["", "confusion (rows: hidden effect, the one named first if it is hidden; columns: named first)",
              " " * 18 + " ".join(f"{c[:8]:>8}" for c in cols)]
    for t, row in s["confusion"].items():
        lines.append(f"  {t:<16}" + " ".join(f"{row.get(c, 0):>8}" for c in cols))
    return "\n".join(lines)
