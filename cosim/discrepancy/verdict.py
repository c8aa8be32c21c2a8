"""The verdict of a diagnosis: whether its fit is physical, and its conclusion's first paragraph.

Physical ranges
    A fit can lower the residual with parameters no rig has: a moving mass or an inertia at
    ~0, an actuator limit at ~0 (the drive would deliver nothing), a friction or an offset
    of a hundred times the largest effort the drive delivered.  Such a fit is degenerate
    (the columns of the effects are nearly dependent on the recording, or the recording is
    not what the model thinks), never a finding: :func:`unphysical` says which parameter is
    outside which range, and the diagnosis refuses the fit with that reason.

The conclusion
    Its first words say how confident it is, from the same facts as the body (the effects'
    look-alikes and the structure left unexplained, :mod:`.diagnosis`):

    * ``found with confidence``: every named effect stands alone (no tie, no structure left);
    * ``most likely ..., tied with ...``: an effect or a discovered term fits, but another
      explanation fits the data as well;
    * ``structure left, not named``: the residual keeps structure after the fit, which may
      then stand in for what is missing: nothing is named as the physics;
    * ``no missing physics found`` and ``cannot diagnose: ...`` as before.

    One short paragraph; the full statement (values, look-alikes, what was withdrawn)
    follows it as the details (``Diagnosis.details``).
"""
from __future__ import annotations

import math

import numpy as np

#: a mass or an inertia below this share of its nominal value is "at ~0" (no description of a rig
#: is a hundred times off; a fit that says so is degenerate or the recording is not the rig's),
#: and so is an actuator limit below this share of the largest recorded effort
NEAR_ZERO = 1e-2
#: a force-like parameter larger than this many times the largest recorded effort is no friction
TOO_LARGE = 100.0
#: core parameter suffixes of masses and inertias
MASSES = ("platform.m", "platform.Ixx", "platform.Iyy", "platform.Izz", "payload.m", ".rotor_inertia")
#: core parameter suffixes of forces (the effort's unit)
FORCES = (".coulomb", ".offset", ".stribeck", ".dead_zone")


def _joint(name: str):
    """0-based joint of ``<j>[i].x``, or None."""
    if "[" not in name:
        return None
    return int(name.split("[", 1)[1].split("]", 1)[0]) - 1


def unphysical(theta: dict, nominal: dict, peak_effort, peak_rate, units: dict | None = None) -> list:
    """The fitted parameters outside their physical range, one sentence each.

    Parameters
    ----------
    theta : dict
        Fitted core parameters.
    nominal : dict
        The nominal model's parameters.
    peak_effort, peak_rate : array_like, shape (nd,)
        Largest |recorded effort| [N or N m] and |joint rate| per joint.
    units : dict, optional
        Core parameter -> unit.

    Returns
    -------
    list of str
        Empty when every parameter is physical.

    Example
    -------
    >>> units = {"rail[1].effort_max": "N"}
    >>> unphysical({"rail[1].effort_max": 3.3e-24}, {"rail[1].effort_max": 0.0}, [80.0], [0.2], units)
    ['rail[1].effort_max = 3.3e-24 N: an actuator limit at ~0 (the recorded effort reaches 80 N on joint 1)']
    """
    units = units or {}
    peak_effort, peak_rate = np.atleast_1d(peak_effort), np.atleast_1d(peak_rate)
    out = []
    for p, v in theta.items():
        u = units.get(p, "")
        v = float(v)
        if not math.isfinite(v):
            out.append(f"{p} = {v}: not a finite number")
            continue
        i, nom = _joint(p), float(nominal.get(p, 0.0))
        if p.endswith(MASSES) and nom > 0 and v < NEAR_ZERO * nom:
            out.append(f"{p} = {v:.4g} {u}: a mass or inertia at ~0 (the model's is {nom:.4g} {u})")
        elif p.endswith(".effort_max") and i is not None and v < NEAR_ZERO * peak_effort[i]:
            out.append(f"{p} = {v:.4g} {u}: an actuator limit at ~0 (the recorded effort reaches "
                       f"{peak_effort[i]:.4g} {units.get('_effort', 'N')} on joint {i + 1})")
        elif p.endswith(FORCES) and i is not None and abs(v) > TOO_LARGE * peak_effort[i]:
            out.append(f"{p} = {v:.4g} {u}: more than {TOO_LARGE:g} times the largest recorded effort on joint {i + 1} "
                       f"({peak_effort[i]:.4g})")
        elif p.endswith(".viscous") and i is not None and abs(v) * peak_rate[i] > TOO_LARGE * peak_effort[i]:
            out.append(f"{p} = {v:.4g} {u}: at the recorded speeds a force more than {TOO_LARGE:g} times the largest "
                       f"recorded effort on joint {i + 1}")
    return out


