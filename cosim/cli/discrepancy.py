"""CLI of the model-discrepancy engine.

* ``cosim diagnose <recording> [--model M] [--out DIR]``: where, why, how much better;
* ``cosim blind-benchmark --cases N --seed S [--clean M] [--robot R]``: blind cases with
  hidden effects, diagnosed and scored against their answer keys;
* ``cosim blind-case --robot R --effect E [--effect E2] --seed S``: one blind case;
* ``cosim discrepancy-demo``: simulate, hide an effect, diagnose it, show the gain.
"""
from __future__ import annotations

import argparse
import math

import json
import sys
import time
from pathlib import Path

from .common import Interrupted, command, input_file, output_dir, recording_file, robot_arg


def _effect_types():
    """The effect types the blind generator can hide (for --help)."""
    from ..discrepancy.blind import TYPES, UNLISTED

    return TYPES + list(UNLISTED)


def model_arg(value: str) -> str:
    """argparse type of ``diagnose --model``: a named parameter set, or a JSON parameter
    file (``cosim params R --json``, or ``{name: value}``) checked here, so that a missing
    file or a value that is not a number is said naming the file and the parameter."""
    import argparse
    import math

    p = Path(value)
    if not (p.exists() or value.endswith(".json") or "/" in value):
        return value  # a set name: the core lists the sets when it has no such one
    if not p.exists():
        raise argparse.ArgumentTypeError(f"{value}: no such parameter file (give a JSON file written by "
                                         f"`cosim params ROBOT --json`, or a parameter set's name)")
    input_file(value)
    try:
        spec = json.loads(p.read_text())
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        where = f" (line {e.lineno}, column {e.colno})" if isinstance(e, json.JSONDecodeError) else ""
        raise argparse.ArgumentTypeError(f"{value}: not a JSON parameter file{where}") from None
    params = spec.get("parameters", spec) if isinstance(spec, dict) else None
    if not isinstance(params, dict):
        raise argparse.ArgumentTypeError(f"{value}: expected a JSON object of parameters {{name: value}}")
    prefix = "parameters." if "parameters" in spec else ""
    for k, v in params.items():
        if k in ("robot", "param_set") and not prefix:
            continue
        x = v.get("value") if isinstance(v, dict) else v
        field = f"{prefix}{k}" + (".value" if isinstance(v, dict) else "")
        if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
            raise argparse.ArgumentTypeError(f"{value}: {field} = {json.dumps(x)} is not a finite number")
    return value


