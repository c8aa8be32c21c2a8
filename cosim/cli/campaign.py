"""The campaign branch of ``cosim diagnose`` (:mod:`cosim.discrepancy.campaign`): several
runs of one rig (``cosim diagnose RUN1 RUN2 ...``, a campaign file, or one recording with a
``run`` column) diagnosed together, each run's own fit beside the joint one."""
from __future__ import annotations

import sys
from pathlib import Path


def _has_run_column(path: str) -> bool:
    """A CSV recording whose header holds a ``run`` column (other formats: read to know)."""
    p = Path(path)
    if p.suffix.lower() != ".csv":
        return False
    try:
        with open(p, encoding="utf-8") as f:
            return "run" in [c.strip() for c in f.readline().split(",")]
    except (OSError, UnicodeDecodeError):
        return False


def is_campaign(args) -> bool:
    """Whether ``cosim diagnose`` was given a campaign: several recordings, a campaign file,
    a recording with a ``run`` column, or a campaign option."""
    recs = args.recording
    if len(recs) > 1 or args.per_run or args.held_out or args.leave_one_out:
        return True
    p = Path(recs[0])
    if p.suffix.lower() in (".toml", ".json") and not p.with_suffix(".csv").exists():
        return True
    return _has_run_column(recs[0])


def _held_out(value):
    if value in (None, "run", "within"):
        return value or "run"
    return int(value) - 1  # the CLI counts runs from 1


def run_campaign(args, out: Path, print_diagnosis):
    """Diagnose the campaign ``args.recording`` names and print it, each fit with
    ``print_diagnosis(d, file=...)`` (the one of ``cosim diagnose``); returns the exit code."""
    from ..discrepancy.campaign import diagnose_campaign, read_campaign
    from .common import working

    c = read_campaign(args.recording, per_run=[p for s in args.per_run for p in s.split(",") if p])
    with working(f"diagnosing a campaign of {len(c.runs)} runs"):
        res = diagnose_campaign(c, args.model, held_out=_held_out(args.held_out), leave_one_out=args.leave_one_out,
                                out=out, window=args.window, threshold=args.threshold,
                                train_fraction=args.train_fraction,
                                effects=args.effects.split(",") if args.effects else None,
                                discovery=not args.no_discovery, instruments=not args.least_squares,
                                replay=not args.no_replay, figures=not args.no_figures,
                                max_samples=args.max_samples)
    if args.json:
        print(res.to_json())
        return 0
    print_campaign(res, print_diagnosis)
    print(f"\nreport of the joint fit: {res.joint.files.get('report')}; campaign: {out / 'campaign.json'}")
    if args.html:  # the page draws one recording's motion; a campaign has several
        print("(no report.html for a campaign: the page draws one recording; diagnose a run alone for it)")
    return 0


def print_campaign(res, print_diagnosis, file=None):
    """The campaign: its conclusion, the joint fit (by ``print_diagnosis``), each run's own fit,
    the replays."""
    from ..discrepancy.campaign_replay import sentence

    file = file or sys.stdout
    p = lambda *a: print(*a, file=file)  # noqa: E731
    p(f"campaign of {len(res.names)} runs ({', '.join(res.names)}): {res.conclusion}")
    p("\njoint fit:")
    print_diagnosis(res.joint, file=file)
    p("\neach run fitted alone with the joint fit's effects:")
    for r in res.per_run:
        vals = ", ".join(f"{k} = {v['value']:.4g} +- {v['ci95']:.2g} {v['unit']}" for k, v in r["params"].items())
        own = ", ".join(f"{k} = {v:.4g}" for k, v in r["declared"].items())
        p(f"  {r['name']}: {vals or 'nothing fitted'}" + (f" (its own, taken out of its data: {own})" if own else ""))
    if res.disagree:
        p("\nruns that disagree beyond their intervals:")
        for x in res.disagree:
            p(f"  {x['run']}: {x['param']} = {x['value']:.4g} +- {x['ci95']:.2g} {x['unit']}, the other runs "
              f"{x['others']:.4g} +- {x['others_ci95']:.2g} ({x['sigmas']:.1f} times the bar: the two 95 % "
              f"intervals combined, widened for the comparisons made)")
    if res.leave_one_out:
        p("\nleave one run out (fitted on the others, judged on it):")
        for x in res.leave_one_out:
            named = ", ".join(x["named"]) or "nothing"
            p(f"  {x['name']}: held-out residual RMS {x['gain']:.3g}x lower; named: {named}")
    if res.replays:
        p("\nreplay of the held-out runs:")
        for r in res.replays:
            p(f"  {sentence(r)}")
