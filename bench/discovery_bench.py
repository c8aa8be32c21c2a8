"""The discovery step on forces no library names, clean recordings and library types held out.

Blind cases of the engine's generator (``cosim.discrepancy.blind``): each hides one force of
``blind.UNLISTED`` (a combination of the core's generic joint force, drawn relative to the
joint's effort, travel and speed along the case's reference), or nothing (clean), or, with
``--hold-out``, one library type diagnosed without that type in the library.  Each recording is
diagnosed knowing only its path; the answer key is read afterwards.

Printed: per case the outcome, then per kind: the force found on the right joints with the
right structure, the largest coefficient error, the held-out RMS ratio of the joint's channel,
library effects named with confidence (no tie among their look-alikes), diagnosis time; and the
right terms flagged a partial fit.  With ``--hold-out``, per type: discovered as the held-out
equation (:func:`_equivalent`), structure reported, the same physics named (checked from the
recording and the key, :func:`_same_physics`), library effects only, and the confident wrong
names over every case (library effects of another type named with confidence, discovered
terms that are not the held-out equation and not said to be partial), with and without the
rule that a fit leaving structure names nothing with confidence.

    .venv/bin/python bench/discovery_bench.py --robots 6pus,delta_clavel --seeds 2 --clean 10 --jobs 2
    .venv/bin/python bench/discovery_bench.py --hold-out --robots 6pus --seeds 2 --jobs 2

``--kinds`` names the hidden forces, or with ``--hold-out`` the library types held out
(``--hold-out --kinds viscous``: that type alone).
"""
from __future__ import annotations

import argparse
import json
import time
from multiprocessing import Pool
from pathlib import Path

import numpy as np


#: a held-out library parameter (its name's last part) -> the discovered coefficients that are
#: the same equation on its joint, each equal to the library parameter's change (Coulomb
#: friction: the direction-split pair at one level, through the same velocity scale when it
#: fades; viscous friction: the rate pair; the drive's offset: the constant)
EQUIVALENT = {"coulomb": ("force_cpos", "force_cneg"), "viscous": ("force_vpos", "force_vneg"), "offset": ("offset",)}
#: relative tolerance of that equality (the benchmark's coefficient tolerance)
EQUAL = 0.15


def _equivalent_coefficients() -> dict:
    """:data:`EQUIVALENT`, plus each coefficient the discovery step declares the same column
    as a library parameter (``discovery.SAME_COLUMN``, where it has one: an added inertia for
    the rotor inertia)."""
    from cosim.discrepancy import discovery

    out = dict(EQUIVALENT)
    for coef, lib in getattr(discovery, "SAME_COLUMN", {}).items():
        out.setdefault(lib, (coef,))
    return out


def _equivalent(term, changes: dict) -> bool:
    """Is the discovered ``term`` the held-out physics on its joint: only the coefficients
    equivalent to a hidden parameter of that joint, each within :data:`EQUAL` of its change?"""
    eq = _equivalent_coefficients()
    mine = {p: v for p, v in changes.items() if p.startswith(f"{next(iter(term.coefficients)).split(']')[0]}]")}
    # a coefficient zero within its interval puts no force into the plant, and a library
    # parameter refitted with the term (the drive's offset the library named) that the term
    # leaves where it was, within its interval, is the library's: neither is part of the term's force
    own = {p: c for p, c in term.coefficients.items()
           if not (abs(c.value) <= c.ci95 or (c.base != 0 and abs(c.value - c.base) <= c.ci95))}
    for p, dv in mine.items():
        want = eq.get(p.rsplit(".", 1)[1])
        if want is None or set(c.rsplit(".", 1)[1] for c in own) != set(want):
            continue
        # a friction with a velocity scale (coulomb_v: one that fades below it) is the fading
        # pair at that scale, within the same tolerance; a sharp one is the sharp pair
        v = mine.get(p + "_v")
        cv = next((val for k, val in term.shape.items() if k.endswith(".force_cv")), None)
        if (v is None) != (cv is None) or (v is not None and abs(cv - v) > EQUAL * abs(v)):
            continue
        if all(abs((c.value - c.base) - dv) <= EQUAL * abs(dv) for c in own.values()):
            return True
    return False


