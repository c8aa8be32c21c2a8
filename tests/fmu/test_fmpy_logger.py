"""fmpy formats FMU log messages in a native proxy that forwards to one process-wide
callback.  After ``cosim.fmu.simulate(..., logger=f)`` and after a master run of the
plant FMU, an FMU instantiated later with fmpy's default callbacks must still log through
fmpy's own printer: before :func:`cosim.fmu.restore_fmpy_logger` its error went to a freed
ctypes callback (a segmentation fault in a test run, or the message silently lost).  Run
in a subprocess so that a crash fails this test instead of killing pytest."""
import subprocess
import sys

SCRIPT = r"""
import ctypes, gc
import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from cosim import fmu
from cosim.master import FMUPlant

path = fmu.fmu_path("6pus")
log = []
try:
    fmu.simulate(path, stop_time=0.002, params={"platform.Izz": 9e-4}, logger=lambda *a: log.append(a))
except Exception:
    pass
assert any(b"platform.Izz" in a[4] for a in log), log   # the caller's logger got the FMU's error
with FMUPlant(path) as plant:
    pass
del log, plant
gc.collect()
junk = [ctypes.CFUNCTYPE(None)(lambda: None) for _ in range(5000)]   # reuse what was freed
md = read_model_description(str(path))
s = FMU2Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extract(str(path)),
              modelIdentifier=md.coSimulation.modelIdentifier, instanceName="late")
try:
    s.instantiate()
except Exception as e:
    print("refused:", e, flush=True)
"""


def test_a_later_default_logger_prints_the_fmus_error():
    p = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, f"exit {p.returncode}: {p.stderr[-2000:]}"
    # fmpy's own printer wrote the wrong-GUID error of the late instance
    assert "[ERROR] fmi2Instantiate: GUID {00000000-0000-0000-0000-000000000000} does not match" in p.stdout, p.stdout
    assert "refused: Failed to instantiate model" in p.stdout
