"""The kinds of case a sweep fans out (:mod:`cosim.sweep`).

Each kind turns ``(base, params)`` into a flat dict of results by calling the package's
own functions (nothing is re-derived here):

* ``scenario``: a co-simulation scenario (:func:`cosim.scenario.run_scenario`) with
  dotted overrides of its TOML (``controller.kp``, ``plant_scale.platform.m``,
  ``reference.to[2]``...); results are its metrics;
* ``calibration``: a synthetic calibration campaign (:mod:`cosim.calibration.data`) of
  a robot with random geometric errors, calibrated (:func:`cosim.calibration.calibrate`),
  scored on held-out poses and against the true robot;
* ``blind``: a blind case of the discrepancy engine (a closed-loop recording with hidden
  effects, :func:`cosim.discrepancy.blind.simulate_case`), diagnosed and scored against
  its answer key;
* ``quattro_tile``: one tile (a slab of x values) of a Quattro index map
  (:func:`cosim.quattro.index_map`); the driver saves the arrays and joins the tiles;
* ``function``: any importable ``module:function`` taking the case's dict.

A kind's ``prepare`` runs in the driver: it reads the files the base names (scenario
TOML, blind config) into plain data, so workers on other machines need no file but the
FMU, which :mod:`cosim.sweep` ships.
"""
from __future__ import annotations

import copy
import hashlib
import importlib
import json
import re
import tomllib
from pathlib import Path

import numpy as np

from ..errors import InputError

REPO = Path(__file__).resolve().parents[2]


def _resolve(path, spec) -> Path:
    """A file named in a spec: relative to the spec's folder, the working directory, the repository."""
    p = Path(path)
    if p.is_absolute():
        return p
    for root in (spec.base_dir, Path.cwd(), REPO):
        if (root / p).exists():
            return root / p
    return spec.base_dir / p


class Kind:
    """Base class: one kind of sweep case."""

    name = ""
    #: allowed base / parameter names (None: not checked here)
    keys: tuple | None = None

    def check(self, spec, fail) -> None:
        """Refuse unknown names at load time (``fail(key, message)`` raises)."""
        if self.keys is None:
            return
        for k in list(spec.base) + list(spec.grid) + list((spec.random or {}).get("vary", {})) + \
                [k for c in spec.cases for k in c]:
            if k not in self.keys:
                fail(k, f"not a parameter of a {self.name} case (known: {', '.join(self.keys)})")
        if spec.plan is not None:
            fail("plan", f"a {self.name} sweep has no [plan]")

    def plan_cases(self, plan, spec) -> list:
        return []

    def auto_cases(self, base, spec) -> list:
        return []

    def prepare(self, spec, cases):
        """Driver side: ``(base as plain data, FMU path or None)``."""
        return dict(spec.base), None

    def run(self, base, params, ctx) -> dict:
        raise NotImplementedError

    def summarize(self, result) -> str:
        return ""


# ------------------------------------------------------------------ scenario

_SECTIONS = ("parameters", "plant_parameters", "plant_scale", "plant_offset", "integrator", "controller",
             "reference", "initial", "noise", "output", "fmu")
_TOP = ("name", "description", "robot", "param_set", "plant", "duration", "step", "seed")
_ELEMENT = re.compile(r"^(\w+)\[(\d+)\]$")


def apply_scenario_override(spec: dict, key: str, value) -> None:
    """Set one dotted override in a scenario dict (TOML layout).

    ``duration`` (a top-level key), ``controller.kp`` (a key of a section; the rest of
    the name after the first dot is the key, so core parameters keep their dots:
    ``plant_scale.platform.m``) or ``reference.to[2]`` (element 2, from 0, of a list).
    """
    if "." not in key:
        if key not in _TOP:
            raise KeyError(f"{key!r} is not a top-level scenario key ({', '.join(_TOP)}) nor section.key")
        spec[key] = value
        return
    sec, rest = key.split(".", 1)
    if sec not in _SECTIONS:
        raise KeyError(f"{key!r}: no scenario section {sec!r} ({', '.join(_SECTIONS)})")
    table = spec.setdefault(sec, {})
    m = _ELEMENT.match(rest)
    if rest not in table and m and isinstance(table.get(m.group(1)), list):
        lst = table[m.group(1)]
        i = int(m.group(2))
        if i >= len(lst):
            raise KeyError(f"{key!r}: {sec}.{m.group(1)} has {len(lst)} elements")
        lst[i] = value
    else:
        table[rest] = value


