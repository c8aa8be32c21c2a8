"""Rules of the flexible stage whose leave-one-out fits are judged against a bar alone
(cosim.discrepancy.flexible.clock.on_time, .beside.once, .copies.copies).

Where a rule asks only whether the trees without a group fall under a bar (the trees with it
plus ``DROP_MIN`` of the variance), their growth stops after 10, 25 or 50 iterations once under it
(``under`` of :func:`~cosim.discrepancy.flexible.cv.cross_validate`): the error chosen over more
iterations is at most that one, so the rule decides as on the whole growth.  Each test runs the
rule twice on a synthetic case, with the stage's cross-validation and with one that ignores the
bar (every growth whole), and asks for the same answer; where the group carries nothing a growth
stops under the bar (the saving is made), where it carries the force none does (a bar set too
high would stop it and change the answer).
"""
import numpy as np
import pytest

from cosim.discrepancy.flexible import beside, clock, copies
from cosim.discrepancy.flexible import cv as cvm
from cosim.discrepancy.flexible.cv import cross_validate, folds


@pytest.fixture(autouse=True)
def _no_kept_fits():
    """Each test's growths made afresh (a whole growth kept by another test is no stopped one), on
    one thread as the stage fits them (an unlimited OpenMP runtime spins on a busy machine)."""
    import sklearn.ensemble  # noqa: F401  (its OpenMP runtime loaded before the limit: threadpoolctl limits the loaded ones)
    from threadpoolctl import threadpool_limits

    for store in (cvm._DONE, cvm._STOPPED, cvm._TARGET):
        store.clear()
    with threadpool_limits(limits=1):
        yield
    for store in (cvm._DONE, cvm._STOPPED, cvm._TARGET):
        store.clear()


def _recording(cv_fn):
    """``cv_fn`` and the list of whether each growth it made was stopped under a bar."""
    stopped = []

    def run(X, y, rows, **kw):
        got = cv_fn(X, y, rows, **kw)
        stopped.append(bool(getattr(got, "stopped", False)))
        return got
    return run, stopped


def _whole(X, y, rows, under=None, **kw):
    """The stage's cross-validation with the bar ignored: every growth whole."""
    return cross_validate(X, y, rows, **kw)


def _signals(seed, n=600):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 9.0, n)
    position = np.sin(2 * np.pi * 0.37 * t) + 0.5 * np.sin(2 * np.pi * 0.91 * t + 1.0)
    history = np.convolve(np.abs(np.gradient(position)), np.ones(60) / 60, mode="same")
    return rng, t, position, history


def _on_time(kind, cv_fn):
    rng, t, position, history = _signals(3)
    window = ((t > 3.0) & (t < 6.0)).astype(float)
    force = np.tanh(2 * position)
    if kind == "time":  # a level over a window of time: time adds to the position, and a slow history
        force = force + window  # that rises and falls with it adds as much (it does not beat time)
        history = history + np.convolve(window, np.ones(120) / 120, mode="same")
    y = force + 0.1 * rng.normal(size=len(t))
    X, rows = np.column_stack([position, history, t]), folds(len(t), 5)
    groups = {"position of slider 1": [0], "history of slider 1": [1], "time": [2]}

    def cv_on(gs, without=(), under=None):
        cols = sorted({i for g in gs for i in groups[g]} - set(without))
        return (cv_fn(X[:, cols], y, rows) if under is None else cv_fn(X[:, cols], y, rows, under=under)), cols
    return clock.on_time(["position of slider 1", "history of slider 1"], groups, y, float(np.var(y)), cv_on)


def test_time_in_the_place_of_histories_is_decided_on_the_trees_stopped_under_the_bar():
    for kind in ("none", "time"):
        run, stopped = _recording(cross_validate)
        got = _on_time(kind, run)
        cvm._DONE.clear(), cvm._STOPPED.clear(), cvm._TARGET.clear()
        assert got == _on_time(kind, _whole)
        # nothing in time: the position's trees fall under the bar early; a window in time: none does
        assert any(stopped) == (kind == "none"), (kind, stopped)
    assert got == ["position of slider 1", "time"]


def _once(kind, cv_fn):
    rng, t, position, _ = _signals(5)
    force = np.tanh(2 * position) + (0.8 * t / 9.0 if kind == "drift" else 0.0)
    y = force + 0.1 * rng.normal(size=len(t))
    X = np.column_stack([position, t])
    groups = {"position of slider 1": [0], "time": [1]}
    return beside.once(["position of slider 1", "time"], groups, X, y, cv_fn)


def test_time_beside_other_groups_is_judged_on_the_trees_stopped_under_the_bar():
    for kind in ("none", "drift"):
        run, stopped = _recording(cross_validate)
        got = _once(kind, run)
        cvm._DONE.clear(), cvm._STOPPED.clear(), cvm._TARGET.clear()
        assert got == _once(kind, _whole)
        assert got == (["position of slider 1", "time"] if kind == "drift" else ["position of slider 1"])
        assert any(stopped) == (kind == "none"), (kind, stopped)


def _copies(kind, cv_fn):
    rng, t, position, _ = _signals(7)
    load = np.sin(2 * np.pi * 0.53 * t + 0.4)
    force = np.tanh(2 * position) + (0.8 * load if kind == "load" else 0.0)
    y = force + 0.1 * rng.normal(size=len(t))
    # the effort: the load (which the reference motion sets too) and, answering the force, its copy
    effort = load + 0.9 * force
    X, rows = np.column_stack([position, effort]), folds(len(t), 5)
    reference = np.column_stack([position, load])
    groups = {"position of slider 1": [0], "effort of slider 1": [1]}
    return copies.copies(["position of slider 1", "effort of slider 1"], groups, X, reference, y, rows, cv_fn)


def test_a_copy_of_the_answer_is_found_on_the_trees_stopped_under_the_bar():
    for kind in ("answer", "load"):
        run, stopped = _recording(cross_validate)
        got = _copies(kind, run)
        cvm._DONE.clear(), cvm._STOPPED.clear(), cvm._TARGET.clear()
        assert got == _copies(kind, _whole)
        # the effort only answers the force: a copy (the position's trees fall under the bar early);
        # a force on the load the reference sets too: the effort stays (no growth stops)
        assert got == (["effort of slider 1"] if kind == "answer" else [])
        assert any(stopped) == (kind == "answer"), (kind, stopped)
