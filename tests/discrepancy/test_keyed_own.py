"""A library friction whose level is keyed on its own joint's position or on the time since the
joint last reversed is not named with confidence (cosim.discrepancy.keyed.elsewhere.modulations
with cosim.discrepancy.keyed.own; docs/discrepancy.md, "Nor where its level follows the joint's own
position or its reversals").

A synthetic two-joint recording as the rule reads it (decimated smoothed position, rate, the
channels' residuals), no diagnosis: joint 1 carries a friction whose level is c0 + c1 b(q1) (b a
band over a third of the stroke) or c0 + c1 exp(-s / tau) (s the time since q1 last reversed),
and the library's Coulomb friction is fitted to it by least squares (the oracle: its level is the
mean one).  The residual left is within the channel's own noise to the structure test's eye, but
the Coulomb force times a function of the position, or of the time since the reversal, explains
it.  A Coulomb friction that is the truth (constant level) is left alone, and so is a kinematic
effect (its force is a function of the position by nature).  A rotor inertia fitted on the
channel of a friction measured keyed is tied beside it, and a discovered term there is marked
partial; beside one "perhaps keyed" by the power alone they are not, nor is a friction beside an
inertia whose level reads keyed.  A friction whose recording leans to a keyed level it cannot
bound below the level itself is tied "perhaps keyed", and so are the effects beside it."""
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from cosim.discrepancy.discovery.terms import DiscoveredTerm
from cosim.discrepancy.keyed.elsewhere import KEYED_ELSEWHERE, modulations, terms_beside, withheld
from cosim.discrepancy.keyed.own import time_since_reversal
from cosim.discrepancy.results import FoundEffect
from cosim.discrepancy.ties import tied

DT, STEP, T = 1e-3, 5, 12.0
V = 3e-4  # velocity scale of the friction's smooth sign [m/s]
NOISE = 0.004  # effort noise [N]


def _motion():
    t = np.arange(0.0, T, DT)
    q = np.column_stack([0.05 * np.sin(2 * math.pi * 0.37 * t) + 0.02 * np.sin(2 * math.pi * 1.13 * t + 0.4),
                         0.04 * np.sin(2 * math.pi * 0.29 * t + 1.0)])
    qd = np.gradient(q, DT, axis=0)
    return t, q, qd, np.gradient(qd, DT, axis=0)


def _case(level, key="coulomb", seed=1):
    """(eng, theta, effects, R) of the stubbed engine: ``level`` (n,) the truth's friction level on
    joint 1, its Coulomb friction fitted at the least-squares level."""
    t, q, qd, qdd = _motion()
    idx = np.arange(0, len(t), STEP)
    rng = np.random.default_rng(seed)
    sign = np.tanh(qd[:, 0] / V)
    truth = level * sign
    fc = float(truth[idx] @ sign[idx] / (sign[idx] @ sign[idx]))  # the library's Coulomb level fitted
    noise = NOISE * rng.normal(size=(len(idx), 2))

    def R(theta):
        r = noise.copy()
        r[:, 0] += truth[idx] - theta.get("rail[1].coulomb", 0.0) * sign[idx]
        return r

    tau = np.column_stack([truth, np.zeros(len(t))]) + 1.0
    pipe = SimpleNamespace(idx=idx, nd=2, t=t, dt=DT, window=0.02, step=STEP * DT, segments=[(0, len(t))],
                           q_s=q, qd_s=qd, qdd_s=qdd, tau_s=tau, rec=SimpleNamespace(), has_pose=False,
                           usable=np.ones((len(idx), 2), bool), qd_noise=np.full(2, 1e-4),
                           model=SimpleNamespace(facts=SimpleNamespace(joint_noun="slider", joint_unit="m",
                                                                       effort_unit="N")))
    eng = SimpleNamespace(pipe=pipe, R=R, accuracy=lambda: np.full(2, NOISE))
    theta = {"rail[1].coulomb": fc}
    effect = FoundEffect(key, "Coulomb friction", "coulomb[1]", "Coulomb friction, joint 1", 1, "effort",
                         {"rail[1].coulomb": {}}, 50.0, 50.0, "", [])
    return eng, theta, [effect], R(theta), t, q


def test_a_friction_rising_over_part_of_the_stroke_is_keyed_on_the_position():
    t, q, _, _ = _motion()
    lo, hi = np.quantile(q[:, 0], [0.55, 0.85])
    band = 0.5 * (np.tanh((q[:, 0] - lo) / 0.002) - np.tanh((q[:, 0] - hi) / 0.002))
    eng, theta, effects, R, _, _ = _case(0.02 + 0.02 * band)
    found = modulations(eng, theta, effects, R)
    assert [m[3] for m in found.get(0, [])] == ["position"], found
    feat = found[0][0][0]  # "q1 in a-b m": the band found overlaps the truth's
    a, b = (float(v) for v in feat.split(" in ")[1].split()[0].split("-"))
    assert a < hi and b > lo, feat
    marked = withheld(effects, [], "slider", found)[0]
    assert marked["lookalikes"][0]["group"] == KEYED_ELSEWHERE and tied(marked["lookalikes"][0])
    assert "keyed on its position" in marked["lookalikes"][0]["name"]


