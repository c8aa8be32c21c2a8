"""Corrupted serialized FMU states fed back to every FMU of a build (the C host tests/fmu/state_fuzz.c).

    .venv/bin/python bench/state_fuzz.py                      # every FMU of build/, a table
    .venv/bin/python bench/state_fuzz.py --fmus PKM_6PUS,PKM_QUATTRO_CTRL --json
    .venv/bin/python bench/state_fuzz.py --build /other/build  # another build's FMUs

For each interface of each FMU the host takes two good states (just instantiated; initialized and
stepped) and puts each of NaN, +-Inf, 0, -1, 1e4, 1e9, 1e300 and a denormal into every 8-byte word
of the serialized block, as corrupted and with its checksum sealed again, into the same instance and
into a fresh one (docs/fmu.md, "FMU state").  A host that dies is a crash; the other columns count
accepted and refused states, values that are not finite returned with fmi2OK, refusals without a
logged message, instances changed by a refused state and instances that could not be put back.
The suite runs a subset (tests/fmu/test_state_fuzz.py); this runs them all.
"""
import argparse
import json
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SOURCE = REPO / "tests" / "fmu" / "state_fuzz.c"
PROBLEMS = ("ok_nonfinite", "silent_refusals", "changed_by_refusal", "unrecoverable")


def compile_host(out_dir: Path) -> Path:
    """Compile the C host with the FMI 2.0 headers fmpy ships; returns the executable."""
    import fmpy

    exe = Path(out_dir) / "state_fuzz"
    headers = Path(fmpy.__file__).parent / "c-code"
    p = subprocess.run(["cc", "-O2", "-std=c11", "-D_DEFAULT_SOURCE", "-Wall", "-Werror", "-I", str(headers),
                        str(SOURCE), "-o", str(exe), "-ldl", "-lm"], capture_output=True, text=True)
    if p.returncode:
        raise RuntimeError(f"compiling {SOURCE} failed:\n{p.stderr}")
    return exe


def interfaces(build: Path, unzip_root: Path, only=None):
    """(FMU name, interface, host arguments) of every interface of the build's FMUs."""
    from fmpy import extract, read_model_description

    fmus = sorted((Path(build) / "fmu").glob("*.fmu"))
    if only:
        fmus = [p for p in fmus if p.stem in only]
        missing = set(only) - {p.stem for p in fmus}
        if missing:
            raise FileNotFoundError(f"not built in {build}/fmu: {sorted(missing)}")
    out = []
    for path in fmus:
        md = read_model_description(str(path))
        unzip = Path(extract(str(path), unzipdir=str(Path(unzip_root) / path.stem)))
        reals = ",".join(str(v.valueReference) for v in md.modelVariables if v.type == "Real")
        for kind, iface in (("me", md.modelExchange), ("cs", md.coSimulation)):
            if iface is not None:
                binary = unzip / "binaries" / "linux64" / f"{iface.modelIdentifier}.so"
                out.append((path.stem, kind, [str(binary), iface.modelIdentifier, md.guid, kind, reals,
                                              str(md.numberOfContinuousStates), str(md.numberOfEventIndicators)]))
    return out


def run(build: Path, only=None, workers: int = 2) -> list[dict]:
    """One summary per FMU interface: the host's counters, its exit code, wall time, stderr tail."""
    with tempfile.TemporaryDirectory() as tmp:
        exe = compile_host(Path(tmp))

        def one(item):
            name, kind, argv = item
            t0 = time.perf_counter()
            p = subprocess.run([str(exe), *argv], capture_output=True, text=True, timeout=1800)
            row = {"fmu": name, "type": kind, "exit": p.returncode, "seconds": time.perf_counter() - t0,
                   "stderr": p.stderr[-800:]}
            if p.stdout.strip():
                row.update(json.loads(p.stdout.strip().splitlines()[-1]))
            # 0/1: the host ran every case (1: problems counted); 2: it could not go on (an FMU
            # that cannot be initialized or give a good state); 3 or a signal: a crash.
            row["crashed"] = p.returncode == 3 or p.returncode < 0
            row["stopped"] = p.returncode == 2
            return row

        with ThreadPoolExecutor(max_workers=workers) as pool:
            return list(pool.map(one, interfaces(build, tmp, only)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", type=Path, default=REPO / "build", help="CMake build directory (default build/)")
    ap.add_argument("--fmus", default="", help="comma-separated FMU names (default: every FMU of the build)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", action="store_true", help="print the summaries as JSON instead of a table")
    a = ap.parse_args(argv)
    rows = run(a.build, [s for s in a.fmus.split(",") if s] or None, a.workers)
    if a.json:
        print(json.dumps(rows))
    else:
        cols = ("cases", "accepted", "refused", *PROBLEMS)
        print(f"| FMU | interface | {' | '.join(cols)} | crashed | s |")
        print("| --- | --- |" + " ---: |" * (len(cols) + 2))
        status = {True: "yes", False: "no"}
        for r in rows:
            vals = " | ".join(str(r.get(c, "-")) for c in cols)
            crashed = "stopped" if r["stopped"] else status[r["crashed"]]
            print(f"| {r['fmu']} | {r['type'].upper()} | {vals} | {crashed} | {r['seconds']:.1f} |")
        total = {c: sum(r.get(c, 0) for r in rows) for c in cols}
        print(f"| all | | {' | '.join(str(total[c]) for c in cols)} | {sum(r['crashed'] for r in rows)} | "
              f"{sum(r['seconds'] for r in rows):.1f} |")
        for r in rows:
            if r["crashed"] or r["stopped"]:
                print(f"{r['fmu']} {r['type']}: {r['stderr'].strip()}", file=sys.stderr)
    bad = any(r["crashed"] or r["exit"] or any(r.get(c) for c in PROBLEMS) for r in rows)
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
