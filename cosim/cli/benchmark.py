"""``cosim bench core``: the reference core's timings against the performance targets, with baselines.

One table, single core, three columns per quantity:

* **core (C++)**: ``build/bin/core_bench`` (bench/core_bench.cpp) calling the C API
  directly; this is the figure compared with The target (PASS / MISS);
* **Python binding**: the same operation through :mod:`cosim.core` /
  :mod:`cosim.simulate` (one batched call, or the Python controller loop);
* **baseline**: the path a user would take without the batched core: a Python loop
  of single-pose calls (IK, dynamics), ``scipy.optimize.least_squares`` on the core's
  inverse kinematics (FK), ``scipy.integrate.solve_ivp`` on the core's forward dynamics
  (simulation).  Every baseline calls the core for the physics; none re-derives it.

Other modules may add targets (``cosim bench <target>``) with :func:`bench_target`.
"""
from __future__ import annotations

import json
import os
import subprocess
import time
from pathlib import Path

import numpy as np

from .common import command

TARGETS: dict = {}


def bench_target(name: str, help: str):
    """Register ``fn(args) -> int`` as ``cosim bench <name>``."""

    def deco(fn):
        TARGETS[name] = (fn, help)
        return fn

    return deco


def _configure(p):
    p.add_argument("target", choices=sorted(TARGETS), help="what to benchmark: " +
                   "; ".join(f"{k}: {v[1]}" for k, v in sorted(TARGETS.items())))
    p.add_argument("--quick", action="store_true", help="smaller sizes and durations (a smoke run, noisier)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON instead of a table")


@command("bench", "benchmarks against the performance targets, with baselines in the same run (cosim bench core)")
def cmd_bench(args):
    return TARGETS[args.target][0](args)


cmd_bench.configure = _configure


# ---------------------------------------------------------------- core target

def core_bench_executable() -> Path:
    """Path of the C++ benchmark built by CMake (``$PKM_BUILD_DIR`` or ``build/``)."""
    from .._native import REPO

    build = Path(os.environ.get("PKM_BUILD_DIR", REPO / "build"))
    return build / "bin" / "core_bench"


def _run_cpp(quick: bool) -> dict:
    exe = core_bench_executable()
    if not exe.exists():
        raise FileNotFoundError(f"{exe} is not built: run ./scripts/bootstrap.sh (or set PKM_BUILD_DIR)")
    cmd = [str(exe), "--json"] + (["--quick"] if quick else [])
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    return {r["key"]: r for r in json.loads(out)}


