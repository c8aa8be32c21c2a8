#!/usr/bin/env python3
"""Time of the default diagnosis (discovery on, replay on) of 10 s recordings at 1 kHz on one core.

    PKM_BUILD_DIR=build .venv/bin/python bench/diagnosis_time_bench.py [--repeat 3] [--cases 6pus_library quattro_backlash]
                                                                        [--dir /tmp/diagnosis_time_cases] [--no-mujoco]
                                                                        [--golden DIR | --check DIR] [--no-memory]

The cases (written once into ``--dir`` and reused; each is 10 s at 1 kHz):

* ``6pus_library``: the 6-PUS hiding a Coulomb friction and a payload (the engine's own generator);
* ``6pus_backlash``: the 6-PUS hiding a backlash (seed 4);
* ``quattro_backlash``: the README's ``cosim blind-case --robot quattro --effect backlash --seed 4``, 10 s;
* ``quattro_dead_zone``: the Quattro hiding a drive dead zone (seed 3: a profile over the width, many actuator efforts);
* ``6pus_clean``: the 6-PUS with nothing hidden (seed 7);
* ``6pus_cable``: the 6-PUS with a force on the platform, ``cosim diagnose``'s platform example
  (``scenarios/6pus_cable.toml``: a cable of 0.4 N from the platform to an anchor 0.29 m away, PD +
  gravity control, tracker poses), run for 10 s;
* ``mujoco_spring``: MuJoCo's 6-PUS with a spring towards home on one rail, a force no library effect
  names (bench/discovery_mujoco_bench.py's generator, seed 1; left out with ``--no-mujoco`` or without
  the ``mujoco`` package);
* ``mujoco_backlash``: MuJoCo's 6-PUS with a 50 um backlash as two bodies (drive body, carriage, stiff
  damped faces) on a rail whose effort changes sign (bench/foreign/mujoco_blind.py, seed 4).

Each diagnosis runs in this process pinned to one core (``os.sched_setaffinity``; BLAS and OpenMP on
one thread through the environment, set before numpy is imported), ``--repeat`` times; the medians of
the CPU time (``time.process_time``: what the diagnosis computed, steadier than the elapsed time on
a shared machine, whose other processes take turns on the core) are printed per stage, and the
elapsed (wall) time of the whole:

* prepare: the residual pipeline (forward kinematics, pose rates, nominal inverse dynamics, smoothing);
* noise model: the noise levels and variance inflation of the channels;
* library: the rest, mostly the candidate columns and the forward selection over the library
  (with the reading of the file and the checks of the recording's conventions);
* inference: refinement, intervals, look-alikes and detectability of the library's effects;
* discovery: the search for terms no library effect names, and the tie rule;
* held-out / localisation: the held-out fit and where the model goes wrong;
* replay: the closed-loop replay of the held-out part (nominal and fitted plant, two-body fit);
* total: ``diagnose`` from reading the file to the replay (the 10 s target), CPU time; wall: elapsed;
* peak MB: the peak resident memory of a fresh process that runs one diagnosis of the case
  (Linux's ``VmHWM``; the interpreter, numpy and the core library hold about 110 MB of it before the
  diagnosis starts).  Measured in a process of its own: in this one the memory the previous runs
  freed stays with the process and would be counted again.

The machine's load average (1 min) is printed beside every case: on a shared machine a figure is
only comparable with one taken at a similar load, and medians are kept for that reason.

``--golden DIR`` writes every reported figure of each diagnosis (the Diagnosis as JSON, without its
timings) into DIR; ``--check DIR`` compares each diagnosis with the one stored there and fails on the
first figure that differs (a speed-up must not change a result).
"""
from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_v] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "bench"), str(REPO / "bench" / "foreign")]

import numpy as np  # noqa: E402

TARGET = 10.0
DURATION = 10.0
#: case -> (robot, hidden effects, seed) of the engine's own generator
OWN = {"6pus_library": ("6pus", ["coulomb", "payload"], 2024),
       "6pus_backlash": ("6pus", ["backlash"], 4),
       "quattro_backlash": ("quattro", ["backlash"], 4),
       "quattro_dead_zone": ("quattro", ["dead_zone"], 3),
       "6pus_clean": ("6pus", [], 7)}
#: case -> scenario file run for DURATION
SCENARIO = {"6pus_cable": "scenarios/6pus_cable.toml"}
MUJOCO = {"mujoco_spring": ("spring", 1), "mujoco_backlash": ("backlash", 4)}
#: stage -> functions whose (outermost) time is the stage's, as "module:qualified name"; the first
#: that exists is wrapped (in every module of the package that holds it), so the bench outlives a
#: function moved between modules
STAGES = {"prepare": ["cosim.discrepancy.residuals:Pipeline.__init__"],
          "noise": ["cosim.discrepancy.noise:NoiseModel.noise_model", "cosim.discrepancy.noise:noise_model"],
          "inference": ["cosim.discrepancy.inference:Inference.finish", "cosim.discrepancy.inference:infer"],
          "discovery": ["cosim.discrepancy.diagnosis:_discover"],
          "held-out": ["cosim.discrepancy.diagnosis:heldout_fit", "cosim.discrepancy.localisation:localise"],
          "replay": ["cosim.discrepancy.diagnosis:_replay"]}