def fit_problems(eng, theta: dict) -> list:
    """:func:`unphysical` for a diagnosis's fit state ``eng`` and its fitted ``theta``."""
    pipe = eng.pipe
    units = {p.name: p.unit for p in eng.model.param_info()}
    units["_effort"] = eng.model.facts.effort_unit
    peak = np.max(np.abs(pipe.tau_s[pipe.idx]), axis=0)
    rate = np.max(np.abs(pipe.qd_s[pipe.idx]), axis=0)
    return unphysical(theta, eng.nominal, peak, rate, units)


def _title(e) -> str:
    vals = "; ".join(f"{v['value']:.4g} +- {v['ci95']:.2g} {v['unit']}" for v in e["params"].values())
    return f"{e['title']} ({vals})" if vals else e["title"]


def _heldout_words(gain) -> str:
    """The held-out sentence: a ratio below 1 (the fit does worse than the nominal model on the
    part it was not fitted on) said as the residual's rise, not as a fraction "lower"."""
    if not (gain and math.isfinite(gain) and gain > 0):
        return ""
    if gain >= 1.0:
        return f" Held-out residual RMS {gain:.3g}x lower."
    return f" Held-out residual RMS {1.0 / gain:.3g}x higher: the fit does not carry over to the held-out part."


def headline(effects, found, left, gain=None, unexplained_group: str = "unexplained", tied=None, others=()) -> str:
    """The conclusion's first paragraph (see the module's text).

    Parameters
    ----------
    effects : list of FoundEffect (dicts)
        The named library effects with their look-alikes.
    found : list of DiscoveredTerm
        Discovered terms (``equation``, ``partial``).
    left : list of dict
        Structure left unexplained (:func:`.structure.unexplained`), ``channel``, ``keyed_on``.
    gain : float, optional
        Held-out residual RMS ratio (nominal over fitted).
    unexplained_group : str
        Group of the look-alike that marks structure left.
    tied : callable
        ``tied(alternative) -> bool`` (:func:`.diagnosis.tied`).
    others : sequence of str
        Further findings by their short names, named like the library's effects: a force on the
        platform (:mod:`.platform_force`), parameters that drift (:mod:`.drift`).

    Returns
    -------
    str
        "" when nothing was fitted and nothing left (the caller's own sentence stands).
    """
    if not effects and not found and not left and not others:
        return ""
    better = _heldout_words(gain)
    # a discovered term by its kinds (its equation, long, is in the details)
    found = [t for t in found if not t.repeats_its_pair]
    short = {id(t): f"a force on {t.channel} no library effect names ({', '.join(t.terms)})"
             if not t.pair else t.equation.split(":")[0] for t in found}
    names = [_title(e) for e in effects] + [short[id(t)] for t in found] + list(others)
    if left:
        where = "; ".join(dict.fromkeys(f"{s['channel']} (keyed on {s['keyed_on']})" for s in left))
        fit = (f" The fit with {', '.join(names)} may stand in for what is missing; none of it is named as the "
               f"physics.") if names else " No effect of the library explains it."
        return f"structure left, not named: the residual keeps structure on {where}.{fit}{better}"
    ties = []
    for e in effects:
        same = [a["name"] for a in e["lookalikes"] if (tied(a) if tied else False) and a["group"] != unexplained_group]
        if same:
            ties.append(f"{_title(e)}, tied with {', '.join(same)}")
    partial = [short[id(t)] for t in found if t.partial]
    if ties or partial:
        what = "; ".join(ties + [f"{eq} (a partial fit)" for eq in partial])
        sure = [n for e, n in zip(effects, names) if not any(t.startswith(_title(e) + ", tied") for t in ties)]
        sure = [n for n in sure if n not in partial] + list(others)
        rest = f" Named alone: {', '.join(sure)}." if sure else ""
        return f"most likely, tied with another explanation: {what}.{rest}{better}"
    return f"found with confidence: {', '.join(names)}.{better}"
