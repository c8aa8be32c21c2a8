"""``cosim calibrate``: kinematic calibration from a recording, the benchmark, the seed examples."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

from .common import command, output_dir, recording_file


def _configure(p):
    p.add_argument("recording", nargs="?", type=recording_file, help="pkm-recording/1 calibration campaign (CSV with its JSON sidecar)")
    p.add_argument("--solver", default="gauss-newton",
                   choices=["pinv", "pinv-iter", "gauss-newton", "lm", "golden"],
                   help="estimation method (default gauss-newton)")
    p.add_argument("--model", default="structural", choices=["structural", "prediction", "full"],
                   help="which parameters to estimate: structural (the cond < limit subset, Tiberi 2020 3.1.1), "
                        "prediction (all, truncated SVD, 3.1.2), full (all; refuses a rank-deficient set)")
    p.add_argument("--basis", default="svd", choices=["svd", "parameters"],
                   help="golden search directions: principal axes of the scaled Jacobian (default) or the parameters "
                        "one at a time as in Vitali 2020 (slow on ill-conditioned problems)")
    p.add_argument("--holdout", type=float, default=0.25, metavar="FRACTION",
                   help="fraction of the poses kept out to verify the calibration (default 0.25)")
    p.add_argument("--params", metavar="NAMES",
                   help="robots calibrated generically (not the 6-PUS or the four-bar): the parameters to fit, "
                        "comma-separated names or shell patterns, e.g. 'leg[*].L' (default: every length "
                        "parameter that moves a joint)")
    p.add_argument("--cond-max", type=float, default=100.0, help="condition-number limit (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the held-out split")
    p.add_argument("--out", metavar="DIR", type=output_dir, help="write figures, the report and the calibrated parameters here")
    p.add_argument("--html", action="store_true", help="with --out: also an interactive, self-contained HTML report")
    p.add_argument("--bench", action="store_true",
                   help="benchmark: 60-parameter 6-PUS calibration on --poses poses against a finite-difference "
                        "baseline (docs/performance.md)")
    p.add_argument("--poses", type=int, default=1000, help="poses of the benchmark (default 1000)")
    p.add_argument("--design", action="store_true",
                   help="pose selection study: D-optimal poses vs Tiberi 2020's ten and random ones")
    p.add_argument("--seed-examples", action="store_true",
                   help="Vitali 2020's four-bar (rounding and cond(A)) and Tiberi 2020's leg-1 table, reproduced")


@command("calibrate", "kinematic calibration from a recording: identifiability, estimates +- SE, accuracy gain")
def cmd_calibrate(args):
    if args.bench:
        from ..calibration.bench import benchmark

        print(benchmark(args.poses))
        return 0
    if args.design:
        from ..calibration.bench import design_study

        print(design_study())
        return 0
    if args.seed_examples:
        from ..calibration.seed import fourbar_seed_study, sixpus_seed_leg1

        print(fourbar_seed_study()["text"])
        print()
        print("Tiberi 2020, Table 4.22 (leg 1, world frame, ten poses):")
        print(sixpus_seed_leg1().text())
        return 0
    if not args.recording:
        print("cosim calibrate: error: give a recording (or --bench, --design, --seed-examples)", file=sys.stderr)
        return 2
    from ..calibration.fit import CalibrationWarning, calibrate
    from .common import working

    with warnings.catch_warnings(), working(f"calibrating from {Path(args.recording).name}"):
        warnings.simplefilter("ignore", CalibrationWarning)  # they are part of the report
        opts = {"basis": args.basis} if args.solver == "golden" else {}
        params = [n.strip() for n in args.params.split(",") if n.strip()] if args.params else None
        res = calibrate(args.recording, solver=args.solver, model=args.model, holdout=args.holdout,
                        cond_max=args.cond_max, seed=args.seed, params=params, **opts)
    print(res.text())
    if args.out:
        for p in res.save(args.out):
            print(f"wrote {p}")
        if args.html:
            from ..report.pages import calibration_page

            print(f"wrote {calibration_page(res, Path(args.out) / 'calibration_report.html')} (interactive)")
    elif args.html:
        print("cosim calibrate: error: --html needs --out DIR (where to write the page)", file=sys.stderr)
        return 2
    return 0


cmd_calibrate.configure = _configure