def test_a_friction_that_relaxes_after_each_reversal_is_keyed_on_the_time_since_it():
    t, _, qd, _ = _motion()
    s = time_since_reversal(qd[:, 0], t, 1e-3)
    eng, theta, effects, R, _, _ = _case(0.02 + 0.03 * np.exp(-s / 0.15))
    found = modulations(eng, theta, effects, R)
    assert "reversal" in [m[3] for m in found.get(0, [])], found
    marked = withheld(effects, [], "slider", found)[0]
    assert "keyed on the time since its last reversal" in marked["lookalikes"][0]["name"]


@pytest.mark.parametrize("key", ["coulomb", "backlash"])
def test_a_constant_level_and_a_kinematic_effect_are_left_alone(key):
    t, q, _, _ = _motion()
    if key == "coulomb":  # the library's truth: a constant level
        assert modulations(*_case(np.full(len(t), 0.03))[:4]) == {}
    else:  # a position-keyed level, but on an effect whose force is position-keyed by nature
        lo, hi = np.quantile(q[:, 0], [0.55, 0.85])
        band = 0.5 * (np.tanh((q[:, 0] - lo) / 0.002) - np.tanh((q[:, 0] - hi) / 0.002))
        found = modulations(*_case(0.02 + 0.02 * band, key="backlash")[:4])
        assert not [m for m in found.get(0, []) if m[3] != "elsewhere"], found


def test_a_friction_too_weak_to_tell_its_level_constant_is_not_named_with_confidence():
    """Near the detection limit: a level of 1 mN that rises by 1 mN over a band of the stroke.
    The Coulomb force fitted to it (about 1.3 mN) explains a chi-square of about 60 against the
    noise (the oracle: n (level / noise)^2 / phi, phi = 4 decimated samples per independent one),
    above the structure test's threshold of 25, yet no product can pass the rule's bar: a change
    of the whole level over half the stroke would explain about 60 / 4 = 15, below 35 + 2 ln M +
    ln n_eff.  The recording cannot tell the level constant, and the friction is tied, "perhaps
    keyed on"; at ten times the level the band's product passes and names the position."""
    t, q, _, _ = _motion()
    lo, hi = np.quantile(q[:, 0], [0.55, 0.85])
    band = 0.5 * (np.tanh((q[:, 0] - lo) / 0.002) - np.tanh((q[:, 0] - hi) / 0.002))
    eng, theta, effects, R, _, _ = _case(0.001 + 0.001 * band)
    n, level = len(eng.pipe.idx), theta["rail[1].coulomb"]
    assert 40 < n * (level / NOISE) ** 2 / 4 < 90  # the Coulomb itself: above the structure threshold
    found = modulations(eng, theta, effects, R)
    assert found and all(m[3].startswith("weak ") for m in found[0]), found
    assert {m[3] for m in found[0]} >= {"weak position"}
    marked = withheld(effects, [], "slider", found)[0]
    assert tied(marked["lookalikes"][0]) and "perhaps keyed on" in marked["lookalikes"][0]["name"]
    assert "too weak to tell its level" in marked["lookalikes"][0]["name"]
    eng, theta, effects, R, _, _ = _case(0.01 + 0.01 * band)
    assert [m[3] for m in modulations(eng, theta, effects, R)[0]] == ["position"]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_friction_the_recording_leans_to_keying_is_not_named_with_confidence(seed):
    """A level of 5 mN that rises by 3 mN after each reversal and relaxes with 0.1 s: no product
    passes the bar, and every kind's best product could see a change of the whole level (the
    power alone would name the Coulomb friction with confidence: the reversal's best could see 65 %
    of it), but the residual leans on the reversal's products (chi-square less ln n_eff 11-19,
    beyond the look-elsewhere cost 2 ln M of about 8) and the bar cannot exclude a change as large
    as the level along them: tied, "perhaps keyed on the time since its last reversal".
    A constant level of the same mean (the library's truth) has no such product and is left
    alone; a rotor inertia beside the leaning friction is tied "perhaps keyed" too (the recording
    leans to a keyed force it may take part of)."""
    t, _, qd, _ = _motion()
    s = time_since_reversal(qd[:, 0], t, 1e-3)
    assert modulations(*_case(np.full(len(t), 0.0065), seed=seed)[:4]) == {}
    eng, theta, effects, R, _, _ = _case(0.005 + 0.003 * np.exp(-s / 0.1), seed=seed)
    effects = effects + [_beside(1)]
    found = modulations(eng, theta, effects, R)
    assert [m[3] for m in found.get(0, [])] == ["leaning reversal"], found
    feat, change, stat, _ = found[0][0]
    assert feat.startswith("exp(-s / ") and change >= 1.0 and stat > 0, found
    marked = withheld(effects, [], "slider", found)
    first = marked[0]["lookalikes"][0]
    assert tied(first) and "perhaps keyed on the time since its last reversal" in first["name"], first
    assert "leans to a level that changes with the time since its last reversal" in first["name"]
    beside = marked[1]["lookalikes"][0]
    assert tied(beside) and beside["name"].startswith(
        "a force on slider 1 perhaps keyed on the time since its last reversal (fitted beside Coulomb friction, "
        "whose level is perhaps keyed on the time since its last reversal"), beside