COLUMNS = ["prepare", "noise", "library", "inference", "discovery", "held-out", "replay", "total"]


def readable(csv: Path) -> bool:
    """Does ``csv`` exist and read as a recording with today's reader?  A case written by older
    code may not (the Quattro's pose column was ``theta``, the core's name is now ``rz``): such a
    file is stale and :func:`make_cases` writes it again."""
    from cosim.errors import InputError
    from cosim.recording import read_recording

    if not csv.exists():
        return False
    try:
        read_recording(csv)
    except (InputError, OSError, ValueError):
        return False
    return True


def make_cases(out: Path, names, mujoco: bool) -> dict:
    """Write the recordings not yet in ``out`` (or stale there: :func:`readable`); returns {case: csv path}."""
    from cosim.discrepancy import blind

    out.mkdir(parents=True, exist_ok=True)
    paths = {}
    cfg = blind.load_config()
    cfg["general"]["duration"] = DURATION
    cfg["general"]["two_effects"] = 0.0
    for name in names:
        csv = out / f"{name}.csv"
        if csv.exists() and not readable(csv):
            print(f"{csv}: stale (does not read with this code), written again", flush=True)
            csv.unlink()
        if name in OWN:
            if not csv.exists():
                robot, hidden, seed = OWN[name]
                csv, _ = blind.make_case(blind.CaseSpec(name, robot, hidden, seed), out, out / "keys", cfg)
        elif name in SCENARIO:
            if not csv.exists():
                from cosim.scenario import run_scenario

                csv = run_scenario(REPO / SCENARIO[name], duration=DURATION, out_dir=out, figures=False,
                                   progress=False).files["recording"]
        elif name in MUJOCO and mujoco:
            if not csv.exists():
                import discovery_mujoco_bench as dmb
                import mujoco_blind as mb

                from cosim.core import Model

                kind, seed = MUJOCO[name]
                m = Model("6pus")
                noise = blind.load_config()["noise"]["6pus"]
                if kind == "backlash":  # a gap of 50 um as two bodies, on a rail whose effort changes sign
                    rec, _ = mb.simulate(m, "backlash", 5e-5, mb.gap_joint(m, seed, DURATION, 2), seed, DURATION,
                                         noise)
                else:
                    rng = np.random.default_rng(seed)
                    force, _, _ = dmb.draw(kind, rng, dmb.motion(m, seed, DURATION), m.ik(m.home()))
                    rec, _ = mb.simulate(m, None, 0.0, 0, seed, DURATION, noise, force=force)
                csv = mb.write_case(m, rec, csv)
        else:
            continue
        paths[name] = Path(csv)
    return paths


class StageClock:
    """Wraps the functions of STAGES to add up their CPU time (``time.process_time``: what this
    process computed, whatever else the machine runs) and wall time; a stage called inside another
    is counted in the outer one."""

    def __init__(self):
        import importlib

        self.cpu = {k: 0.0 for k in STAGES}
        self.wall = dict(self.cpu)
        self.found = {}
        self.depth = 0
        for stage, targets in STAGES.items():
            for t in targets:
                mod, qual = t.split(":")
                try:
                    owner = importlib.import_module(mod)
                except ImportError:
                    continue
                *path, attr = qual.split(".")
                for p in path:
                    owner = getattr(owner, p, None)
                if owner is None or not callable(getattr(owner, attr, None)):
                    continue
                self._wrap(owner, attr, stage)
                self.found.setdefault(stage, []).append(t)
                if stage != "held-out":
                    break

    def _wrap(self, owner, attr, stage):
        fn = getattr(owner, attr)
        clock = self

        def timed(*a, **k):
            clock.depth += 1
            c0, t0 = time.process_time(), time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                clock.depth -= 1
                if clock.depth == 0:  # a stage inside another is the outer one's
                    clock.cpu[stage] += time.process_time() - c0
                    clock.wall[stage] += time.perf_counter() - t0

        setattr(owner, attr, timed)
        if not isinstance(owner, type):  # a module's function: also where other modules imported it
            for name, mod in list(sys.modules.items()):
                if name.startswith("cosim.discrepancy") and getattr(mod, attr, None) is fn:
                    setattr(mod, attr, timed)

    def reset(self):
        for k in self.cpu:
            self.cpu[k] = self.wall[k] = 0.0


def figures(d) -> dict:
    """Every reported figure of a diagnosis (its JSON and residuals, without the timings and file names)."""
    from cosim.jsonable import jsonable

    out = json.loads(d.to_json())
    out["residual"] = json.loads(json.dumps(d.residual, default=jsonable))
    out.pop("timings", None)
    out.pop("files", None)
    out.pop("recording", None)
    return out


