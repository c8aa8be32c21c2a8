"""fmpy's validation (``fmpy.validation.validate_fmu``: the modelDescription.xml against the
standard's schema and fmpy's checks) of every FMU the build made, FMI 2.0 (``build/fmu``) and
FMI 3.0 (``build/fmu/fmi3``), plant and controller: one row per FMU with its problems.

    .venv/bin/python bench/fmu_validate.py          # about 30 s for all

The suite validates a few of them (tests/fmu/test_model_description.py, tests/fmu/test_fmi3.py);
this command checks all.  Exits 1 if any FMU has a problem.
"""
import sys
import time
from pathlib import Path

from fmpy.validation import validate_fmu

from cosim import fmu


def main() -> int:
    root = fmu.build_dir() / "fmu"
    paths = sorted(root.glob("*.fmu")) + sorted((root / "fmi3").glob("*.fmu"))
    if not paths:
        print(f"no FMU in {root}: run ./scripts/bootstrap.sh first", file=sys.stderr)
        return 2
    print(f"| FMU | FMI | problems | time [s] |\n| --- | --- | --- | --- |")
    bad = 0
    for p in paths:
        t0 = time.perf_counter()
        problems = validate_fmu(str(p))
        bad += bool(problems)
        version = "3.0" if p.parent.name == "fmi3" else "2.0"
        shown = "; ".join(problems[:3]) if problems else "0"
        print(f"| {p.stem} | {version} | {shown} | {time.perf_counter() - t0:.1f} |")
    print(f"\n{len(paths)} FMUs, {bad} with problems")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
