"""Corrupted serialized FMU states, every FMU of the build, both interfaces.

A compiled C host (tests/fmu/state_fuzz.c, built here with the FMI headers fmpy ships) takes
two good states of each FMU interface (just instantiated; initialized and stepped), and puts
each of NaN, +-Inf, 0, -1, 1e4, 1e9, 1e300 and a denormal into every 8-byte word of the
serialized block in turn, as corrupted and with its checksum sealed again, into the same
instance and into a fresh one.  Accepted states are used (every Real read, a step taken or the
Model Exchange states, derivatives and indicators read).  Nothing may crash, return a value
that is not finite with fmi2OK, refuse without a message through the logger, or keep an
instance from being put back to a good state.
"""
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
from fmpy import extract, read_model_description

from cosim import fmu

DRIVER_SOURCE = Path(__file__).with_name("state_fuzz.c")


@pytest.fixture(scope="module")
def driver(tmp_path_factory):
    import fmpy

    headers = Path(fmpy.__file__).parent / "c-code"
    exe = tmp_path_factory.mktemp("state_fuzz") / "state_fuzz"
    p = subprocess.run(["cc", "-O2", "-std=c11", "-D_DEFAULT_SOURCE", "-Wall", "-Werror", "-I", str(headers),
                        str(DRIVER_SOURCE), "-o", str(exe), "-ldl", "-lm"], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    return exe


def _runs(tmp_path):
    """(FMU name, argv) of every interface of every built FMU."""
    fmus = sorted((fmu.build_dir() / "fmu").glob("*.fmu"))
    assert fmus, f"no FMU in {fmu.build_dir() / 'fmu'}: run ./scripts/bootstrap.sh"
    runs = []
    for path in fmus:
        md = read_model_description(str(path))
        unzip = extract(str(path), unzipdir=str(tmp_path / path.stem))
        reals = ",".join(str(v.valueReference) for v in md.modelVariables if v.type == "Real")
        for kind, iface in (("me", md.modelExchange), ("cs", md.coSimulation)):
            if iface is None:
                continue
            binary = Path(unzip) / "binaries" / "linux64" / f"{iface.modelIdentifier}.so"
            runs.append((f"{path.stem} {kind}", [str(binary), iface.modelIdentifier, md.guid, kind, reals,
                                                 str(md.numberOfContinuousStates),
                                                 str(md.numberOfEventIndicators)]))
    return runs


def test_corrupted_states_never_crash_nor_poison_an_instance(driver, tmp_path):
    def run(item):
        name, argv = item
        p = subprocess.run([str(driver), *argv], capture_output=True, text=True, timeout=600)
        return name, p

    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(run, _runs(tmp_path)))
    total, accepted, problems = 0, 0, []
    for name, p in results:
        if p.returncode not in (0, 1):
            problems.append(f"{name}: the host died (exit {p.returncode}): {p.stderr[-600:]}")
            continue
        s = json.loads(p.stdout.strip().splitlines()[-1])
        total += s["cases"]
        accepted += s["accepted"]
        if p.returncode or s["ok_nonfinite"] or s["silent_refusals"] or s["unrecoverable"]:
            problems.append(f"{name}: {s}: {p.stderr[-600:]}")
    assert not problems, "\n".join(problems)
    assert total >= 50_000, total
    # The sealed corruptions that stay valid (a parameter set to 0 or 1e4 where that is in
    # range, a time moved) were accepted and then used; the rest refused.
    assert 0 < accepted < total / 2, (accepted, total)
