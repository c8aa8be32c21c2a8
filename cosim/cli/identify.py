"""``cosim identify RECORDING``: a serial arm's base inertial and drive parameters identified from
a recording (cosim/identification), printed as a table with intervals; ``--out`` writes the
identified model as the JSON parameter file ``cosim diagnose --model`` takes."""
from __future__ import annotations

from .common import command, input_file, output_file


def _configure(p):
    p.add_argument("recording", type=input_file, help="pkm-recording/1 CSV of a serial arm (q, qd, tau)")
    p.add_argument("--robot", default=None, help="the arm's description (default: the recording's robot)")
    p.add_argument("--set", dest="param_set", default=None, help="its named parameter set the fit starts from")
    p.add_argument("--cutoff", type=float, default=10.0, help="low-pass cut-off of q, qd and the efforts [Hz]")
    p.add_argument("--extra", action="append", default=[], metavar="PARAM",
                   help="a further parameter the efforts are linear in, identified too (joint[2].force_k1); "
                        "repeatable")
    p.add_argument("--nearest", action="store_true",
                   help="give the nearest physically consistent model even when the least-squares parameters are "
                        "significantly not a rigid arm's (default: refuse, exit 2)")
    p.add_argument("--out", type=output_file, default=None, metavar="FILE.json",
                   help="write the identified model's parameters there (cosim diagnose --model FILE.json)")
    p.add_argument("--json", action="store_true", help="print the identification as JSON")


@command("identify", "identify a serial arm's base inertial and drive parameters from a recording, with intervals")
def cmd_identify(args):
    from ..identification import identify

    ident = identify(args.recording, args.robot, param_set=args.param_set, cutoff=args.cutoff,
                     extra=tuple(args.extra), strict=not args.nearest)
    if args.json:
        print(ident.to_json())
    else:
        print(f"{len(ident.names)} base parameters from {ident.samples} samples (consistent fit: cost "
              f"{ident.gap:.3g}, 0.1 % bound {ident.gap_bound:.3g})")
        print(f"{'base parameter':70s} {'consistent':>12s} {'least sq.':>12s} {'95 % interval':>27s}")
        for r in ident.table():
            c = r["combination"] if len(r["combination"]) <= 70 else r["combination"][:67] + "..."
            print(f"{c:70s} {r['value']:12.6g} {r['least_squares']:12.6g} [{r['low']:12.6g}, {r['high']:12.6g}]")
        print("residual RMS per joint [N m or N]: " + ", ".join(f"{s:.4g} (of {r:.4g})"
                                                         for s, r in zip(ident.sigma, ident.rms)))
    if args.out:
        ident.write(args.out, args.robot)
        if not args.json:
            print(f"{args.out}: the identified model (cosim diagnose RECORDING --model {args.out})")
    return 0


cmd_identify.configure = _configure
