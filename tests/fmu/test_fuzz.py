"""A seeded fuzz run of both plant FMUs (tests/fmu/fuzz_driver.py in a subprocess, so a
crash fails the test instead of killing pytest): 2,000 cases each of random call
sequences with hostile values (huge, tiny, denormal, NaN, inf, negative parameters,
starts, inputs, step sizes, continuous states); no crash, and no value that is not
finite returned with status OK.  (The FMUs before the finiteness checks failed this:
322 Quattro and 12 6-PUS cases with the same seeds.)"""
import json
import subprocess
import sys
from pathlib import Path

import pytest

from cosim import fmu

DRIVER = Path(__file__).with_name("fuzz_driver.py")


@pytest.mark.parametrize("robot,seed", [("6pus", 1), ("quattro", 2)])
def test_fuzzed_fmu_never_crashes_nor_returns_a_non_finite_value_with_ok(robot, seed):
    path = fmu.fmu_path(robot)
    p = subprocess.run([sys.executable, str(DRIVER), str(path), str(seed), "2000"], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode in (0, 1), f"the fuzz driver died (exit {p.returncode}): {p.stderr[-2000:]}"
    stats = json.loads(p.stdout.strip().splitlines()[-1])
    assert stats["cases"] == 2000
    assert stats["refused"] > 500, stats          # the hostile values were exercised and refused
    # each case made a sequence of calls (~10 a case; fewer since a non-zero sensor.delay, one of the fuzzed
    # parameters, is refused at initialization)
    assert stats["calls"] > 9 * stats["cases"]
    assert stats["ok_nonfinite"] == 0, stats["examples"]
    assert p.returncode == 0
