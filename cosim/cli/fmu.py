"""``cosim fmu ROBOT|PATH.toml``: a robot's FMUs for the platforms a user asks for (docs/fmu.md,
"Platforms, source-code FMUs and which file to give to which tool")."""
from __future__ import annotations

from .common import command, output_dir, robot_arg


def _configure(p):
    from ..fmu import PLATFORMS

    p.add_argument("robot", type=robot_arg, help="a listed robot (cosim robots) or a description file")
    p.add_argument("--platforms", default="linux64",
                   help=f"comma-separated binaries to include: {', '.join(PLATFORMS)} (default linux64)")
    p.add_argument("--fmi", type=int, choices=[2, 3], default=2, help="FMI version: 2 (default) or 3 (FMI 3.0 FMUs, no source-code FMU)")
    p.add_argument("--source", action="store_true", help="also the source-code FMUs (<ID>_sources.fmu)")
    p.add_argument("--out", type=output_dir, required=True, help="folder to write the .fmu files to")


@command("fmu", "write a robot's plant and controller FMUs with the platforms' binaries asked for (and source FMUs)")
def cmd_fmu(args):
    from ..fmu import package

    platforms = [p.strip() for p in args.platforms.split(",") if p.strip()]
    files = package(args.robot, out=args.out, platforms=platforms, source=args.source, fmi=args.fmi)
    for f in files:
        print(f"{f}  ({f.stat().st_size / 1024:.0f} kB)")
    return 0


cmd_fmu.configure = _configure