def _positive(kind):
    """argparse type: a finite number > 0 of ``kind`` (int: ``--max-samples``, float:
    ``--block-seconds``)."""
    import argparse

    def parse(value: str):
        try:
            v = kind(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{value!r} is not a {'whole ' if kind is int else ''}number") from None
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(f"{value} must be a positive number")
        return v

    return parse


def _diag_configure(p):
    p.add_argument("recording", type=recording_file, nargs="+",
                   help="pkm-recording/1 CSV (its JSON sidecar beside it); several: the runs of a campaign, diagnosed "
                        "together (also a campaign file runs = [...], or one recording with a run column)")
    p.add_argument("--held-out", default=None, metavar="run|within|K",
                   help="campaign: hold out the last run (default), the end of every run, or run K (from 1)")
    p.add_argument("--leave-one-out", action="store_true",
                   help="campaign: also fit on all runs but one and judge on it, for every run")
    p.add_argument("--per-run", action="append", default=[], metavar="PARAM",
                   help="campaign: a core parameter each run has its own value of (an effort offset rail[1].offset, "
                        "an encoder offset); repeatable")
    p.add_argument("--model", type=model_arg, default=None,
                   help="model to test: a named parameter set or a JSON parameter file (cosim params R --json); "
                        "default: the robot's default set with the sidecar's overrides")
    p.add_argument("--out", type=output_dir, default=None, help="report directory (default: results/diagnosis/<recording name>)")
    p.add_argument("--threshold", type=float, default=10.0, help="BIC decrease an effect must bring (default 10)")
    p.add_argument("--window", type=float, default=0.05, help="smoothing window [s] (default 0.05)")
    p.add_argument("--train-fraction", type=float, default=0.7,
                   help="share of the recording, from its start, the effects are fitted on; the rest is held out for "
                        "the before/after comparison and the replay (default 0.7)")
    p.add_argument("--effects", default=None, help="comma-separated effect keys to test (default: the library)")
    p.add_argument("--no-replay", action="store_true", help="skip the closed-loop replay of the held-out part")
    p.add_argument("--compare", action="append", default=[], metavar="SET",
                   help="also replay the robot's named parameter set SET (e.g. a published model) on the held-out "
                        "part, beside the nominal and the fitted plant (repeatable)")
    p.add_argument("--no-figures", action="store_true", help="write the report without figures")
    p.add_argument("--least-squares", action="store_true",
                   help="fit masses, inertias and viscous friction by least squares on the measured motion instead "
                        "of instrumental variables from the reference (biased low by rate noise; for comparison)")
    p.add_argument("--no-discovery", action="store_true",
                   help="skip the search for forces no library effect names (the discovery step)")
    p.add_argument("--no-families", action="store_true",
                   help="the discovery step searches one joint's position and rate only, not friction growing with "
                        "the load, friction zones, couplings to another joint nor effort x position terms "
                        "(docs/discovery_families.md)")
    p.add_argument("--families", action="store_true", help=argparse.SUPPRESS)  # the default; kept for old scripts
    p.add_argument("--no-platform", action="store_true",
                   help="skip the search for one force on the platform (a wrench, a cable to an anchor, a drag)")
    p.add_argument("--no-flexible", action="store_true",
                   help="skip the flexible model of the structure left (boosted trees: how much of it is explainable "
                        "and on which inputs it depends; docs/flexible.md)")
    p.add_argument("--black-box", action="store_true",
                   help="the replay also runs the fitted plant plus the flexible model's force as a black-box term "
                        "(marked as such in the report)")
    p.add_argument("--no-drift", action="store_true",
                   help="skip the test of the fitted parameters for a drift over the recording (a trend, a step)")
    p.add_argument("--max-samples", type=_positive(int), default=None,
                   help="most rows the diagnosis holds (default 100000, discrepancy.working_set.MAX_SAMPLES); a longer recording is diagnosed on blocks "
                        "spread over all of it, each at the full rate (docs/discrepancy.md, Long recordings)")
    p.add_argument("--block-seconds", type=_positive(float), default=None,
                   help="length of those blocks [s] (default 20)")
    p.add_argument("--json", action="store_true", help="print the diagnosis as JSON")
    p.add_argument("--html", action="store_true",
                   help="also write report.html: interactive, self-contained (3D robot, residual windows, effects)")


@command("diagnose", "model-discrepancy diagnosis of a recording: where, which missing physics, how much better")
def cmd_diagnose(args):
    from ..discrepancy import diagnose
    from ..discrepancy.working_set import BLOCK_SECONDS, MAX_SAMPLES, working_set

    from .common import working

    from .campaign import is_campaign, run_campaign

    out = Path(args.out) if args.out else Path("results") / "diagnosis" / Path(args.recording[0]).stem
    if is_campaign(args):
        return run_campaign(args, out, print_diagnosis)
    args.recording = args.recording[0]
    t0 = time.perf_counter()
    try:
        # read first (a bar of the rows on a terminal), then the diagnosis of what was kept
        ws = working_set(args.recording, max_samples=args.max_samples or MAX_SAMPLES,
                         block_seconds=args.block_seconds or BLOCK_SECONDS, progress=None)
        with working(f"diagnosing {Path(args.recording).name}"):
            d = diagnose(ws, args.model, out=out, window=args.window, threshold=args.threshold,
                         train_fraction=args.train_fraction, compare=args.compare,
                         effects=args.effects.split(",") if args.effects else None, replay=not args.no_replay,
                         figures=not args.no_figures, instruments=not args.least_squares,
                         discovery=not args.no_discovery, platform=not args.no_platform,
                         drift=not args.no_drift, families=not args.no_families, flexible=not args.no_flexible,
                         black_box=args.black_box)
    except KeyboardInterrupt:
        raise Interrupted(f"interrupted after {time.perf_counter() - t0:.1f} s of diagnosis, no report written "
                          f"({out}/report.md and diagnosis.json are written at the end)") from None
    if args.json:
        from ..discrepancy.report import _strip_arrays

        print(_strip_arrays(d))
        return 0
    print_diagnosis(d)
    print(f"\nreport: {d.files.get('report')}")
    if args.html:
        from ..report.pages import diagnosis_page

        print(f"interactive report: {diagnosis_page(d, out / 'report.html')}")
    return 0


cmd_diagnose.configure = _diag_configure


def print_diagnosis(d, file=None):
    # sys.stdout is looked up at call time: a default bound at import would keep a stream
    # that a test harness (or a redirect) has since closed.
    file = file or sys.stdout
    p = lambda *a: print(*a, file=file)  # noqa: E731
    p(f"{d.recording} ({d.robot}): {d.conclusion}")
    if d.details:
        p(f"\ndetails: {d.details}")
    from ..discrepancy.flexible import reported
    from ..discrepancy.working_set import sentence

    if sentence(d.settings.get("working_set")):
        p(f"({sentence(d.settings['working_set'])})")
    if d.localisation.get("summary"):
        p("\nwhere:")
        for s in d.localisation["summary"]:
            p(f"  {s}")
    if d.discovered:
        p("\nmissing physics no library effect names (discovery step; the core's joint force <j>[i].force_*):")
        for t in d.discovered:
            p(f"  {t.equation}")
            p(f"    such a term comes from: {t.mechanisms}")
            p(f"    held-out {t.channel}: RMS {t.heldout_before:.3g} -> {t.heldout_after:.3g}")
            for x in t.instead_of:
                p(f"    library effect it replaces: {x}")
            if t.partial:
                p(f"    not named as the physics: {t.partial}")
    shown = reported(getattr(d, "flexible", None) or [])
    if shown:
        p("\nwhere no equation was found (a flexible model of what is left, judged out of fold, over blocks in time):")
        for f in shown:
            p(f"  {f.statement}")
    pf = getattr(d, "platform_force", None)
    if pf is not None:
        p("\na force on the platform (one for the whole robot; the core's wrench.*, cable.*, platform_drag.*):")
        p(f"  {pf.equation}")
        p(f"    such a force comes from: {pf.mechanisms}")
        for x in pf.instead_of:
            p(f"    library effect it replaces: {x}")
    for dr in getattr(d, "drifts", None) or []:
        p(f"\ndrift: {dr.equation}")
        p("  refitted per window: " + ", ".join(f"{v:.4g} +- {c:.2g} at {t:.3g} s" for t, v, c in
                                               zip(dr.windows["t"], dr.windows["value"], dr.windows["ci95"])))
    if d.effects:
        p("\nwhy (most important first; importance = chi-square increase when the term is removed):")
        seen_bic = set()
        for e in d.effects:
            vals = ", ".join(f"{k} = {v['value']:.4g} +- {v['ci95']:.2g} {v['unit']}" for k, v in e["params"].items())
            # terms that entered in one selection step share its delta BIC: say it once
            step = (f"delta BIC {e['delta_bic']:.0f}" if e["delta_bic"] not in seen_bic
                    else "entered in the same step")
            seen_bic.add(e["delta_bic"])
            p(f"  {e['title']}: {vals}  (importance {e.get('importance', float('nan')):.0f}, {step})")
            for a in e["lookalikes"]:
                if a["delta_bic"] < 10:
                    p(f"    vs {a['statement']}")
    for title, items in (("not excited by this recording", d.not_excited), ("not tested", d.unavailable)):
        if items:
            p(f"\n{title}:")
            for x in items:
                p(f"  {x}")
    h = d.heldout
    if not h:  # not diagnosed (the conclusion says why): no fit to compare
        p(f"\n(stopped after {d.timings.get('total', 0):.2f} s)")
        return
    if not d.theta:
        p(f"\nheld-out {h['start']:.2f}-{h['end']:.2f} s: nothing fitted, the nominal model stands")
    elif h["affected"] and math.isfinite(h["gain"]):
        windows = (f" ({h['gain_windows']:.1f}x in the windows out of band)" if math.isfinite(h["gain_windows"])
                   else "")
        p(f"\nhow much better (held-out {h['start']:.2f}-{h['end']:.2f} s): residual RMS {h['gain']:.1f}x lower"
          f"{windows} on {', '.join(h['affected'])}")
    else:
        p(f"\nheld-out {h['start']:.2f}-{h['end']:.2f} s: the fitted model changes no channel beyond its noise there")
    for name in h["affected"]:
        c = h["channels"][name]
        nrmse = (f"NRMSE {c['nrmse_na']}" if c.get("nrmse_na") else
                 f"NRMSE {c['nrmse_before'] * 100:.2f} % -> {c['nrmse_after'] * 100:.2f} %")
        p(f"  {name}: RMS {c['rms_before']:.3g} -> {c['rms_after']:.3g} {c['unit']} ({nrmse}, noise {c['noise']:.2g})")
    if d.replay:  # which replay ran (closed loop, open loop with its method), or why none did
        from ..discrepancy.open_loop import sentence as replay_sentence

        p(f"  {replay_sentence(d.replay)}")
    if d.replay and d.replay.get("runs"):
        for name, run in d.replay["runs"].items():
            if "rms_tau" in run:
                p(f"  replay, {name} plant: RMS difference, efforts " + " ".join(f"{v:.3g}" for v in run["rms_tau"])
                  + " (relative " + " ".join(f"{100 * v:.2f} %" for v in run.get("rel_tau", [])) + ")"
                  + "; readings " + " ".join(f"{v:.3g}" for v in run["rms_q"]))
        tb = d.replay.get("two_body") or {}
        if tb.get("params"):
            p("  two bodies fitted on " + f"{tb['window'][0]:.2f}-{tb['window'][1]:.2f} s: "
              + ", ".join(f"{k} = {v:.4g}" for k, v in tb["params"].items() if k != "drive.two_body")
              + f" (differences to the recording there: {tb['score']:.2f}x the reading model's)")
        elif tb.get("skipped"):
            p(f"  no two-body replay: {tb['skipped']}")
    p(f"\n(diagnosed in {d.timings.get('total', 0):.2f} s)")


def _bench_configure(p):
    p.add_argument("--cases", type=int, default=40, help="effect cases (default 40)")
    p.add_argument("--clean", type=int, default=10, help="clean cases (default 10)")
    p.add_argument("--seed", type=int, default=1, help="seed of the case plan (default 1)")
    p.add_argument("--robot", type=_robot_or_both, default="6pus",
                   help="robot (any the core knows), or 'both': every robot scenarios/blind/config.toml lists")
    p.add_argument("--out", type=output_dir, default="results/blind", help="output directory (default results/blind)")
    p.add_argument("--jobs", type=int, default=1, help="parallel processes (default 1)")
    p.add_argument("--report", action="store_true", help="write a diagnosis report per case")
    p.add_argument("--threshold", type=float, default=10.0)
    p.add_argument("--hold-out", action="store_true",
                   help="diagnose each effect case with its hidden types taken out of the library and score whether "
                        "'structure left unexplained' is reported")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no line per case, only the summary")
    p.add_argument("--verbose", action="store_true", help="a line per case (the default on a terminal is a bar)")


def _case_progress(total, quiet, verbose):
    """A tqdm bar with the time left on a terminal (the last case's result beside it), a
    line per case when not on a terminal or with --verbose, nothing with --quiet."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit="case", disable=True if quiet or verbose else None, leave=False,
               desc="blind benchmark")

    def progress(line):
        if quiet:
            return
        if bar.disable:
            print(line, flush=True)
            return
        bar.update(1)
        bar.set_postfix_str(" ".join(line.split()[:3])[:40])

    return progress, bar


@command("blind-benchmark", "blind benchmark: recordings with hidden effects, diagnosed and scored against keys")
def cmd_blind_benchmark(args):
    from ..discrepancy import blind

    robots = tuple(blind.load_config()["effects"]) if args.robot == "both" else (args.robot,)
    t0 = time.perf_counter()
    total = len(blind.plan(args.cases, args.clean, args.seed, robots, blind.load_config()))
    progress, bar = _case_progress(total, args.quiet, args.verbose)
    try:
        res = blind.benchmark(args.cases, args.seed, args.clean, robots, args.out, jobs=args.jobs,
                              report=args.report, threshold=args.threshold, replay=False, progress=progress,
                              hold_out=args.hold_out)
    finally:
        bar.close()
    text = blind.format_summary(res["summary"])
    print()
    print(text)
    print(f"\n{len(res['cases'])} cases in {time.perf_counter() - t0:.0f} s; recordings in {args.out}/cases, "
          f"answer keys in {args.out}/keys, scores in {args.out}/benchmark.json")
    (Path(args.out) / "summary.txt").write_text(text + "\n")
    return 0


cmd_blind_benchmark.configure = _bench_configure


def _robot_or_both(value):
    return value if value == "both" else robot_arg(value)


def _case_configure(p):
    p.add_argument("--robot", type=robot_arg, default="6pus",
                   help="robot (any the core knows; effect sizes from scenarios/blind/config.toml or derived)")
    p.add_argument("--effect", action="append", default=[], help=f"effect type to hide (repeatable; none: clean): {', '.join(_effect_types())}")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--name", default=None, help="case name (default: from the effects and seed)")
    p.add_argument("--out", type=output_dir, default="results/blind/cases", help="recording directory")
    p.add_argument("--keys", type=output_dir, default="results/blind/keys", help="answer-key directory (kept apart)")


@command("blind-case", "write one blind case: a recording with hidden effects and its answer key apart")
def cmd_blind_case(args):
    from ..discrepancy import blind

    robot = Path(args.robot).name.removesuffix(".toml")  # a description file names its cases by its stem
    name = args.name or f"{robot}_{'+'.join(args.effect) or 'clean'}_{args.seed}"
    csv, key = blind.make_case(blind.CaseSpec(name, args.robot, list(args.effect), args.seed), args.out, args.keys)
    print(f"recording: {csv}\nanswer key: {key}")
    return 0


cmd_blind_case.configure = _case_configure


def _demo_configure(p):
    p.add_argument("--out", type=output_dir, default="results/discrepancy_demo", help="output directory")
    p.add_argument("--robot", type=robot_arg, default="6pus", help="robot (any the core knows)")
    p.add_argument("--effect", default="coulomb", help=f"effect to hide (default coulomb): {', '.join(_effect_types())}")
    p.add_argument("--seed", type=int, default=3)


@command("discrepancy-demo", "end-to-end demo: simulate a plant with a hidden effect, diagnose it, show the gain")
def cmd_discrepancy_demo(args):
    from ..discrepancy import blind, diagnose

    out = Path(args.out)
    print(f"1. simulating a closed-loop {args.robot} run whose plant hides: {args.effect} ...")
    csv, key = blind.make_case(blind.CaseSpec(f"demo_{args.effect}", args.robot, [args.effect], args.seed),
                               out / "recording", out / "answer_key")
    print(f"   recording {csv} (the answer key is kept apart in {key})")
    print("2. diagnosing it against the nominal model ...")
    d = diagnose(csv, out=out / "report")
    print_diagnosis(d)
    truth = json.loads(Path(key).read_text())["effects"]
    print("\n3. the answer key:", "; ".join(f"{h['type']}: " + ", ".join(f"{k} = {v:.4g}" for k, v in h["params"].items())
                                           for h in truth))
    print(f"report: {d.files.get('report')}")
    return 0


cmd_discrepancy_demo.configure = _demo_configure
