"""Structure left unexplained: what the selected model leaves in the residual.

After the selection, each residual channel is tested for a constant offset and for a part
keyed on the motion of its joint: the sign of the joint velocity, that sign at low speed only
(a friction that changes below some speed: a Stribeck peak, a friction that fades), the sign of
the commanded effort, the joint position, the velocity, the acceleration; when none of those, on
the platform pose; and for a line of the residual's spectrum at a frequency the motion does not
hold (:func:`.lines.lines`: a force turning or pulsing at a fixed rate, e.g. an unbalance).  The
yardstick is the residual's own
high-frequency noise (median absolute difference of samples one smoothing window
apart), not the engine's noise model: an effect outside the library inflates that one
and would pass for noise ("within noise"); a line found is taken out of the residual before
the yardstick is measured and the families are fitted (a fast periodic force would otherwise
be the yardstick itself).  A family of regressors counts when it
explains more than ``threshold`` + k log n (chi-square in independent samples, BIC-like)
of the residual; the report names the channel, what the structure is keyed on and the
library effects of that kind, which came closest.
"""
from __future__ import annotations

import math

import numpy as np

from .results import Structure
from .signatures import LOW_SPEEDS, families as _families, own_noise, samples_per_independent  # noqa: F401

#: signature -> (what it is keyed on, the library effects of that kind)
SIGNATURES = {
    "offset": ("nothing: a constant offset", ["encoder offset (a reading)", "dead zone under a one-signed "
                                                 "command", "gravity tilt", "payload"]),
    "velocity_sign": ("the sign of the joint velocity", ["Coulomb friction", "Stribeck friction"]),
    "low_speed": ("the sign of the joint velocity at low speed", ["Stribeck friction",
                                                                  "friction that fades at low speed"]),
    "command_sign": ("the sign of the commanded effort", ["dead zone", "backlash"]),
    "position": ("the joint position", ["geometry", "payload", "gravity tilt", "encoder offset"]),
    "pose": ("the platform pose", ["geometry", "gravity tilt", "payload", "encoder offset"]),
    "velocity": ("the joint velocity", ["viscous friction", "actuator / sensor delay"]),
    "acceleration": ("the joint acceleration", ["rotor inertia", "platform mass or inertia", "delays"]),
    "periodic": ("time: a force repeating at a fixed frequency", ["none: no library effect repeats at a "
                                                                  "frequency the motion does not hold"]),
}

#: signatures fitted with their mean (the others are centred: the offset is tested alone)
SIGNED = ("velocity_sign", "command_sign")

#: chi-square (independent samples) a family must explain beyond k log n to be reported;
#: set on the clean and effect cases of the engine's own generator (docs/discrepancy.md)
THRESHOLD = 25.0


def unexplained(pipe, R, floor=None, threshold: float = THRESHOLD) -> list:
    """Channels whose residual ``R`` (decimated samples x channels) keeps structure.

    ``floor`` (per channel, optional): the smallest noise level a channel is given (the
    engine's ``floor()``: the pipeline's own accuracy), so that the round-off of a
    noiseless recording is not taken for structure.

    Returns one dict per channel with structure: ``channel``, ``joint`` (1-based),
    ``signature``, ``keyed_on``, ``closest`` (library effects of that kind), ``chi2``
    (explained, in independent samples), ``rms`` (of the structured part) and ``noise``
    (the residual's high-frequency noise), in the channel's unit.
    """
    R = np.asarray(R, float)
    n = R.shape[0]
    lag = int(math.ceil(pipe.window / pipe.step)) + 1
    phi = samples_per_independent(pipe)
    n_eff = n / phi
    if n < 8 * lag or n_eff < 10:
        return []
    from .lines import lines

    periodic = {x["channel"]: x for x in lines(pipe, R, floor, threshold)}
    out = []
    for c, name in enumerate(pipe.channels):
        low = 0.0 if floor is None else floor[c]
        best, sigma = _best_family(pipe, c, R[:, c], own_noise(pipe, R[:, c] - R[:, c].mean(), low), threshold)
        if c in periodic:
            # the families again on the residual without the lines, against its own noise; the
            # channel's answer changes only where the lines explain more than they do, or where
            # the lines had hidden every family
            y = periodic[c]["clean"]
            best_clean, sigma_clean = _best_family(pipe, c, y, own_noise(pipe, y - y.mean(), low), threshold)
            chosen = _periodic(periodic[c], best_clean)
            if chosen is not best_clean or best is None:
                best, sigma = chosen, sigma_clean
        if best:
            keyed, closest = SIGNATURES[best[1]] if len(best) < 5 else (best[4], SIGNATURES["periodic"][1])
            out.append(Structure(name, c % pipe.nd + 1, best[1], keyed, list(closest), best[2], best[3], sigma,
                                 lines=list(periodic[c]["lines"]) if best[1] == "periodic" else []))
    out.sort(key=lambda e: -e.chi2)
    return out


