"""The one JSON encoder of the package: numpy arrays and scalars, paths and complex numbers
(``json.dumps(obj, default=jsonable)``), used by recordings' sidecars, scenario metrics and
diagnoses alike."""
from __future__ import annotations

import math
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


def finite(o):
    """``o`` with every non-finite number (NaN, +-inf), in containers and arrays too, replaced by None:
    what JSON can carry (it has no NaN), for ``json.dumps(finite(o), allow_nan=False, default=jsonable)``.
    Whoever writes a None in place of a number says why beside it."""
    if isinstance(o, float):
        return o if math.isfinite(o) else None
    if isinstance(o, dict):
        return {k: finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [finite(v) for v in o]
    if o is None or isinstance(o, (str, int)):
        return o
    return finite(jsonable(o))