class ScenarioKind(Kind):
    name = "scenario"

    def check(self, spec, fail):
        if "scenario" not in spec.base:
            fail("base.scenario", "names the scenario TOML every case starts from")
        for k in [k for k in spec.base if k != "scenario"] + spec.param_names():
            head = k.split(".", 1)[0]
            if "." in k and head not in _SECTIONS or "." not in k and k not in _TOP:
                fail(k, f"not a scenario key: a top-level key ({', '.join(_TOP)}) or section.key with a section "
                        f"of {', '.join(_SECTIONS)}")
        if spec.plan is not None:
            fail("plan", "a scenario sweep has no [plan]")
        if "fmu.path" in spec.param_names():
            fail("fmu.path", "one FMU per sweep (shipped once to the workers): set it in [base]")
        if not _resolve(spec.base["scenario"], spec).exists():
            fail("base.scenario", f"file {spec.base['scenario']} not found")

    def prepare(self, spec, cases):
        from ..scenario import fmu_path, scenario_from_dict

        path = _resolve(spec.base["scenario"], spec)
        sc = tomllib.loads(path.read_text())
        sc.setdefault("name", path.stem)
        for k, v in spec.base.items():
            if k != "scenario":
                apply_scenario_override(sc, k, v)
        fmu = None
        plants = {sc.get("plant", "core")} | {c.params["plant"] for c in cases if "plant" in c.params}
        if "fmu" in plants:
            s = copy.deepcopy(sc)
            s["plant"] = "fmu"
            fmu = fmu_path(scenario_from_dict(s))
        return {"scenario": sc, "source": str(path)}, fmu

    def run(self, base, params, ctx):
        from ..scenario import run_scenario, scenario_from_dict

        sc = copy.deepcopy(base["scenario"])
        for k, v in params.items():
            apply_scenario_override(sc, k, v)
        if sc.get("plant") == "fmu" and ctx.fmu is not None:
            sc.setdefault("fmu", {})["path"] = str(ctx.fmu)
        out = run_scenario(scenario_from_dict(sc), export=False, figures=False, progress=False)
        m = dict(out.metrics)
        m.pop("units", None)
        return m


# --------------------------------------------------------------- calibration

CALIBRATION_DEFAULTS = {
    "robot": "6pus",            # any robot: the 6-PUS and the four-bar have their own campaigns, the others the generic one
    "seed": 1,                  # the real robot, its poses and the noise
    "n_poses": 60,              # measured poses (6-PUS: random in the Tiberi 2020 workspace; four-bar: crank angles)
    "tracker_noise": 10e-6,     # m, standard deviation of the measured position (four-bar: of X)
    "angle_noise": -1.0,        # rad; < 0: tracker_noise over the platform radius
    "encoder_noise": 0.0,       # m
    "max_length": 0.5e-3,       # m, geometric errors of the real robot (uniform +-)
    "max_angle_deg": 0.5,       # deg, tilt of the error model's unit vectors in the real robot (6-PUS rails)
    "theta_min_deg": 30.0,      # joint range of an output campaign (the four-bar's crank)
    "theta_max_deg": 60.0,
    "solver": "gauss-newton",
    "model": "structural",
    "holdout": 0.25,
    "cond_max": 100.0,
    "weighting": "tracker",
    "validation_poses": 100,    # noise-free poses of the real robot the calibrated model is scored on
    "params": "",               # generic robots: parameters calibrated (comma-separated names / patterns; "": all)
    "error_params": "",         # parameters of the real robot that differ ("": the error model, or every geometric one)
    "pose_fraction": 0.5,       # robots without a declared workspace: poses in this fraction of the core's reach
}


def _names(v):
    return [n.strip() for n in v.split(",") if n.strip()] if isinstance(v, str) else list(v or [])