def _best_family(pipe, c, y, sigma, threshold):
    """``(best, sigma)``: the family that explains the most of channel c's residual ``y``
    against the noise ``sigma`` beyond its cost and ``threshold``, as ``(stat, signature, chi2,
    rms)`` (None: none does, or no noise to judge against)."""
    if not sigma > 0:
        return None, sigma
    n = len(y)
    phi = samples_per_independent(pipe)
    n_eff = n / phi
    mean = float(y.mean())
    r = y - mean

    def scored(sig_name, F):
        if sig_name in SIGNED:  # a sign carries its own mean (a one-signed command is an offset too)
            z, X = y, F
        else:
            z, X = r, F - F.mean(axis=0)
        beta, *_ = np.linalg.lstsq(X, z, rcond=None)
        fit = X @ beta
        chi2 = float(fit @ fit) / sigma ** 2 / phi
        return chi2 - F.shape[1] * math.log(n_eff), sig_name, chi2, float(np.sqrt(np.mean(fit ** 2)))

    families = _families(pipe, c % pipe.nd)
    pose = families.pop("pose")
    best = None
    for sig_name, F in families.items():
        cand = scored(sig_name, F)
        if cand[0] > threshold and (best is None or cand[0] > best[0]):
            best = cand
    chi2 = n * mean ** 2 / sigma ** 2 / phi  # a constant alone: the mean against its noise
    stat = chi2 - math.log(n_eff)
    if stat > threshold and (best is None or stat > best[0]):  # a sign that fits as well is more specific
        best = (stat, "offset", chi2, abs(mean))
    if best is None and pose.shape[1]:
        # the joint's own motion keys nothing: the pose as a whole (a length error of a leg
        # moves its joint by a pose-dependent amount) is the last, least specific family
        cand = scored("pose", pose)
        if cand[0] > threshold:
            best = cand
    return best, sigma


def _periodic(found, best):
    """The channel's lines (:func:`.lines.lines`) as a candidate ``(stat, "periodic", chi2, rms,
    keyed_on)`` when they explain more than the best family ``best`` (None: no family)."""
    stat = found["chi2"] - found["cost"]
    if best is not None and best[0] >= stat:
        return best
    (f, a), more = found["lines"][0], len(found["lines"]) - 1
    keyed = (f"time: a force repeating at {f:.3g} Hz (amplitude {a:.3g})"
             + (f" and {more} weaker line(s) beside it" if more else ""))
    rms = math.sqrt(sum(x * x for _, x in found["lines"]) / 2.0)
    return stat, "periodic", found["chi2"], rms, keyed


def sentence(items: list) -> str:
    """One clause for the conclusion: the strongest structure per channel."""
    parts = [f"{e['channel']} keyed on {e['keyed_on']} (rms {e['rms']:.3g} against noise {e['noise']:.3g}; closest "
             f"library effects: {', '.join(e['closest'])})" for e in items[:3]]
    more = f" and {len(items) - 3} more channel(s)" if len(items) > 3 else ""
    return "structure left unexplained: " + "; ".join(parts) + more
