"""The one JSON encoder of the package: numpy arrays and scalars, paths and complex numbers
(``json.dumps(obj, default=jsonable)``), used by recordings' sidecars, scenario metrics and
diagnoses alike."""
from __future__ import annotations

from dataclasses import asdict, is_dataclass
from pathlib import Path

import numpy as np


def jsonable(o):
    """``default=`` hook of :func:`json.dumps`: dataclasses become dicts, arrays lists, numpy scalars Python numbers,
    paths strings, complex numbers their text (a pole 0.5+1j is written "(0.5+1j)")."""
    if is_dataclass(o) and not isinstance(o, type):
        return asdict(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    if isinstance(o, complex):
        return str(o)
    raise TypeError(f"cannot write {type(o).__name__} to JSON")
