"""The EMPS replay's force error with the samples aligned two ways (docs/emps.md, "Which
samples are compared").

The rig's controller has one sample of computation delay: the force it applies during sample
k is the command it computed at sample k - 1.  The replay's figure (the benchmark's measure,
norm of the force difference over the norm of the recorded force) compares the replay's
``tau`` row k, the force applied during sample k, with the recorded ``vir * gtau`` of sample k.
Aligned on the computation instead, the replay's row k + 1 (computed at k) goes with the
recorded row k.  This script replays the published model (``robots/emps.toml``, set
``reference``) over the whole file and over the held-out part (the last 40 %, its controller
primed with the recorded past) and prints the error for the replay shifted by -1, 0 and +1
samples against the recording.

    .venv/bin/python bench/emps_alignment.py
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from cosim.core import Model
from cosim.discrepancy.runs import closed_loop, controller_from, reference_from_recording
from cosim.importing import to_recording

DATA = Path(__file__).resolve().parents[1] / "data" / "emps"


def errors(rec, model, start: int) -> dict:
    """Relative force error [%] of the replay from sample ``start``, per shift s: the
    replay's row k + s against the recording's row k."""
    ref = reference_from_recording(rec, model)
    ctrl, why = controller_from(rec.controller, model)
    if ctrl is None:
        raise SystemExit(why)
    hist = (rec.q[:start], rec.qd[:start]) if start > 0 else None
    res = closed_loop(model, ctrl, ref, x0=rec.q[start], xd0=rec.qd[start], start=start, rtol=1e-8, atol=1e-10,
                      f_ext=getattr(rec, "f_ext", None), history=hist)
    y = rec.tau[start:start + len(res.time), 0]
    u = res.tau_logged[:, 0]
    out = {}
    for s in (-1, 0, 1):
        a, b = (u[s:], y[:len(y) - s]) if s >= 0 else (u[:s], y[-s:])
        out[s] = 100 * np.linalg.norm(a - b) / np.linalg.norm(b)
    return out


def main():
    rec = to_recording(DATA / "DATA_EMPS.mat", DATA / "emps_map.toml", progress=False)
    model = Model("emps", "reference")
    k0 = int(np.searchsorted(rec.time, rec.time[0] + 0.6 * (rec.time[-1] - rec.time[0])))  # the diagnosis' split
    for name, start in (("whole file", 0), (f"held-out part (from t = {rec.time[k0]:.2f} s)", k0)):
        e = errors(rec, model, start)
        print(f"published model, {name}: replay row k vs recorded row k {e[0]:.3f} %; "
              f"row k + 1 vs k (aligned on the computation) {e[1]:.3f} %; row k - 1 vs k {e[-1]:.3f} %")


if __name__ == "__main__":
    main()
