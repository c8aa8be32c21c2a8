"""``cosim quattro ...``: index maps and figures, the map benchmark, the stated maxima of
Virzi 2010, and the Adept Cycle times predicted against the measured tables."""
from __future__ import annotations

import json

import numpy as np

from .common import command, output_dir

# Results stated by Virzi 2010 on the robot axis x = y = 0, as (index, what, z [m]).
STATED = [
    ("mu_T", "max", -1.170, "best translational manipulability (Fig. 3.2)"),
    ("mu_xy", "=1", -0.920, "horizontal isotropy point P_xy, mu_xy = 1 (Fig. 3.3)"),
    ("mu_z_eig", "max", -1.020, "vertical channel centre P_z (Fig. 3.5c)"),
    ("kat", "min", -1.100, "least mass index (Fig. 5.6)"),
    ("alfa_x", "max", -0.850, "best horizontal acceleration (Fig. 5.9)"),
]


def axis_feature(param_set: str | None, index: str, what: str, params: dict | None = None, dz: float = 0.001):
    """z [m] of an index feature on the robot axis (max, min, or where it crosses 1)."""
    from .. import quattro

    m = quattro.model(param_set, params)
    h = m.quattro_constants()["base_height"]
    z = np.arange(-1.06 - h, -0.56 - h + dz / 2, dz)
    mp = quattro.index_map(x=[0.0], y=[0.0], z=z, model=m)
    v = mp[index][0, 0]
    if what == "max":
        return float(z[np.nanargmax(v)])
    if what == "min":
        return float(z[np.nanargmin(v)])
    return float(z[np.nanargmin(np.abs(v - 1.0))])


def _configure(p):
    sub = p.add_subparsers(dest="action", required=True)
    m = sub.add_parser("map", help="every index on the 21 x 21 x 51 grid, one figure per index")
    m.add_argument("--out", type=output_dir, required=True, help="output directory for the figures")
    m.add_argument("--set", dest="param_set", default="appendix_a", help="parameter set (default appendix_a)")
    from ..quattro import index_names

    m.add_argument("--index", action="append", choices=index_names(), metavar="NAME",
                   help=f"only these indices (repeatable): {', '.join(index_names())}")
    m.add_argument("--npz", action="store_true", help="also save the arrays as quattro_maps.npz")
    b = sub.add_parser("bench", help="time of the full map against the 1 s target and a numpy baseline")
    b.add_argument("--set", dest="param_set", default="appendix_a")
    b.add_argument("--json", action="store_true")
    s = sub.add_parser("maxima", help="the index features stated by Virzi 2010, as found with each parameter set")
    s.add_argument("--json", action="store_true")
    c = sub.add_parser("cycle", help="predicted Adept Cycle times vs Tables 6.1-6.5, figure + correlation")
    c.add_argument("--out", type=output_dir, required=True, help="output directory for the figure and the CSV")
    c.add_argument("--set", dest="param_set", default="appendix_a")
    c.add_argument("--n", type=int, default=200, help="grid intervals per segment")
    c.add_argument("--qd-max", type=float, default=None, help="arm speed limit [rad/s] (default none)")
    c.add_argument("--fit", default="6.1,6.5", metavar="TABLES",
                   help="fit the cycle model (torque fraction, settling per stop; terms chosen by AIC) on these "
                        "tables and predict the others (comma-separated, default 6.1,6.5; 'none' to skip)")


