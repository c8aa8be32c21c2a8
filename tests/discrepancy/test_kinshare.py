"""A residual pipeline built with another's kinematics (``Pipeline(..., kinematics=first)``, the
platform-force stage's second pipeline) equals the pipeline built from scratch, bit for bit: its
nominal residual, reference effort and every evaluation (drive layer, mechanism, geometry, pose
term); the kinematics are taken only when the models differ in parameters that move no joint."""
import numpy as np
import pytest

from cosim.core import Model
from cosim.discrepancy.residuals import Pipeline

CABLE = {"cable.tension": 0.4, "cable.anchor_z": 0.3}


def _model(params):
    """The 6-PUS with ``params`` set; a value given as a string "*f" scales the nominal one by f."""
    m = Model("6pus")
    nominal = m.params()
    m.set_params({k: nominal[k] * float(v[1:]) if isinstance(v, str) else v for k, v in params.items()})
    return m


def _same(a, b):
    if a is None or b is None:
        return a is None and b is None
    return np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("params, taken", [(CABLE, True), ({"payload.m": 0.1, "gravity.x": 0.05}, True),
                                           ({"leg[1].L": "*1.001"}, False), ({**CABLE, "rail[2].S0x": "*1.01"}, False)])
def test_a_pipeline_with_anothers_kinematics_equals_one_built_from_scratch(clean_runs, params, taken):
    rec = clean_runs["6pus"]
    first = Pipeline(rec, Model("6pus"))
    first.evaluate({"leg[2].L": first.nominal["leg[2].L"] * 1.001})  # a geometry change's pose motion kept
    shared = Pipeline(rec, _model(params), kinematics=first)
    fresh = Pipeline(rec, _model(params))
    assert (shared.x_f is first.x_f) == taken and (shared.x_s is first.x_s) == taken
    for k in ("x_f", "xd_f", "xdd_f", "x_s", "tau_ref_s"):
        assert _same(getattr(shared, k), getattr(fresh, k)), k
    j = "rail"
    cases = [{}, {f"{j}[1].coulomb": 0.05}, {"payload.m": 0.05}, {"leg[2].L": fresh.nominal["leg[2].L"] * 1.001},
             {"leg[2].L": fresh.nominal["leg[2].L"] * 1.001, "payload.m": 0.05}, {f"{j}[3].encoder_offset": 1e-4},
             {"cable.tension": 0.2}, {}]
    for p in cases:
        a, b = shared.evaluate(p), fresh.evaluate(p)
        assert _same(a.eff, b.eff) and _same(a.kin, b.kin), p
        assert _same(shared.pose_term(p), fresh.pose_term(p)), p
    if fresh.has_reference:
        assert _same(shared.reference_effort({"payload.m": 0.05}), fresh.reference_effort({"payload.m": 0.05}))


def test_kinematics_of_another_recording_or_smoothing_are_not_taken(clean_runs):
    first = Pipeline(clean_runs["6pus"], Model("6pus"))
    other = Pipeline(clean_runs["6pus"], _model(CABLE), window=0.07, kinematics=first)
    assert other.x_s is not first.x_s
    assert np.array_equal(other.x_s, Pipeline(clean_runs["6pus"], _model(CABLE), window=0.07).x_s)


def test_the_actuators_efforts_and_the_readings_are_taken_when_neither_kinds_parameters_differ(clean_runs):
    """A saturation's and a dead zone's efforts and a sensor's readings computed by the first
    pipeline serve the second (the model with a force on the platform) and equal those the second
    would compute; a model whose actuator or sensor parameters differ computes its own."""
    rec = clean_runs["6pus"]
    first = Pipeline(rec, Model("6pus"))
    sat = {"rail[2].effort_max": 0.3 * float(np.abs(first.tau_c[:, 1]).max()), "rail[4].dead_zone": 0.01}
    first.evaluate(sat)
    first.evaluate({"rail[3].encoder_offset": 1e-4})
    taken = [k for k in first._memo.entries if k[0] in ("A", "K")]
    assert any(k[0] == "A" and k[1] for k in taken)  # a moved actuator's efforts among them
    shared = Pipeline(rec, _model(CABLE), kinematics=first)
    fresh = Pipeline(rec, _model(CABLE))
    for k in taken:
        assert shared._memo.entries.get(k) is first._memo.entries[k], k
    for p in (sat, {"rail[3].encoder_offset": 1e-4}, {}):
        a, b = shared.evaluate(p), fresh.evaluate(p)
        assert _same(a.eff, b.eff) and _same(a.kin, b.kin), p
    for own in ({**CABLE, "rail[1].effort_max": 0.5}, {**CABLE, "rail[1].encoder_offset": 1e-4}):
        other = Pipeline(rec, _model(own), kinematics=first)
        assert other.x_f is first.x_f  # the kinematics taken, the efforts and readings not
        assert not any(k[0] in ("A", "K") for k in other._memo.entries), own


@pytest.mark.parametrize("flexible", [{"rail[6].backlash": 2e-4}, {"rail[2].compliance": 1e-4}])
def test_readings_that_read_the_dynamics_are_not_taken(clean_runs, flexible):
    """Under a backlash or a compliance the encoder reads the effort the transmission carries,
    which the force on the platform changes: the second pipeline computes those readings itself
    and its residual equals the one built from scratch (taken, the readings against the
    tracker differ)."""
    rec = clean_runs["6pus"]
    first = Pipeline(rec, Model("6pus"))
    first.evaluate(flexible)
    first.evaluate({"rail[3].encoder_offset": 1e-4})
    shared = Pipeline(rec, _model({"cable.tension": 4.0, "cable.anchor_z": 0.3}), kinematics=first)
    fresh = Pipeline(rec, _model({"cable.tension": 4.0, "cable.anchor_z": 0.3}))
    readings = [k for k in first._memo.entries if k[0] == "K"]
    assert any(dict(k[1]).get(next(iter(flexible))) for k in readings)
    for k in readings:
        assert (shared._memo.entries.get(k) is first._memo.entries[k]) == (next(iter(flexible)) not in dict(k[1])), k
    for p in (flexible, {"rail[3].encoder_offset": 1e-4}):
        a, b = shared.evaluate(p), fresh.evaluate(p)
        assert _same(a.eff, b.eff) and _same(a.kin, b.kin), p
