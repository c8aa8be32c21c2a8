"""The FMU in an FMI importer not written here and not fmpy: OSP libcosim (PyPI
``libcosimpy``, installed by the project's requirements).  Driven by libcosim_driver.py
in its own process; its trajectory must equal the one fmpy's FMU2Slave produces with the
same inputs."""
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from cosim import fmu

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from libcosim_driver import OUTPUTS, input_sequence  # noqa: E402

H = 1e-3
N = 200


def _libcosim_and_fmpy(path, tau0, n, outputs, scale, tmp_path):
    """The same input sweep through libcosim (its own process) and fmpy's FMU2Slave: the
    libcosim run's record and the two output tables, (n, len(outputs)) each."""
    import libcosimpy  # noqa: F401  (a missing importer is a failure: it is in requirements.txt)

    out = tmp_path / "libcosim.json"
    r = subprocess.run([sys.executable, str(HERE / "libcosim_driver.py"), str(path), str(out), str(n), str(H),
                        json.dumps(tau0.tolist()), json.dumps(outputs), str(scale)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-2000:]
    got = json.loads(out.read_text())
    taus = input_sequence(tau0, n, H, scale)
    with fmu.FMUInstance(path) as f:
        ref = []
        for tau in taus:
            f.step(H, tau=tau)
            ref.append([f.get(v) for v in outputs])
    lc, ref = np.array(got["values"]), np.array(ref)
    assert lc.shape == ref.shape == (n, len(outputs))
    return got, lc, ref


def test_libcosim_runs_the_fmu_like_fmpy(fmu_file, model, tmp_path):
    tau0 = model.gravity_load(model.home())
    got, lc, ref = _libcosim_and_fmpy(fmu_file, tau0, N, OUTPUTS, 0.05, tmp_path)
    assert got["outputs"] == OUTPUTS
    np.testing.assert_array_equal(np.array(got["tau"]), input_sequence(tau0, N, H))
    assert np.max(np.abs(ref[-1] - ref[0])) > 1e-5  # the input sweep moved the platform
    # Same binary, same inputs, same steps: equal up to the importers' time arithmetic.
    assert np.max(np.abs(lc - ref)) < 1e-12


# The FMUs of the described robots (robots/robots.list), each in libcosim against fmpy: the
# description packed into the binary, compiled when libcosim instantiates it.
LISTED = [n.split("#")[0].strip() for n in (HERE.parents[1] / "robots" / "robots.list").read_text().splitlines()]
LISTED = [n for n in LISTED if n]


@pytest.mark.parametrize("robot", LISTED)
def test_libcosim_runs_the_described_fmus_like_fmpy(robot, tmp_path):
    from cosim.core import Model

    m = Model(robot)
    tau0 = m.gravity_load(m.home())
    # an effort that moves it: 2 % of its gravity load, or of its mass (a horizontal axis has no load)
    scale = 0.02 * max(1.0, float(np.abs(tau0).max()), float(np.diag(m.mass_matrix(m.home())).max()))
    outputs = list(m.facts.pose_names) + [f"q[{i}]" for i in range(1, m.ndof + 1)]
    _, lc, ref = _libcosim_and_fmpy(fmu.fmu_path(robot), tau0, 100, outputs, scale, tmp_path)
    assert np.max(np.abs(ref[-1] - ref[0])) > 1e-6  # the robot moved
    np.testing.assert_allclose(lc, ref, rtol=0, atol=1e-12)