def _best(f, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        best = min(best, time.perf_counter() - t0)
    return best


def _poses(m, n, rng):
    """Poses around home (x, y +-20 mm, z 70..90 mm, rotations +-3 deg), as core_bench."""
    home = m.home()
    u = rng.uniform(-1.0, 1.0, size=(n, 6))
    x = np.empty((n, 6))
    x[:, 0] = home[0] + 0.020 * u[:, 0]
    x[:, 1] = home[1] + 0.020 * u[:, 1]
    x[:, 2] = 0.080 + 0.010 * u[:, 2]
    x[:, 3:] = home[3:] + np.deg2rad(3.0) * u[:, 3:]
    return x


def _pd_controller(m, q0, kp=2000.0, kd=30.0, amp=0.003, freq=1.0):
    """PD + gravity compensation on a sinusoidal stroke reference (as core_bench)."""
    ph0 = np.arange(6) * np.pi / 3

    def tau(t, x, xd):
        ph = 2 * np.pi * freq * t + ph0
        qr = q0 + amp * np.sin(ph)
        qdr = amp * 2 * np.pi * freq * np.cos(ph)
        return m.gravity_load(x) + kp * (qr - m.ik(x)) + kd * (qdr - m.joint_velocity(x, xd))

    return tau


def python_rows(quick: bool = False, seed: int = 1) -> dict:
    """Timings of the Python binding and of the baselines, keyed like core_bench's rows.

    Returns ``{key: {"python": value, "baseline": value, "baseline_what": str}}`` in the
    row's unit (ns per pose/call, us per solve, simulated s per wall s).
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import least_squares

    from ..core.model import Model
    from ..simulate import simulate

    m = Model("6pus")
    rng = np.random.default_rng(seed)
    out = {}

    # IK: one batched call vs a Python loop of single-pose calls.
    n = 100_000 if quick else 1_000_000
    x = _poses(m, n, rng)
    m.ik(x[:1000])
    t_batch = _best(lambda: m.ik(x), 1 if quick else 3)
    nl = 2000 if quick else 10000
    t_loop = _best(lambda: [m.ik(x[k]) for k in range(nl)], 1)
    out["ik_ns"] = {"python": t_batch / n * 1e9, "baseline": t_loop / nl * 1e9,
                    "baseline_what": "Python loop of single-pose Model.ik"}

    # FK from a guess 1 mm / 1 mrad away: batched Newton vs scipy least_squares on the IK residual.
    nf = 2000 if quick else 20000
    xs = x[:nf]
    q = m.ik(xs)
    guess = xs + 1e-3 * rng.uniform(-1.0, 1.0, size=xs.shape)
    t_fk = _best(lambda: m.fk(q, guess), 1 if quick else 3)
    ns = 20 if quick else 100

    def lsq():
        for k in range(ns):
            least_squares(lambda xx, k=k: m.ik(xx) - q[k], guess[k], xtol=1e-15, ftol=1e-15, gtol=1e-15)

    t_ls = _best(lsq, 1)
    out["fk_us"] = {"python": t_fk / nf * 1e6, "baseline": t_ls / ns * 1e6,
                    "baseline_what": "scipy least_squares on Model.ik (2-point Jacobian)"}

    # Dynamics: one batched call vs a Python loop of single calls.
    nd = 20_000 if quick else 200_000
    xv = 0.1 * rng.uniform(-1.0, 1.0, size=(nd, 6))
    xa = 2.0 * rng.uniform(-1.0, 1.0, size=(nd, 6))
    xp = x[:nd]
    tau = m.inverse_dynamics(xp, xv, xa)
    t_id = _best(lambda: m.inverse_dynamics(xp, xv, xa), 1 if quick else 3)
    t_fd = _best(lambda: m.forward_dynamics(xp, xv, tau), 1 if quick else 3)
    nl = 2000 if quick else 10000
    t_idl = _best(lambda: [m.inverse_dynamics(xp[k], xv[k], xa[k]) for k in range(nl)], 1)
    t_fdl = _best(lambda: [m.forward_dynamics(xp[k], xv[k], tau[k]) for k in range(nl)], 1)
    out["id_ns"] = {"python": t_id / nd * 1e9, "baseline": t_idl / nl * 1e9,
                    "baseline_what": "Python loop of single calls"}
    out["fd_ns"] = {"python": t_fd / nd * 1e9, "baseline": t_fdl / nl * 1e9,
                    "baseline_what": "Python loop of single calls"}

    # Simulation: the PD-controlled motion at 1 ms updates, Python controller in both.
    T = 0.2 if quick else 1.0
    dt = 1e-3
    x0 = m.home()
    ctl = _pd_controller(m, m.ik(x0))
    t0 = time.perf_counter()
    simulate(m, x0, t_end=T, dt=dt, tau=ctl)
    t_sim = time.perf_counter() - t0
    Tb = 0.05 if quick else 0.2
    y = np.concatenate([x0, np.zeros(6)])
    t0 = time.perf_counter()
    for k in range(int(round(Tb / dt))):
        u = ctl(k * dt, y[:6], y[6:])
        sol = solve_ivp(lambda t, s, u=u: np.concatenate([s[6:], m.forward_dynamics(s[:6], s[6:], u)]),
                        (k * dt, (k + 1) * dt), y, method="RK45", rtol=1e-8, atol=1e-10)
        y = sol.y[:, -1]
    t_ivp = time.perf_counter() - t0
    out["sim_bdf_1ms"] = {"python": T / t_sim, "baseline": Tb / t_ivp,
                          "baseline_what": "scipy solve_ivp RK45 (rtol 1e-8) on Model.forward_dynamics, "
                                           "same PD at 1 ms"}
    return out


def _fmt(v):
    if v is None or not np.isfinite(v):
        return "-"
    return f"{v:.3g}" if (abs(v) >= 1e5 or abs(v) < 1e-2) else f"{v:.4g}"


def core_table(cpp: dict, py: dict) -> str:
    """The combined table (text)."""
    head = (f"{'quantity':<50} {'unit':<13} {'core C++':>10} {'Python':>10} {'baseline':>10}  "
            f"{'target':>10}  {'':4}")
    lines = ["6-PUS reference core, single thread: performance targets (PASS/MISS on the C++ figure)", head,
             "-" * len(head)]
    notes = []
    for key, r in cpp.items():
        p = py.get(key, {})
        tgt = (">= " if r["higher_is_better"] else "<= ") + _fmt(r["target"])
        lines.append(f"{r['label']:<50} {r['unit']:<13} {_fmt(r['value']):>10} {_fmt(p.get('python')):>10} "
                     f"{_fmt(p.get('baseline')):>10}  {tgt:>10}  {'PASS' if r['pass'] else 'MISS'}")
        if r.get("note"):
            notes.append(f"  {r['label']}: {r['note']}")
        if p.get("baseline_what"):
            notes.append(f"  {r['label']}: baseline = {p['baseline_what']}")
    lines.append("")
    lines.append("notes:")
    lines.extend(notes)
    lines.append("  Python column of the simulation: Simulator + a Python PD controller (ik, joint velocity, "
                 "gravity load per 1 ms step), 1 s")
    return "\n".join(lines)


@bench_target("core", "6-PUS IK/FK/ID/FD and CVODE simulation rate (C++, Python binding, baselines)")
def bench_core(args):
    cpp = _run_cpp(args.quick)
    py = python_rows(args.quick)
    if args.json:
        print(json.dumps({"core": list(cpp.values()), "python": py}, indent=2))
    else:
        print(core_table(cpp, py))
    return 0
