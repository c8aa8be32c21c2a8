"""Corrupted serialized FMU states (the C host tests/fmu/state_fuzz.c, driven by bench/state_fuzz.py).

Every 8-byte word of two good states per interface (just instantiated; initialized and stepped)
replaced in turn by NaN, +-Inf, 0, -1, 1e4, 1e9, 1e300 and a denormal, as corrupted and with the
checksum sealed again, into the same instance and into a fresh one; accepted states are used.
Nothing may crash, return a value that is not finite with fmi2OK, refuse without a message through
the logger, change an instance by a refused state, or keep it from going back to a good state.

The suite runs one FMU of each kind (hand-written plants with both interfaces, a described plant,
the test tree's toy, a hand-written and a described controller); `bench/state_fuzz.py` runs every
FMU of the build (docs/fmu.md gives its figures).
"""
import importlib.util
from pathlib import Path

from cosim import fmu

BENCH = Path(__file__).resolve().parents[2] / "bench" / "state_fuzz.py"
SUBSET = ["PKM_6PUS", "PKM_QUATTRO", "PKM_PLANAR_3RRR", "PKM_SLIDER_CRANK", "PKM_QUATTRO_CTRL",
          "PKM_PLANAR_3RRR_CTRL"]


def _bench():
    spec = importlib.util.spec_from_file_location("state_fuzz_bench", BENCH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_corrupted_states_never_crash_nor_poison_an_instance():
    bench = _bench()
    rows = bench.run(fmu.build_dir(), SUBSET)
    assert {(r["fmu"], r["type"]) for r in rows} >= {("PKM_6PUS", "me"), ("PKM_6PUS", "cs"),
                                                     ("PKM_QUATTRO_CTRL", "cs")}
    problems = [r for r in rows if r["crashed"] or r["exit"] or not r.get("checksum")
                or any(r.get(c) for c in bench.PROBLEMS)]
    assert not problems, problems
    total = sum(r["cases"] for r in rows)
    accepted = sum(r["accepted"] for r in rows)
    assert total >= 50_000, total
    # The sealed corruptions that stay valid (a parameter set to 0 or 1e4 where that is in
    # range, a time moved) were accepted and then used; the rest refused.
    assert 0 < accepted < total / 2, (accepted, total)
