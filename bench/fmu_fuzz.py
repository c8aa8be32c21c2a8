"""The call-sequence fuzz (tests/fmu/fuzz_driver.py) on every FMU of a build, FMI 2.0 and 3.0.

    .venv/bin/python bench/fmu_fuzz.py                          # every FMU, both versions, 2,000 cases each
    .venv/bin/python bench/fmu_fuzz.py --fmi 3 --cases 2000     # the FMI 3.0 FMUs only
    .venv/bin/python bench/fmu_fuzz.py --fmus PKM_6PUS,PKM_EMPS --json

Each FMU runs in its own subprocess (a crash is a row, not the end of the run): random call
sequences with hostile parameters, starts, inputs, step sizes and continuous states.  The
columns count cases, calls, refusals (an FMI status other than OK), Model Exchange cases and
derivative evaluations that succeeded, and values that are not finite returned with OK (must
be 0).  The suite runs 2,000 cases on two FMI 2.0 FMUs and 500 on two FMI 3.0 FMUs
(tests/fmu/test_fuzz.py); this runs them all.
"""
import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DRIVER = REPO / "tests" / "fmu" / "fuzz_driver.py"


def run(path: Path, seed: int, cases: int) -> dict:
    t = time.perf_counter()
    p = subprocess.run([sys.executable, str(DRIVER), str(path), str(seed), str(cases)], capture_output=True,
                       text=True)
    row = {"fmu": path.stem, "fmi": 3 if path.parent.name == "fmi3" else 2, "exit": p.returncode,
           "seconds": round(time.perf_counter() - t, 1)}
    if p.returncode in (0, 1) and p.stdout.strip():
        row.update(json.loads(p.stdout.strip().splitlines()[-1]))
    else:
        row["error"] = p.stderr.strip()[-300:]
    return row


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=str(REPO / "build"))
    ap.add_argument("--fmi", default="2,3", help="FMI versions: 2, 3 or 2,3")
    ap.add_argument("--fmus", default="", help="comma-separated identifiers (default: all)")
    ap.add_argument("--cases", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    folder = Path(a.build) / "fmu"
    wanted = {s for s in a.fmus.split(",") if s}
    paths = []
    for v in a.fmi.split(","):
        d = folder if v.strip() == "2" else folder / "fmi3"
        paths += [p for p in sorted(d.glob("*.fmu")) if not wanted or p.stem in wanted]
    rows = [run(p, a.seed + k, a.cases) for k, p in enumerate(paths)]
    if a.json:
        print(json.dumps(rows, indent=1))
    else:
        cols = ["fmu", "fmi", "exit", "cases", "calls", "refused", "me_cases", "derivatives_ok", "ok_nonfinite",
                "seconds"]
        print("| " + " | ".join(cols) + " |")
        print("|" + "---|" * len(cols))
        for r in rows:
            print("| " + " | ".join(str(r.get(c, r.get("error", "-") if c == "cases" else "-")) for c in cols) + " |")
    bad = [r for r in rows if r["exit"] != 0 or r.get("ok_nonfinite")]
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