class CalibrationKind(Kind):
    name = "calibration"
    keys = tuple(CALIBRATION_DEFAULTS)

    def run(self, base, params, ctx):
        from ..calibration import data as cd
        from ..calibration import calibrate
        from ..calibration.error_model import error_model
        from ..core.model import Model

        p = {**CALIBRATION_DEFAULTS, **base, **params}
        seed, n = int(p["seed"]), int(p["n_poses"])
        nominal = Model(p["robot"])
        em = error_model(nominal)
        real = cd.real_params(nominal, max_length=p["max_length"], max_angle_deg=p["max_angle_deg"], rng=[seed, 1],
                              names=_names(p["error_params"]) or None)
        if em is not None and em.measure == "output":  # an output measured at joint values (the four-bar)
            theta = np.radians(np.linspace(p["theta_min_deg"], p["theta_max_deg"], n))
            rec = cd.output_campaign(nominal, real, theta, noise=p["tracker_noise"], rng=[seed, 3])
        else:  # joints at poses in the robot's workspace (its error model's, or the core's reach)
            poses = cd.candidate_poses(nominal, n, rng=[seed, 2], fraction=p["pose_fraction"])
            rec = cd.joint_campaign(nominal, real, poses, tracker_noise=p["tracker_noise"],
                                    angle_noise=None if p["angle_noise"] < 0 else p["angle_noise"],
                                    encoder_noise=p["encoder_noise"], rng=[seed, 3])
        res = calibrate(rec, solver=p["solver"], model=p["model"], holdout=p["holdout"], cond_max=p["cond_max"],
                        seed=seed, weighting=p["weighting"], params=_names(p["params"]) or None)
        s = res.solution
        out = {"poses": int(len(rec.time)), "equations": int(res.problem.nmeas), "parameters": len(s.names),
               "estimated": int(np.sum(s.free)), "rank": int(s.rank), "converged": bool(s.converged),
               "iterations": int(s.iterations), "residual_rms_before": float(s.rms_before),
               "residual_rms_after": float(s.rms_after), "solve_seconds": float(s.seconds)}
        for label, a in (("calibration", res.calibration_accuracy), ("holdout", res.holdout_accuracy)):
            if a is None:
                continue
            out.update({f"{label}.poses": a.n, f"{label}.position_rms_nominal": a.position[0],
                        f"{label}.position_rms_calibrated": a.position[1], f"{label}.gain": a.gain})
            if res.problem.measure == "joints" and {"m", "rad"} <= set(nominal.facts.pose_units):
                out.update({f"{label}.orientation_rms_nominal": a.orientation[0],
                            f"{label}.orientation_rms_calibrated": a.orientation[1]})
        out.update(self._truth(p, nominal, real, res, seed))
        return out

    @staticmethod
    def _truth(p, nominal, real_params, res, seed):
        """Accuracy against the real robot on noise-free poses (the truth calibration never sees)."""
        from ..calibration import data as cd

        nv = int(p["validation_poses"])
        if nv <= 0:
            return {}
        real = nominal.copy()
        real.set_params(real_params)
        cal = res.calibrated_model()
        if res.problem.measure == "output":
            from ..calibration.error_model import output

            th = np.radians(np.linspace(p["theta_min_deg"], p["theta_max_deg"], nv))
            x = output(real, th, jacobian=False)
            e0 = output(nominal, th, jacobian=False) - x
            e1 = output(cal, th, jacobian=False) - x
        else:
            X = cd.candidate_poses(nominal, nv, rng=[seed, 4], fraction=p["pose_fraction"])
            q, st = real.ik(X, errors="status")
            X, q = X[st == 0], q[st == 0]
            lin = [i for i, u in enumerate(nominal.facts.pose_units) if u == "m"]
            errs = []
            for m in (nominal, cal):
                xf, st2 = m.fk(q, x_guess=X, errors="status")
                ok = st2 == 0
                errs.append(np.where(ok, np.linalg.norm(xf[:, lin] - X[:, lin], axis=1), np.nan))
            e0, e1 = errs
        rms = lambda v: float(np.sqrt(np.nanmean(np.square(v))))  # noqa: E731
        return {"truth.poses": int(np.sum(np.isfinite(e1))), "truth.position_rms_nominal": rms(e0),
                "truth.position_rms_calibrated": rms(e1), "truth.gain": rms(e0) / rms(e1)}

    def summarize(self, result):
        if not result.ok:
            return ""
        L = ["calibration trials (median over the cases that ran):"]
        for name, unit, f in (("holdout.position_rms_nominal", "um", 1e6),
                              ("holdout.position_rms_calibrated", "um", 1e6),
                              ("truth.position_rms_calibrated", "um", 1e6), ("truth.gain", "x", 1.0)):
            v = result.column(name)
            if np.isfinite(v).any():
                L.append(f"  {name:<34} {np.nanmedian(v) * f:10.4g} {unit}  (range {np.nanmin(v) * f:.4g} .. "
                         f"{np.nanmax(v) * f:.4g})")
        return "\n".join(L)


