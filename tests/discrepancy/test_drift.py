"""Drifts: a friction that falls over the recording and a payload changed half way are reported
as a trend and a step with their size and time; a constant effect is not.  6-PUS recordings
simulated by the core in closed loop, the plant's parameters changed between pieces of the run
(the state and the controller carried over), with the blind generator's sensor noise."""
import dataclasses

import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy import blind, diagnose
from cosim.discrepancy.excitation import excitation
from cosim.discrepancy.runs import closed_loop
from cosim.master import make_reference
from cosim.recording import Recording

DT, LEAD, DURATION = 1e-3, 0.5, 6.0


def _record(params_at, pieces, seed=11):
    """A recording whose plant has ``params_at(k)`` over piece k of ``pieces`` equal pieces."""
    cfg = blind.load_config()
    m = Model("6pus")
    traj = excitation(m, DURATION, seed=seed, lead_in=LEAD)
    ref = make_reference(m, traj, step=DT, duration=round(traj.duration / DT) * DT)
    ctrl = blind._controller("pd_gravity", m, cfg, DT)
    k0, n = int(LEAD / DT), len(ref.time)
    edges = [0] + [k0 + round(i * (n - k0) / pieces) for i in range(1, pieces)] + [n]
    parts, x0, xd0 = [], None, None
    for k, (a, b) in enumerate(zip(edges[:-1], edges[1:])):
        plant = m.copy()
        plant.set_params(params_at(k))
        sub = dataclasses.replace(ref, **{f.name: getattr(ref, f.name)[:b + 1] for f in dataclasses.fields(ref)
                                          if isinstance(getattr(ref, f.name), np.ndarray)})
        hist = (np.concatenate([p.q for p in parts]), np.concatenate([p.qd for p in parts])) if parts else None
        res = closed_loop(plant, blind._controller("pd_gravity", m, cfg, DT), sub, x0=x0, xd0=xd0, start=a,
                          noise=cfg["noise"]["6pus"], seed=seed + 17 * k, history=hist)
        parts.append(res.head(b - a) if k < pieces - 1 else res)
        if k < pieces - 1:
            x0, xd0 = res.x[b - a], res.xd[b - a]
    cat = {f: np.concatenate([getattr(p, f) for p in parts]) for f in ("time", "q", "qd", "tau_logged", "pose")}
    s = slice(k0, None)
    return Recording("6pus", cat["time"][s], cat["q"][s], cat["qd"][s], cat["tau_logged"][s], qref=ref.q[s],
                     pose=cat["pose"][s], controller=dict(ctrl.describe(), rate_hz=1000.0)), edges


def test_a_friction_falling_over_the_recording_is_a_trend_with_its_size():
    pieces, c0, c1 = 12, 0.12, 0.04  # N, rail 2's Coulomb friction as the drive warms up

    def at(k):
        return {"rail[2].coulomb": c0 + (c1 - c0) * (k + 0.5) / pieces}
    rec, _ = _record(at, pieces)
    d = diagnose(rec, figures=False, replay=False, discovery=False, platform=False)
    assert "rail[2].coulomb" in d.theta, d.conclusion
    dr = {x.param: x for x in d.drifts}
    assert "rail[2].coulomb" in dr, d.conclusion
    x = dr["rail[2].coulomb"]
    assert x.kind == "trend"
    # the staircase's change from the first piece's centre to the last's, over the recording's length
    want = (c1 - c0) * (pieces - 1) / pieces * (rec.time[-1] - rec.time[0]) / (DURATION - LEAD)
    assert abs(x.size - want) < 0.2 * abs(want), (x.size, want)
    assert abs(x.size - want) < max(x.ci95, 0.05 * abs(want)) * 3
    assert len(x.windows["value"]) == 6 and x.windows["value"][0] > x.windows["value"][-1]
    assert "drift: rail[2].coulomb drifts from" in d.details
    assert "a drift of rail[2].coulomb (a trend)" in d.conclusion


def test_a_payload_changed_half_way_is_a_step_at_its_time():
    rec, edges = _record(lambda k: {"payload.m": 0.0 if k == 0 else 0.1}, 2)
    t_step = edges[1] * DT
    d = diagnose(rec, figures=False, replay=False, discovery=False, platform=False)
    steps = [x for x in d.drifts if x.kind == "step" and x.param in ("payload.m", "platform.m")]
    assert steps, d.conclusion
    x = steps[0]
    assert abs(x.size - 0.1) < 0.015, x.equation
    assert abs(x.time - t_step) < 0.25, (x.time, t_step)


@pytest.mark.parametrize("seed", [12])
def test_a_constant_friction_is_no_drift(seed):
    rec, _ = _record(lambda k: {"rail[2].coulomb": 0.08}, 1, seed=seed)
    d = diagnose(rec, figures=False, replay=False, discovery=False, platform=False)
    assert "rail[2].coulomb" in d.theta, d.conclusion
    assert not d.drifts, [x.equation for x in d.drifts]
