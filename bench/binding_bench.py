"""Cost of one core call from Python, beside Pinocchio's Python ``rnea`` in the same run.

    .venv/bin/python bench/binding_bench.py [--calls 20000] [--repeats 5]

Rows: ``cosim.core.Model`` single calls on the 6-PUS (inverse and forward dynamics,
inverse kinematics, the Jacobian, the gravity load), the same C functions through plain
ctypes with pointer casts (what the binding did before), the batched calls per item
(1000 items a call), and Pinocchio's ``rnea`` / ``aba`` on a 6-DoF serial arm
(``buildSampleModelManipulator``) from PyPI ``pin``.  Best of the repeats, microseconds
per call, one core.  (Pinocchio needs ``.venv/bin/pip install -r bench/requirements.txt``.)
"""
from __future__ import annotations

import argparse
import ctypes as C
import sys
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from cosim._native import lib, ptr  # noqa: E402
from cosim.core import Model  # noqa: E402


def per_call(f, calls: int, repeats: int) -> float:
    return min(timeit.repeat(f, number=calls, repeat=repeats)) / calls * 1e6


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--calls", type=int, default=20000, help="calls per timing (default 20000)")
    ap.add_argument("--repeats", type=int, default=5, help="timings; the best is printed (default 5)")
    a = ap.parse_args(argv)
    m = Model("6pus")
    x, xd, xdd = m.home(), np.full(6, 0.01), np.full(6, 0.1)
    tau = m.inverse_dynamics(x, xd, xdd)
    rows = [
        ("Model.inverse_dynamics (one pose)", lambda: m.inverse_dynamics(x, xd, xdd)),
        ("Model.forward_dynamics (one pose)", lambda: m.forward_dynamics(x, xd, tau)),
        ("Model.ik (one pose)", lambda: m.ik(x)),
        ("Model.jacobian (one pose)", lambda: m.jacobian(x)),
        ("Model.gravity_load (one pose)", lambda: m.gravity_load(x)),
    ]
    out = np.empty(6)
    raw = lambda: lib.pkm_inverse_dynamics(m._m, m._d, ptr(x), ptr(xd), ptr(xdd), ptr(out))  # noqa: E731
    rows.append(("ctypes pkm_inverse_dynamics, pointer casts", raw))
    X, XD, XDD = (np.broadcast_to(v, (1000, 6)).copy() for v in (x, xd, xdd))
    TAU = m.inverse_dynamics(X, XD, XDD)
    batched = [("Model.inverse_dynamics, 1000 poses, per pose", lambda: m.inverse_dynamics(X, XD, XDD)),
               ("Model.forward_dynamics, 1000 poses, per pose", lambda: m.forward_dynamics(X, XD, TAU))]
    table = [(label, per_call(f, a.calls, a.repeats)) for label, f in rows]
    table += [(label, per_call(f, max(1, a.calls // 1000), a.repeats) / 1000) for label, f in batched]
    try:
        import pinocchio as pin

        pm = pin.buildSampleModelManipulator()
        pd = pm.createData()
        q, v, acc = pin.neutral(pm), np.full(pm.nv, 0.01), np.full(pm.nv, 0.1)
        t = pin.rnea(pm, pd, q, v, acc)
        table.append((f"Pinocchio {pin.__version__} rnea, 6-DoF arm (one call)",
                      per_call(lambda: pin.rnea(pm, pd, q, v, acc), a.calls, a.repeats)))
        table.append((f"Pinocchio {pin.__version__} aba, 6-DoF arm (one call)",
                      per_call(lambda: pin.aba(pm, pd, q, v, t), a.calls, a.repeats)))
    except ImportError:
        table.append(("Pinocchio: not installed (pip install -r bench/requirements.txt)", float("nan")))
    print(f"one call from Python, best of {a.repeats} x {a.calls} calls, one core")
    print(f"{'call':58s} {'us/call':>8s}")
    for label, us in table:
        print(f"{label:58s} {us:8.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
