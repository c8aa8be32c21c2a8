"""A second FMI 3.0 importer: the tests' own host built for FMI 3.0 (tests/fmu/host/fmi_host.c
as fmi3_host), natively and, cross-compiled, under Wine (x86_64-windows) and QEMU
(aarch64-linux).  It runs the FMI 3.0 plant and controller FMUs through the scripts of the
FMI 2.0 platform tests (a closed PD step with the FMU states saved, serialised and restored,
a refused NaN effort; the plant as Model Exchange) and prints the FMI 2.0 FMUs' numbers and
messages (the FMI 2.0 host on the FMI 2.0 FMUs, linux64, is the reference)."""
import numpy as np
import pytest

from platform_host import PLATFORMS, as_fmi3, fmu_pair, largest_difference, loop_script, me_script, run

CASES = [("6pus", p) for p in PLATFORMS] + [("hexapod_ups", "linux64")]


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The FMI 2.0 host on the FMI 2.0 FMUs (linux64): the loop and the Model Exchange run."""
    out = {}
    for robot in sorted({r for r, _ in CASES}):
        folder = tmp_path_factory.mktemp(robot + "_fmi2")
        plant, ctrl = fmu_pair(robot, folder)
        out[robot] = (run("linux64", loop_script(plant, ctrl, robot, "linux64"), folder),
                      run("linux64", me_script(plant, robot, "linux64"), folder))
    return out


@pytest.mark.parametrize("robot,platform", CASES)
def test_fmi3_host_runs_the_fmi3_fmus_as_fmi2(reference, robot, platform, tmp_path):
    plant, ctrl = fmu_pair(robot, tmp_path, fmi=3)
    loop = run(platform, loop_script(plant, ctrl, robot, platform), tmp_path, fmi=3)
    me = run(platform, me_script(plant, robot, platform), tmp_path, fmi=3)
    for got, ref in zip((loop, me), reference[robot]):
        assert len(got["values"]) == len(ref["values"]) and got["values"]
        assert largest_difference(ref, got) <= 1e-12
        assert got["lines"] == as_fmi3(ref["lines"])
    # the restore went back, bit for bit
    np.testing.assert_array_equal(loop["values"][4], loop["values"][2])
    np.testing.assert_array_equal(me["values"][2], me["values"][1])
    assert np.max(np.abs(loop["values"][2][1:] - loop["values"][0][1:])) > 1e-4  # the PD step moved it
    # the NaN effort is an Error with the FMU's message
    assert "status setReal Error" in loop["lines"]
    assert any(ln.startswith("log plant Error logStatusError: fmi3SetFloat64") and "tau[1] = nan" in ln
               for ln in loop["lines"]), loop["lines"]
