"""``cosim run scenarios/<name>.toml``: run a co-simulation scenario, print its metrics."""
from __future__ import annotations

import sys
from pathlib import Path

from ..core.model import robot_facts
from ..core.simulator import METHOD_TITLES
from .common import command, output_dir, output_file, recording_file, toml_file


def _configure(p):
    p.add_argument("scenario", type=toml_file, help="scenario TOML file (see scenarios/ and docs/scenarios.md)")
    p.add_argument("--plant", choices=["core", "fmu"], default=None,
                   help="plant to step: the CS FMU through fmpy or the core directly (default: the file's)")
    p.add_argument("--duration", type=float, default=None, help="override the duration [s]")
    p.add_argument("--out", type=output_dir, default=None, help="output directory (default: the file's [output] dir or results/<name>)")
    p.add_argument("--no-figures", action="store_true", help="do not write the figure")
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p.add_argument("--html", action="store_true",
                   help="also write <name>_report.html: interactive, self-contained (3D robot in motion, errors, efforts)")


#: the integrators of the core plant (cosim.simulate), as the run summary names them: the core's table
INTEGRATORS = METHOD_TITLES


def _small(unit: str):
    """(scale, unit) to print a small quantity of ``unit``: metres in mm, radians in mrad."""
    return {"m": (1e3, "mm"), "rad": (1e3, "mrad")}.get(unit, (1.0, unit))


def print_summary(out, file=None) -> None:
    """A short human-readable summary of a scenario run's metrics."""
    import sys

    f = file or sys.stdout
    m = out.metrics
    res = out.result
    c = m["controller"]
    print(f"scenario {m['scenario']}: robot {m['robot']}, plant {m['plant']['kind']}, controller "
          f"{c['type']} (kp {_g(c['kp'])} {c['kp_unit']}, kd {_g(c['kd'])} {c['kd_unit']})", file=f)
    loop = ("compiled loop in the core" if res.loop == "compiled"
            else f"Python loop: {res.loop_note}" if res.loop_note else "Python loop")
    method = INTEGRATORS.get(m["plant"].get("method"))
    if method:
        loop += f", plant integrated by {method}"
    print(f"  {len(res)} samples at {res.step * 1e3:g} ms, {m['duration']:g} s simulated in {m['wall_time']:.2f} s wall"
          f" ({loop})", file=f)
    facts = robot_facts(m["robot"])
    pose_unit = dict(zip(facts.pose_names, facts.pose_units))
    # lengths in mm / um, angles in mrad / urad: the sizes a step and its errors have
    jscale, jname = _small(facts.joint_unit)
    if "steady_state" in m:
        ss = m["steady_state"]
        for k, v in m["step_info"]["pose"].items():
            if "RiseTime" in v:
                sc, un = _small(pose_unit[k])
                print(f"  step of {k} by {v['Amplitude'] * sc:+.2f} {un}: rise {v['RiseTime'] * 1e3:.1f} ms, "
                      f"settling (2 %) {v['SettlingTime'] * 1e3:.1f} ms, overshoot {v['Overshoot']:.2f} %", file=f)
        pred = m.get("predicted_step_info")
        if pred:
            j = max(range(len(pred)), key=lambda i: pred[i]["mass"])
            p = pred[j]
            inertia = "kg m2" if facts.angular_joints else "kg"
            print(f"  python-control, decoupled joint {j + 1} (m = {p['mass']:.3g} {inertia}, wn = {p['wn']:.1f} rad/s, "
                  f"zeta = {p['damping']:.2f}): rise {p['RiseTime'] * 1e3:.1f} ms, settling {p['SettlingTime'] * 1e3:.1f} ms, "
                  f"overshoot {p['Overshoot']:.2f} %", file=f)
        print(f"  steady-state joint error qref - q [{jname}]: "
              + " ".join(f"{e * jscale:+.4f}" for e in ss["joint_error"]), file=f)
        if "predicted_joint_error_equilibrium" in ss:
            print(f"  predicted Kp^-1 g                 [{jname}]: "
                  + " ".join(f"{e * jscale:+.4f}" for e in ss["predicted_joint_error_equilibrium"])
                  + (f"   (max relative difference {ss['prediction_relative_error']:.2e})"
                     if ss.get("prediction_relative_error") is not None else
                     f"   (gravity loads no joint; max difference {ss['prediction_absolute_error'] * jscale:.3g} "
                     f"{jname})"), file=f)
        else:
            print(f"  max |e_ss| = {ss['joint_error_max']:.3g} {facts.joint_unit} (predicted 0 with gravity "
                  f"compensation)", file=f)
        pe = ss["pose_error"]
        print("  steady-state pose error: " + ", ".join(
            f"{n} {e * 1e3 * _small(u)[0]:+.3f} {'u' + u if u in ('m', 'rad') else u}"
            for n, u, e in zip(facts.pose_names, facts.pose_units, pe)), file=f)
    if "tracking" in m:
        tr = m["tracking"]
        print(f"  pen-point tracking error: RMS {tr['pen_error_rms'] * 1e6:.4g} um, max {tr['pen_error_max'] * 1e6:.4g} um "
              f"at t = {tr['pen_error_max_time']:.3f} s; largest effort {tr['effort_max']:.3g} {res.units['tau_applied']}",
              file=f)
    if "poses" in m:
        errs = [p["position_error"] for p in m["poses"]]
        print(f"  {m['held_poses']} held poses, {sum(p['rows'] for p in m['poses'])} rows while held (column label); "
              f"true position vs commanded at the holds: max {max(errs) * 1e6:.3g} um (the plant's own geometry)"
              if errs else "  no held poses", file=f)
    if "motion" in m:
        mo = m["motion"]
        print(f"  tracking over the run: joint error RMS [{jname}] "
              + " ".join(f"{e * jscale:.4g}" for e in mo["joint_error_rms"])
              + f", max {mo['joint_error_max'] * jscale:.4g} {jname} at t = {mo['joint_error_max_time']:.3f} s; "
              f"largest effort {max(mo['effort_max']):.3g} {res.units['tau_applied']}", file=f)
    if m["saturated_samples"]:
        print(f"  actuator saturation active at {m['saturated_samples']} samples", file=f)
    for k, p in out.files.items():
        print(f"  {k}: {p}", file=f)


