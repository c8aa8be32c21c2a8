"""``cosim urdf ARM.urdf``: a serial arm's URDF read into a robot description (cosim/robots/urdf.py),
printed or written with ``--out``; the description is checked by the core before it is written."""
from __future__ import annotations

from .common import command, input_file, output_file


def _configure(p):
    p.add_argument("urdf", type=input_file, help="the URDF file (revolute, continuous, prismatic and fixed joints)")
    p.add_argument("--out", type=output_file, default=None, metavar="FILE.toml",
                   help="write the description there (default: print it)")
    p.add_argument("--tip", default=None, metavar="LINK",
                   help="the link whose frame is the tool frame (default: the end of the fixed joints below the "
                        "last moving joint)")
    p.add_argument("--name", default=None, help="the robot's name (default: the URDF's <robot name>)")


@command("urdf", "read a serial arm's URDF into a robot description (TOML, docs/robots.md)")
def cmd_urdf(args):
    from ..core.model import Model
    from ..robots.urdf import register_urdf, urdf_description

    text = urdf_description(args.urdf, tip=args.tip, name=args.name)
    m = Model(register_urdf(args.urdf, tip=args.tip, name=args.name))  # the core's checks, before anything is written
    if args.out is None:
        print(text)
        return 0
    with open(args.out, "w") as f:
        f.write(text)
    print(f"{args.out}: {m.robot}, {m.ndof} joints ({', '.join(m.facts.pose_names)}); "
          f"cosim params {args.out} lists its parameters")
    return 0


cmd_urdf.configure = _configure