def _same_physics(kind: str, effect, changes: dict, d, csv) -> bool:
    """Is the library ``effect`` the held-out physics on this recording, checked from the
    recording and the answer key?  A heavier platform as a payload at its centre and a gap on a
    one-signed joint as an encoder offset (:func:`cosim.discrepancy.blind.same_physics_stand_in`);
    a dead zone as the drive's offset on a joint whose command stays beyond the dead band with
    one sign (all but the engine's ``GAP_MINORITY`` of the samples): a constant u0 sgn(u) there,
    the offset within :data:`EQUAL` of it."""
    from cosim.discrepancy import blind
    from cosim.discrepancy.diagnosis import GAP_MINORITY
    from cosim.recording import read_recording

    named = d.named()
    if named and effect["key"] == named[0] and blind.same_physics_stand_in(kind, changes, d):
        return True
    if kind == "smooth_coulomb" and effect["key"] == "coulomb" and effect["joint"] is not None:
        return _step_friction(changes, d, csv, effect)
    if effect["key"] != "offset" or effect["joint"] is None:
        return False
    value = next(iter(effect["params"].values()))["value"] - next(iter(effect["params"].values()))["nominal"]
    if kind == "gravity_tilt":
        return _constant_load(changes, d.robot, csv, effect["joint"] - 1, value,
                              d.noise["sigma"][f"tau{effect['joint']}"])
    if kind != "dead_zone":
        return False
    name = next((p for p in changes if p.endswith(f"[{effect['joint']}].dead_zone")), None)
    if name is None:
        return False
    u0 = changes[name]
    u = np.asarray(read_recording(csv).tau, float)[:, effect["joint"] - 1]
    sign = 1.0 if np.mean(u > 0) >= 0.5 else -1.0
    if np.mean(sign * u <= u0) >= GAP_MINORITY:
        return False
    return bool(abs(value - sign * u0) <= EQUAL * u0)


def _step_friction(changes: dict, d, csv, effect) -> bool:
    """Is a friction fading below its velocity scale, c tanh(qd / v), the library's Coulomb
    friction on this recording: the fitted one differs from it by an RMS below the effort
    channel's noise over the recording's rates (where the joint rarely moves slower than v)?"""
    from cosim.core import Model
    from cosim.recording import read_recording

    j = effect["joint"]
    name = next((p for p in changes if p.endswith(f"[{j}].coulomb")), None)
    if name is None:
        return False
    m = Model(d.robot)
    qd = np.asarray(read_recording(csv).qd, float)[:, j - 1]
    v = changes.get(name + "_v", 0.0) + m.param(name + "_v")
    eps = m.param("drive.v_eps")
    truth = (changes[name] + m.param(name)) * np.tanh(qd / (v if v > 0 else eps))
    fitted = next(iter(effect["params"].values()))["value"] * np.tanh(qd / eps)
    return bool(np.sqrt(np.mean((truth - fitted) ** 2)) < d.noise["sigma"][f"tau{j}"])


def _constant_load(changes: dict, robot: str, csv, j: int, offset: float, sigma: float) -> bool:
    """Is the static load the hidden parameters add on joint ``j`` (the core's gravity load
    with them minus without, along the recording's poses) a constant force there: its RMS
    about its mean below the effort channel's noise ``sigma`` (what varies, the recording cannot
    show), and the fitted ``offset`` within :data:`EQUAL` of that mean?  Then the drive's offset
    is the same physics on this recording."""
    from cosim.core import Model
    from cosim.recording import read_recording

    nominal, truth = Model(robot), Model(robot)
    truth.set_params({p: nominal.param(p) + dv for p, dv in changes.items()})
    rec = read_recording(csv)
    x = rec.pose_full if rec.pose_full is not None else rec.pose
    if x is None:  # no poses to check the load along: not shown to be the same physics
        return False
    x = np.asarray(x, float)[::20]
    load = (truth.gravity_load(x) - nominal.gravity_load(x))[:, j]
    mean = float(np.mean(load))
    return bool(np.sqrt(np.mean((load - mean) ** 2)) < sigma and abs(offset - mean) <= EQUAL * abs(mean))