def first_difference(a, b, where="") -> str | None:
    """Where two JSON trees differ first (None if identical)."""
    if type(a) is not type(b):
        return f"{where}: {a!r} != {b!r}"
    if isinstance(a, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{where}.{k}: only on one side"
            w = first_difference(a[k], b[k], f"{where}.{k}")
            if w:
                return w
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{where}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            w = first_difference(x, y, f"{where}[{i}]")
            if w:
                return w
        return None
    if a != b and not (isinstance(a, float) and a != a and b != b):
        return f"{where}: {a!r} != {b!r}"
    return None


def _peak_of(csv: str) -> float:
    """Peak resident memory [MB] of this process after one default diagnosis of csv."""
    from cosim.discrepancy import diagnose

    diagnose(csv, figures=False)
    try:  # the high-water mark of this process's memory (ru_maxrss would carry the parent's over)
        with open("/proc/self/status") as f:
            return next(int(x.split()[1]) / 1024.0 for x in f if x.startswith("VmHWM:"))
    except (OSError, StopIteration):
        return float("nan")


def peak_memory(csv: Path) -> float:
    """Peak resident memory [MB] of a fresh process diagnosing csv once."""
    import multiprocessing

    with multiprocessing.get_context("spawn").Pool(1) as pool:
        return pool.apply(_peak_of, (str(csv),))


def time_case(csv: Path, repeat: int, clock: StageClock):
    """``repeat`` default diagnoses of csv: per run the load, CPU time per stage and in total,
    and the wall time in total."""
    from cosim.discrepancy import diagnose

    rows, d = [], None
    for _ in range(repeat):
        clock.reset()
        load = os.getloadavg()[0]
        c0, t0 = time.process_time(), time.perf_counter()
        d = diagnose(csv, figures=False)
        row = {"load": load, "samples": d.settings["samples"], "wall": time.perf_counter() - t0,
               "total": time.process_time() - c0}
        row.update(clock.cpu)
        row["library"] = row["total"] - sum(clock.cpu.values())
        rows.append(row)
    return rows, d


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--cases", nargs="+", default=list(OWN) + list(SCENARIO) + list(MUJOCO))
    ap.add_argument("--dir", type=Path, default=Path("/tmp/diagnosis_time_cases"),
                    help="where the recordings are written once and reused")
    ap.add_argument("--no-mujoco", action="store_true")
    ap.add_argument("--no-memory", action="store_true", help="leave out the peak memory (a fresh process per case)")
    ap.add_argument("--golden", type=Path, help="write every figure of each diagnosis here")
    ap.add_argument("--check", type=Path, help="compare every figure of each diagnosis with those written here")
    args = ap.parse_args(argv)
    try:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
        core = f"core {min(os.sched_getaffinity(0))}"
    except (AttributeError, OSError):
        core = "affinity not set"
    mujoco = not args.no_mujoco
    if mujoco:
        try:
            import mujoco as _  # noqa: F401
        except ImportError:
            mujoco = False
    paths = make_cases(args.dir, args.cases, mujoco)
    from cosim.discrepancy.platform_force import short_name as platform_name
    clock = StageClock()
    print(f"one core ({core}), BLAS/OpenMP on one thread, median of {args.repeat}; CPU seconds per stage "
          f"(library: the rest of the diagnosis, mostly the candidate columns and the selection); wall: elapsed")
    head = (f"{'case':<18} {'samples':>7} {'load':>5} " + " ".join(f"{c:>9}" for c in COLUMNS)
            + f" {'wall':>8} {'peak MB':>8}  target  named")
    print(head)
    ok, bad = True, []
    for name, csv in paths.items():
        rows, d = time_case(csv, args.repeat, clock)
        med = {c: statistics.median(r[c] for r in rows) for c in COLUMNS + ["wall", "load"]}
        med["peak"] = float("nan") if args.no_memory else peak_memory(csv)
        flag = "met" if med["total"] < TARGET else "MISSED"
        ok &= med["total"] < TARGET
        named = ", ".join(d.named() + [t.equation for t in d.discovered]
                          + ([platform_name(d.platform_force)] if d.platform_force is not None else [])) or "clean"
        print(f"{name:<18} {rows[0]['samples']:>7} {med['load']:>5.2f} " + " ".join(f"{med[c]:>8.2f}s" for c in COLUMNS)
              + f" {med['wall']:>7.2f}s {med['peak']:>8.0f}  {flag:<6}  {named}", flush=True)
        fig = figures(d)
        if args.golden:
            args.golden.mkdir(parents=True, exist_ok=True)
            (args.golden / f"{name}.json").write_text(json.dumps(fig, indent=1, sort_keys=True))
        if args.check:
            ref = json.loads((args.check / f"{name}.json").read_text())
            diff = first_difference(ref, json.loads(json.dumps(fig)))
            if diff:
                bad.append(f"{name}{diff}")
    print(f"(target: total CPU time < {TARGET:g} s for {DURATION:g} s at 1 kHz on one core; load: 1-min load "
          f"average of the machine when each run started, median)")
    if args.check:
        print("figures identical to " + str(args.check) if not bad else "FIGURES DIFFER:\n  " + "\n  ".join(bad))
    return 0 if ok and not bad else 1


if __name__ == "__main__":
    sys.exit(main())
