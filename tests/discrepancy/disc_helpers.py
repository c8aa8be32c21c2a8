"""Helpers of the discrepancy-engine tests: plants with hidden effects, closed-loop runs."""
import copy
import types

import numpy as np

from cosim.core import Model
from cosim.discrepancy import blind
from cosim.discrepancy.excitation import excitation
from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.motion import MOTION
from cosim.discrepancy.runs import closed_loop
from cosim.master import make_reference


#: hidden effects of the combined noiseless runs (one plant holding many effects)
COMBINED = {
    "6pus": {"rail[1].coulomb": 0.03, "rail[2].viscous": 0.5, "rail[3].rotor_inertia": 0.05,
             "rail[1].stribeck": 0.03, "rail[1].stribeck_v": 0.004, "rail[4].backlash": 5e-5,
             "rail[2].compliance": 8e-5, "rail[3].encoder_offset": 6e-5, "payload.m": 0.05, "payload.x": 0.01,
             "payload.y": -0.008, "payload.z": 0.01, "gravity.x": 0.1, "gravity.y": -0.08,
             "actuator.delay": 0.003, "sensor.delay": 0.002, "leg[4].L": 0.1162, "platform.Izz": 0.00062,
             "platform.m": 0.38},
    "quattro": {"arm[1].coulomb": 0.3, "arm[2].viscous": 0.1, "arm[3].rotor_inertia": 0.20275 + 0.025,
                "arm[1].stribeck": 0.3, "arm[1].stribeck_v": 0.02, "arm[4].backlash": 1e-3,
                "arm[2].compliance": 8e-5, "arm[3].encoder_offset": 1.2e-3, "payload.m": 0.1,
                "gravity.x": 0.1, "gravity.y": -0.08, "actuator.delay": 0.003, "sensor.delay": 0.002,
                "leg[1].L": 0.826, "leg[2].L": 0.826, "leg[3].L": 0.826, "leg[4].L": 0.826, "platform.m": 0.314},
}


def run(robot, hidden=None, duration=3.0, seed=5, noise=None, scale=1.0):
    """A closed-loop recording of a plant with ``hidden`` parameters (PD + gravity
    compensation designed on the nominal model), after a 0.5 s lead-in."""
    cfg = blind.load_config()
    m = Model(robot)
    traj = excitation(m, duration, seed=seed, scale=scale)
    ref = make_reference(m, traj, step=1e-3, duration=round(traj.duration / 1e-3) * 1e-3)
    plant = m.copy()
    if hidden:
        plant.set_params(hidden)
    ctrl = blind._controller("pd_gravity", m, cfg, 1e-3)
    res = closed_loop(plant, ctrl, ref, noise=noise, seed=seed)
    k0 = 500
    return res.to_recording(effort="logged", start=k0, qref=ref.q, controller=ctrl.describe())


#: the fixed-seed blind subset: (robot, hidden types, seed)
SUBSET = [
    ("6pus", ["coulomb"], 101),
    ("6pus", ["payload"], 102),
    ("6pus", ["actuator_delay"], 103),
    ("6pus", ["encoder_offset"], 104),
    ("6pus", ["saturation"], 105),
    ("6pus", ["stribeck"], 106),
    ("6pus", [], 107),
    ("6pus", [], 108),
    ("quattro", ["rotor_inertia"], 109),
    ("quattro", [], 110),
]


def strip_pose(rec):
    """The same recording without its tracker columns."""
    r = copy.copy(rec)
    r.pose = None
    return r


def rms(a, axis=0):
    return np.sqrt(np.mean(np.asarray(a) ** 2, axis=axis))


def stage_groups() -> set:
    """The group names the flexible stage gives a 6-slider recording with a pose and a reference
    (its inputs on a made-up recording: only the names are read), and the group a channel's fit
    adds where the reference's platform acceleration explains it: a declaration's vocabulary."""
    n, dt = 400, 1e-3
    t = np.arange(n) * dt
    rng = np.random.default_rng(0)
    q = np.cumsum(rng.normal(size=(n, 6)), axis=0) * 1e-4
    pipe = types.SimpleNamespace(
        idx=np.arange(20, n - 20, 10), nd=6, t=t, segments=[(0, n)], dt=dt, tau_s=rng.normal(size=(n, 6)),
        q_s=q, qd_s=np.gradient(q, dt, axis=0), qdd_s=rng.normal(size=(n, 6)), has_pose=True,
        x_s=rng.normal(size=(n, 6)), channels=[f"tau{i}" for i in range(1, 7)], S=lambda a, deriv=0: a,
        rec=types.SimpleNamespace(qref=q),
        model=types.SimpleNamespace(facts=types.SimpleNamespace(joint_noun="slider", joint_unit="m", effort_unit="N")))
    _, cols = flexible.inputs(pipe, np.zeros((len(pipe.idx), 6)), direction=True)
    return set(flexible.input_groups(cols)) | {MOTION}


def check_declaration(kind, key, truth, joint, platform, vocabulary, own_inputs=True):
    """Assert that ``key``, the inputs a bench mechanism ``kind`` is declared keyed on, is
    well-formed in the stage's ``vocabulary`` (:func:`stage_groups`): need/any/allowed, something
    to meet, nothing outside what is allowed; a platform kind (in ``platform``) acts on no rail, a
    rail's force is on its joint and (``own_inputs``) names one of that rail's inputs."""
    assert set(key) == {"need", "any", "allowed"}, kind
    assert key["need"] or key["any"], kind  # a declaration that nothing meets judges nothing
    assert key["need"] <= key["allowed"] and key["any"] <= key["allowed"], kind
    assert key["allowed"] <= vocabulary, (kind, key["allowed"] - vocabulary)
    if kind in platform:
        assert joint is None and "rail" not in truth, kind
    else:  # a rail's force: its own inputs are named after the rail it acts on
        assert truth["rail"] in (joint if isinstance(joint, tuple) else (joint,)), kind
        if own_inputs:
            assert any(g.endswith(f"slider {truth['rail']}") for g in key["need"] | key["any"]), kind


def check_mechanism_acts(mb, m, seed, hook, edit, duration, kind):
    """A mechanism's ``hook``/``edit`` built for ``bench/foreign/mujoco_blind.simulate`` (``mb``)
    runs in MuJoCo over ``duration`` [s] without the effort noise and changes the recorded
    efforts against the same run without it."""
    import math

    noise = dict(blind.load_config()["noise"]["6pus"])
    noise = {k: (0.0 if np.isscalar(v) else [0.0] * len(v)) for k, v in noise.items()}  # the force alone differs
    rec, _ = mb.simulate(m, None, 0.0, 0, seed, duration, noise, hook=hook, edit=edit)
    clean, _ = mb.simulate(m, None, 0.0, 0, seed, duration, noise)
    tau, tau0 = np.asarray(rec.tau), np.asarray(clean.tau)
    assert np.isfinite(tau).all() and np.isfinite(np.asarray(rec.q)).all()
    assert tau.shape == tau0.shape
    # [N]: the mechanism acts, at a tenth of the effort noise (5 mN) or more (a run is
    # deterministic at its seed: a no-op differs by round-off)
    assert math.sqrt(np.mean((tau - tau0) ** 2)) > 5e-4, kind
