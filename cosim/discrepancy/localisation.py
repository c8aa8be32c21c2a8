"""Localisation: where the nominal model goes wrong.

For every residual channel (the effort of joint i, the reading of joint i): the time
windows where the nominal residual leaves its noise band (3 sigma of the final fit),
the motion phase of each sample (from the smoothed rate and acceleration of the same
joint) and how much more often than chance the residual is out of band in each phase,
and the part of the workspace where it is largest.

Phases, per joint, with v95 and a95 the 95th percentiles of |qd| and |qdd|:

* ``standstill``: |qd| < 0.02 v95 and |qdd| < 0.05 a95;
* ``reversal``: moving (not standstill) with |qd| < 0.1 v95: passing through zero speed;
* ``acceleration peak``: |qdd| > 0.5 a95;
* ``constant velocity``: |qdd| < 0.15 a95;
* ``transition``: the rest.
"""
from __future__ import annotations

import numpy as np

PHASES = ["standstill", "reversal", "acceleration peak", "constant velocity", "transition"]


def phases(qd, qdd) -> np.ndarray:
    """Phase index (into PHASES) per sample and joint, shape (m, nd)."""
    v = np.percentile(np.abs(qd), 95, axis=0) + 1e-15
    a = np.percentile(np.abs(qdd), 95, axis=0) + 1e-15
    aqd, aqdd = np.abs(qd) / v, np.abs(qdd) / a
    out = np.full(qd.shape, 4, dtype=int)
    still = (aqd < 0.02) & (aqdd < 0.05)
    rev = ~still & (aqd < 0.1)
    acc = ~still & ~rev & (aqdd > 0.5)
    const = ~still & ~rev & ~acc & (aqdd < 0.15)
    out[const] = 3
    out[acc] = 2
    out[rev] = 1
    out[still] = 0
    return out


def windows(t, out, gap, min_len):
    """Runs of True in ``out`` (gaps shorter than ``gap`` [s] merged, runs shorter than
    ``min_len`` dropped): list of (i0, i1) index pairs, inclusive."""
    idx = np.flatnonzero(out)
    if idx.size == 0:
        return []
    runs = []
    start = prev = idx[0]
    for i in idx[1:]:
        if t[i] - t[prev] > gap:
            runs.append((start, prev))
            start = i
        prev = i
    runs.append((start, prev))
    return [(a, b) for a, b in runs if t[b] - t[a] >= min_len]


def localise(eng, sel, k: float = 3.0) -> dict:
    """Windows, phases and workspace region of the nominal residual, per channel."""
    pipe = eng.pipe
    pos = pipe.idx
    t = pipe.t[pos]
    R0 = eng.R0
    Rf = eng.R(sel.theta) if sel.theta else R0
    sig = np.maximum(sel.sigma, eng.accuracy())  # round-off of a noiseless recording is no band
    qd, qdd, x = pipe.qd_s[pos], pipe.qdd_s[pos], pipe.x_s[pos]
    ph = phases(qd, qdd)
    nd = pipe.nd
    gap = 2 * pipe.window * pipe.dt
    min_len = pipe.window * pipe.dt
    chans = {}
    flagged_any = np.zeros(len(t), bool)
    summary = []
    for c, name in enumerate(pipe.channels):
        j = c % nd
        z = np.abs(R0[:, c]) / sig[c]
        out = z > k
        flagged_any |= out
        base = np.bincount(ph[:, j], minlength=len(PHASES)) / len(t)
        hit = np.bincount(ph[out, j], minlength=len(PHASES)) / max(out.sum(), 1)
        enrich = {PHASES[i]: float(hit[i] / base[i]) if base[i] > 0 and out.any() else 0.0
                  for i in range(len(PHASES))}
        wins = []
        for a, b in windows(t, out, gap, min_len):
            seg = slice(a, b + 1)
            pk = a + int(np.argmax(z[seg]))
            frac = np.bincount(ph[seg, j], minlength=len(PHASES)) / (b - a + 1)
            wins.append({"start": float(t[a]), "end": float(t[b]), "peak_time": float(t[pk]),
                         "peak": float(R0[pk, c]), "peak_sigma": float(z[pk]),
                         "phases": {PHASES[i]: float(frac[i]) for i in range(len(PHASES)) if frac[i] > 0}})
        after = np.abs(Rf[:, c]) / sig[c] > k
        chans[name] = {"rms": float(np.sqrt(np.mean(R0[:, c] ** 2))), "noise": float(sig[c]),
                       "out_of_band": float(out.mean()), "out_of_band_after": float(after.mean()),
                       "windows": wins, "phase_enrichment": enrich}
        if out.mean() > 0.02:
            top = sorted(enrich.items(), key=lambda kv: -kv[1])[:2]
            if top[0][1] < 1.3:
                where = "throughout the motion (no phase stands out)"
            else:
                where = f"most at {top[0][0]} (x{top[0][1]:.1f} over chance)" + (
                    f" and {top[1][0]} (x{top[1][1]:.1f})" if top[1][1] > 1.3 else "")
            spans = f" in {len(wins)} window(s)" if wins else " in scattered samples (no window)"
            summary.append(f"{name}: out of its noise band {out.mean() * 100:.0f} % of the time{spans}, {where}; "
                           f"{after.mean() * 100:.0f} % after the fit")
    ws = _workspace(pipe, x, R0, sig, flagged_any)
    if ws.get("summary"):
        summary.append(ws["summary"])
    return {"channels": chans, "phases": PHASES, "workspace": ws, "summary": summary, "band_sigma": k,
            "phase_fractions": {PHASES[i]: float(np.mean(ph == i)) for i in range(len(PHASES))}}


def _workspace(pipe, x, R0, sig, flagged):
    """Where in the workspace the residual is largest: mean normalised residual in the
    quartiles of each pose coordinate."""
    cols = pipe.rec.pose_columns
    z = np.max(np.abs(R0) / sig, axis=1)
    out = {"coordinates": cols, "flagged_fraction": float(flagged.mean()), "bins": {}}
    best = None
    for c, name in enumerate(cols):
        edges = np.quantile(x[:, c], [0, 0.25, 0.5, 0.75, 1.0])
        if edges[-1] - edges[0] <= 1e-12:
            continue
        b = np.clip(np.searchsorted(edges, x[:, c], side="right") - 1, 0, 3)
        means = [float(z[b == i].mean()) if np.any(b == i) else 0.0 for i in range(4)]
        out["bins"][name] = {"edges": edges.tolist(), "mean_sigma": means}
        # a quarter whose mean is below half the noise level is as quiet as noise: the
        # contrast is counted against that, not against a near-zero mean
        contrast = max(means) / max(min(means), 0.5)
        if best is None or contrast > best[0]:
            i = int(np.argmax(means))
            best = (contrast, name, edges[i], edges[i + 1], means[i])
    if best and best[0] > 1.5 and flagged.mean() > 0.02:
        unit = "rad" if best[1].startswith("r") or best[1] == "theta" else "m"
        out["summary"] = (f"workspace: the residual is largest for {best[1]} in [{best[2]:.4g}, {best[3]:.4g}] {unit} "
                          f"({best[0]:.1f} times the quietest quarter)")
        out["region"] = {"coordinate": best[1], "low": float(best[2]), "high": float(best[3]),
                         "contrast": float(best[0])}
    return out
