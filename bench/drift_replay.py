"""The replay with a drift against the replay with its mean: drift cases of the generator
(:mod:`cosim.discrepancy.blind.drifts`, seeds 100-104 of each kind, none used while writing
the code: seeds 1 and 11 were), diagnosed as a user would (library, no discovery, no platform
stage), and the held-out part replayed in closed loop with the fitted plant carrying the
drift as its parameter's time course ("fitted") and holding the constant fitted
("fitted, mean"); and the held-out residual's gain (nominal RMS over fitted RMS on the
held-out rows, ``Diagnosis.heldout["gain"]``) of the same diagnosis without the drift test
(the constants) and with it (the drifts' courses, fitted on the fitting rows).

Prints a Markdown table (docs/drift.md): the drift's truth and what was found, and the RMS
of the held-out effort difference [N] for both plants: on the drifting rail for a friction
trend, over the six rails for a payload.

Usage: PYTHONPATH=. python bench/drift_replay.py [first_seed] [n]
"""
import sys
import time

import numpy as np

from cosim.discrepancy import diagnose
from cosim.discrepancy.blind.drifts import KINDS, drift_case


def _rms(run, joint=None):
    """RMS of the held-out effort difference over the rails, or on rail ``joint`` (1-based) [N]."""
    if "rms_tau" not in run:
        return float("nan")
    r = np.asarray(run["rms_tau"])
    return float(r[joint - 1]) if joint else float(np.sqrt(np.mean(r**2)))


def main(first=100, n=5):
    print("| case | truth | found | modelled | held-out residual gain, mean | with the drift | replay RMS effort, "
          "mean [N] | with the drift [N] | ratio | CPU [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for kind in KINDS:
        for seed in range(first, first + n):
            rec, truth = drift_case(kind, seed)
            w = time.process_time()
            d = diagnose(rec, figures=False, replay=True, discovery=False, platform=False)
            cpu = time.process_time() - w
            g_mean = diagnose(rec, figures=False, replay=False, discovery=False, platform=False,
                              drift=False).heldout.get("gain", float("nan"))
            g_drift = d.heldout.get("gain", float("nan"))
            u = "N" if kind == "trend" else "kg"
            if kind == "trend":
                want = f"{truth['param']} {truth['start']:.3f} -> {truth['end']:.3f} {u}"
            else:
                want = f"{truth['param']} +{truth['size']:.3f} {u} at {truth['t0']:.2f} s"
            drs = d.drifts
            got = "; ".join(f"{x.param} {x.kind} {x.start:.3f} -> {x.end:.3f} {x.unit}"
                            + (f" at {x.time:.2f} s" if x.kind == "step" else "") for x in drs) or "none"
            modelled = "; ".join("yes" if x.course is not None else "no" for x in drs) or "-"
            runs = (d.replay or {}).get("runs", {})
            j = int(truth["param"][5]) if kind == "trend" else None  # the drifting rail; a payload: all six
            mean = _rms(runs.get("fitted, mean", runs.get("fitted", {})), j)
            drift = _rms(runs["fitted"], j) if "fitted, mean" in runs else float("nan")
            ratio = mean / drift if drift == drift else float("nan")
            print(f"| {kind} {seed} | {want} | {got} | {modelled} | {g_mean:.2f} | {g_drift:.2f} | {mean:.4f} | "
                  f"{drift:.4f} | {ratio:.2f} | {cpu:.1f} |", flush=True)


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:3]))
