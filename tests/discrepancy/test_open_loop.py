"""Open-loop experiments (cosim.discrepancy.open_loop): a torque run of a described axis (the EMPS
carriage) with no controller and no reference, simulated by the core with a hidden friction and
noisy readings, diagnosed and replayed open loop by multiple shooting.

The oracle is the simulated plant: the fitted model must replay the held-out motion closer than
the nominal (frictionless) one, and the replay must say which method it ran."""
import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy import diagnose
from cosim.discrepancy.open_loop import open_loop_replay
from cosim.plants import CorePlant
from cosim.recording import Recording, write_recording

HIDDEN = {"rail[1].coulomb": 20.0, "rail[1].viscous": 150.0}


def torque_run(duration=5.0, dt=1e-3, seed=3, noise=(1e-6, 2e-4, 0.3), hidden=None):
    """Torque steps of random height and length, each followed by its mirror image (the carriage
    comes back: no controller keeps it inside its stroke), simulated by the core's plant."""
    rng = np.random.default_rng(seed)
    plant = Model("emps")
    plant.set_params(HIDDEN if hidden is None else hidden)
    n = int(round(duration / dt)) + 1
    t = np.arange(n) * dt
    tau = np.zeros(n)
    k = 0
    while k < n:
        a, d = rng.uniform(35.0, 90.0), int(rng.uniform(0.15, 0.4) / dt)
        tau[k:k + d], tau[k + d:k + 2 * d] = a, -a
        k += 2 * d
    p = CorePlant(plant, rtol=1e-9, atol=1e-11)
    p.initialize(0.0, plant.fk(np.array([[0.12]]))[0], np.zeros(1))
    q, qd = np.zeros((n, 1)), np.zeros((n, 1))
    for k in range(n):
        y = p.outputs()
        q[k], qd[k] = y.q, y.qd
        if k < n - 1:
            p.set_input(tau[k:k + 1])
            p.do_step(t[k], dt)
    return Recording("emps", t, q + rng.normal(0, noise[0], q.shape), qd + rng.normal(0, noise[1], qd.shape),
                     tau[:, None] + rng.normal(0, noise[2], (n, 1)))


@pytest.fixture(scope="module")
def rec():
    return torque_run()


def test_the_fitted_model_replays_the_held_out_motion_better_than_the_nominal(rec):
    d = diagnose(rec, effects=["coulomb", "viscous", "platform_mass"], discovery=False, figures=False)
    r = d.replay
    assert r["kind"] == "open loop", r
    assert "multiple shooting" in r["method"] and "0.5 s" in r["method"], r["method"]
    nominal, fitted = r["runs"]["nominal"]["rel_qd"][0], r["runs"]["fitted"]["rel_qd"][0]
    # frictionless, the nominal carriage runs away from the recorded speeds within each window
    assert fitted < 0.1 * nominal, (fitted, nominal)
    assert fitted < 0.05, fitted


def test_the_true_plant_replays_to_the_noise_and_windows_bound_the_drift(rec):
    true = Model("emps")
    true.set_params(HIDDEN)
    first = 2001  # the first 2 s
    one = open_loop_replay(rec, {"true": true}, window=0.5, stop=first)
    # the true plant, restarted every 0.5 s, stays within a few times the rate noise (2e-4 m/s)
    assert one["runs"]["true"]["rms_qd"][0] < 2e-3, one
    # a model 10 % off in viscous friction: longer windows let its error grow (drift)
    off = Model("emps")
    off.set_params({**HIDDEN, "rail[1].viscous": 165.0})
    short = open_loop_replay(rec, {"off": off}, window=0.1, stop=first)["runs"]["off"]["rms_q"][0]
    long = open_loop_replay(rec, {"off": off}, window=2.0, stop=first)["runs"]["off"]["rms_q"][0]
    assert short < long, (short, long)


def test_the_cli_says_which_replay_ran(rec, tmp_path, capsys):
    from cosim.cli.main import main

    csv, _ = write_recording(tmp_path / "torque.csv", rec)
    code = main(["diagnose", str(csv), "--effects", "coulomb,viscous", "--no-discovery", "--no-figures",
                 "--out", str(tmp_path / "out")])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "replay: open loop (the recorded effort in, the motion out), multiple shooting" in text, text


def test_a_campaign_of_torque_runs_is_held_out_within_runs_and_replayed_open_loop():
    from cosim.discrepancy.campaign import diagnose_campaign, read_campaign

    c = read_campaign([torque_run(duration=2.5, seed=s) for s in (4, 5)])
    res = diagnose_campaign(c, held_out="within", effects=["coulomb", "viscous"], discovery=False, figures=False)
    assert res.held_out == "the last 30 % of every run", res.held_out
    assert [r["kind"] for r in res.replays] == ["open loop", "open loop"], res.replays
    for r in res.replays:  # each run's held-out end, from its own recorded states
        assert r["runs"]["fitted"]["rel_qd"][0] < 0.1 * r["runs"]["nominal"]["rel_qd"][0], r
    fitted = {p: v for e in res.joint.effects for p, v in e["params"].items()}
    for p, truth in HIDDEN.items():
        assert abs(fitted[p]["value"] - truth) <= fitted[p]["ci95"], (p, fitted[p], truth)
