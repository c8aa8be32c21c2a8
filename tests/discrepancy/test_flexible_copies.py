"""Inputs that carry the controller's answer to a force, not its cause
(cosim.discrepancy.flexible.copies): where the recording has a reference motion, a named
acceleration, effort or history stays only where its counterpart along the reference adds beside
the other named inputs.

Synthetic, truth in closed form: a friction on slider 1 whose level decays after each reversal of
its commanded rate and follows a slow state no input records, sign(qd1) (0.2 + 0.5 exp(-s / 0.3)
+ 0.3 w(t)) with s the time since the reversal, and the channel's own model effort carrying the
commanded motion's load and a copy of that force lagged by 30 ms (what the drive's controller
answers in closed loop); its counterpart along the reference is the load alone.  The rate alone
tells neither the decay nor w, so the copy adds a share beside it: the consequence's bar
(:func:`cosim.discrepancy.flexible.select.gain`) passes it.
"""
import types

import numpy as np

from cosim.discrepancy.flexible import stage as flexible
from cosim.discrepancy.flexible.beside import rules
from cosim.discrepancy.flexible.copies import copies, counterparts
from cosim.discrepancy.flexible.select import consequences, select


def _lagged(f, dt, tau=0.03):
    a = np.exp(-dt / tau)
    out = np.empty(len(f))
    out[0] = f[0]
    for i in range(1, len(f)):
        out[i] = a * out[i - 1] + (1 - a) * f[i]
    return out


