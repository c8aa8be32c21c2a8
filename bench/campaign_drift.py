"""Drifts between the runs of a campaign (:mod:`cosim.discrepancy.campaign_drift`) on generated
campaigns (:mod:`cosim.discrepancy.blind.campaigns`: eight closed-loop EMPS runs of 2 s, start
times 10-30 min apart, one friction drifting linearly in time by 5-25 % over the campaign, or
none), diagnosed with the runs' start times and the last run held out.

Prints a Markdown table (docs/drift.md): per case the truth, the drift named (parameter, change
over the campaign, its 95 % interval), the held-out run's effort residual gain (nominal RMS over
fitted RMS) with the shared constant, with the drift predicted from the other runs, and with
the plant's true values (the floor: the run's noise and its samples at rest, where the friction's
sign is not known from the reading), and the closed-loop replay's relative effort error of the
held-out run with the constant and with the drift; then the counts.

Seeds: 1-5 (drift and clean) were the ones looked at while writing the code; the report uses
100 on.

Usage: PYTHONPATH=. python bench/campaign_drift.py [first_seed] [n_drift] [n_clean]
"""
import sys
import time

import numpy as np

from cosim.discrepancy.blind.campaigns import drift_campaign
from cosim.discrepancy.campaign import diagnose_campaign, read_campaign


def _rel(res, plant):
    r = res.replays[0] if res.replays else {}
    x = r.get("runs", {}).get(plant, {})
    return 100 * x["rel_tau"][0] if "rel_tau" in x else float("nan")


def case(seed, drift):
    recs, times, truth = drift_campaign(seed, robot="emps", drift=drift)
    w = time.process_time()
    res = diagnose_campaign(read_campaign(recs, times=times), effects=["coulomb", "viscous"], discovery=False,
                            figures=False)
    cpu = time.process_time() - w
    found = res.drifts[0] if res.drifts else None
    h = res.drift_heldout[0] if res.drift_heldout else None
    want = (f"{truth['param']} {truth['values'][0]:.2f} -> {truth['values'][-1]:.2f} ({100 * truth['relative']:+.1f} %)"
            if drift else "none")
    got = "; ".join(f"{d.param} {d.start:.2f} -> {d.end:.2f} ({100 * d.relative:+.1f} %, change "
                    f"{d.change:+.3g} ± {d.slope_ci95 * (d.x[-1] - d.x[0]):.2g})" for d in res.drifts) or "none"
    right = (found is not None and len(res.drifts) == 1 and found.param == truth["param"]
             and abs(found.change - truth["change"]) <= 0.15 * abs(truth["change"])) if drift else not res.drifts
    if h:
        from cosim.core import Model
        from cosim.discrepancy.campaign_drift import _rms

        hid = dict(truth["hidden"], **{truth["param"]: truth["values"][-1]}) if drift else truth["hidden"]
        floor = h["rms"]["nominal"] / _rms(recs[-1], Model("emps"), hid, 0.05)
        g = f"{h['gain_constant']:.2f} | {h['gain_drift']:.2f} | {floor:.2f} | {h['ratio']:.2f}"
    else:
        g = f"{res.joint.heldout.get('gain', float('nan')):.2f} | - | - | -"
    rd = _rel(res, "fitted, drift")
    print(f"| {'drift' if drift else 'clean'} {seed} | {want} | {got} | {'yes' if right else 'NO'} | {g} | "
          f"{_rel(res, 'fitted'):.2f} | {rd:.2f} | {cpu:.1f} |", flush=True)
    return right, h


def main(first=100, n_drift=10, n_clean=20):
    print("| case | truth | drift named | right | held-out gain, constant | with the drift | with the truth | ratio | "
          "replay effort error, constant [%] | with the drift [%] | CPU [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    ok_d, ratios, ok_c = 0, [], 0
    for s in range(first, first + n_drift):
        right, h = case(s, True)
        ok_d += right
        if h:
            ratios.append(h["ratio"])
    for s in range(first, first + n_clean):
        ok_c += case(s, False)[0]
    print(f"\ndrifts named right: {ok_d}/{n_drift}; clean campaigns not called drifting: {ok_c}/{n_clean}; "
          f"held-out residual ratio constant/drift: median {np.median(ratios) if ratios else float('nan'):.2f}, "
          f"range {min(ratios, default=float('nan')):.2f}-{max(ratios, default=float('nan')):.2f}")


if __name__ == "__main__":
    main(*(int(a) for a in sys.argv[1:4]))
