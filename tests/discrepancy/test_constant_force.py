"""A constant force on one rail (a cable carrier pulling one way), hidden in MuJoCo's physics of
the 6-PUS: the library's constant effort offset on that rail is this physics, and is what is named.

The rail carries gravity, so its command keeps one sign and never comes near zero: a drive dead
zone (u - u0 sgn(u) beyond +-u0) is then the same constant on this recording, its column the
offset's to rounding.  The offset is named (a constant is all the recording shows), the dead zone
stays its tie."""
import sys
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import discovery_mujoco_bench as dmb  # noqa: E402
import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402
from cosim.recording import read_recording  # noqa: E402


def test_a_constant_force_on_a_one_signed_rail_is_named_the_offset(tmp_path):
    m = Model("6pus")
    seed, duration = 331, 3.0
    force, truth, joints = dmb.draw("constant_force", np.random.default_rng(seed), dmb.motion(m, seed, duration),
                                    m.ik(m.home()))
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, duration, blind.load_config()["noise"]["6pus"], force=force)
    csv = mb.write_case(m, rec, tmp_path / "run.csv")
    (j,) = joints
    # the case this is about: the rail's command keeps one sign, further from zero than the force
    tau = np.asarray(read_recording(csv).tau)[:, j - 1]
    want = truth[f"rail[{j}].force_c"]
    assert min(np.mean(tau > 0), np.mean(tau < 0)) == 0 and np.abs(tau).min() > abs(want)
    d = diagnose(csv, figures=False, replay=False)
    assert d.named()[:1] == ["offset"], d.conclusion
    assert not d.discovered, d.conclusion
    assert set(d.theta) == {f"rail[{j}].offset"}, d.theta
    # the bench's convention: the force on the rail is the offset the drive is missing
    assert abs(d.theta[f"rail[{j}].offset"] / want - 1) < 0.15, (d.theta, truth)
    assert "dead_zone" in d.ties("offset"), d.conclusion