def _run(job):
    from cosim.discrepancy import blind, diagnose
    from cosim.discrepancy.diagnosis import tied
    from cosim.discrepancy.effects import groups_for
    from cosim.core import Model
    try:
        from cosim.discrepancy.diagnosis import UNEXPLAINED
    except ImportError:  # a checkout without the rule: no such look-alike
        UNEXPLAINED = "unexplained"

    robot, kind, seed, out, hold_out = job
    hidden = [] if kind == "clean" else [kind]
    spec = blind.CaseSpec(f"{robot}_{kind}_{seed}", robot, hidden, seed)
    try:
        csv, kp = blind.make_case(spec, Path(out) / "cases", Path(out) / "keys")
    except Exception as e:  # noqa: BLE001 - a case the generator cannot make is reported
        return {"robot": robot, "kind": kind, "seed": seed, "failed": f"generator: {e}"}
    effects = None
    if hold_out:
        lib = sorted({g.effect.key for g in groups_for(Model(robot), True)[0]})
        drop = {kind} | set(blind.HOLD_OUT_WITH.get(kind, ()))
        effects = [e for e in lib if e not in drop]
    t0 = time.perf_counter()
    d = diagnose(csv, figures=False, replay=False, effects=effects)
    dt = time.perf_counter() - t0
    key = json.loads(Path(kp).read_text())
    row = {"robot": robot, "kind": kind, "seed": seed, "time": dt, "conclusion": d.conclusion,
           "discovered": [t.equation for t in d.discovered], "named": d.named(),
           "confident": [e["key"] for e in d.effects if not any(tied(a) for a in e["lookalikes"])],
           # without the look-alike that marks a fit leaving structure unexplained
           "confident_before": [e["key"] for e in d.effects
                                if not any(tied(a) for a in e["lookalikes"] if a["group"] != UNEXPLAINED)],
           "unexplained": [u["channel"] for u in d.unexplained]}
    if kind == "clean":
        row["clean"] = not d.effects and not d.discovered and not d.unexplained
        return row
    truth = dict(key["effects"][0], spread=key["spread"])
    joints = truth["joints"]
    found = {t.joint: t for t in d.discovered}
    if hold_out:
        changes = {p: v - truth["nominal"][p] for p, v in truth["params"].items()}
        equivalent = [t for t in d.discovered if _equivalent(t, changes)]
        stand_ins = [t for t in d.discovered if t not in equivalent]
        same = [e for e in d.effects if _same_physics(kind, e, changes, d, csv)]
        wrong = [e for e in d.effects if e not in same]
        # confident: no tie among its look-alikes; "before" ignores the look-alike that marks a
        # fit leaving its own joints structured (what the report named with confidence without it)
        row.update(
            confident_wrong=[e["title"] for e in wrong if not any(tied(a) for a in e["lookalikes"])]
            + [t.equation for t in stand_ins if not t.partial],
            confident_wrong_before=[e["title"] for e in wrong if not any(
                tied(a) for a in e["lookalikes"] if a["group"] != UNEXPLAINED)] + [t.equation for t in stand_ins],
            same_physics=[e["title"] for e in same], stand_ins=[t.equation for t in stand_ins],
            partial=[t.equation for t in d.discovered if t.partial])
        row["outcome"] = ("discovered" if equivalent and not stand_ins and not any(t.partial for t in equivalent)
                          else "structure" if d.unexplained else
                          "same physics" if same and not wrong else
                          "nothing" if not d.effects and not d.discovered else "library only")
        row["terms"] = [t.equation for t in equivalent]
        return row
    if kind == "constant_force":
        # the drive's offset: the library's offset effect names it, or the discovery step finds
        # it as a constant; either way the one parameter <j>[i].offset on the right joint
        name = next(iter(truth["params"]))
        want, got = truth["params"][name], d.theta.get(name)
        others = [k for k, v in d.theta.items() if k.endswith(".offset") and k != name and v != 0]
        ch = d.heldout["channels"].get(f"tau{joints[0]}", {}) if isinstance(d.heldout, dict) else {}
        err = abs(got / want - 1) if got is not None else float("inf")
        row.update(right=bool(got is not None and err < 0.15 and not others), error=err,
                   gain=ch.get("rms_before", 0.0) / max(ch.get("rms_after", 1e-300), 1e-300),
                   confident=[k for k in row["confident"] if k != "offset"],
                   confident_before=[k for k in row["confident_before"] if k != "offset"],
                   partial=[j for j in joints if j in found and found[j].partial],
                   tied=[e["key"] for e in d.effects if d.ties(e["key"])], covered=[])
        return row
    need = joints if kind != "ripple" else [j for j in joints if j in found]
    ok = (kind != "ripple" or len(need) >= len(joints) - 1) and all(j in found for j in need)
    ok = ok and all(blind.unlisted_structure_ok(kind, found[j], truth) for j in need) and set(found) <= set(joints)
    errs = [e for j in need if j in found for e in blind.unlisted_errors(kind, found[j], truth)]
    gains = [found[j].heldout_before / max(found[j].heldout_after, 1e-300) for j in need if j in found]
    # interval coverage: each hidden coefficient the discovered terms carry, inside its 95 % interval?
    cover = []
    for t in d.discovered:
        for name, c in t.coefficients.items():
            if name in truth["params"] and not name.endswith((".force_sin", ".force_cos")):
                cover.append(bool(abs(c.value - truth["params"][name]) <= c.ci95))
        # a ripple by its amplitude, as its equation states it: the split into sin and cos is the
        # phase at q = 0, which a period known to 0.1 % moves by a radian when q = 0 lies 25
        # periods from the stroke
        pre = next(iter(t.coefficients)).rsplit(".", 1)[0]
        s, co = t.coefficients.get(f"{pre}.force_sin"), t.coefficients.get(f"{pre}.force_cos")
        if s is not None and co is not None:
            want = np.hypot(truth["params"].get(f"{pre}.force_sin", 0.0), truth["params"].get(f"{pre}.force_cos", 0.0))
            if want > 0:
                cover.append(bool(abs(np.hypot(s.value, co.value) - want) <= np.hypot(s.ci95, co.ci95)))
    row.update(right=bool(ok), error=max(errs) if errs else float("inf"), gain=min(gains) if gains else 0.0,
               tied=[e["key"] for e in d.effects if d.ties(e["key"])], covered=cover,
               partial=[j for j in need if j in found and found[j].partial])
    return row


