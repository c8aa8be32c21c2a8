"""Sweeps: many scenario runs, calibration trials, blind cases or index-map tiles, on Dask.

A sweep spec (TOML, ``scenarios/sweeps/*.toml``, format in docs/sweep.md) names the
*kind* of case, the *base* configuration shared by every case and the parameters to
vary: a ``[grid]`` (every combination), ``[random]`` draws with a seed, explicit
``[[cases]]``.  Each case is a plain dict of parameters; its *case id* is a hash of
that dict (:func:`case_id`), so it does not depend on the order or the number of the
other cases.  A case runs through :func:`run_case`, which calls the kind's function
(:mod:`cosim.sweep.kinds`) and returns one record: the parameters, a flat dict of
results, ``status`` (``"ok"`` or ``"error"``, with the exception's type and message:
a failing case never stops the sweep), the wall time and the worker.

:func:`run_sweep` fans the cases out over a Dask cluster (``dask.distributed``): a
``LocalCluster`` of one single-threaded worker *process* per core by default (the
core and the FMUs are C libraries called through ctypes: processes, not threads, run
them in parallel), or an existing cluster given by its scheduler address.  Records
are appended to ``<out>/results.jsonl`` (flushed and synced) as the cases finish, in
any order, so a killed sweep keeps what it finished; running it again with
``resume=True`` skips every case id already in the file.  At the end the table
``<out>/results.csv`` is written in case order.  ``workers=0`` runs the same cases
in a plain loop in this process (the serial reference).

FMU plants: the driver reads the ``.fmu`` once and scatters its bytes to the
workers; a worker writes them to a local cache keyed by their SHA-256
(:func:`materialise_fmu`) and each case instantiates its own FMU there, in the
worker process, in the thread that runs it: no FMU instance crosses a process or
thread boundary.

Example
-------
>>> from cosim.sweep import load_spec, run_sweep
>>> spec = load_spec("scenarios/sweeps/calibration_noise.toml")
>>> res = run_sweep(spec, out="results/sweeps/calibration_noise", workers=2)
>>> res.column("holdout.position_rms_calibrated")     # [m], one per case, NaN if failed
"""
from __future__ import annotations

import csv
import hashlib
import json
import math
import os
import socket
import sys
import tempfile
import time
import tomllib
import traceback
import warnings
import zlib
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from itertools import islice, product
from pathlib import Path

import numpy as np

__all__ = ["SweepSpec", "SweepSpecError", "SweepError", "Case", "SweepResult", "load_spec", "spec_from_dict",
           "case_id", "run_case", "run_sweep", "read_records", "flatten", "materialise_fmu", "default_workers"]

REPO = Path(__file__).resolve().parents[2]
FORMAT = "pkm-sweep/1"
RESULTS = "results.jsonl"
TABLE = "results.csv"
META = "sweep.json"

_TOP_KEYS = {"name", "description", "kind", "base", "grid", "random", "cases", "plan", "results"}
_DISTRIBUTIONS = ("uniform", "loguniform", "normal", "integers", "choice")
_GRID_FORMS = ("linspace", "logspace", "range")
#: lists longer than this are stored as one JSON string, not one column per element
MAX_LIST_COLUMNS = 32


class SweepSpecError(ValueError):
    """A sweep spec that cannot be run; names the file and the key."""


class SweepError(RuntimeError):
    """A sweep that cannot start or go on (results of another spec in the directory...)."""


# ------------------------------------------------------------------------ spec

@dataclass
class Case:
    """One case: its position in the spec, its id and its parameters."""

    index: int
    id: str
    params: dict