# --------------------------------------------------------------------- blind

BLIND_DEFAULTS = {"robot": "6pus", "effects": [], "seed": 1, "controller": "", "case": "", "threshold": 10.0,
                  "window": 0.05, "train_fraction": 0.7, "config": "scenarios/blind/config.toml"}
_BLIND_CONFIG_SECTIONS = ("general", "noise", "effects")


class BlindKind(Kind):
    name = "blind"

    def check(self, spec, fail):
        for k in list(spec.base) + spec.param_names():
            head = k.split(".", 1)[0]
            if k not in BLIND_DEFAULTS and not ("." in k and head in _BLIND_CONFIG_SECTIONS):
                fail(k, f"not a blind-case key ({', '.join(BLIND_DEFAULTS)}, or a generator config override "
                        f"general.*, noise.*, effects.*)")
        if spec.plan is not None:
            for k in spec.plan:
                if k not in ("cases", "clean", "seed", "robots"):
                    fail(f"plan.{k}", "unknown key (known: cases, clean, seed, robots)")

    def plan_cases(self, plan, spec):
        from ..discrepancy import blind

        specs = blind.plan(int(plan.get("cases", 40)), int(plan.get("clean", 10)), int(plan.get("seed", 1)),
                           tuple(plan.get("robots", ["6pus"])), self._config(spec))
        return [{"case": s.case, "robot": s.robot, "effects": list(s.hidden), "seed": int(s.seed)} for s in specs]

    def _config(self, spec):
        with open(_resolve(spec.base.get("config", BLIND_DEFAULTS["config"]), spec), "rb") as f:
            return tomllib.load(f)

    def prepare(self, spec, cases):
        base = {k: v for k, v in spec.base.items() if k != "config"}
        base["_config"] = self._config(spec)
        return base, None

    def run(self, base, params, ctx):
        from dataclasses import asdict

        from ..discrepancy import blind, diagnose

        p = {**BLIND_DEFAULTS, **base, **params}
        cfg = copy.deepcopy(base["_config"])
        for k, v in p.items():
            if "." in k and k.split(".", 1)[0] in _BLIND_CONFIG_SECTIONS:
                sec, rest = k.split(".", 1)
                node = cfg.setdefault(sec, {})
                *path, leaf = rest.split(".")
                for part in path:
                    node = node.setdefault(part, {})
                node[leaf] = v
        effects = p["effects"]
        if isinstance(effects, str):
            effects = [e for e in effects.split("+") if e and e != "clean"]
        unknown = [e for e in effects if e not in blind.TYPES]
        if unknown:
            raise InputError(f"unknown effect type(s) {unknown} (known: {', '.join(blind.TYPES)})")
        name = p["case"] or f"{p['robot']}_{'+'.join(effects) or 'clean'}_{p['seed']}"
        spec = blind.CaseSpec(name, p["robot"], list(effects), int(p["seed"]), p["controller"] or None)
        import time

        t0 = time.perf_counter()
        rec, hidden, info = blind.simulate_case(spec, cfg)
        t1 = time.perf_counter()
        d = diagnose(rec, replay=False, figures=False, threshold=float(p["threshold"]), window=float(p["window"]),
                     train_fraction=float(p["train_fraction"]))
        t2 = time.perf_counter()
        key = {"case": spec.case, "robot": spec.robot, "seed": spec.seed, "effects": [asdict(h) for h in hidden],
               **info}
        s = blind.score(d, key)
        s.update({"t_generate": t1 - t0, "t_diagnose": t2 - t1, "conclusion": d.conclusion})
        flat = {k: v for k, v in s.items() if k not in ("hidden", "named", "param_error")}
        flat["hidden"] = "+".join(s["hidden"]) or "none"
        flat["named"] = "+".join(s["named"]) or "none"
        flat["controller"] = info.get("controller")
        for t, e in s.get("param_error", {}).items():
            flat[f"param_error.{t}"] = e
        for h in key["effects"]:
            for n, v in h["params"].items():
                flat[f"true.{n}"] = v
                flat[f"fitted.{n}"] = d.theta.get(n, h["nominal"].get(n, 0.0))
        flat["_raw"] = s
        return flat

    def summarize(self, result):
        from ..discrepancy import blind

        ids = {r["case_id"] for r in result.rows if r["status"] == "ok"}
        raws = [r["raw"] for r in result.records if r.get("status") == "ok" and "raw" in r and r["case_id"] in ids]
        if not raws:
            return ""
        text = blind.format_summary(blind.summarize(raws))
        (Path(result.out) / "summary.txt").write_text(text + "\n")
        return text