@command("quattro", "Adept Quattro (Virzi 2010): index maps, benchmark, stated maxima, cycle times vs measurements")
def cmd_quattro(args):
    if args.action == "map":
        from .. import quattro

        mp = quattro.index_map(param_set=args.param_set)
        files = quattro.plot_maps(mp, args.out, names=args.index)
        ok = int((mp.status == 0).sum())
        print(f"map: {mp.status.size} poses ({ok} reachable), {len(mp.values)} indices in {mp.seconds:.3f} s "
              f"(set '{args.param_set}')")
        if args.npz:
            from pathlib import Path

            f = Path(args.out) / "quattro_maps.npz"
            np.savez_compressed(f, x=mp.x, y=mp.y, z=mp.z, status=mp.status, **mp.values)
            files.append(f)
        for f in files:
            print(f"wrote {f}")
        return 0
    if args.action == "bench":
        from .. import quattro

        r = quattro.benchmark(args.param_set)
        if args.json:
            print(json.dumps(r, indent=2))
            return 0
        print(f"{'what':<44} {'time':>10}  {'target':>8}")
        print(f"{'core, one batched call, all 22 indices':<44} {r['map_s']:>9.3f}s  {'< 1 s':>8}  "
              f"{'PASS' if r['map_s'] < 1.0 else 'FAIL'}")
        print(f"{'numpy loop over per-pose core calls, 3 idx':<44} {r['baseline_s']:>9.3f}s  {'':>8}")
        print(f"{r['points']} poses ({r['reachable']} reachable), {r['per_pose_us']:.1f} us per pose, "
              f"speed-up x{r['speedup']:.0f} over the baseline (which computes 3 of the 22 indices)")
        return 0
    if args.action == "maxima":
        from .. import quattro

        rows = []
        for name, what, zs, desc in STATED:
            r = {"index": name, "feature": what, "stated_mm": zs * 1e3, "what": desc}
            for ps, params in (("appendix_a", None), ("default", quattro.centred_tool(quattro.model("default")))):
                r[ps] = axis_feature(ps, name, what, params) * 1e3
            rows.append(r)
        if args.json:
            print(json.dumps(rows, indent=2))
            return 0
        print("On the robot axis x = y = 0, rz = 0 (default set with the tool point at the platform centre as in the thesis' maps):")
        print(f"{'index':<9} {'feature':<7} {'stated':>8} {'appendix_a':>11} {'default':>9}  what")
        for r in rows:
            print(f"{r['index']:<9} {r['feature']:<7} {r['stated_mm']:>8.0f} {r['appendix_a']:>11.0f} "
                  f"{r['default']:>9.0f}  {r['what']}")
        return 0
    if args.action == "cycle":
        from pathlib import Path

        from ..quattro import cycle_fit as cf
        from ..quattro import cycle_time as ct
        from .common import working

        with working("timing the cycles of Tables 6.1-6.5"):
            cmp = ct.compare(param_set=args.param_set, n=args.n, qd_max=args.qd_max)
        Path(args.out).mkdir(parents=True, exist_ok=True)
        f = Path(args.out) / "quattro_cycle_times.csv"
        with open(f, "w") as fh:
            fh.write("table,cycle,layout,z_mm,measured_10_cycles_s,predicted_10_cycles_s\n")
            for name, tc in sorted(cmp.tables.items()):
                for z, a, b in zip(tc.z, tc.measured_t10, tc.predicted_t10):
                    fh.write(f"{name},{tc.cycle},{tc.layout},{z * 1e3:.0f},{a:.4f},{b:.4f}\n")
        tables = [f]
        for name, tc in sorted(cmp.tables.items()):
            print(tc.summary())
        fit = None
        if args.fit.strip().lower() != "none":
            fit_tables = tuple(t.strip() for t in args.fit.split(",") if t.strip())
            with working(f"fitting the cycle model on table(s) {', '.join(fit_tables)}"):
                fit = cf.select_cycle_model(fit_tables=fit_tables, param_set=args.param_set, n=args.n)
            f = Path(args.out) / "quattro_cycle_model.csv"
            with open(f, "w") as fh:
                fh.write("table,layout,cycle,z_mm,measured_s,torque_limited_s,model_s,used_for_fit\n")
                for name, ms in sorted(fit.measured.items()):
                    for i, z in enumerate(ms.z):
                        fh.write(f"{name},{ms.layout},{ms.cycle},{z * 1e3:.0f},{ms.t10[i] / 10:.5f},"
                                 f"{fit.torque_limited_t10[name][i] / 10:.5f},{fit.model_t10[name][i] / 10:.5f},"
                                 f"{int(name in fit.fit_tables)}\n")
            tables.append(f)
            print(fit.summary())
        for f in ct.plot_comparison(cmp, args.out, fit=fit) + tables:
            print(f"wrote {f}")
        return 0
    raise ValueError(f"unknown action {args.action}")


cmd_quattro.configure = _configure
