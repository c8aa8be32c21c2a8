"""Signals injected into the loop (cosim.injection, pkm_ctrl_update_injected,
pkm_closed_loop's inject).

Oracles, none of them the injection code: the truth runs are the stepwise loop with a plain
Python controller that adds the signal itself (a PD law written in the test + w, clipped by hand where the
signal goes before the saturation; the law given q + w or qref + w); the discrete
controller's injected part is checked against its closed form (w one computation delay
later while nothing clips).
"""
import numpy as np
import pytest

from cosim import controllers as ctl
from cosim.closed_loop import ClosedLoop
from cosim.core import Model
from cosim.errors import InputError
from cosim.injection import Injection, from_recording
from cosim.master import ReferenceTable
from cosim.plants import CorePlant
from cosim.recording import Recording, read_recording, write_recording

H = 1e-3
N = 600
KP, KD, SAT = 4.0e4, 6.0e2, 300.0


def _reference(m, a=0.02):
    t = np.arange(N) * H
    q = 0.1 + a * np.sin(2 * np.pi * 2 * t)[:, None]
    qd = a * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t)[:, None]
    qdd = -a * (2 * np.pi * 2) ** 2 * np.sin(2 * np.pi * 2 * t)[:, None]
    return ReferenceTable(t, q, qd, qdd, q.copy())


