"""Sweep specs: the TOML file, its checks, the cases it makes and their ids (:mod:`cosim.sweep`).

A spec names the *kind* of case, the *base* configuration shared by every case and the
parameters to vary: a ``[grid]`` (every combination), ``[random]`` draws with a seed,
explicit ``[[cases]]`` (format: docs/sweep.md).  Each case is a plain dict of
parameters; its id is a hash of that dict (:func:`case_id`), so it does not depend on
the order or the number of the other cases.

Example
-------
>>> from cosim.sweep import load_spec
>>> spec = load_spec("scenarios/sweeps/pd_gains.toml")
>>> [c.id for c in spec.case_list()][:2]       # 16 hex digits each
"""
from __future__ import annotations

import hashlib
import json
import math
import tomllib
import zlib
from dataclasses import dataclass, field
from itertools import product
from pathlib import Path

import numpy as np

from .errors import SweepSpecError

FORMAT = "pkm-sweep/1"

_TOP_KEYS = {"name", "description", "kind", "base", "grid", "random", "cases", "plan", "results"}
_DISTRIBUTIONS = ("uniform", "loguniform", "normal", "integers", "choice")
_GRID_FORMS = ("linspace", "logspace", "range")


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
