"""Diagnoses of a fixed set of recordings, for a before/after comparison of two checkouts of
the discrepancy engine (a refactoring that must not change a reported figure).

    python bench/diagnosis_compare.py record /tmp/after --cases /tmp/diag_cases
    PYTHONPATH=/path/to/other/checkout python bench/diagnosis_compare.py record /tmp/before --cases /tmp/diag_cases
    python bench/diagnosis_compare.py compare /tmp/before /tmp/after

The other checkout may be a bare tree (``git archive <commit> | tar -x -C DIR``): its Python
package comes first on PYTHONPATH, and ``PKM_LIB=build/lib/libpkm.so`` gives it this build's core.
``record`` writes the recordings into ``--cases`` when they are not there yet (so both runs
diagnose the same files: give both the same folder), then diagnoses each one (BLAS on one
thread, no figures) into ``<out>/<case>/`` (``diagnosis.json``, ``report.md``); ``compare``
prints per case how many values of ``diagnosis.json`` (timings and file paths left out) and
lines of ``report.md`` (its timings line left out) differ, the first few of them, and exits 1
if any case differs.  Floats are compared as JSON writes them (shortest round-trip text): equal
means equal to the bit.

Cases: nine blind cases of ``cosim blind-case`` with the test subset's settings (7.2 s, one
effect): on the 6-PUS a Coulomb friction, a payload, an actuator delay, a saturation, a Stribeck
friction, none, a quadratic drag (a force no library effect names: the discovery step); on the
Quattro a rotor inertia and a backlash; the two with a backlash and a Coulomb friction also
replayed in closed loop; and the EMPS file of ``data/emps`` imported as in the README
(fitted on 60 %, replayed with its reference parameters).
"""
import argparse
import copy
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
#: (robot, hidden effects, seed) of the blind cases
BLIND = [("6pus", ["coulomb"], 101), ("6pus", ["payload"], 102), ("6pus", ["actuator_delay"], 103),
         ("6pus", ["saturation"], 105), ("6pus", ["stribeck"], 106), ("6pus", [], 107),
         ("quattro", ["rotor_inertia"], 109), ("quattro", ["backlash"], 4), ("6pus", ["drag"], 2)]
REPLAYED = ("6pus_coulomb_101", "quattro_backlash_4")
SKIP_KEYS = ("timings", "files")


def record(out: Path, cases: Path) -> None:
    from cosim.discrepancy import blind, diagnose
    from cosim.importing import import_recording

    cases.mkdir(parents=True, exist_ok=True)
    cfg = copy.deepcopy(blind.load_config())
    cfg["general"]["duration"] = 7.2
    cfg["general"]["two_effects"] = 0.0
    todo = []
    for robot, hidden, seed in BLIND:
        name = f"{robot}_{'+'.join(hidden) or 'clean'}_{seed}"
        csv = cases / f"{name}.csv"
        if not csv.exists():
            csv, _ = blind.make_case(blind.CaseSpec(name, robot, hidden, seed), cases, cases / "keys", cfg)
        todo.append((name, csv, {"replay": name in REPLAYED}))
    emps = cases / "DATA_EMPS.csv"
    if not emps.exists():
        import_recording(ROOT / "data/emps/DATA_EMPS.mat", ROOT / "data/emps/emps_map.toml", cases)
    todo.append(("emps", emps, {"train_fraction": 0.6, "compare": ["reference"]}))
    for name, csv, kw in todo:
        t0 = time.perf_counter()
        d = diagnose(str(csv), figures=False, out=out / name, **kw)
        print(f"{name:28s} {time.perf_counter() - t0:6.1f} s  {d.conclusion[:90]}", flush=True)


def _diff(a, b, path, out):
    if type(a) is not type(b):
        out.append((path, a, b))
    elif isinstance(a, dict):
        for k in sorted(set(a) | set(b)):
            if k in SKIP_KEYS and not path:
                continue
            if k not in a or k not in b:
                out.append((f"{path}.{k}", a.get(k, "<none>"), b.get(k, "<none>")))
            else:
                _diff(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list):
        if len(a) != len(b):
            out.append((f"{path} (length)", len(a), len(b)))
        for i, (u, v) in enumerate(zip(a, b)):
            _diff(u, v, f"{path}[{i}]", out)
    elif a != b and not (a != a and b != b):  # nan equals nan here
        out.append((path, a, b))


def _values(o) -> int:
    if isinstance(o, dict):
        return sum(_values(v) for v in o.values())
    if isinstance(o, list):
        return sum(_values(v) for v in o)
    return 1


def compare(a: Path, b: Path) -> int:
    bad, total = 0, 0
    for case in sorted(p for p in a.iterdir() if p.is_dir()):
        other = b / case.name
        if not (other / "diagnosis.json").exists():
            print(f"{case.name}: missing in {b}")
            bad += 1
            continue
        ja, jb = (json.loads((d / "diagnosis.json").read_text()) for d in (case, other))
        ja, jb = ({k: v for k, v in j.items() if k not in SKIP_KEYS} for j in (ja, jb))
        total += _values(ja)
        diffs = []
        _diff(ja, jb, "", diffs)
        ra, rb = ([ln for ln in (d / "report.md").read_text().splitlines() if not ln.startswith("Timings")]
                  for d in (case, other))
        lines = [(x, y) for x, y in zip(ra, rb) if x != y] + ([("(lines)", len(ra), len(rb))] if len(ra) != len(rb) else [])
        print(f"{case.name:28s} {_values(ja):5d} values, {len(diffs)} differ; {len(ra)} report lines, {len(lines)} differ")
        for d in (diffs + lines)[:5]:
            print("    ", d)
        bad += bool(diffs or lines)
    print(f"{total} values compared: " + ("identical" if not bad else f"{bad} case(s) differ"))
    return 1 if bad else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record", help="diagnose the cases into OUT")
    r.add_argument("out", type=Path)
    r.add_argument("--cases", type=Path, default=Path("/tmp/pkm_diagnosis_cases"),
                   help="folder of the recordings (written when missing; default /tmp/pkm_diagnosis_cases)")
    c = sub.add_parser("compare", help="compare two outputs of record")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = p.parse_args(argv)
    if args.cmd == "record":
        from cosim.discrepancy._threads import one_blas_thread

        with one_blas_thread():
            record(args.out, args.cases)
        return 0
    return compare(args.a, args.b)


if __name__ == "__main__":
    sys.exit(main())
