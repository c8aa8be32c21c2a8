"""Inputs for a body the platform carries on a spring (cosim.discrepancy.flexible.motion): its force,
the platform's acceleration through the body's resonance, is named on the platform's motion; the
resonance and the direction are fitted on each fold's fitted rows.

Synthetic, truth in closed form and integrated apart from the code under test: a platform pose
(the reference's, which the platform follows)
of six coordinates (x, y, z in m, three angles), each a sum of four sines at 0.3-9 Hz with
amplitudes in 1/f^2 (accelerations of like size over the band), recorded at 1 kHz and decimated
by 10; a mass on a spring and damper along the world direction d (6 Hz, damping ratio 0.08)
integrated by scipy's solve_ivp from the sines' second derivatives, its force on the platform
k x + c x' on the channel, with noise.  The stage's other inputs: the pose and the rails'
positions, rates and accelerations, each rail an oblique mix of the six coordinates (what the
inverse kinematics makes of the pose).
"""
import types

import numpy as np
from scipy.integrate import solve_ivp

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.cv import at, folds
from cosim.discrepancy.flexible.motion import MOTION, bank, extend, extended

DT, STEP, SECONDS = 1e-3, 10, 9.0
F0, ZETA = 6.0, 0.08


def _platform(seed):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, SECONDS + DT / 2, DT)
    f = rng.uniform(0.3, 9.0, (6, 4))
    amp = rng.uniform(0.5, 1.0, (6, 4)) * 0.01 / (1.0 + f) ** 2
    ph = rng.uniform(0.0, 2 * np.pi, (6, 4))

    def pose(tt, deriv=0):
        w = 2 * np.pi * f
        arg = w[None] * np.asarray(tt)[:, None, None] + ph[None]
        s = np.sin(arg) if deriv == 0 else -(w[None] ** 2) * np.sin(arg)
        return (amp[None] * s).sum(axis=2)
    return t, pose


def _carried(seed=3, sigma=0.02):
    """(pipe, X, columns, y, noise): the channel's residual is the carried body's force."""
    rng = np.random.default_rng(seed)
    t, pose = _platform(seed)
    d = np.array([0.4, -0.8, 0.45])
    d /= np.linalg.norm(d)
    w0 = 2 * np.pi * F0

    def body(tt, s):  # x'' + 2 zeta w0 x' + w0^2 x = -a . d  (per unit mass)
        a = pose([tt], 2)[0, :3] @ d
        return [s[1], -a - 2 * ZETA * w0 * s[1] - w0 * w0 * s[0]]
    sol = solve_ivp(body, (t[0], t[-1]), [0.0, 0.0], t_eval=t, max_step=DT, rtol=1e-8, atol=1e-12)
    force = w0 * w0 * sol.y[0] + 2 * ZETA * w0 * sol.y[1]
    idx = np.arange(0, len(t), STEP)
    y = force[idx] / np.std(force[idx]) * 0.2 + rng.normal(0.0, sigma, len(idx))
    x = pose(t)
    mix = rng.normal(size=(6, 6))
    q, qdd = x @ mix, pose(t, 2) @ mix
    qd = np.gradient(q, DT, axis=0)
    cols, X = [], []
    for k in range(6):
        for name, v, quantity, unit in ((f"q{k + 1}", q, "position", "m"), (f"qd{k + 1}", qd, "rate", "m/s"),
                                        (f"qdd{k + 1}", qdd, "acceleration", "m/s^2")):
            X.append(v[idx, k])
            cols.append((name, f"{quantity} of slider {k + 1}", k + 1, quantity, unit))
    for i in range(6):
        X.append(x[idx, i])
        cols.append((f"pose[{i}]", "the platform pose", None, "pose", ""))
    facts = types.SimpleNamespace(pose_units=("m", "m", "m", "rad", "rad", "rad"))
    pipe = types.SimpleNamespace(channels=["tau1"], window=5, step=1, x_s=x, idx=idx, t=t, dt=DT, nd=6,
                                 segments=[(0, len(t))], has_pose=True, model=types.SimpleNamespace(facts=facts),
                                 ref_motion=(x, None, pose(t, 2)))  # the platform follows its reference
    return pipe, np.column_stack(X), cols, y, sigma


