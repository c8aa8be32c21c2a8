"""Trajectories of the core's integrator on a fixed set of cases, for a before/after
comparison of two builds of the core (a refactoring that must not change a bit).

    PKM_LIB=/path/a/libpkm.so python bench/sim_compare.py record a.npz
    PKM_LIB=/path/b/libpkm.so python bench/sim_compare.py record b.npz
    python bench/sim_compare.py compare a.npz b.npz

``record`` runs every case through the library PKM_LIB names (the build's by default) and
saves the states, the statistics, the statuses and messages of the stops; ``compare``
prints per case the largest absolute difference of the states, whether the counters and
messages are equal, and exits 1 if any case differs.

Cases: the 6-PUS under a varying open-loop input with each method (RK 5(4), RK 3(2), BDF,
Adams); with an actuator delay; with a two-body joint; driven into a stroke limit and
falling into a singularity; a
rollback (state saved, advanced, loaded, advanced again); the planar 3-RRR with stiff
friction (the explicit methods hand the stretch to BDF); a step budget too small; and the compiled closed loop of
the scenarios ``6pus_step_pd`` (two-body variant too) and ``described/emps_step_pd``.
"""
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
TWO_BODY = {"drive.two_body": 1, "rail[6].backlash": 40e-6, "rail[6].compliance": 1e-6,
            "rail[6].rotor_inertia": 0.05, "rail[6].transmission_damping": 130.0}
SCENARIOS = ["6pus_step_pd.toml", "6pus_step_pd_two_body.toml", "described/emps_step_pd.toml"]


def _open_loop(robot, method, params=None, t_end=0.2, dt=1e-3, amp=0.2, rollback=False, tau=None,
               **options):
    from cosim.core import Model
    from cosim.simulate import Simulator

    model = Model(robot, params=params or {})
    sim = Simulator(model, method=method, **options)
    g = model.gravity_load(model.home()) if tau is None else np.asarray(tau, float)
    rows, status, message = [], "ok", ""
    saved = None
    n = int(round(t_end / dt))
    k = 0
    try:
        while k < n:
            t = k * dt
            sim.set_input(g + amp * np.sin(2 * np.pi * 5 * t + np.arange(g.size)))
            sim.advance((k + 1) * dt)
            t1, x, xd = sim.state
            rows.append(np.concatenate([[t1], x, xd]))
            k += 1
            if rollback and k == n // 2 and saved is None:
                saved = (k, sim.save_state())
            if rollback and k == n and saved is not None:  # back to the middle, once
                k, state = saved
                sim.load_state(state)
                rollback = False
    except Exception as e:  # a stop: its status and message are part of the result
        status, message = type(e).__name__, str(e)
        t1, x, xd = sim.state
        rows.append(np.concatenate([[t1], x, xd]))
    stats = sim.stats
    return np.array(rows), np.array([stats[k] for k in sorted(stats)], float), f"{status}: {message}"


def _scenario(name):
    with tempfile.TemporaryDirectory() as out:
        subprocess.run([str(ROOT / ".venv/bin/cosim"), "run", str(ROOT / "scenarios" / name), "--plant", "core",
                        "--duration", "0.5", "--out", out, "--no-figures"], check=True, capture_output=True)
        csvs = sorted(Path(out).glob("*.csv"))
        data = [np.genfromtxt(c, delimiter=",", skip_header=1) for c in csvs]
    return np.concatenate([d.ravel() for d in data]), np.zeros(0), ""


def cases():
    out = {}
    for method in ["erk", "erk23", "bdf", "adams"]:
        out[f"6pus_{method}"] = lambda m=method: _open_loop("6pus", m)
    out["6pus_erk_actuator_delay"] = lambda: _open_loop("6pus", "erk", {"actuator.delay": 0.0025})
    out["6pus_bdf_actuator_delay"] = lambda: _open_loop("6pus", "bdf", {"actuator.delay": 0.0025})
    out["6pus_erk_two_body"] = lambda: _open_loop("6pus", "erk", TWO_BODY, t_end=0.1)
    out["6pus_erk_rollback"] = lambda: _open_loop("6pus", "erk", {"actuator.delay": 0.0025}, rollback=True)
    for method in ["erk", "bdf"]:  # a stroke limit; no input at all: the platform falls to a singularity
        out[f"6pus_{method}_stroke_limit"] = lambda m=method: _open_loop("6pus", m, amp=2.0)
        out[f"6pus_{method}_falls"] = lambda m=method: _open_loop("6pus", m, amp=0.0, t_end=2.0, tau=[0.0] * 6)
    out["planar_3rrr_erk_stiff_hand_over"] = lambda: _open_loop(
        "planar_3rrr", "erk", {"arm[2].coulomb": 1e4}, t_end=0.005, amp=0.0, tau=[0.2, -0.1, 0.15])
    out["planar_3rrr_erk23_stiff_hand_over"] = lambda: _open_loop(
        "planar_3rrr", "erk23", {"arm[2].coulomb": 1e4}, t_end=0.005, amp=0.0, tau=[0.2, -0.1, 0.15])
    for method in ["erk", "bdf"]:  # the step budget runs out
        out[f"6pus_{method}_step_budget"] = lambda m=method: _open_loop("6pus", m, max_steps=3)
    for name in SCENARIOS:
        out[f"scenario_{name}"] = lambda n=name: _scenario(n)
    return out


def record(path):
    saved = {}
    for name, run in cases().items():
        states, stats, message = run()
        saved[name + ".states"] = states
        saved[name + ".stats"] = stats
        saved[name + ".message"] = np.array(message)
        print(f"{name:40s} {states.shape[0]:6d} rows  {message[:90]}")
    np.savez(path, **saved)


def compare(path_a, path_b):
    a, b = np.load(path_a), np.load(path_b)
    names = sorted({k.rsplit(".", 1)[0] for k in a.files})
    worst = 0.0
    same_all = True
    print(f"{'case':40s} {'max |a - b|':>12s}  counters  message")
    for name in names:
        sa, sb = a[name + ".states"], b[name + ".states"]
        diff = float(np.max(np.abs(sa - sb))) if sa.shape == sb.shape and sa.size else (0.0 if sa.shape == sb.shape else np.inf)
        counters = np.array_equal(a[name + ".stats"], b[name + ".stats"])
        message = str(a[name + ".message"]) == str(b[name + ".message"])
        same_all = same_all and diff == 0 and counters and message
        worst = max(worst, diff)
        print(f"{name:40s} {diff:12.3g}  {'equal' if counters else 'DIFFER':8s}  {'equal' if message else 'DIFFER'}")
    print(f"largest difference over {len(names)} cases: {worst:.3g}")
    return 0 if same_all else 1


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "record":
        record(sys.argv[2])
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(compare(sys.argv[2], sys.argv[3]))
    else:
        print(__doc__)
        sys.exit(2)
