"""``cosim parasitic ROBOT``: the parasitic motion of a lower-mobility robot (the pose components
it does not declare, forced by its legs' passive joints) at poses, its sensitivity to
geometric parameters, and a map over two coordinates (cosim/parasitic.py)."""
from __future__ import annotations

import numpy as np

from .common import command, output_file, robot_arg
from ..errors import InputError


def _configure(p):
    p.add_argument("robot", type=robot_arg, help="robot name or description file (e.g. tripod_3prs)")
    p.add_argument("--pose", nargs="+", type=float, action="append", default=None, metavar="V",
                   help="a pose in the robot's coordinates [m, rad] (repeat for more; default: home)")
    p.add_argument("--param", action="append", default=[], metavar="NAME",
                   help="also print d(parasitic)/d(NAME), a parameter of `cosim params ROBOT` (repeatable)")
    p.add_argument("--map", metavar="FILE.png", default=None, type=output_file,
                   help="draw each parasitic component over a grid of two coordinates (the others at home)")
    _map_options(p)


def _map_options(p):
    """The map's options, shared by `cosim parasitic --map` and `cosim map`."""
    p.add_argument("--axes", nargs=2, default=None, metavar=("A", "B"),
                   help="the map's two coordinates (default: the last two declared)")
    p.add_argument("--span", type=float, default=None, help="the map's half-width about home [m or rad]")
    p.add_argument("--grid", type=int, default=21, help="map points per axis (2-201)")
    p.add_argument("--slices", type=int, default=3,
                   help="map rows: values of the remaining coordinate (e.g. z) across its span (default 3)")


def _check_map_options(args):
    if not 2 <= args.grid <= 201:
        raise InputError(f"--grid {args.grid}: give 2 to 201 points per axis")
    if not 1 <= args.slices <= 9:
        raise InputError(f"--slices {args.slices}: give 1 to 9 rows")


def _map_configure(p):
    p.add_argument("robot", type=robot_arg, help="robot name or description file (e.g. tripod_3prs)")
    p.add_argument("--out", metavar="FILE.png", default=None, type=output_file,
                   help="the figure (default parasitic_map_ROBOT.png)")
    _map_options(p)


@command("parasitic", "parasitic motion of a lower-mobility robot (3-PRS, 3-RPS): the undeclared pose components "
                      "at poses, their sensitivity to parameters (--param), a map (--map)")
def cmd_parasitic(args):
    from ..core import Model
    from ..parasitic import (POSE_NAMES, POSE_UNITS, parasitic_components, parasitic_map, parasitic_motion,
                             parasitic_sensitivity)

    m = Model(args.robot)
    names = list(m.facts.pose_names)
    poses = np.array(args.pose if args.pose else [m.home()], float)
    if poses.ndim != 2 or poses.shape[1] != m.ndof:
        raise InputError(f"--pose takes {m.ndof} values ({' '.join(names)}) for {m.robot}")
    _check_map_options(args)
    for p in args.param:
        m.param(p)  # an unknown name says so before any work
    m.ik(poses)  # every pose inside the joints' limits (the message names the leg and the pose)
    comps = parasitic_components(m)
    if not comps:
        print(f"{m.robot} declares all six pose components: no parasitic motion")
        return 0
    par = parasitic_motion(m, poses)
    sens = {p: parasitic_sensitivity(m, poses, p) for p in args.param}
    head = [f"{n} [{u}]" for n, u in zip(names, m.facts.pose_units)]
    head += [f"{POSE_NAMES[k]} [{POSE_UNITS[k]}]" for k in comps]
    for p in args.param:
        unit = next(i.unit for i in m.param_info() if i.name == p)
        head += [f"d{POSE_NAMES[k]}/d{p} [{POSE_UNITS[k]}/{unit}]" for k in comps]
    print("  ".join(f"{h:>16}" for h in head))
    for k in range(len(poses)):
        row = list(poses[k]) + list(par[k]) + [v for p in args.param for v in sens[p][k]]
        print("  ".join(f"{v:>16.6g}" for v in row))
    if args.map:
        _draw(m, args.map, args)
    return 0


def _draw(m, path, args):
    from ..parasitic import parasitic_components, plot_parasitic_map

    if not parasitic_components(m):
        raise InputError(f"{m.robot} declares all six pose components: no parasitic motion to map")
    maps = plot_parasitic_map(m, path, axes=args.axes, span=args.span, grid=args.grid, slices=args.slices)
    for c, (name, unit) in enumerate(zip(maps[0]["names"], maps[0]["units"])):
        vals = np.concatenate([mp["values"][:, :, c].ravel() for mp in maps])
        print(f"  {name}: {np.nanmin(vals):+.6g} ... {np.nanmax(vals):+.6g} {unit} over the map")
    print(f"map: {path}")
    return 0


cmd_parasitic.configure = _configure


@command("map", "parasitic-motion map: x, y, rz of a 3-PRS or 3-RPS over its z, rx, ry workspace (the drawing of "
                "`cosim parasitic ROBOT --map`)")
def cmd_map(args):
    from ..core import Model

    _check_map_options(args)
    m = Model(args.robot)
    _draw(m, args.out or f"parasitic_map_{m.robot}.png", args)
    return 0


cmd_map.configure = _map_configure