def _decaying_friction(n=900, sigma=0.05, seed=3, keyed_on_load=False):
    """``(X, columns, reference, y)``: the rate, the own model effort and another drive's effort of
    the stage's columns, and their counterparts along the reference.  ``keyed_on_load``: the force
    is instead sign(qd1) 0.25 |load2| with load2 the other drive's effort along the reference (a
    bearing the neighbouring drive preloads), its measured effort holding a small copy of it."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    dt = t[1] - t[0]
    qd1 = np.sin(2 * np.pi * 0.41 * t) + 0.4 * np.sin(2 * np.pi * 1.3 * t + 0.5)
    direction = np.sign(qd1)
    since = np.zeros(n)
    for i in range(1, n):
        since[i] = 0.0 if direction[i] != direction[i - 1] else since[i - 1] + dt
    wear = np.sin(2 * np.pi * 0.11 * t + 0.7)  # a slow state no input records
    load1 = 0.3 * np.sin(2 * np.pi * 0.29 * t + 2.0)
    load2 = np.sin(2 * np.pi * 0.17 * t + 1.0) + 0.6 * np.sin(2 * np.pi * 0.53 * t)
    if keyed_on_load:
        f = np.tanh(qd1 / 0.05) * 0.25 * np.abs(load2)
    else:
        f = np.tanh(qd1 / 0.05) * (0.2 + 0.5 * np.exp(-since / 0.3) + 0.3 * wear)
    copy = _lagged(f, dt)
    measured = np.column_stack([qd1, load1 + copy, load2 + 0.1 * copy])
    reference = np.column_stack([qd1, load1, load2])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"), ("effort1", "effort of slider 1", 1, "effort", "N"),
            ("effort2", "effort of slider 2", 2, "effort", "N")]
    return measured, cols, reference, f + rng.normal(0.0, sigma, n)


def _named(X, cols, y, reference, named):
    groups = flexible.input_groups(cols)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    follow = consequences(cols, groups, 1)
    after = rules(X, y, fold_rows, groups, follow, None, flexible.cross_validate, reference=reference)
    return sorted(select(X, y, fold_rows, groups, named, float(np.var(y)), follow=follow,
                         cross_validate=flexible.cross_validate, after=after)[0])


def test_the_own_effort_that_copies_the_force_is_not_named_where_its_reference_counterpart_adds_nothing():
    # without a reference the consequence's bar names the copy beside the rate; its counterpart
    # along the reference (the commanded motion's load) adds nothing, so with it the rate alone is
    X, cols, reference, y = _decaying_friction()
    assert _named(X, cols, y, None, ["rate of slider 1", "effort of slider 1"]) == \
        ["effort of slider 1", "rate of slider 1"]  # the situation the rule is for
    assert _named(X, cols, y, reference, ["rate of slider 1", "effort of slider 1"]) == ["rate of slider 1"]


def test_an_effort_the_force_is_keyed_on_stays_named_its_reference_counterpart_carrying_the_load():
    X, cols, reference, y = _decaying_friction(keyed_on_load=True)
    named = ["rate of slider 1", "effort of slider 2"]
    assert _named(X, cols, y, reference, named) == sorted(named)


def test_no_reference_no_copy_and_a_recording_without_one_has_no_counterparts():
    X, cols, reference, y = _decaying_friction()
    groups = flexible.input_groups(cols)
    fold_rows = flexible.folds(len(y), flexible.gap_for(1.0))
    assert copies(["rate of slider 1", "effort of slider 1"], groups, X, None, y, fold_rows,
                  flexible.cross_validate) == []
    assert counterparts(types.SimpleNamespace(channels=["tau1"]), X, cols) is None
    assert counterparts(types.SimpleNamespace(rec=types.SimpleNamespace(qref=None), tau_ref_s=None), X, cols) is None


def test_the_counterparts_are_the_reference_motions_acceleration_effort_and_histories():
    # a joint at the stage's columns (flexible.inputs): each column built from the measured
    # acceleration or effort is replaced, its position and rate left as they are
    n, dt, step = 3000, 1e-3, 10
    t = np.arange(n) * dt
    q = 0.02 * np.sin(2 * np.pi * 0.7 * t)[:, None]
    idx = np.arange(60, n - 60, step)

    def S(a, deriv=0):
        from scipy.signal import savgol_filter

        return savgol_filter(a, 31, 3, deriv=deriv, delta=dt, axis=0, mode="interp")
    tau_ref = 5.0 * S(q, deriv=2)
    pipe = types.SimpleNamespace(
        idx=idx, nd=1, t=t, segments=[(0, n)], dt=dt, tau_s=tau_ref + 0.1, q_s=S(q), qd_s=S(q, deriv=1),
        qdd_s=S(q, deriv=2) + 0.5, has_pose=False, channels=["tau1"], window=31, step=step, S=S,
        rec=types.SimpleNamespace(qref=q), tau_ref_s=tau_ref,
        model=types.SimpleNamespace(facts=types.SimpleNamespace(joint_noun="slider", joint_unit="m", effort_unit="N")))
    X, cols = flexible.inputs(pipe, np.zeros((len(idx), 1)), direction=True)
    Xr = counterparts(pipe, X, cols)
    at = {c[0]: i for i, c in enumerate(cols)}
    assert np.allclose(Xr[:, at["effort1"]], tau_ref[idx, 0])
    assert np.allclose(Xr[:, at["qdd1"]], S(q, deriv=2)[idx, 0])
    assert np.allclose(Xr[:, at["effort1 low-passed 1 s"]] + 0.1, X[:, at["effort1 low-passed 1 s"]], atol=1e-3)
    for name in ("q1", "qd1", "qd1 reference"):
        assert np.array_equal(Xr[:, at[name]], X[:, at[name]])


def test_a_joints_history_beside_its_own_rate_is_not_judged_as_a_copy():
    # a friction whose level a slow state of the joint sets (a heating drive's power history):
    # the measured history is its input, and a counterpart along the reference that does not
    # carry that state (here a slow signal of its own) would take it for a copy
    n = 900
    t = np.linspace(0.0, 9.0, n)
    qd1 = np.sin(2 * np.pi * 0.41 * t) + 0.4 * np.sin(2 * np.pi * 1.3 * t + 0.5)
    heat = 1.0 + 0.5 * np.sin(2 * np.pi * 0.13 * t)
    y = np.tanh(qd1 / 0.05) * heat + np.random.default_rng(4).normal(0.0, 0.05, n)
    X = np.column_stack([qd1, heat])
    reference = np.column_stack([qd1, 1.0 + 0.5 * np.sin(2 * np.pi * 0.37 * t + 1.0)])
    cols = [("qd1", "rate of slider 1", 1, "rate", "m/s"),
            ("|effort1 qd1| low-passed 8 s", "history of slider 1", 1, "history", "N m/s")]
    groups = flexible.input_groups(cols)
    fold_rows = flexible.folds(n, flexible.gap_for(1.0))
    assert copies(["rate of slider 1", "history of slider 1"], groups, X, reference, y, fold_rows,
                  flexible.cross_validate) == []


def test_the_copies_trees_are_fitted_on_the_columns_fitted_per_fold_with_the_counterparts_in_each():
    """With inputs whose columns are fitted per fold (:class:`~cosim.discrepancy.flexible.cv.FoldInputs`:
    a projected pose column fitted on each fold's fitted rows), every cross-validation the rule makes is
    given those per-fold columns, the judged effort replaced by its counterpart in each fold's columns as
    in the whole array: columns fitted on every sample, held-out rows included, would judge the held-out
    rows on what was fitted on them."""
    from cosim.discrepancy.flexible.cv import N_FOLDS, FoldInputs, cross_validate, folds

    rng = np.random.default_rng(5)
    n = 400
    whole = rng.normal(size=(n, 3))  # rate of slider 1, effort of slider 1, the projected pose
    variants = np.repeat(whole[None], N_FOLDS, axis=0)
    variants[:, :, 2] += np.arange(1, N_FOLDS + 1)[:, None] * rng.normal(size=(N_FOLDS, n))  # per fold
    X = FoldInputs(whole, variants)
    reference = whole + np.array([0.0, 1.0, 0.0]) * rng.normal(size=(n, 3))  # the effort's counterpart
    groups = {"rate of slider 1": [0], "effort of slider 1": [1], "platform pose": [2]}
    y = whole[:, 1] + 0.5 * whole[:, 2]
    given = []

    def spy(M, y_, fold_rows):
        given.append(M)
        return cross_validate(M, y_, fold_rows)

    copies(list(groups), groups, X, reference, y, folds(n, gap=2), spy)
    assert len(given) == 2  # the trees on every named group, and without the effort
    for M, cols in zip(given, [(0, 1, 2), (0, 2)]):
        assert getattr(M, "variants", None) is not None
        for b in range(N_FOLDS):
            for j, c in enumerate(cols):
                expected = reference[:, c] if c == 1 else variants[b, :, c]
                np.testing.assert_array_equal(M.variants[b, :, j], expected)
                np.testing.assert_array_equal(np.asarray(M)[:, j], reference[:, c] if c == 1 else whole[:, c])
    np.testing.assert_array_equal(np.asarray(X), whole)  # the stage's inputs untouched
    np.testing.assert_array_equal(X.variants[:, :, 1], np.repeat(whole[None, :, 1], N_FOLDS, axis=0))