def _g(v):
    return f"{v:.4g}" if isinstance(v, float) else str([float(f"{x:.4g}") for x in v])


@command("run", "run a co-simulation scenario (TOML) against the FMU or the core; export recording, metrics, figure")
def cmd_run(args):
    import json

    from ..jsonable import jsonable
    from ..closed_loop import LoopInterrupted
    from ..scenario import export_partial, run_scenario
    from .common import Interrupted, exits_on_interrupt

    before = "interrupted before the first step, nothing written"
    try:
        # a ctrl-C during the set-up (seconds for a long run, much of it inside single calls
        # into the core or numpy) ends the command at once: there is nothing to keep yet
        with exits_on_interrupt(f"cosim run: {before}") as guard:
            try:
                out = run_scenario(args.scenario, plant=args.plant, duration=args.duration, out_dir=args.out,
                                   figures=False if args.no_figures else None, started=guard.disarm)
            except LoopInterrupted:
                raise
            except KeyboardInterrupt:  # the main thread saw it first: the same words
                if guard.armed:
                    guard.disarm()
                    raise Interrupted(before) from None
                raise
    except LoopInterrupted as e:
        part = e.partial
        if len(part) < 2:
            raise Interrupted(before) from None
        # said at once (a long recording takes a while to write), then written
        sc, d = e.scenario, e.out_dir
        print(f"cosim run: interrupted at t = {part.time[-1]:.6g} s, partial results in {d / sc.name}.csv (the "
              f"recording up to then, {len(part)} samples)", file=sys.stderr, flush=True)
        export_partial(sc, e, d)
        return 130
    if args.html:
        from ..report.pages import run_page

        where = Path(out.files["recording"]).parent if "recording" in out.files else Path(args.out or "results")
        out.files["interactive report"] = str(run_page(out, where / f"{out.scenario.name}_report.html"))
    if args.json:
        print(json.dumps(out.metrics, indent=2, default=jsonable))
    else:
        print_summary(out)
    return 0


cmd_run.configure = _configure


@command("export-ssp", "write a step scenario as an SSP archive (plant FMU + controller FMU) for other FMI tools")
def cmd_export_ssp(args):
    from ..ssp import export_scenario_ssp

    path = export_scenario_ssp(args.scenario, args.out)
    print(f"wrote {path}: plant and controller FMUs, their connections and the set-point "
          f"(runs in any SSP 1.0 engine, e.g. OSP libcosim; docs/fmu.md)")
    return 0


def _export_configure(p):
    p.add_argument("scenario", type=toml_file, help="scenario file (TOML) with a step reference")
    p.add_argument("--out", type=output_file, required=True, help="the .ssp archive to write")


cmd_export_ssp.configure = _export_configure