def _signal(amplitude):
    """A 0/amplitude square wave, 25 ms on, 25 ms off, from 50 ms."""
    k = np.arange(N)
    return (amplitude * ((k >= 50) & ((k // 25) % 2 == 0)))[:, None].astype(float)


def _truth(m, ref, point, w):
    """The stepwise loop with a Python controller that adds w itself at ``point``."""
    def raw(t, q, qd, row):  # the PD law, unsaturated, written here
        return KP * (row.q - q) + KD * (row.qd - qd)

    def controller(t, q, qd, row):
        k = int(round(t / H))
        if point == "reference":
            row = type(row)(row.q + w[k], row.qd, row.qdd, row.x, row.xd, row.xdd)
        if point == "measurement":
            q = q + w[k]
        u = np.asarray(raw(t, q, qd, row), float)
        if point == "command":
            return np.clip(u + w[k], -SAT, SAT)
        return np.clip(u, -SAT, SAT) + (w[k] if point == "command_after_saturation" else 0.0)

    rec = ClosedLoop(CorePlant(m), controller).run(ref)
    assert rec.loop == "python"
    law_only = np.clip(np.asarray([raw(t, q, qd, ref.at(k)) for k, (t, q, qd) in
                                   enumerate(zip(rec.time, rec.q, rec.qd))]), -SAT, SAT)
    return rec, law_only


@pytest.fixture(scope="module")
def emps():
    m = Model("emps")
    return m, _reference(m)


def _replay(m, ref, inj, compiled=True):
    return ClosedLoop(CorePlant(m), ctl.pd(ndof=1, kp=KP, kd=KD, saturation=SAT), compiled=compiled).run(
        ref, inject=inj)


def test_a_signal_added_to_the_command_replays_to_1e_9_with_the_right_declaration(emps):
    m, ref = emps
    w = _signal(400.0)  # drives the command into its +-300 N saturation
    truth, law = _truth(m, ref, "command", w)
    assert np.any(np.abs(truth.tau_cmd) >= SAT)  # the signal makes the command clip
    # recorded with the signal in the effort, and without it
    for (in_effort, recorded), compiled in zip(((True, truth.tau_cmd), (False, law)) * 2, (True, True, False, False)):
        inj = Injection(w, point="command", in_effort=in_effort)
        rep = _replay(m, ref, inj, compiled)  # stepwise: the controller's compiled copy takes the signal
        assert rep.loop == ("compiled" if compiled else "python")
        np.testing.assert_allclose(rep.q, truth.q, rtol=0, atol=1e-9)
        np.testing.assert_allclose(inj.effort_seen(rep.tau_cmd, rep.tau_inj), recorded, rtol=0, atol=1e-9)
        # the wrong declaration of the effort: off by the signal where it acted
        wrong = Injection(w, point="command", in_effort=not in_effort).effort_seen(rep.tau_cmd, rep.tau_inj)
        assert np.max(np.abs(wrong - recorded)) > 50.0
    # the wrong point: after the saturation, or the signal as a force on the carriage
    after = _replay(m, ref, Injection(w, point="command_after_saturation"))
    force = ClosedLoop(CorePlant(m), ctl.pd(ndof=1, kp=KP, kd=KD, saturation=SAT)).run(ref, f_ext=w)
    none = _replay(m, ref, None)
    for wrong in (after, force, none):
        assert np.max(np.abs(wrong.q - truth.q)) > 1e-5


@pytest.mark.parametrize("point, amplitude", [("reference", 2e-3), ("measurement", 2e-3),
                                              ("command_after_saturation", 400.0)])
def test_the_other_points_replay_the_hand_made_loop_on_both_back_ends(emps, point, amplitude):
    m, ref = emps
    w = _signal(amplitude)
    truth, _ = _truth(m, ref, point, w)
    for compiled in (True, False):
        rep = _replay(m, ref, Injection(w, point=point), compiled)
        np.testing.assert_allclose(rep.q, truth.q, rtol=0, atol=1e-9, err_msg=f"{point} compiled={compiled}")
        np.testing.assert_allclose(rep.tau_cmd, truth.tau_cmd, rtol=0, atol=1e-9)
    # the recorded reading is the sensor's, not the one the controller was given
    if point == "measurement":
        np.testing.assert_allclose(rep.q, rep.q_true, rtol=0, atol=0)


@pytest.mark.parametrize("compiled", [True, False])
def test_the_discrete_controller_delays_the_injected_command_with_its_output(compiled):
    m = Model("emps")
    t = np.arange(N) * H
    hold = np.full((N, 1), 0.1)
    ref = ReferenceTable(t, hold, np.zeros((N, 1)), np.zeros((N, 1)), hold.copy())
    desc = {"kind": "discrete", "period": H, "law": "cascade_pp", "kp": 160.18, "kv": 243.45,
            "saturation": [-10.0, 10.0], "output_gain": 35.15, "delay_samples": 1}
    w = _signal(0.5 * 35.15)  # half a volt, in N through the drive gain: no clipping
    rec = ClosedLoop(CorePlant(m), ctl.discrete(desc, ndof=1, model=m), compiled=compiled).run(ref, inject=Injection(w))
    assert rec.loop == ("compiled" if compiled else "python")
    np.testing.assert_allclose(rec.tau_inj[1:], w[:-1], rtol=0, atol=1e-9)
    assert rec.tau_inj[0, 0] == 0.0


def test_a_python_law_saturated_before_the_signal_is_refused(emps):
    m, ref = emps

    class Clipped:  # a law the core does not implement, with its own saturation
        saturation = SAT

        def __call__(self, t, q, qd, row):
            return np.clip(KP * (row.q - q), -SAT, SAT)

    with pytest.raises(InputError, match="before the saturation of a Python controller"):
        ClosedLoop(CorePlant(m), Clipped()).run(ref, inject=Injection(_signal(1.0), point="command"))


@pytest.mark.parametrize("signal, words", [(np.zeros((N - 1, 1)), r"shape \(599, 1\), the run \(600, 1\)"),
                                           (np.full((N, 1), np.nan), "row 0 \\(t = 0 s\\), joint 1 is nan")])
def test_a_signal_of_the_wrong_length_or_not_finite_is_refused(emps, signal, words):
    m, ref = emps
    with pytest.raises(InputError, match=words):
        _replay(m, ref, Injection(signal))


def test_a_declaration_without_in_effort_or_at_an_unknown_point_is_refused():
    with pytest.raises(InputError, match="in_effort must be true or false"):
        Injection(np.zeros((3, 1)), point="command", in_effort=None)
    with pytest.raises(InputError, match="'torque' is not one of"):
        Injection(np.zeros((3, 1)), point="torque")


def test_a_recording_carries_the_signal_and_its_declaration(tmp_path):
    t = np.arange(5) * H
    w = np.array([0.0, 5.0, 5.0, 0.0, 0.0])
    rec = Recording(robot="emps", time=t, q=np.zeros((5, 1)), qd=np.zeros((5, 1)), tau=np.ones((5, 1)),
                    extra={"inject1": w}, sidecar={"injection": {"point": "command", "in_effort": False}})
    back = read_recording(write_recording(tmp_path / "r.csv", rec)[0])
    inj = from_recording(back)
    np.testing.assert_array_equal(inj.signal[:, 0], w)
    assert (inj.point, inj.in_effort) == ("command", False)
    assert back.sidecar["units"]["inject"] == "N"
    np.testing.assert_array_equal(inj.applied_from_recorded(back.tau)[:, 0], 1.0 + w)
    back.sidecar.pop("injection")
    with pytest.raises(InputError, match="where was the signal added"):
        from_recording(back)


def test_the_effort_residual_adds_a_command_signal_the_recording_left_out(emps):
    from cosim.discrepancy.residuals import Pipeline

    m, _ = emps
    ref = _reference(m, 0.005)
    w = _signal(100.0)  # no clipping: the command reaching the drive is the recorded one plus w
    truth, law = _truth(m, ref, "command", w)
    assert np.all(np.abs(truth.tau_cmd) < SAT)
    rms = {}
    for in_effort in (False, True):
        rec = Recording(robot="emps", time=truth.time, q=truth.q, qd=truth.qd, tau=law, qref=ref.q,
                        extra={"inject1": w[:, 0]}, sidecar={"injection": {"point": "command", "in_effort": in_effort}})
        rms[in_effort] = float(np.sqrt(np.mean(Pipeline(rec, m).evaluate().eff ** 2)))
    # declared right, the nominal model explains the recording; declared wrong, the signal is left
    assert rms[False] < 0.02 * rms[True] and rms[True] > 20.0
