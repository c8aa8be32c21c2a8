"""The residual pipeline's caches change no figure: every evaluation, in any order and
after any other, equals the residual formed directly from the core (the whole inverse
dynamics of the model with the parameters set, smoothed with scipy's Savitzky-Golay filter)
bit for bit, whether the parameters move the drive layer, the mechanism or both."""
import numpy as np
import pytest
from scipy.signal import savgol_filter

from cosim.core import Model
from cosim.discrepancy.residuals import Pipeline, _at


def _direct(pipe, params):
    """The effort residual of section 2 of docs/discrepancy.md, computed from scratch."""
    m = Model(pipe.model.robot)
    m.set_params(params)
    S = lambda a: savgol_filter(a, pipe.window, pipe.polyorder, axis=0, mode="interp", delta=pipe.dt)  # noqa: E731
    tau_id = S(m.inverse_dynamics(pipe.x_f, pipe.xd_f, pipe.xdd_f))
    applied = S(m.actuator_effort(pipe.tau_c)) if any(k.endswith(".effort_max") for k in params) else pipe.tau_s
    d = (m.param("actuator.delay") + m.param("sensor.delay")) / pipe.dt
    return _at(applied, pipe.idx - d) - tau_id[pipe.idx]


@pytest.mark.parametrize("robot", ["6pus", "quattro"])
def test_cached_evaluations_equal_the_direct_residual_bit_for_bit(clean_runs, robot):
    rec = clean_runs[robot]
    pipe = Pipeline(rec, Model(robot))
    j = pipe.model.facts.joint_prefix
    cases = [{}, {f"{j}[1].coulomb": 0.05}, {f"{j}[2].viscous": 0.4, f"{j}[1].coulomb": 0.05},
             {"payload.m": 0.05}, {"payload.m": 0.05, f"{j}[3].rotor_inertia": 0.02},
             {f"{j}[2].offset": 0.1, f"{j}[2].force_k1": 2.0}, {f"{j}[1].effort_max": 0.5 * np.abs(pipe.tau_c).max()},
             {"actuator.delay": 0.002, f"{j}[1].coulomb": 0.05}, {f"{j}[1].coulomb": 0.05},
             {"payload.m": 0.05, f"{j}[2].coulomb": 0.03, f"{j}[2].force_k1": 1.5},
             {"cable.tension": 0.3, "cable.anchor_z": 0.4, f"{j}[4].viscous": 0.2},
             {"gravity.x": 0.05, f"{j}[1].rotor_inertia": 0.01}, {}]
    first = {}
    for params in cases:  # repeats come from the cache
        got = pipe.evaluate(params).eff
        assert np.array_equal(got, _direct(pipe, params)), params
        key = tuple(sorted(params.items()))
        if key in first:
            assert np.array_equal(got, first[key])
        first[key] = got


def test_a_built_pipeline_is_fixed_and_its_evaluations_leave_its_attributes_alone(clean_runs):
    """The cache and the scratch model are the pipeline's Memo: evaluating keeps every attribute
    the same object, and setting one raises."""
    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    before = dict(vars(pipe))
    pipe.evaluate({f"{pipe.model.facts.joint_prefix}[1].coulomb": 0.05})
    assert vars(pipe).keys() == before.keys() and all(vars(pipe)[k] is v for k, v in before.items())
    assert len(pipe._memo.entries) > 0
    with pytest.raises(AttributeError, match="fixed once built"):
        pipe.idx = pipe.idx[:10]


@pytest.mark.parametrize("robot, moving, still", [
    ("6pus", ["leg[1].L", "leg[3].px", "rail[2].S0x", "rail[5].sy"],
     ["payload.m", "payload.x", "platform.m", "leg[2].m", "slider[1].m", "gravity.x", "cable.tension",
      "cable.anchor_x", "wrench.fz", "platform_drag.linear"]),
    ("quattro", ["leg[1].L", "leg[3].px", "arm[2].Ax", "arm[4].r"],
     ["payload.m", "platform.m", "arm[1].mass", "leg[2].m", "gravity.y", "cable.tension", "wrench.fx"])])
def test_the_joint_motion_moves_with_lengths_and_positions_not_with_masses_or_forces(clean_runs, robot, moving,
                                                                                       still):
    """The joint motion of the recorded poses is cached once for every drive layer added on a
    mechanism whose masses, gravity or platform force differ from the nominal ones; a length,
    position or direction of the mechanism moves it (the inverse kinematics of a pose reads
    them), a mass or a force does not."""
    pipe = Pipeline(clean_runs[robot], Model(robot))
    assert all(pipe._moves_joints(n) for n in moving), [n for n in moving if not pipe._moves_joints(n)]
    assert not any(pipe._moves_joints(n) for n in still), [n for n in still if pipe._moves_joints(n)]


def test_a_kept_residual_is_keyed_on_the_exact_values_and_handed_out_as_a_copy(clean_runs):
    """The last evaluations' residuals are kept whole (``Memo.residual``): the same parameters
    again (in another order, as ints or floats) give the same residual, other values of the same
    parameters their own, and a caller that changes the arrays it got changes no later answer."""
    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    j = pipe.model.facts.joint_prefix
    a = {f"{j}[1].coulomb": 0.05, "payload.m": 0.05}
    b = {"payload.m": 0.05, f"{j}[1].coulomb": 0.05 + 1e-3}  # the same names, another value
    first = pipe.evaluate(a).eff
    assert np.array_equal(first, _direct(pipe, a))
    assert np.array_equal(pipe.evaluate(b).eff, _direct(pipe, b))
    again = pipe.evaluate(dict(reversed(list(a.items()))))
    assert np.array_equal(again.eff, first) and again.eff is not first
    again.eff[:] = 0.0  # a caller's own copy
    assert np.array_equal(pipe.evaluate(a).eff, _direct(pipe, a))
    assert np.array_equal(pipe.evaluate({}).eff, _direct(pipe, {}))
