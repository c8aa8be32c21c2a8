"""The engine on recordings from Drake, a second simulator the project did not write.

A few cases of bench/foreign/drake_blind.py (which runs every effect type and clean cases):
the 6-PUS as a Drake MultibodyPlant built from the core's parameters (bench/foreign/drake_6pus.py),
first checked against the core's inverse dynamics, then a clean run, a run hiding a joint
damping in Drake's physics, one hiding a spring between a rail's drive and carriage and one
hiding a cable pulling the platform, diagnosed blind; the
truth is compared only afterwards.  pydrake
(``drake`` in requirements.txt) is required."""
import sys
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parents[2] / "bench"
sys.path[:0] = [str(BENCH / "foreign"), str(BENCH)]

import drake_6pus as d6  # noqa: E402
import drake_blind as db  # noqa: E402
import mujoco_blind as mb  # noqa: E402

from cosim.core import Model  # noqa: E402
from cosim.discrepancy import blind, diagnose  # noqa: E402

NOISE = blind.load_config()["noise"]["6pus"]


def _diagnosis(folder, effect, value, joint):
    """(truth, diagnosis) of a 6 s Drake recording of the 6-PUS hiding ``effect``."""
    m = Model("6pus")
    rec, truth = d6.simulate(m, effect, value, joint, seed=21, duration=6.0, noise=NOISE)
    csv = mb.write_case(m, rec, folder / "run.csv")  # the plant's joint zero is home: declared in the sidecar
    return truth, diagnose(csv, figures=False, replay=False)


def test_drakes_plant_moves_as_the_cores_inverse_dynamics_says():
    # a clean 3 s run at 0.1 ms: the forces Drake applied against the core's inverse dynamics
    # along Drake's motion, 0.004-0.015 of the 5 mN effort noise per rail (legs 1.5x heavier in
    # Drake: 9-18x the noise; Drake at 1 ms: up to 0.17x)
    ratio = db.model_check(Model("6pus"), seed=9050, duration=3.0, noise=NOISE)
    assert np.all(ratio < 0.1), ratio


def test_a_clean_drake_recording_is_called_clean(tmp_path):
    _, d = _diagnosis(tmp_path, None, 0.0, 0)
    assert d.named() == [] and d.conclusion == "no missing physics found", d.conclusion


def test_drakes_joint_damping_is_found_as_the_rails_viscous_friction(tmp_path):
    # 0.5 N s/m of damping on rail 3's prismatic joint (Drake's own joint damping)
    truth, d = _diagnosis(tmp_path, "viscous", 0.5, 2)
    assert d.named()[0] == "viscous", d.conclusion
    est = d.plant_parameters()["rail[3].viscous"]
    assert abs(est - truth["rail[3].viscous"]) < 0.10 * truth["rail[3].viscous"], (est, truth)


def test_a_cable_on_drakes_platform_is_found_as_the_engines_platform_cable(tmp_path):
    # 0.4 N of constant tension from the platform to an anchor drawn 0.2-0.5 m away (Drake's
    # applied spatial force, its direction renewed every step), a 4 s recording: found once for
    # the whole robot as a cable (on this seed tension within 0.13 %, anchor within 2.4 % of its
    # distance), no library effect named in its place
    m = Model("6pus")
    rec, truth = d6.simulate(m, "cable", 0.4, 0, seed=21, duration=4.0, noise=NOISE)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    found, tension_error, anchor_error = db.cable_found(d, truth)
    assert found and d.named() == [], d.conclusion
    assert tension_error < 0.10 and anchor_error < 0.15, (tension_error, anchor_error)


def _changes(m, seed, duration, quiet, kinds):
    """Per kind, the efforts' change from a clean noise-free run on Drake and on MuJoCo, the
    mechanism drawn once per simulator: Drake's through drake_unlisted's hook or body (a model
    edit of MuJoCo's case built as a force of Drake's state or as the same body), MuJoCo's as its
    case runs it."""
    import drake_unlisted as du
    import mujoco_unlisted as mu

    clean_drake = d6.simulate(m, None, 0.0, 0, seed, duration, quiet)[0].tau
    clean_mujoco = mb.simulate(m, None, 0.0, 0, seed, duration, quiet)[0].tau
    out, mo = {}, mu.motion(m, seed)
    for kind in kinds:
        hook, edit = mu.draw(kind, np.random.default_rng(seed), m, mo)[:2]
        drake_hook, body = du.drawn(kind, np.random.default_rng(seed), m, mo)[:2]
        on_drake = d6.simulate(m, None, 0.0, 0, seed, duration, quiet, body=body,
                               load=du.load_of(drake_hook))[0].tau
        on_mujoco = mb.simulate(m, None, 0.0, 0, seed, duration, quiet, hook=hook, edit=edit)[0].tau
        out[kind] = (on_drake - clean_drake, on_mujoco - clean_mujoco)
    return out