@dataclass
class SweepSpec:
    """A parsed sweep spec (see docs/sweep.md for the TOML layout).

    Attributes
    ----------
    name : str
    kind : str
        ``scenario``, ``calibration``, ``blind``, ``quattro_tile`` or ``function``.
    base : dict
        Configuration every case starts from (flat, dotted keys).
    grid : dict
        Parameter name -> list of values; every combination is a case.
    random : dict or None
        ``{"n": draws, "seed": int, "vary": {name: {distribution: args}}}``; combined
        with every grid point.
    cases : list of dict
        Explicit cases, run in addition.
    plan : dict or None
        Kind-specific case generator (``blind``: the blind benchmark's plan).
    results : dict
        ``include`` / ``exclude``: glob patterns on result names.
    path : Path or None
        The file it came from (relative paths of the base resolve from its folder).
    """

    name: str
    kind: str
    base: dict = field(default_factory=dict)
    grid: dict = field(default_factory=dict)
    random: dict | None = None
    cases: list = field(default_factory=list)
    plan: dict | None = None
    results: dict = field(default_factory=dict)
    description: str = ""
    path: Path | None = None

    @property
    def where(self) -> str:
        return str(self.path) if self.path else f"sweep {self.name}"

    @property
    def base_dir(self) -> Path:
        return self.path.parent if self.path else Path.cwd()

    def param_names(self) -> list:
        """Names of the varied parameters, in spec order (grid, random, explicit, plan)."""
        names = list(self.grid)
        if self.random:
            names += [n for n in self.random["vary"] if n not in names]
        for c in self.case_list():
            names += [n for n in c.params if n not in names]
        return names

    def case_list(self) -> list:
        """Every case of the spec, in order; duplicates (same parameters) kept once."""
        from .kinds import get_kind

        kind = get_kind(self.kind)
        points = [dict(zip(self.grid, combo)) for combo in product(*self.grid.values())] if self.grid else [{}]
        if self.random:
            draws = _draws(self.random)
            points = [{**p, **d} for p in points for d in draws]
        explicit = [dict(c) for c in self.cases]
        if self.plan is not None:
            explicit += kind.plan_cases(self.plan, self)
        if explicit and not (self.grid or self.random):
            points = []
        points += explicit
        auto = kind.auto_cases(self.base, self)
        if auto:
            points = [{**p, **a} for p in points for a in auto]
        out, seen = [], set()
        for p in points:
            cid = case_id(p)
            if cid in seen:
                continue
            seen.add(cid)
            out.append(Case(len(out), cid, p))
        return out

    def fingerprint(self) -> str:
        """Hash of what makes two sweeps' results comparable: the kind and the base."""
        base = {k: (_callable_name(v) if callable(v) else v) for k, v in self.base.items()}
        return _hash({"format": FORMAT, "kind": self.kind, "base": base})[:16]

    def to_dict(self) -> dict:
        d = {"name": self.name, "kind": self.kind, "description": self.description,
             "base": {k: (_callable_name(v) if callable(v) else v) for k, v in self.base.items()},
             "grid": self.grid, "cases": self.cases, "results": self.results}
        if self.random:
            d["random"] = self.random
        if self.plan is not None:
            d["plan"] = self.plan
        return d


def load_spec(path) -> SweepSpec:
    """Read and check a sweep spec (TOML).

    Parameters
    ----------
    path : str or Path
        The ``.toml`` file (format: docs/sweep.md).

    Raises
    ------
    SweepSpecError
        Naming the file and the key (unknown key or kind, a grid value that is not a
        list, an unknown distribution, a parameter both in the grid and drawn...).
    """
    path = Path(path)
    if not path.exists():
        raise SweepSpecError(f"{path}: sweep spec not found")
    try:
        d = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise SweepSpecError(f"{path}: not valid TOML: {e}") from None
    return spec_from_dict(d, name=path.stem, path=path)