def test_a_body_carried_on_a_spring_is_named_on_the_platforms_motion():
    # without the resonance's column the trees on the rails' and the pose's columns of the same
    # instant claim 0.20 of it out of fold and name rails 3's and 6's accelerations (measured); with
    # it the platform's motion alone (0.91, the resonance found at 6.3 Hz)
    pipe, X, cols, y, sigma = _carried()
    fit = flexible.fit_channel(pipe, X, cols, y, sigma, ("N", "tau1"))
    assert fit.explained and fit.share > 0.85
    assert [d.group for d in fit.inputs] == [MOTION]
    assert abs(fit.resonance[0] - F0) < 0.1 * F0


def test_the_resonance_is_fitted_on_each_folds_fitted_rows_only():
    # the residual changed on a fold's held-out rows leaves that fold's column as it was; the final
    # model's column (on every sample) is rebuilt from the pipeline by extended
    pipe, X, cols, y, sigma = _carried()
    rows = folds(len(y), 5)
    groups = flexible.input_groups(cols)
    responses = bank(pipe)
    Xe, cols_e, groups_e, resonance = extend(X, cols, groups, y, rows, responses)
    assert groups_e[MOTION] == [X.shape[1]] and cols_e[-1][1] == MOTION
    held = rows[2][0]
    y2 = y.copy()
    y2[held] = 0.5 * y[held] + np.random.default_rng(1).normal(0.0, 0.05, len(held))
    Xe2, _, _, _ = extend(X, cols, groups, y2, rows, responses)
    assert np.array_equal(at(Xe, 2), at(Xe2, 2))
    assert not np.allclose(at(Xe, 1)[:, -1], at(Xe2, 1)[:, -1])
    assert np.allclose(extended(X, pipe, resonance)[:, -1], np.asarray(Xe)[:, -1])


def test_no_column_without_a_reference_or_a_moving_length():
    # the column is the commanded motion's: without a reference (the measured pose only), or with
    # no length coordinate of the reference that moves, none
    pipe, X, cols, y, sigma = _carried()
    assert bank(types.SimpleNamespace(**{**vars(pipe), "ref_motion": None})) is None
    x, _, xdd = pipe.ref_motion
    still = np.column_stack([np.zeros((len(x), 3)), x[:, 3:]])
    assert bank(types.SimpleNamespace(**{**vars(pipe), "ref_motion": (still, None, xdd)})) is None
    nan = xdd.copy()
    nan[5, 0] = np.nan
    assert bank(types.SimpleNamespace(**{**vars(pipe), "ref_motion": (x, None, nan)})) is None
    Xe, cols_e, _, resonance = extend(X, cols, flexible.input_groups(cols), y, folds(len(y), 5), None)
    assert Xe is X and resonance == ()


def test_no_column_where_the_resonance_explains_nothing_out_of_fold():
    # a force on one rail's speed |qd| (a drag the same both ways): the resonance's linear fit
    # explains none of it held out (below MOTION_MIN), and the trees get no column to split on by chance
    pipe, X, cols, y, sigma = _carried()
    friction = 0.2 * np.abs(X[:, 1]) / np.std(X[:, 1]) + np.random.default_rng(4).normal(0.0, sigma, len(y))
    Xe, _, groups, resonance = extend(X, cols, flexible.input_groups(cols), friction, folds(len(y), 5), bank(pipe))
    assert Xe is X and resonance == () and MOTION not in groups


def test_a_pipelines_bank_is_filtered_once_and_equals_the_plain_filtering(clean_runs):
    """The stage asks for the bank on every channel: a pipeline's is filtered once, the same
    values as the resonators' filtering of its platform's acceleration, bit for bit, read-only."""
    from cosim.core import Model
    from cosim.discrepancy.flexible.motion import FREQUENCIES, platform_acceleration, resonated
    from cosim.discrepancy.residuals import Pipeline

    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    first, again = bank(pipe), bank(pipe)
    a = platform_acceleration(pipe)
    assert a is not None and list(first) == list(FREQUENCIES)
    for f in FREQUENCIES:
        assert np.array_equal(first[f], resonated(a, pipe.dt, f, [0])[pipe.idx])
        assert again[f] is first[f] and not first[f].flags.writeable
    assert again is not first  # the caller's own dict