def main(argv=None):
    from cosim.discrepancy import blind

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--robots", default="6pus,delta_clavel")
    ap.add_argument("--kinds", help="the hidden forces (default: every one of blind.UNLISTED); with --hold-out, "
                                    "the library types held out (default: every type of each robot)")
    ap.add_argument("--seeds", type=int, default=2, help="cases per kind and robot")
    ap.add_argument("--seed0", type=int, default=100)
    ap.add_argument("--clean", type=int, default=10, help="clean cases per robot")
    ap.add_argument("--hold-out", action="store_true", help="library types, each held out of the library")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--out", default="results/discovery_bench")
    a = ap.parse_args(argv)
    robots = a.robots.split(",")
    jobs = []
    for r in robots:
        if a.hold_out:
            types = blind.types_for(r, blind.with_robot(blind.load_config(), __import__("cosim.core").core.Model(r)))
            kinds = types if a.kinds is None else a.kinds.split(",")
            if set(kinds) - set(types):
                ap.error(f"--kinds: {r} has no library type {sorted(set(kinds) - set(types))} (its types: {types})")
        else:
            kinds = (a.kinds or ",".join(blind.UNLISTED)).split(",")
        for k in kinds:
            for s in range(a.seeds):
                jobs.append((r, k, a.seed0 + 17 * s + 3, a.out, a.hold_out))
        if not a.hold_out:
            jobs += [(r, "clean", a.seed0 + 1000 + s, a.out, False) for s in range(a.clean)]
    with Pool(a.jobs) as pool:
        rows = []
        for row in pool.imap_unordered(_run, jobs):
            rows.append(row)
            print(json.dumps({k: v for k, v in row.items() if k != "conclusion"}), flush=True)
    Path(a.out).mkdir(parents=True, exist_ok=True)
    (Path(a.out) / ("holdout.json" if a.hold_out else "rows.json")).write_text(json.dumps(rows, indent=1))
    print()
    ok_rows = [r for r in rows if "failed" not in r]
    failed = [r for r in rows if "failed" in r]
    if a.hold_out:
        print("| robot | held-out type | cases | discovered as its equation | structure | same physics | "
              "library only | confident wrong names (without the structure rule) |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        n = {"": 0, "_before": 0}
        for r in robots:
            for k in sorted({x["kind"] for x in ok_rows if x["robot"] == r}):
                g = [x for x in ok_rows if x["robot"] == r and x["kind"] == k]
                c = lambda o: sum(x["outcome"] == o for x in g)  # noqa: E731
                w = {s: sum(len(x[f"confident_wrong{s}"]) for x in g) for s in n}
                n = {s: n[s] + w[s] for s in n}
                print(f"| {r} | {k} | {len(g)} | {c('discovered')} | {c('structure')} | {c('same physics')} | "
                      f"{c('library only')} | {w['']} ({w['_before']}) |")
        print(f"\nconfident wrong names over all {len(ok_rows)} cases: {n['']} (without the rule "
              f"{n['_before']}); cases with one: "
              f"{sum(bool(x['confident_wrong']) for x in ok_rows)}")
    else:
        print("| robot | force | cases | right joints and structure | largest coefficient error (median) | "
              "held-out RMS ratio (min) | library named with confidence | median time [s] |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        for r in robots:
            for k in a.kinds.split(","):
                g = [x for x in ok_rows if x["robot"] == r and x["kind"] == k]
                if not g:
                    continue
                errs = [x["error"] for x in g]
                print(f"| {r} | {k} | {len(g)} | {sum(x['right'] for x in g)} | "
                      f"{max(errs) * 100:.1f} % ({np.median(errs) * 100:.1f} %) | "
                      f"{min(x['gain'] for x in g):.1f} | {sum(bool(x['confident']) for x in g)} | "
                      f"{np.median([x['time'] for x in g]):.1f} |")
            cl = [x for x in ok_rows if x["robot"] == r and x["kind"] == "clean"]
            if cl:
                print(f"| {r} | clean | {len(cl)} | called clean: {sum(x['clean'] for x in cl)}, with a discovered "
                      f"term: {sum(bool(x['discovered']) for x in cl)} | | | | "
                      f"{np.median([x['time'] for x in cl]):.1f} |")
        eff = [x for x in ok_rows if x["kind"] != "clean"]
        cov = [c for x in eff for c in x.get("covered", [])]
        if cov:
            print(f"\n95 % intervals of the discovered coefficients containing the truth: {sum(cov)}/{len(cov)}")
        if eff:
            print(f"\nall: right {sum(x['right'] for x in eff)}/{len(eff)}, coefficients within 15 % "
                  f"{sum(x['error'] < 0.15 for x in eff)}/{len(eff)}, held-out >= 3x "
                  f"{sum(x['gain'] >= 3 for x in eff)}/{len(eff)}, library named with confidence "
                  f"{sum(bool(x['confident']) for x in eff)} (without the structure rule "
                  f"{sum(bool(x.get('confident_before', x['confident'])) for x in eff)}), right terms flagged "
                  f"a partial fit {sum(x['right'] and bool(x.get('partial')) for x in eff)}")
    for r in failed:
        print(f"not generated: {r['robot']} {r['kind']} seed {r['seed']}: {r['failed']}")


if __name__ == "__main__":
    main()