def spec_from_dict(d: dict, name: str = "sweep", path=None) -> SweepSpec:
    """A sweep spec from a dict with the layout of the TOML file.

    Parameters
    ----------
    d : dict
        Content with the TOML layout (``kind``, ``[base]``, ``[grid]``...).
    name : str
        Name if ``d`` has none.
    path : str or Path, optional
        Where relative paths of the base are resolved from (default: the working
        directory).
    """
    from .kinds import KINDS, get_kind

    path = Path(path) if path else None
    where = str(path) if path else f"sweep {d.get('name', name)}"

    def fail(key, msg):
        raise SweepSpecError(f"{where}: {key}: {msg}")

    for k in d:
        if k not in _TOP_KEYS:
            fail(k, f"unknown key (known: {', '.join(sorted(_TOP_KEYS))})")
    kind = d.get("kind")
    if kind not in KINDS:
        fail("kind", f"needs one of {', '.join(KINDS)}, got {kind!r}")
    for sec in ("base", "grid", "random", "plan", "results"):
        if sec in d and not isinstance(d[sec], dict):
            fail(sec, "must be a table")
    base = _flatten_keys(d.get("base", {}), stop=lambda v: False)
    grid = {}
    for k, v in _flatten_keys(d.get("grid", {}), stop=_is_grid_form).items():
        grid[k] = _grid_values(v, f"grid.{k}", fail)
    rnd = None
    if "random" in d:
        r = dict(d["random"])
        for k in r:
            if k not in ("n", "seed", "vary"):
                fail(f"random.{k}", "unknown key (known: n, seed, vary)")
        if not isinstance(r.get("n"), int) or r["n"] < 1:
            fail("random.n", f"needs a number of draws >= 1, got {r.get('n')!r}")
        if not isinstance(r.get("seed"), int):
            fail("random.seed", "needs an integer seed (the draws are reproducible)")
        vary = _flatten_keys(r.get("vary", {}), stop=_is_distribution)
        if not vary:
            fail("random.vary", "names no parameter to draw")
        for k, v in vary.items():
            _check_distribution(v, f"random.vary.{k}", fail)
            if k in grid:
                fail(f"random.vary.{k}", "is also in [grid]: vary a parameter one way")
        rnd = {"n": r["n"], "seed": r["seed"], "vary": vary}
    cases = d.get("cases", [])
    if not isinstance(cases, list) or not all(isinstance(c, dict) for c in cases):
        fail("cases", "must be an array of tables ([[cases]])")
    cases = [_flatten_keys(c, stop=lambda v: False) for c in cases]
    res = d.get("results", {})
    for k in res:
        if k not in ("include", "exclude"):
            fail(f"results.{k}", "unknown key (known: include, exclude)")
        if not (isinstance(res[k], list) and all(isinstance(p, str) for p in res[k])):
            fail(f"results.{k}", "must be a list of glob patterns")
    spec = SweepSpec(name=str(d.get("name", name)), kind=kind, base=base, grid=grid, random=rnd, cases=cases,
                     plan=d.get("plan"), results=dict(res), description=str(d.get("description", "")).strip(),
                     path=path)
    get_kind(kind).check(spec, fail)
    if not spec.case_list():
        fail("grid", "the spec makes no case")
    return spec


def _flatten_keys(d, stop, prefix=""):
    """Nested TOML tables -> dotted names (``controller.kp``), except the leaves ``stop`` accepts."""
    out = {}
    for k, v in d.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict) and not stop(v):
            out.update(_flatten_keys(v, stop, name + "."))
        else:
            out[name] = v
    return out


def _is_grid_form(v):
    return isinstance(v, dict) and len(v) == 1 and next(iter(v)) in _GRID_FORMS


def _is_distribution(v):
    return isinstance(v, dict) and len(v) == 1 and next(iter(v)) in _DISTRIBUTIONS


def _grid_values(v, key, fail):
    if _is_grid_form(v):
        form, a = next(iter(v.items()))
        if form == "range":
            if not (isinstance(a, list) and 1 <= len(a) <= 3 and all(isinstance(x, int) for x in a)):
                fail(key, "range needs [stop], [start, stop] or [start, stop, step] integers")
            return list(range(*a))
        if not (isinstance(a, list) and len(a) == 3 and isinstance(a[2], int) and a[2] >= 1):
            fail(key, f"{form} needs [start, stop, number of values]")
        vals = np.linspace(a[0], a[1], a[2]) if form == "linspace" else np.logspace(a[0], a[1], a[2])
        return [float(x) for x in vals]
    if isinstance(v, dict):
        fail(key, f"a table here must be one of {', '.join(_GRID_FORMS)} (or give a list of values)")
    if not isinstance(v, list):
        fail(key, f"needs a list of values (one value: [{v!r}]), got {type(v).__name__}")
    if not v:
        fail(key, "an empty list makes no case")
    return list(v)


