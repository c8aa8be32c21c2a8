"""One case of a sweep: run the kind's function, catch its failure, flatten its results
into one record (:mod:`cosim.sweep`)."""
from __future__ import annotations

import json
import os
import socket
import time
import traceback
import warnings
from dataclasses import dataclass
from fnmatch import fnmatchcase
from pathlib import Path

import numpy as np

from .shipping import materialise_fmu
from .spec import _canonical

#: lists longer than this are stored as one JSON string, not one column per element
MAX_LIST_COLUMNS = 32


def _scalar(v):
    if isinstance(v, np.generic):
        return v.item()
    if v is None or isinstance(v, (bool, int, float, str)):
        return v
    if isinstance(v, complex):
        return str(v)
    if isinstance(v, Path):
        return str(v)
    return repr(v)


def flatten(d: dict, prefix: str = "") -> dict:
    """Nested results -> one flat dict: ``a.b`` for tables, ``a[i]`` for list elements;
    numpy values become Python scalars; lists longer than ``MAX_LIST_COLUMNS`` stay one
    JSON string."""
    out = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, name + "."))
        elif isinstance(v, (list, tuple, np.ndarray)):
            seq = v.tolist() if isinstance(v, np.ndarray) else list(v)
            if len(seq) > MAX_LIST_COLUMNS:
                out[name] = json.dumps(_canonical(seq))
                continue
            for i, x in enumerate(seq):
                if isinstance(x, dict):
                    out.update(flatten(x, f"{name}[{i}]."))
                elif isinstance(x, (list, tuple, np.ndarray)):
                    out.update(flatten({f"{name}[{i}]": x}))
                else:
                    out[f"{name}[{i}]"] = _scalar(x)
        else:
            out[name] = _scalar(v)
    return out


def _select(results: dict, patterns: dict) -> dict:
    inc, exc = patterns.get("include"), patterns.get("exclude", [])
    return {k: v for k, v in results.items()
            if (not inc or any(fnmatchcase(k, p) for p in inc)) and not any(fnmatchcase(k, p) for p in exc)}



@dataclass
class CaseContext:
    """What the driver gives a case besides its parameters: the local FMU path, if any."""

    fmu: Path | None = None


def run_case(kind: str, base: dict, params: dict, cid: str, fmu: dict | None = None,
             fmu_data: bytes | None = None, patterns: dict | None = None) -> dict:
    """Run one case and return its record; never raises for a failing case.

    Parameters
    ----------
    kind : str
        Kind of case (:data:`cosim.sweep.kinds.KINDS`).
    base : dict
        The prepared base configuration (plain data: loaded files, no paths to read).
    params : dict
        The case's parameters.
    cid : str
        Its case id.
    fmu : dict, optional
        ``{"sha256", "name", "path"}`` of the FMU plant; with ``fmu_data`` (its bytes)
        it is written to this worker's cache (:func:`materialise_fmu`), without them
        ``path`` is used as it is (the serial loop).
    fmu_data : bytes, optional
    patterns : dict, optional
        ``include`` / ``exclude`` globs on the result names.

    Returns
    -------
    dict
        ``case_id``, ``params``, ``status`` ("ok" or "error"), ``results`` (flat),
        ``error_type``, ``error``, ``where`` (innermost frame), ``warnings``,
        ``seconds``, ``worker`` (host:pid); ``arrays`` and ``raw`` when the kind returns
        them (``_arrays``, ``_raw`` keys).
    """
    from .kinds import get_kind

    t0 = time.perf_counter()
    rec = {"case_id": cid, "params": params, "status": "ok", "results": {}}
    caught = []
    try:
        ctx = CaseContext()
        if fmu:
            ctx.fmu = materialise_fmu(fmu["sha256"], fmu["name"], fmu_data) if fmu_data is not None \
                else Path(fmu["path"])
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", UserWarning)
            out = get_kind(kind).run(base, params, ctx)
        if not isinstance(out, dict):
            raise TypeError(f"the {kind} case function returned {type(out).__name__}, not a dict of results")
        out = dict(out)
        arrays, raw = out.pop("_arrays", None), out.pop("_raw", None)
        rec["results"] = _select(flatten(out), patterns or {})
        if arrays is not None:
            rec["arrays"] = {k: np.asarray(v) for k, v in arrays.items()}
        if raw is not None:
            rec["raw"] = _canonical(raw)
    except Exception as e:  # a failing case is a result, not the end of the sweep
        tb = traceback.extract_tb(e.__traceback__)
        rec.update(status="error", error_type=type(e).__name__, error=str(e) or repr(e),
                   where=f"{Path(tb[-1].filename).name}:{tb[-1].lineno} ({tb[-1].name})" if tb else "")
    msgs = []
    for w in caught or []:
        if issubclass(w.category, UserWarning) and str(w.message) not in msgs:
            msgs.append(str(w.message))
    if msgs:
        rec["warnings"] = msgs[:5]
    rec["seconds"] = time.perf_counter() - t0
    rec["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    return rec
