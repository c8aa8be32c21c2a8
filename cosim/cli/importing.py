"""``cosim import``: a recording as the rig wrote it (MATLAB, HDF5, CSV, TSV, Parquet, a ROS 2
bag, MCAP) made into a pkm-recording through a map file (docs/importing.md)."""
from __future__ import annotations

from pathlib import Path

from .common import command, input_file, output_dir, robot_arg, toml_file


def source_path(value: str) -> str:
    """argparse type of the source: a file (:func:`input_file`) or a ROS 2 bag's folder (the
    one holding ``metadata.yaml``)."""
    if Path(value).is_dir() and (Path(value) / "metadata.yaml").is_file():
        return value
    return input_file(value)


def _configure(p):
    p.add_argument("source", type=source_path,
                   help="the rig's file: MATLAB .mat (v5 or v7.3), HDF5 .h5, CSV, TSV, Parquet, MCAP, or a ROS 2 bag's "
                        "folder")
    p.add_argument("--map", type=toml_file, required=True, metavar="MAP.toml",
                   help="which variable feeds which recording column, with units (docs/importing.md)")
    p.add_argument("--out", type=output_dir, required=True, metavar="DIR", help="folder of the pkm-recording (made if missing)")
    p.add_argument("--name", help="file name of the recording without extension (default: the source's)")
    p.add_argument("--robot", type=robot_arg, help="robot name or description file, instead of the map's robot")
    p.add_argument("--format", dest="file_format", default="csv", choices=["csv", "parquet", "hdf5"],
                   help="the recording's table (default csv; parquet and hdf5 are read in blocks, for long recordings)")


@command("import", "make a pkm-recording from a rig's file (MATLAB, HDF5, CSV, TSV, Parquet, ROS 2 bag, MCAP) through "
                   "a map of its variables")
def cmd_import(args):
    from ..importing import import_recording

    res = import_recording(args.source, args.map, args.out, name=args.name, robot=args.robot,
                           file_format=args.file_format)
    rec = res.recording
    n, span = len(rec), float(rec.time[-1] - rec.time[0])
    derived = ", ".join(rec.sidecar.get("derived", {})) or "none"
    print(f"wrote {res.table} ({n} rows, {span:.6g} s, robot {rec.robot}, from {res.source.format}; "
          f"derived: {derived}) and {res.sidecar.name} in {res.seconds:.2f} s")
    absent = rec.sidecar["source"].get("absent_optional")
    if absent:
        print(f"optional columns not in the file: {', '.join(absent)}")
    return 0


cmd_import.configure = _configure