def _check_distribution(v, key, fail):
    if not _is_distribution(v):
        fail(key, f"needs one distribution table: {{uniform = [lo, hi]}}, {{loguniform = [lo, hi]}}, "
                  f"{{normal = [mean, std]}}, {{integers = [lo, hi]}} (hi excluded) or {{choice = [...]}}")
    dist, a = next(iter(v.items()))
    if dist == "choice":
        if not (isinstance(a, list) and a):
            fail(key, "choice needs a non-empty list")
        return
    if not (isinstance(a, list) and len(a) == 2 and all(isinstance(x, (int, float)) for x in a)):
        fail(key, f"{dist} needs two numbers")
    if dist in ("uniform", "integers") and not a[0] < a[1]:
        fail(key, f"{dist} needs lo < hi, got {a}")
    if dist == "loguniform" and not 0 < a[0] < a[1]:
        fail(key, f"loguniform needs 0 < lo < hi, got {a}")
    if dist == "normal" and not a[1] >= 0:
        fail(key, f"normal needs a standard deviation >= 0, got {a[1]}")


def _draws(rnd) -> list:
    """The ``n`` random points: each parameter has its own generator seeded by (seed, name),
    so adding or removing a parameter does not change the draws of the others."""
    n, cols = rnd["n"], {}
    for name, v in rnd["vary"].items():
        dist, a = next(iter(v.items()))
        g = np.random.default_rng([rnd["seed"], zlib.crc32(name.encode())])
        if dist == "uniform":
            cols[name] = [float(x) for x in g.uniform(a[0], a[1], n)]
        elif dist == "loguniform":
            cols[name] = [float(x) for x in np.exp(g.uniform(math.log(a[0]), math.log(a[1]), n))]
        elif dist == "normal":
            cols[name] = [float(x) for x in g.normal(a[0], a[1], n)]
        elif dist == "integers":
            cols[name] = [int(x) for x in g.integers(int(a[0]), int(a[1]), n)]
        else:
            cols[name] = [a[int(i)] for i in g.integers(0, len(a), n)]
    return [{k: cols[k][i] for k in cols} for i in range(n)]


