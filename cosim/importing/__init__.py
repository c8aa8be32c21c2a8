"""Recordings imported as they come: MATLAB (v5, v7.3), HDF5, CSV or TSV files with any
variable names, made into pkm-recordings through a map file (docs/importing.md).

* :mod:`.sources`: open a file, list its variables, load the ones needed;
* :mod:`.mapfile`: the map (TOML): per recording column the variable, scale, offset, unit,
  optional or derived; robot, controller, sensors, parameters;
* :mod:`.units`: units and their factors to SI;
* :mod:`.convert`: source + map -> :class:`~cosim.recording.Recording`, written.

Example (a rig's MATLAB file and its map; ``data/`` has a real one, docs/importing.md; runnable
examples in each function's docstring)::

    from cosim.importing import import_recording
    res = import_recording("rig.mat", "rig_map.toml", "out/rig")
    res.table, res.sidecar      # out/rig/rig.csv and out/rig/rig.json
"""
from .convert import Imported, derive, import_recording, to_recording
from .errors import ImportFailure
from .mapfile import DERIVATIONS, ImportMap, read_map
from .sources import Source, open_source

__all__ = ["DERIVATIONS", "ImportFailure", "ImportMap", "Imported", "Source", "derive", "import_recording",
           "open_source", "read_map", "to_recording"]
