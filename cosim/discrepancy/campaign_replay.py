"""The replay of a campaign's held-out runs (:mod:`.campaign`): each held-out piece of a run
replayed on its own, from the run's own recorded state, with the nominal and the jointly
fitted plant: in closed loop (the run's controller and reference, primed with the run's own
rows before the piece, never another run's) when the run has them, in open loop by multiple
shooting (:mod:`.open_loop`) when it is an open-loop experiment."""
from __future__ import annotations

import numpy as np

from .open_loop import can_replay_open_loop, declared_open_loop, open_loop_replay

#: rows of a run's start the controller is primed with before a held-out piece that starts the run
PRIME_ROWS = 50


def _plants(joint, model, rec, drift=None):
    """The nominal and the jointly fitted plant, and "fitted, drift" with ``drift``
    ({parameter: value}, the run's predicted values of the parameters that drift) when given."""
    from .diagnosis import _model_for

    m = _model_for(rec, model)
    fitted = m.copy()
    if joint.theta:
        fitted.set_params(joint.theta)
    out = {"nominal": m, "fitted": fitted}
    if drift:
        out["fitted, drift"] = fitted.copy()
        out["fitted, drift"].set_params(drift)
    return out


def _closed(rec, plants, a, b):
    """Closed-loop replay of rows a:b of one run (its controller primed with its rows before a)."""
    from .runs import closed_loop, controller_from, reference_from_recording

    m = plants["nominal"]
    ctrl, why = controller_from(rec.controller, m)
    if ctrl is None:
        return {"skipped": why}
    run = rec.slice(0, b)
    s = max(a, min(PRIME_ROWS, b - 2))
    ref = reference_from_recording(run, m)
    x0 = m.fk(np.asarray(run.q[s:s + 1], float))[0]
    xd0 = m.pose_velocity(x0[None, :], np.asarray(run.qd[s:s + 1], float))[0]
    out = {"kind": "closed loop", "start_row": s, "runs": {}}
    for name, plant in plants.items():
        ctrl, _ = controller_from(rec.controller, m)
        try:
            res = closed_loop(plant, ctrl, ref, x0=x0, xd0=xd0, start=s, rtol=1e-8, atol=1e-10,
                              f_ext=getattr(run, "f_ext", None), history=(run.q[:s], run.qd[:s]))
        except Exception as e:  # noqa: BLE001 - a failing replay is reported
            out["runs"][name] = {"error": str(e)}
            continue
        sl = slice(s, s + len(res.time))
        d_tau = res.tau_logged - run.tau[sl]
        out["runs"][name] = {"rms_q": np.sqrt(np.mean((res.q - run.q[sl]) ** 2, axis=0)).tolist(),
                             "rms_tau": np.sqrt(np.mean(d_tau ** 2, axis=0)).tolist(),
                             "rel_tau": (np.linalg.norm(d_tau, axis=0)
                                         / np.maximum(np.linalg.norm(run.tau[sl], axis=0), 1e-300)).tolist()}
    return out


def replay_held_out(c, pieces, joint, model, drift=None) -> list:
    """Per held-out piece ``(run, a, b, True)`` of ``pieces``: ``run`` (name), ``rows``, and the
    replay (closed loop: ``rel_tau`` per plant; open loop: ``rel_qd``, with its ``method``; or
    ``skipped`` with the reason).  ``drift``: {run name: {parameter: value}}, the values of the
    parameters that drift between runs predicted for that run (:mod:`.campaign_drift`), replayed
    as the plant "fitted, drift"."""
    out = []
    for k, a, b, test in pieces:
        if not test:
            continue
        rec = c.runs[k]
        plants = _plants(joint, model, rec, (drift or {}).get(c.names[k]))
        if rec.qref is not None and rec.controller and not declared_open_loop(rec):
            r = _closed(rec, plants, a, b)
        elif can_replay_open_loop(rec)[0]:
            r = {"kind": "open loop", **open_loop_replay(rec, plants, start=a, stop=b)}
        else:
            r = {"skipped": "the run has a controller but no reference (qref), or a reference but no controller"}
        out.append({"run": c.names[k], "rows": [int(a), int(b)], **r})
    return out


def sentence(r: dict) -> str:
    """One line of a held-out run's replay."""
    if "skipped" in r:
        return f"{r['run']}: no replay: {r['skipped']}"
    key, what = ("rel_qd", "rate error") if r["kind"] == "open loop" else ("rel_tau", "effort error")
    errs = ", ".join(f"{name} {' '.join(f'{100 * v:.2f} %' for v in x[key])}" if key in x else f"{name}: {x['error']}"
                     for name, x in r["runs"].items())
    how = r["method"] if r["kind"] == "open loop" else "closed loop, the run's controller and reference"
    return f"{r['run']}: {how}; relative {what}: {errs}"