# -------------------------------------------------------------- quattro tile

QUATTRO_DEFAULTS = {"param_set": "default", "x": None, "y": None, "z": None, "theta": 0.0, "tiles": 8,
                    "indices": [], "save_arrays": True, "tile": 0}


def _axis(v, default):
    if v is None:
        return default
    if isinstance(v, dict):
        return np.linspace(float(v["min"]), float(v["max"]), int(v["n"]))
    return np.asarray(v, float)


class QuattroTileKind(Kind):
    name = "quattro_tile"

    def check(self, spec, fail):
        for k in list(spec.base) + spec.param_names():
            head = k.split(".", 1)[0]
            if head not in QUATTRO_DEFAULTS:
                fail(k, f"not a quattro_tile key ({', '.join(QUATTRO_DEFAULTS)})")
        if spec.plan is not None:
            fail("plan", "a quattro_tile sweep has no [plan]")
        t = spec.base.get("tiles", QUATTRO_DEFAULTS["tiles"])
        if not isinstance(t, int) or t < 1:
            fail("base.tiles", f"needs a number of tiles >= 1, got {t!r}")

    @staticmethod
    def _unflatten(base):
        # [base] x = {min, max, n} arrives flattened as x.min, x.max, x.n
        out = {}
        for k, v in base.items():
            if "." in k:
                a, b = k.split(".", 1)
                out.setdefault(a, {})[b] = v
            else:
                out[k] = v
        return out

    def auto_cases(self, base, spec):
        varied = set(spec.grid) | set((spec.random or {}).get("vary", {})) | {k for c in spec.cases for k in c}
        if "tile" in varied:  # tiles chosen by hand
            return []
        return [{"tile": k} for k in range(int(base.get("tiles", QUATTRO_DEFAULTS["tiles"])))]

    def prepare(self, spec, cases):
        return self._unflatten(spec.base), None

    def _grid(self, p):
        from ..quattro import model

        m = model(p["param_set"])
        h = m.quattro_constants()["base_height"]
        x = _axis(p["x"], np.linspace(-0.5, 0.5, 21))
        y = _axis(p["y"], np.linspace(-0.5, 0.5, 21))
        z = _axis(p["z"], np.linspace(-1.06 - h, -0.56 - h, 51))
        return m, x, y, z

    def run(self, base, params, ctx):
        from ..quattro import BETTER, index_map

        p = {**QUATTRO_DEFAULTS, **base, **params}
        m, x, y, z = self._grid(p)
        tiles, k = int(p["tiles"]), int(p["tile"])
        if not 0 <= k < tiles:
            raise InputError(f"tile {k} out of range: the map is cut into {tiles} tiles along x")
        xs = np.array_split(x, tiles)[k]
        if xs.size == 0:
            raise InputError(f"tile {k}: more tiles ({tiles}) than x values ({x.size})")
        mp = index_map(xs, y, z, theta=float(p["theta"]), model=m)
        out = {"x_from": float(xs[0]), "x_to": float(xs[-1]), "points": int(mp.status.size),
               "reachable": int(np.sum(mp.status == 0)), "core_seconds": mp.seconds}
        names = list(p["indices"]) or list(mp.values)
        unknown = [n for n in names if n not in mp.values]
        if unknown:
            raise InputError(f"unknown Quattro index name(s) {unknown} (known: {', '.join(mp.values)})")
        for n in names:
            v = mp.values[n]
            if np.isfinite(v).any():
                best = mp.argbest(n)
                kb = np.nanargmax(v) if BETTER[n] == "max" else np.nanargmin(v)
                out[f"{n}.best"] = float(v.flat[kb])
                out[f"{n}.at"] = [float(c) for c in best]
            else:
                out[f"{n}.best"] = float("nan")
        if p["save_arrays"]:
            out["_arrays"] = {"x": xs, "y": y, "z": z, "status": mp.status, **{n: mp.values[n] for n in names}}
        return out

    def summarize(self, result):
        from ..quattro import BETTER

        L = []
        groups = {}
        ok = [r for r in result.rows if r["status"] == "ok"]
        for r in ok:
            g = json.dumps({k: r[k] for k in result.spec.param_names() if k != "tile" and k in r}, sort_keys=True)
            groups.setdefault(g, []).append(r)
        tiles = int(result.spec.base.get("tiles", QUATTRO_DEFAULTS["tiles"]))
        for g, rows in groups.items():
            label = "" if g == "{}" else f" {g}"
            names = [c[:-5] for c in rows[0] if c.endswith(".best")]
            L.append(f"Quattro index map{label}: {len(rows)}/{tiles} tiles, "
                     f"{sum(r['reachable'] for r in rows)} reachable of {sum(r['points'] for r in rows)} poses")
            for n in names:
                vals = [(r[f"{n}.best"], r) for r in rows if isinstance(r.get(f"{n}.best"), float)
                        and np.isfinite(r[f"{n}.best"])]
                if not vals:
                    continue
                v, r = (max if BETTER[n] == "max" else min)(vals, key=lambda t: t[0])
                at = [r.get(f"{n}.at[{i}]") for i in range(3)]
                L.append(f"  {n:<10} best {v:.6g} at (x, y, z) = ({at[0]:.4g}, {at[1]:.4g}, {at[2]:.4g}) m")
            if len(rows) == tiles and all(r.get("case_id") for r in rows):
                path = self._join(result, rows, g)
                if path is not None:
                    result.files[f"map{label}"] = path
        return "\n".join(L)

    @staticmethod
    def _join(result, rows, g):
        out = Path(result.out)
        parts = []
        for r in sorted(rows, key=lambda r: r["tile"]):
            f = out / "arrays" / f"{r['case_id']}.npz"
            if not f.exists():
                return None
            parts.append(np.load(f))
        joined = {"x": np.concatenate([p["x"] for p in parts]), "y": parts[0]["y"], "z": parts[0]["z"]}
        for k in parts[0].files:
            if k not in joined:
                joined[k] = np.concatenate([p[k] for p in parts], axis=0)
        name = "quattro_map.npz" if g == "{}" else f"quattro_map_{hashlib.sha256(g.encode()).hexdigest()[:8]}.npz"
        np.savez_compressed(out / name, **joined)
        return out / name


# ------------------------------------------------------------------ function

class FunctionKind(Kind):
    name = "function"

    def check(self, spec, fail):
        f = spec.base.get("function")
        if not (callable(f) or isinstance(f, str) and ":" in f):
            fail("base.function", "names the case function as 'package.module:function' (or is a callable)")

    @staticmethod
    def resolve(f):
        if callable(f):
            return f
        mod, _, attr = f.partition(":")
        obj = importlib.import_module(mod)
        for part in attr.split("."):
            obj = getattr(obj, part)
        return obj

    def run(self, base, params, ctx):
        fn = self.resolve(base["function"])
        return fn({**{k: v for k, v in base.items() if k != "function"}, **params})


KINDS = {k.name: k for k in (ScenarioKind(), CalibrationKind(), BlindKind(), QuattroTileKind(), FunctionKind())}


def get_kind(name: str) -> Kind:
    try:
        return KINDS[name]
    except KeyError:
        raise InputError(f"unknown kind of sweep case {name!r} (known: {', '.join(KINDS)})") from None
