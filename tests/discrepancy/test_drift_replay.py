"""The replay carries a drift the diagnosis found: a friction that falls over the recording and
a payload put on part way (cases of :mod:`cosim.discrepancy.blind.drifts`, the core's time
courses in the simulated plant), replayed over the held-out part with the drift as the
plant's time course and with the constant fitted.  The oracle is the recording itself: the
held-out efforts, which neither fit saw."""
import numpy as np
import pytest

from cosim.discrepancy import diagnose
from cosim.discrepancy.blind.drifts import drift_case


def _rms(run):
    return float(np.sqrt(np.mean(np.square(run["rms_tau"]))))


@pytest.mark.parametrize("kind, seed", [("trend", 1), ("step", 11)])
def test_the_replay_with_the_drift_beats_the_mean(kind, seed):
    rec, truth = drift_case(kind, seed, duration=4.0)
    d = diagnose(rec, figures=False, replay=True, discovery=False, platform=False)
    modelled = [x for x in d.drifts if x.course is not None and x.kind == kind]
    assert modelled, (d.conclusion, [(x.equation, x.held) for x in d.drifts])
    assert "modelled as a drift" in d.details + d.conclusion
    runs = d.replay["runs"]
    with_drift, mean = _rms(runs["fitted"]), _rms(runs["fitted, mean"])
    assert with_drift < 0.5 * mean, (with_drift, mean)
    c = modelled[0].course
    if kind == "trend":  # the rate fitted on the fitting rows against the plant's
        assert abs(c["rate"] - truth["rate"]) < 0.2 * abs(truth["rate"]), (c, truth)
    else:
        assert abs(c["size"] - truth["size"]) < 0.2 * truth["size"] and abs(c["t0"] - truth["t0"]) < 0.25, (c, truth)


def test_a_drift_case_of_an_unknown_kind_is_refused():
    from cosim.errors import InputError

    with pytest.raises(InputError, match="kind 'ramp' is none of"):
        drift_case("ramp", 1)


def test_a_drift_only_the_held_out_part_shows_is_not_carried_by_the_plant():
    """A Coulomb friction that steps down at 85 % of the recording, after the fitting rows end
    (70 %): the whole recording names the step, the fitting rows alone see none, so the plant
    that is judged on the held-out part holds the mean instead of a drift it never saw."""
    rec, truth = drift_case("step", 11, duration=4.0,
                            step={"param": "rail[2].coulomb", "value": 0.12, "size": -0.08, "at": 0.85})
    d = diagnose(rec, figures=False, replay=False, discovery=False, platform=False)
    named = [x for x in d.drifts if x.param == "rail[2].coulomb"]
    assert named and named[0].kind == "step" and abs(named[0].time - truth["t0"]) < 0.1, d.drifts
    assert named[0].course is None and "do not support a drift" in named[0].held, named[0]
    assert "the plant holds the mean" in d.conclusion + d.details
