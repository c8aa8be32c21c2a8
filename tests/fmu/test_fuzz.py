"""A seeded fuzz run of the plant FMUs (tests/fmu/fuzz_driver.py in a subprocess, so a crash
fails the test instead of killing pytest): random call sequences with hostile values (huge,
tiny, denormal, NaN, inf, negative parameters, starts, inputs, step sizes, continuous
states); no crash, and no value that is not finite returned with status OK.  (The FMUs
before the finiteness checks failed this: 322 Quattro and 12 6-PUS cases with the same
seeds.)  The FMI 2.0 FMUs run 2,000 cases each here, the FMI 3.0 FMUs of the same binaries
500 (bench/fmu_fuzz.py runs 2,000 on every FMU of both versions)."""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from cosim import fmu

DRIVER = Path(__file__).with_name("fuzz_driver.py")


@pytest.mark.parametrize("robot,seed,fmi,cases", [("6pus", 1, 2, 2000), ("quattro", 2, 2, 2000),
                                                  ("6pus", 3, 3, 500), ("quattro", 4, 3, 500)])
def test_fuzzed_fmu_never_crashes_nor_returns_a_non_finite_value_with_ok(robot, seed, fmi, cases):
    path = fmu.fmu_path(robot, fmi=fmi)
    p = subprocess.run([sys.executable, str(DRIVER), str(path), str(seed), str(cases)], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode in (0, 1), f"the fuzz driver died (exit {p.returncode}): {p.stderr[-2000:]}"
    stats = json.loads(p.stdout.strip().splitlines()[-1])
    assert stats["cases"] == cases
    assert stats["refused"] > cases // 4, stats  # the hostile values were exercised and refused
    # each case made a sequence of calls (initialization counted as one; fewer since a non-zero
    # sensor.delay, one of the fuzzed parameters, is refused at initialization)
    assert stats["calls"] > 6 * stats["cases"]
    # Model Exchange was exercised: hostile continuous states set, derivatives evaluated
    assert stats["me_cases"] > cases // 8 and stats["derivatives_ok"] > cases // 20, stats
    assert stats["ok_nonfinite"] == 0, stats["examples"]
    assert p.returncode == 0