@command("view", "write (and print the path of) a self-contained HTML page with the robot of a recording in 3D")
def cmd_view(args):
    from ..report import view

    path = view(args.recording, out=args.out)
    print(f"wrote {path}: open it in a browser (works offline; the slider moves the robot through the recording)")
    return 0


def _view_configure(p):
    p.add_argument("recording", type=recording_file, help="pkm-recording/1 CSV (its JSON sidecar beside it)")
    p.add_argument("--out", type=output_file, default=None, help="the page to write (default: <recording>_view.html beside it)")


cmd_view.configure = _view_configure


def _axis(value: str):
    """NAME=START:STOP:N (a grid axis) or NAME=VALUE (a fixed coordinate)."""
    import argparse

    name, _, rest = value.partition("=")
    try:
        parts = [float(v) for v in rest.split(":")]
    except ValueError:
        parts = []
    if not name or len(parts) not in (1, 3) or (len(parts) == 3 and (parts[2] < 1 or parts[2] != int(parts[2]))):
        raise argparse.ArgumentTypeError(f"{value!r}: give NAME=START:STOP:N (an axis) or NAME=VALUE (m, rad)")
    return name.strip(), parts


def _indices_configure(p):
    from .common import robot_arg

    p.add_argument("--robot", type=robot_arg, required=True, help="robot (any the core knows, or a description file)")
    p.add_argument("--axis", type=_axis, action="append", default=[], metavar="NAME=START:STOP:N",
                   help="a swept pose coordinate, e.g. x=-0.2:0.2:21 [m, rad] (repeatable)")
    p.add_argument("--at", type=_axis, action="append", default=[], metavar="NAME=VALUE",
                   help="a coordinate held at a value (default: home's)")
    p.add_argument("--out", type=output_dir, metavar="DIR", help="write indices.npz (the grids) and indices.json (the summary) here")


@command("indices", "performance indices any robot has (singularity measures, speed transmission, inertia, "
                    "gravity effort) on a grid of poses, from the core")
def cmd_indices(args):
    import json
    import sys

    import numpy as np

    from ..core.model import Model
    from ..indices import index_map

    if not args.axis:
        print("cosim indices: error: give at least one --axis NAME=START:STOP:N", file=sys.stderr)
        return 2
    axes = {}
    for name, parts in args.axis:
        if len(parts) != 3:
            print(f"cosim indices: error: --axis {name}: give START:STOP:N", file=sys.stderr)
            return 2
        axes[name] = np.linspace(parts[0], parts[1], int(parts[2]))
    fixed = {name: parts[0] for name, parts in args.at}
    model = Model(args.robot)
    need, have = grid_memory(model, [len(v) for v in axes.values()]), available_memory()
    if need > 0.5 * have:
        n = int(np.prod([len(v) for v in axes.values()], dtype=float))
        print(f"cosim indices: error: --axis: a grid of {n:,} poses ({' x '.join(str(len(v)) for v in axes.values())}) "
              f"needs about {_bytes(need)} of memory, this machine has {_bytes(have)} free: use fewer points per "
              f"axis (e.g. 101 each)", file=sys.stderr)
        return 2
    try:
        mp = index_map(model, fixed=fixed, **axes)
    except ValueError as e:
        print(f"cosim indices: error: {e}", file=sys.stderr)
        return 2
    print(mp.summary())
    if args.out:
        d = Path(args.out)
        d.mkdir(parents=True, exist_ok=True)
        np.savez(d / "indices.npz", **{f"axis_{k}": v for k, v in mp.axes.items()}, **mp.values)
        (d / "indices.json").write_text(json.dumps({"robot": mp.robot, "fixed": mp.fixed, "units": mp.units,
                                                    "axes": {k: v.tolist() for k, v in mp.axes.items()},
                                                    "summary": mp.summary()}, indent=2))
        print(f"wrote {d / 'indices.npz'} and {d / 'indices.json'}")
    return 0


cmd_indices.configure = _indices_configure


def grid_memory(model, sizes) -> float:
    """Bytes :func:`cosim.indices.index_map` holds for a grid of ``sizes`` points per axis:
    per pose, the axes' meshes, the pose, its joints and statuses, and every index (8 bytes
    each)."""
    import numpy as np

    from ..indices import index_units

    n = float(np.prod(sizes, dtype=float))
    return 8.0 * n * (len(sizes) + 3 * model.ndof + len(index_units(model)) + 2)


def available_memory() -> float:
    """Bytes of memory available now (Linux ``MemAvailable``; the physical memory elsewhere)."""
    import os

    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def _bytes(b: float) -> str:
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if b >= size:
            return f"{b / size:.3g} {unit}"
    return f"{b / 1e3:.3g} kB"