def _beside(joint=1):
    """A rotor inertia fitted on ``joint`` beside the Coulomb friction of joint 1 (its parameter
    is not in theta: the rule reads no force of it, it only sits on the channel)."""
    return FoundEffect("rotor_inertia", "rotor inertia", f"rotor_inertia[{joint}]", f"rotor inertia, joint {joint}",
                       joint, "effort", {f"rail[{joint}].rotor_inertia": {}}, 30.0, 30.0, "", [])


def test_an_effect_fitted_beside_a_keyed_friction_loses_its_confidence_too():
    """A friction that relaxes after each reversal is tied as keyed; the rotor inertia fitted on
    the same channel (it can take the part of the keyed force that follows the acceleration at
    a reversal) gets a tie that says beside what; an inertia on the other joint does not."""
    t, _, qd, _ = _motion()
    s = time_since_reversal(qd[:, 0], t, 1e-3)
    eng, theta, effects, R, _, _ = _case(0.02 + 0.03 * np.exp(-s / 0.15))
    effects = effects + [_beside(1), _beside(2)]
    found = modulations(eng, theta, effects, R)
    assert "reversal" in [m[3] for m in found.get(0, [])] and set(found) == {0}, found
    marked = withheld(effects, [], "slider", found)
    first = marked[1]["lookalikes"][0]
    assert first["group"] == KEYED_ELSEWHERE and tied(first), marked[1]
    assert first["name"] == ("a force on slider 1 keyed on the time since its last reversal (fitted beside Coulomb "
                             "friction, whose level is keyed on the time since its last reversal: it may stand in "
                             "for part of that force)")
    assert marked[2]["lookalikes"] == []  # another joint's channel
    assert [a["group"] for a in marked[0]["lookalikes"]] == [KEYED_ELSEWHERE]  # its own tie, once
    # an inertia whose level reads keyed (a stand-in itself) does not tie the friction beside it
    marked = withheld(effects[:2], [], "slider", {1: [("|qdd2|", 61.0, 0.002, "elsewhere")]})
    assert marked[0]["lookalikes"] == [] and marked[1]["lookalikes"][0]["group"] == KEYED_ELSEWHERE


def test_a_discovered_term_beside_a_keyed_friction_is_a_partial_fit():
    """A term discovered on the channel of a friction whose level relaxes after each reversal (an
    acceleration term takes the bump after each reversal) is marked partial, "fitted beside ...";
    one on the other joint is not, nor one beside a friction tied "perhaps keyed" by the power
    alone; beside one the recording leans to keying it is."""
    t, _, qd, _ = _motion()
    s = time_since_reversal(qd[:, 0], t, 1e-3)
    eng, theta, effects, R, _, _ = _case(0.02 + 0.03 * np.exp(-s / 0.15))
    found = modulations(eng, theta, effects, R)
    term = DiscoveredTerm(1, "tau1", ["inertia"], "slider 1: F = m qdd", {}, {}, "", {}, 0.0, 0.0, 0.0, "qdd1")
    other = replace(term, joint=2, channel="tau2")
    out = terms_beside([term, other], effects, found, "slider")
    assert out[0].partial.startswith("fitted beside Coulomb friction, whose level is keyed on the time since its "
                                     "last reversal"), out[0].partial
    assert out[1].partial == ""
    weak = {0: [("exp(-s / 0.2 s)", 1.5, float("nan"), "weak reversal")]}
    assert terms_beside([term], effects, weak, "slider")[0].partial == ""
    leaning = {0: [("exp(-s / 0.1 s)", 1.4, 12.5, "leaning reversal")]}
    assert terms_beside([term], effects, leaning, "slider")[0].partial.startswith(
        "fitted beside Coulomb friction, whose level is perhaps keyed on the time since its last reversal")


def test_a_friction_only_perhaps_keyed_leaves_the_effect_beside_it_alone():
    """Near the detection limit the friction is tied "perhaps keyed" (no keyed force measured): the
    inertia beside it keeps its confidence."""
    t, q, _, _ = _motion()
    lo, hi = np.quantile(q[:, 0], [0.55, 0.85])
    band = 0.5 * (np.tanh((q[:, 0] - lo) / 0.002) - np.tanh((q[:, 0] - hi) / 0.002))
    eng, theta, effects, R, _, _ = _case(0.001 + 0.001 * band)
    effects = effects + [_beside(1)]
    found = modulations(eng, theta, effects, R)
    assert found and all(m[3].startswith("weak ") for m in found[0]), found
    marked = withheld(effects, [], "slider", found)
    assert "perhaps keyed on" in marked[0]["lookalikes"][0]["name"] and marked[1]["lookalikes"] == []
