"""``cosim sweep <spec>``: run a sweep of scenario runs, calibration trials, blind cases
or Quattro map tiles on Dask (a LocalCluster by default), with a results table."""
from __future__ import annotations

import sys

from .common import Interrupted, command, output_dir, toml_file
from ..errors import InputError


def _configure(p):
    p.add_argument("spec", nargs="?", type=toml_file, help="sweep spec TOML (see scenarios/sweeps/ and docs/sweep.md)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="address of an existing Dask scheduler (tcp://host:8786); default: a LocalCluster")
    p.add_argument("--workers", type=int, default=None,
                   help="LocalCluster worker processes (default: one per core); 0: a plain loop in this process")
    p.add_argument("--out", type=output_dir, default=None, help="sweep directory (default results/sweeps/<name>)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--resume", action="store_true", help="skip the cases already in <out>/results.jsonl")
    g.add_argument("--overwrite", action="store_true", help="discard the results already in <out>")
    p.add_argument("--retry-failed", action="store_true", help="with --resume: run the failed cases again")
    p.add_argument("--max-cases", type=int, default=None, metavar="N",
                   help="stop after N cases (the others stay pending: --resume later)")
    p.add_argument("--list", action="store_true", help="print the cases (index, id, parameters) and exit")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--strict", action="store_true", help="exit with status 3 if a case failed")
    p.add_argument("--bench", action="store_true",
                   help="benchmark: speed-up of 2 local workers over the serial loop on 100 cases")
    p.add_argument("--cases", type=int, default=100, help="--bench: number of cases (default 100)")
    p.add_argument("--kind", choices=["calibration", "scenario", "both"], default="both",
                   help="--bench: kind of case (default both)")


@command("sweep", "run a sweep (scenario / calibration / blind / quattro_tile cases) on Dask; results table "
                  "(exit status 0: all done; 3: a case failed, with --strict; 4: cases left pending; 130: "
                  "interrupted by ctrl-C, what finished is kept)")
def cmd_sweep(args):
    import json

    from ..sweep.runner import SweepError, load_spec, run_sweep

    if args.bench:
        from ..sweep.bench import main as bench_main

        return bench_main(["--cases", str(args.cases), "--kind", args.kind])
    if not args.spec:
        raise InputError("give a sweep spec (scenarios/sweeps/*.toml) or --bench")
    spec = load_spec(args.spec)
    if args.list:
        cases = spec.case_list()
        print(f"sweep {spec.name} ({spec.kind}): {len(cases)} cases")
        for c in cases:
            print(f"{c.index:>5} {c.id}  {json.dumps(c.params)}")
        return 0
    try:
        res = run_sweep(spec, out=args.out, scheduler=args.scheduler, workers=args.workers, resume=args.resume,
                        overwrite=args.overwrite, retry_failed=args.retry_failed, max_cases=args.max_cases,
                        progress=False if args.no_progress else None)
    except SweepError as e:
        print(f"cosim sweep: error: {e}", file=sys.stderr)
        return 2
    print(res.text())
    sys.stdout.flush()
    if res.interrupted:
        raise Interrupted(f"interrupted after {len(res.rows)} of {len(res.rows) + res.pending} cases, partial results "
                          f"in {res.files['results']} and {res.files['table']}; {res.pending} pending: run it again "
                          f"with --resume")
    if res.pending and args.max_cases is None:
        print(f"cosim sweep: {res.pending} case(s) pending (cancelled by the cluster): run it again with --resume",
              file=sys.stderr)
        return 4
    return 3 if args.strict and res.failed else 0


cmd_sweep.configure = _configure