def test_an_unlisted_mechanisms_hook_acts_on_drakes_plant_as_on_mujocos():
    # bench/foreign/drake_unlisted.py runs mujoco_unlisted's hooks on Drake through a view of
    # Drake's state in MuJoCo's fields: noise-free 1.5 s runs, the efforts' change from a clean
    # run on each simulator, Drake's against MuJoCo's; a spindle's moment on the platform (a
    # torque written in xfrc_applied, of the platform's rotation and angular rate) and a pump's
    # pulses on a rail (the hook's returned rail force).  Seed 91998: changes of 19 mN
    # and 0.25 N RMS on the most affected rail (the effort noise is 5 mN), the two simulators
    # within 0.2 mN of each other.  Two kinds MuJoCo builds by editing its model, built on Drake as
    # forces of its state (drake_unlisted.drake_hook): a damper between rails 1 and 2 (MuJoCo's
    # fixed tendon; 0.11 N, within 0.14 mN) and a coiled cord from carriage 2 to the platform
    # (MuJoCo's spatial tendon with stiffness; 6.4 mN, within 5 uN); a pendulum hung in the
    # platform, the same body on Drake's ball joint (37 mN, within 10 uN); a flexure in leg 2's
    # ball joint (MuJoCo's ball stiffness and damping; on Drake moments between the leg and its
    # carriage, drake_unlisted.drake_load: 0.25 N, within 5 uN); and that joint's dry friction
    # (5.7 mN m, a moment on the ball's dofs on both: 40 mN, within 20 uN)
    m = Model("6pus")
    quiet = {k: [0.0] * len(v) if isinstance(v, list) else 0.0 for k, v in NOISE.items()}
    rms = lambda x: np.sqrt(np.mean(np.square(x), axis=0))  # noqa: E731
    changes = _changes(m, 91998, 1.5, quiet, ("gyro_spindle", "pulse_pump", "coupling_damper", "coiled_cord", "slosh",
                                           "flexure_joint", "ball_joint_friction"))
    for kind, (on_drake, on_mujoco) in changes.items():
        assert rms(on_mujoco).max() > 0.005, (kind, rms(on_mujoco))
        assert rms(on_drake - on_mujoco).max() < 0.02 * rms(on_mujoco).max(), (kind, rms(on_drake), rms(on_mujoco))


def test_a_loose_payload_moves_drakes_rails_as_mujocos():
    # noise-free 3 s runs, seed 91998, the efforts' change from a clean run on each simulator: a
    # payload loose in a tray on the platform (a mass on a slide joint, limits at +-play, dry
    # friction; on Drake SAP's limits and the friction a smooth sign of the joint's rate,
    # drake_unlisted.drake_load): 20-57 mN RMS per rail, Drake's within 4 % of MuJoCo's (the
    # slides start at other instants: sample by sample the changes differ by 35 % of their size)
    m = Model("6pus")
    quiet = {k: [0.0] * len(v) if isinstance(v, list) else 0.0 for k, v in NOISE.items()}
    rms = lambda x: np.sqrt(np.mean(np.square(x), axis=0))  # noqa: E731
    on_drake, on_mujoco = map(rms, _changes(m, 91998, 3.0, quiet, ("loose_payload",))["loose_payload"])
    assert on_mujoco.max() > 0.01 and np.all(np.abs(on_drake - on_mujoco) < 0.1 * on_mujoco), (on_drake, on_mujoco)


def test_drakes_prismatic_spring_between_drive_and_carriage_is_found_as_the_rails_compliance(tmp_path):
    # rail 2 made two bodies in Drake (the drive on the rail's joint, read by the encoder and
    # driven by the motor; the carriage on a relative prismatic joint): 8e-5 m/N as Drake's
    # PrismaticSpring on that joint, a 4 s recording whose sidecar declares the drive's mass as
    # the rail's rotor inertia; the compliance found within 15 %
    m = Model("6pus")
    rec, truth = d6.simulate(m, "compliance", 8e-5, 1, seed=21, duration=4.0, noise=NOISE)
    d = diagnose(mb.write_case(m, rec, tmp_path / "run.csv"), figures=False, replay=False)
    assert d.named()[0] == "compliance", d.conclusion
    est = d.plant_parameters()["rail[2].compliance"]
    assert abs(est - truth["rail[2].compliance"]) < 0.15 * truth["rail[2].compliance"], (est, truth)


def test_a_soft_pad_on_drake_pushes_the_platform_back_only_past_the_pad():
    # drake_unlisted.drake_hook's soft pad (MuJoCo's sphere-on-plane contact as a force of Drake's
    # state): 250 N/m past the pad at z = 0.31 m on the +z side; 2 mm past it and still, a push of
    # 0.5 N down; moving in at 0.1 m/s, 0.3 N more; 1 mm short of it, or moving out faster
    # than the spring pushes, nothing
    from types import SimpleNamespace

    import drake_unlisted as du
    import mujoco_unlisted as mu

    pad = du.drake_hook("soft_stop", {"axis": "z", "side": 1.0, "at": 0.31, "stiffness": 250.0}, Model("6pus"))
    model = SimpleNamespace(body=lambda name: SimpleNamespace(id=1))

    def push(z, vz):
        data = SimpleNamespace(xpos=np.array([[0, 0, 0], [0.01, -0.02, z]], float),
                               xmat=np.tile(np.eye(3).ravel(), (2, 1)),
                               qvel=np.array([0, 0, vz, 0, 0, 0], float), xfrc_applied=np.zeros((2, 6)))
        pad(model, data, 0.0, np.zeros(6), np.zeros(6), np.zeros(6))
        return data.xfrc_applied[1]

    assert np.allclose(push(0.312, 0.0), [0, 0, -0.5, 0, 0, 0])
    assert np.allclose(push(0.312, 0.1), [0, 0, -0.5 - mu.PAD_DAMPING * 0.1, 0, 0, 0])
    assert np.allclose(push(0.309, 0.0), 0.0)
    assert np.allclose(push(0.312, -1.0), 0.0)