def _canonical(o):
    if isinstance(o, dict):
        return {str(k): _canonical(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_canonical(v) for v in o]
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return _canonical(o.tolist())
    if isinstance(o, Path):
        return str(o)
    return o


def _hash(o) -> str:
    s = json.dumps(_canonical(o), sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(s.encode()).hexdigest()


def case_id(params: dict) -> str:
    """Stable id of a case: the first 16 hex digits of the SHA-256 of its parameters as
    canonical JSON (sorted keys; floats by their shortest round-trip repr)."""
    return _hash(params)[:16]


def _callable_name(f) -> str:
    return f"{getattr(f, '__module__', '?')}:{getattr(f, '__qualname__', repr(f))}"


# --------------------------------------------------------------------- results

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


# ----------------------------------------------------------------- FMU shipping

_FMU_CACHE: dict = {}


def fmu_cache_dir() -> Path:
    """Worker-local folder of shipped FMUs: ``$PKM_SWEEP_FMU_CACHE`` or ``<tmp>/pkm-sweep-fmu``."""
    return Path(os.environ.get("PKM_SWEEP_FMU_CACHE", Path(tempfile.gettempdir()) / "pkm-sweep-fmu"))


def materialise_fmu(sha256: str, name: str, data: bytes | None) -> Path:
    """The local path of the FMU with this SHA-256, written from ``data`` if needed.

    The file goes to ``fmu_cache_dir()/<sha256[:16]>/<name>`` through a temporary file
    and an atomic rename, so several worker processes on one host may do it at once.
    A cached file is checked once per process; one whose checksum differs (damaged,
    half written by a killed process) is rewritten.
    """
    if sha256 in _FMU_CACHE and _FMU_CACHE[sha256].exists():
        return _FMU_CACHE[sha256]
    d = fmu_cache_dir() / sha256[:16]
    path = d / name
    if not (path.exists() and _sha256(path.read_bytes()) == sha256):
        if data is None:
            raise SweepError(f"FMU {name} (sha256 {sha256[:16]}) is not on this worker and was not shipped")
        if _sha256(data) != sha256:
            raise SweepError(f"FMU {name}: the shipped bytes do not match their checksum {sha256[:16]}")
        d.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=d, suffix=".part")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    _FMU_CACHE[sha256] = path
    return path


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


# ----------------------------------------------------------------- one case

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


# ------------------------------------------------------------------- storage

def read_records(out) -> list:
    """The records of ``<out>/results.jsonl`` in file order (a case run again: its last
    record wins when the table is made).  A last line cut short by a killed process is
    ignored (and cut off by :func:`_open_results` before appending)."""
    p = Path(out) / RESULTS
    if not p.exists():
        return []
    recs = []
    lines = p.read_bytes().split(b"\n")
    for i, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            recs.append(json.loads(line))
        except json.JSONDecodeError as e:
            if i == len(lines) or (i == len(lines) - 1 and not lines[-1]):
                break  # the last line, written when the process was killed
            raise SweepError(f"{p}, line {i}: not a JSON record ({e}); the results file is damaged") from None
    return recs


def _open_results(out: Path):
    """Open the results file for appending, first cutting off a partial last line."""
    p = out / RESULTS
    if p.exists():
        data = p.read_bytes()
        if data and not data.endswith(b"\n"):
            keep = data.rfind(b"\n") + 1
            with open(p, "r+b") as f:
                f.truncate(keep)
    return open(p, "a", encoding="utf-8")


def _append(f, rec: dict) -> None:
    f.write(json.dumps(_canonical(rec), allow_nan=True, separators=(",", ":")) + "\n")
    f.flush()
    os.fsync(f.fileno())


def _save_arrays(out: Path, rec: dict) -> None:
    arrays = rec.pop("arrays", None)
    if arrays is None:
        return
    d = out / "arrays"
    d.mkdir(exist_ok=True)
    tmp = d / f"{rec['case_id']}.part.npz"
    np.savez_compressed(tmp, **arrays)
    os.replace(tmp, d / f"{rec['case_id']}.npz")
    rec["arrays_file"] = f"arrays/{rec['case_id']}.npz"


# ---------------------------------------------------------------------- table

@dataclass
class SweepResult:
    """What :func:`run_sweep` leaves: one row per case of the spec that has a result.

    Attributes
    ----------
    spec : SweepSpec
    out : Path
        The sweep's directory (``results.jsonl``, ``results.csv``, ``sweep.json``).
    rows : list of dict
        Flat rows in case order: ``case_id``, ``index``, ``status``, the parameters, the
        results, ``error_type``, ``error``, ``seconds``, ``worker``.
    records : list of dict
        The raw records (with ``raw`` data of the kinds that return some).
    ran, skipped, pending : int
        Cases run by this call, found already done, left without a result.
    seconds : float
        Wall time of this call (cluster start-up included).
    startup : float
        Time to start (or reach) the cluster.
    interrupted : bool
        The call was stopped by Ctrl-C (KeyboardInterrupt); what finished is kept.
    cluster : str
        Where the cases ran ("serial", the LocalCluster or the scheduler address).
    summary : str
        The kind's summary (blind benchmark scores, best index poses...).
    """

    spec: SweepSpec
    out: Path
    rows: list
    records: list
    ran: int = 0
    skipped: int = 0
    pending: int = 0
    seconds: float = 0.0
    startup: float = 0.0
    cluster: str = "serial"
    interrupted: bool = False
    summary: str = ""
    files: dict = field(default_factory=dict)

    @property
    def ok(self) -> list:
        return [r for r in self.rows if r["status"] == "ok"]

    @property
    def failed(self) -> list:
        return [r for r in self.rows if r["status"] != "ok"]

    def column(self, name: str) -> np.ndarray:
        """One column as a float array (NaN where a row has no number)."""
        out = np.full(len(self.rows), np.nan)
        for i, r in enumerate(self.rows):
            v = r.get(name)
            if isinstance(v, (int, float)):
                out[i] = float(v)
        return out

    def text(self) -> str:
        L = [f"sweep {self.spec.name} ({self.spec.kind}): {len(self.rows)} of {len(self.spec.case_list())} cases "
             f"have a result: {len(self.ok)} ok, {len(self.failed)} failed; this call ran {self.ran} "
             f"({self.skipped} already done, {self.pending} left) on {self.cluster} in {self.seconds:.1f} s"]
        for r in self.failed[:10]:
            p = ", ".join(f"{k} = {_show(r.get(k))}" for k in self.spec.param_names() if k in r)
            L.append(f"  FAILED case {r['index']} [{r['case_id']}] ({p}): {r.get('error_type')}: {r.get('error')}")
        if len(self.failed) > 10:
            L.append(f"  ... {len(self.failed) - 10} more failed cases in the table")
        if self.interrupted:
            L.append(f"  interrupted: {self.pending} case(s) pending; run again with --resume (resume=True)")
        if self.summary:
            L += ["", self.summary]
        for k, p in self.files.items():
            L.append(f"{k}: {p}")
        return "\n".join(L)


def _show(v):
    return f"{v:.6g}" if isinstance(v, float) else json.dumps(v) if isinstance(v, (list, dict)) else str(v)


def _rows(spec: SweepSpec, records: list) -> list:
    last = {}
    for r in records:
        last[r["case_id"]] = r
    names = set(spec.param_names())
    rows = []
    for c in spec.case_list():
        r = last.get(c.id)
        if r is None:
            continue
        row = {"case_id": c.id, "index": c.index, "status": r["status"]}
        row.update(c.params)
        for k, v in r.get("results", {}).items():
            row[f"result.{k}" if k in names or k in row else k] = v
        for k in ("error_type", "error", "where"):
            if k in r:
                row[k] = r[k]
        if r.get("warnings"):
            row["warnings"] = " | ".join(r["warnings"])
        row["seconds"], row["worker"] = r.get("seconds"), r.get("worker")
        rows.append(row)
    return rows


def write_table(path, spec: SweepSpec, rows: list) -> Path:
    """The rows as CSV: ids and status, the parameters, the results (union of the
    columns, first seen first), the error and timing columns; empty cells where a row
    has no value; lists and tables of parameters as JSON."""
    head = ["case_id", "index", "status"] + spec.param_names()
    tail = ["error_type", "error", "where", "warnings", "seconds", "worker"]
    cols = list(head)
    for r in rows:
        for k in r:
            if k not in cols and k not in tail:
                cols.append(k)
    cols += tail
    path = Path(path)
    tmp = path.with_suffix(".csv.part")
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in rows:
            w.writerow(["" if r.get(c) is None else json.dumps(r[c]) if isinstance(r.get(c), (list, dict))
                        else r[c] for c in cols])
    os.replace(tmp, path)
    return path


# --------------------------------------------------------------------- driver

def default_workers() -> int:
    """One worker process per core this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def _start_client(scheduler, workers):
    import logging
    import signal
    import threading

    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = Client(scheduler, timeout="5s")
        except (OSError, TimeoutError) as e:
            raise SweepError(f"no Dask scheduler answers at {scheduler} within 5 s ({e.__class__.__name__}): start "
                             f"one (dask scheduler) or leave out --scheduler for a local cluster") from None
        n = sum(client.nthreads().values())
        return client, None, f"scheduler {scheduler} ({len(client.nthreads())} workers, {n} threads)"
    n = int(workers or default_workers())
    # one thread per process: the core and the FMUs hold the GIL in ctypes calls and an
    # FMU instance must stay in the thread that made it
    # ctrl-C in a terminal reaches the whole process group: the worker processes are
    # started with SIGINT ignored (inherited, and Python then installs no handler), so only
    # this process stops, keeps what finished and closes the cluster, with no worker
    # printing a KeyboardInterrupt traceback
    main_thread = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main_thread else None
    try:
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None,
                               silence_logs=logging.ERROR)
    finally:
        if main_thread:
            signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster, f"LocalCluster ({n} worker processes, 1 thread each)"


def _prepare(spec: SweepSpec, cases: list):
    from .kinds import get_kind

    base, fmu_path = get_kind(spec.kind).prepare(spec, cases)
    fmu = None
    if fmu_path is not None:
        fmu_path = Path(fmu_path)
        data = fmu_path.read_bytes()
        fmu = {"sha256": _sha256(data), "name": fmu_path.name, "path": str(fmu_path.resolve()), "bytes": data}
    return base, fmu


def _check_out(out: Path, spec: SweepSpec, resume: bool, overwrite: bool) -> None:
    meta = out / META
    has = (out / RESULTS).exists() and (out / RESULTS).stat().st_size > 0
    if has and overwrite:
        (out / RESULTS).unlink()
        for p in (out / TABLE, meta):
            if p.exists():
                p.unlink()
        return
    if has and not resume:
        raise SweepError(f"{out} already holds results of a sweep: resume it (--resume / resume=True) or start "
                         f"again (--overwrite / overwrite=True), or choose another --out")
    if has and meta.exists():
        old = json.loads(meta.read_text())
        if old.get("fingerprint") != spec.fingerprint():
            raise SweepError(f"{out} holds results of a sweep with another kind or base configuration "
                             f"({old.get('kind')}, fingerprint {old.get('fingerprint')} vs {spec.fingerprint()}): "
                             f"its results would not be comparable; use another --out or --overwrite")


def run_sweep(spec, *, out=None, scheduler: str | None = None, workers: int | None = None, client=None,
              resume: bool = False, overwrite: bool = False, retry_failed: bool = False,
              max_cases: int | None = None, progress: bool | None = None, window: int | None = None) -> SweepResult:
    """Run the cases of a sweep on Dask (or in a loop) and gather their results.

    Parameters
    ----------
    spec : SweepSpec or str or Path
        The spec (or its TOML file).
    out : str or Path, optional
        The sweep's directory (default ``results/sweeps/<name>``).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``); its workers need
        this package and the core library (docs/sweep.md).
    workers : int, optional
        Worker processes of the LocalCluster (default: one per core); 0 runs the cases
        in a plain loop in this process.
    client : distributed.Client, optional
        Use this client (and its cluster) instead of starting one.
    resume : bool
        Skip the cases whose id is already in ``<out>/results.jsonl``.
    overwrite : bool
        Discard the results already in ``out``.
    retry_failed : bool
        With ``resume``, run again the cases recorded as failed.
    max_cases : int, optional
        Run only the first ``max_cases`` cases still to do (the others stay pending: a
        deliberate partial run, resumed later).
    progress : bool, optional
        tqdm progress bar (default: on a terminal).
    window : int, optional
        Cases in flight at once (default: 4 per worker thread, at least 8).

    Returns
    -------
    SweepResult

    Raises
    ------
    SweepError
        ``out`` holds results and neither ``resume`` nor ``overwrite`` was given, or
        they come from a spec with another kind or base.
    """
    from tqdm import tqdm

    from .kinds import get_kind

    t_start = time.perf_counter()
    if not isinstance(spec, SweepSpec):
        spec = load_spec(spec)
    out = Path(out) if out is not None else Path("results") / "sweeps" / spec.name
    out.mkdir(parents=True, exist_ok=True)
    _check_out(out, spec, resume, overwrite)
    cases = spec.case_list()
    done = {}
    for r in read_records(out):
        if r["status"] == "ok" or not retry_failed:
            done[r["case_id"]] = r
        else:
            done.pop(r["case_id"], None)
    todo = [c for c in cases if c.id not in done]
    skipped = len(cases) - len(todo)
    meta = {"format": FORMAT, "name": spec.name, "kind": spec.kind, "fingerprint": spec.fingerprint(),
            "spec": spec.to_dict(), "spec_file": str(spec.path) if spec.path else None,
            "cases": [{"index": c.index, "case_id": c.id, "params": c.params} for c in cases]}
    (out / META).write_text(json.dumps(_canonical(meta), indent=1, allow_nan=True))
    base, fmu = _prepare(spec, todo) if todo else ({}, None)
    # a deliberate partial run: the first max_cases cases still to do, the rest stays pending
    todo_run = todo if max_cases is None else todo[:max(0, int(max_cases))]
    patterns = spec.results
    ran = 0
    cluster_desc, startup = "serial", 0.0
    f = _open_results(out)
    bar = tqdm(total=len(todo_run), unit="case", desc=spec.name, disable=None if progress is None
               else not progress, dynamic_ncols=True)

    def record(rec):
        nonlocal ran
        _save_arrays(out, rec)
        _append(f, rec)
        ran += 1
        bar.update(1)
        if rec["status"] != "ok":
            bar.write(f"case {rec.get('index')} [{rec['case_id']}] failed: {rec.get('error_type')}: "
                      f"{rec.get('error')}"[:400])

    own_client = own_cluster = None
    interrupted = False
    index = {}  # key of each future in flight -> its case
    try:
        if workers == 0 and client is None and scheduler is None:
            fmu_arg = {k: v for k, v in fmu.items() if k != "bytes"} if fmu else None
            for c in todo_run:
                rec = run_case(spec.kind, base, c.params, c.id, fmu_arg, None, patterns)
                rec["index"] = c.index
                record(rec)
        elif todo_run:
            from distributed import CancelledError, as_completed

            t0 = time.perf_counter()
            if client is None:
                own_client, own_cluster, cluster_desc = _start_client(scheduler, workers)
                client = own_client
            else:
                cluster_desc = f"client {client.scheduler.address} ({len(client.nthreads())} workers)"
            startup = time.perf_counter() - t0
            nthreads = max(1, sum(client.nthreads().values()))
            win = window or max(8, 4 * nthreads)
            fmu_arg = fmu_data = None
            if fmu:
                fmu_arg = {k: v for k, v in fmu.items() if k != "bytes"}
                # one copy per worker, not one per task; workers write it to their cache
                fmu_data = client.scatter(fmu["bytes"], broadcast=True, hash=False)
            # hash=False: a key of its own per call, so that the release of a previous
            # call's copy (same content) cannot delete the data this call depends on
            base_f = client.scatter([base], broadcast=True, hash=False)[0]
            prefix = f"sweep-{spec.fingerprint()}-"

            def submit(c):
                fut = client.submit(run_case, spec.kind, base_f, c.params, c.id, fmu_arg, fmu_data, patterns,
                                    key=prefix + c.id, retries=0)
                index[fut.key] = (c, fut)
                return fut

            it = iter(todo_run)
            ac = as_completed([submit(c) for c in islice(it, win)])
            for fut in ac:
                c, _ = index.pop(fut.key)
                try:
                    rec = fut.result()
                except CancelledError as e:  # not the case's doing: leave it pending for a resume
                    bar.write(f"case {c.index} [{c.id}] was cancelled by the cluster ({e}); it stays pending")
                    fut.release()
                    nxt = next(it, None)
                    if nxt is not None:
                        ac.add(submit(nxt))
                    continue
                except Exception as e:  # the worker died while running it (a crash in a C library...)
                    rec = {"case_id": c.id, "params": c.params, "status": "error", "results": {},
                           "error_type": type(e).__name__, "error": f"the case did not come back from its worker: {e}",
                           "seconds": None, "worker": None}
                fut.release()
                rec["index"] = c.index
                record(rec)
                nxt = next(it, None)
                if nxt is not None:
                    ac.add(submit(nxt))
    except KeyboardInterrupt:  # Ctrl-C: keep what finished, write the table, say how to go on
        interrupted = True
    finally:
        bar.close()
        f.close()
        if index and client is not None and own_client is None:
            # interrupted: the caller's cluster should not go on with them
            client.cancel([fu for _, fu in index.values()])
        if own_client is not None:
            own_client.close()
        if own_cluster is not None:
            own_cluster.close()
    records = read_records(out)
    rows = _rows(spec, records)
    res = SweepResult(spec, out, rows, records, ran=ran, skipped=skipped, pending=len(cases) - len(rows),
                      seconds=time.perf_counter() - t_start, startup=startup, cluster=cluster_desc,
                      interrupted=interrupted)
    res.files["results"] = out / RESULTS
    res.files["table"] = write_table(out / TABLE, spec, rows)
    try:
        res.summary = get_kind(spec.kind).summarize(res) or ""
    except Exception as e:  # a summary is a convenience: never lose the sweep over it
        res.summary = f"(no summary: {type(e).__name__}: {e})"
    return res


def _main(argv=None):  # pragma: no cover - python -m cosim.sweep SPEC ... (same as cosim sweep; cosim/sweep/__main__.py)
    from ..cli import main

    return main(["sweep", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":  # pragma: no cover
    sys.exit(_main())
