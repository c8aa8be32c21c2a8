"""The FMI 3.0 FMUs (build/fmu/fmi3): fmpy validates each, its arrays are the rows of the FMI
2.0 table, and fmpy runs them (Co-Simulation, Model Exchange, FMU state, refused input, a
closed PD loop with the controller FMU) to the same numbers as the FMI 2.0 FMUs of the same
binary, with the same messages."""
import ctypes as C
import struct
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.validation import validate_fmu

from cosim import fmu
from cosim.core import Model

REPO = Path(__file__).resolve().parents[2]

H = 1e-3
ROBOTS = ["6pus", "quattro", "hexapod_ups"]  # with a table of its own (6pus, quattro) and the described FMUs' table


def fmi3_files():
    """Every plant and controller FMU of the robots the toolkit lists, as FMI 3.0 (a missing
    one is a failure: the build makes one per FMI 2.0 FMU, never a skip)."""
    listed = [ln.split("#")[0].strip() for ln in (REPO / "robots" / "robots.list").read_text().splitlines()]
    robots = [r for r in listed if r]  # "6pus" and "quattro" are listed (robots/6pus.toml, quattro.toml)
    return [fmu.build_dir() / "fmu" / "fmi3" / f"{fmu.fmu_id(r)}{s}.fmu" for r in robots for s in ("", "_CTRL")]


def fmi2_outputs(md2):
    """The FMI 2.0 Real outputs in value-reference order (the rows of the table)."""
    return [v for v in md2.modelVariables if v.causality == "output" and v.type == "Real"]


def flat(md3, causality):
    """The FMI 3.0 Float64 variables of a causality with their sizes, in value-reference order."""
    return [(v, int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1)
            for v in md3.modelVariables if v.causality == causality and v.type == "Float64"]


def hold_input(robot):
    """Efforts near the gravity load at home: the platform drifts slowly and smoothly."""
    m = Model(robot)
    g = m.gravity_load(m.home())
    return g + 0.05 * np.linspace(0.3, -0.2, g.size)


# fmpy's validation takes ~2 s an FMU: the suite validates the kinds (a plant in C++, its
# controller, a described plant with a drive model); bench/fmu_validate.py validates every one.
@pytest.mark.parametrize("ident", ["PKM_6PUS", "PKM_6PUS_CTRL", "PKM_HEXAPOD_UPS", "PKM_EMPS"])
def test_fmpy_validates_the_fmi3_fmus(ident):
    f = fmu.build_dir() / "fmu" / "fmi3" / f"{ident}.fmu"
    assert validate_fmu(str(f)) == []  # schema, variable names, model structure
    assert read_model_description(str(f)).fmiVersion == "3.0"


def test_arrays_where_the_model_has_arrays():
    md = read_model_description(str(fmu.fmu_path("6pus", fmi=3)))
    dims = {v.name: [int(d.start) for d in v.dimensions] for v in md.modelVariables}
    for name in ("tau", "q", "qd", "q_drive", "qd_drive", "pose", "twist", "accel", "pose0", "twist0"):
        assert dims[name] == [6], name
    assert dims["singularity.direct"] == [] and dims["time"] == []
    assert md.numberOfContinuousStates == 12
    assert md.numberOfEventIndicators == 1 + 2 * 6  # singularity margin, both stroke limits per slider
    ctrl = read_model_description(str(fmu.fmu_path("6pus", fmi=3)).replace("PKM_6PUS", "PKM_6PUS_CTRL"))
    cdims = {v.name: [int(d.start) for d in v.dimensions] for v in ctrl.modelVariables}
    assert cdims["kp"] == [6, 6] and cdims["lti.A"] == [12, 12] and cdims["lti.B"] == [12, 6]
    assert ctrl.modelExchange is None


@pytest.mark.parametrize("path", fmi3_files(), ids=lambda p: p.stem)
def test_each_fmi3_variable_is_rows_of_the_fmi2_table(path):
    # Taken in order, the FMI 3.0 parameters, inputs and outputs are the FMI 2.0 variables,
    # with the same start values: the two descriptions are one table.
    md3 = read_model_description(str(path))
    md2 = read_model_description(str(path.parent.parent / path.name))
    rows = [v for v in md2.modelVariables]
    starts3 = []
    for v in md3.modelVariables:
        if v.causality in ("independent", "local"):
            continue
        n = int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1
        s = v.start.split() if isinstance(v.start, str) else ([] if v.start is None else [v.start])
        starts3 += [float(x) for x in s] if s else [None] * n
    assert len(starts3) == len(rows)
    for v, s in zip(rows, starts3):
        if v.start is not None:
            assert float(v.start) == s, v.name


def _compare(robot, kind, stop):
    hold = hold_input(robot)
    p2, p3 = fmu.fmu_path(robot), fmu.fmu_path(robot, fmi=3)
    md2, md3 = read_model_description(str(p2)), read_model_description(str(p3))
    taus2 = [v.name for v in md2.modelVariables if v.causality == "input"]
    outs2 = [v.name for v in fmi2_outputs(md2)]
    outs3 = [v.name for v, _ in flat(md3, "output")]
    kw = dict(fmi_type=kind, stop_time=stop, output_interval=H, relative_tolerance=1e-10 if kind == "ModelExchange"
              else None)
    r2 = simulate_fmu(str(p2), start_values=dict(zip(taus2, hold)), output=outs2, **kw)
    r3 = simulate_fmu(str(p3), start_values={"tau": hold}, output=outs3, **kw)
    a2 = np.column_stack([r2[n] for n in outs2])
    a3 = np.column_stack([r3[n].reshape(len(r3), -1) for n in outs3])
    assert a2.shape == a3.shape and a2.shape[0] == int(round(stop / H)) + 1
    np.testing.assert_array_equal(r2["time"], r3["time"])
    return a2, a3, md2


@pytest.mark.parametrize("robot", ROBOTS)
@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_fmpy_runs_fmi3_equal_to_fmi2(robot, kind):
    a2, a3, md2 = _compare(robot, kind, 0.1)
    assert np.max(np.abs(a3 - a2)) <= 1e-12
    assert np.max(np.abs(a2[-1] - a2[0])) > 1e-6  # it moved: the comparison means something


# ------------------------------------------------------------------ by hand

class Instance:
    """An FMI 3.0 instance through fmpy's low-level class, its log lines kept."""

    def __init__(self, path, kind="CoSimulation", name="plant", params=None, initialize=True, early_return=False):
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.size = {v.name: (int(np.prod([int(d.start) for d in v.dimensions])) if v.dimensions else 1)
                     for v in self.md.modelVariables}
        self.log = []
        cls = FMU3Slave if kind == "CoSimulation" else FMU3Model
        self.f = cls(guid=self.md.guid, unzipDirectory=extract(str(path)), modelIdentifier=self.md.coSimulation
                     .modelIdentifier, instanceName=name)
        more = {"earlyReturnAllowed": True} if early_return else {}
        self.f.instantiate(logMessage=lambda env, st, cat, msg: self.log.append((st, msg.decode())), **more)
        self.time = 0.0
        for k, v in (params or {}).items():
            self.set(k, v)
        if initialize:
            self.f.enterInitializationMode(startTime=0.0)
            self.f.exitInitializationMode()

    def get(self, name):
        return np.array(self.f.getFloat64([self.vr[name]], self.size[name]))

    def set(self, name, value):
        self.f.setFloat64([self.vr[name]], np.broadcast_to(np.asarray(value, float), (self.size[name],)).tolist())

    def step(self, tau=None):
        if tau is not None:
            self.set("tau", tau)
        r = self.f.doStep(self.time, H)
        self.time += H
        return r

    def close(self):
        self.f.freeInstance()


def test_state_rollback_serialisation_and_damaged_states():
    hold = hold_input("6pus")
    path = fmu.fmu_path("6pus", fmi=3)
    a = Instance(path, name="a")
    for _ in range(20):
        a.step(hold)
    s = a.f.getFMUState()
    t_mid = a.time
    first = []
    for k in range(20):
        a.step(hold * (1 + 0.01 * k))
        first.append(a.get("pose"))
    a.f.setFMUState(s)
    a.time = t_mid
    again = []
    for k in range(20):
        a.step(hold * (1 + 0.01 * k))
        again.append(a.get("pose"))
    assert np.array_equal(first, again)
    assert np.max(np.abs(first[-1] - first[0])) > 1e-6
    blob = bytes(a.f.serializeFMUState(s))
    a.f.freeFMUState(s)

    b = Instance(path, name="b")
    b.f.setFMUState(b.f.deserializeFMUState(blob))
    b.time = t_mid
    for k in range(20):
        b.step(hold * (1 + 0.01 * k))
    assert np.array_equal(b.get("pose"), first[-1])

    # Damaged blocks are refused with a message, the instance keeps its state.
    before = b.get("pose")
    flipped = bytearray(blob)
    flipped[len(blob) // 2] ^= 0x40
    truncated = blob[:-8]
    # The same block with a NaN in the plant's part, sealed again with its checksum (FNV-1a 64
    # over the block, its own field, bytes 112..119 of the header, read as zero).
    nan = bytearray(blob)
    nan[-8:] = struct.pack("<d", float("nan"))
    h = 14695981039346656037
    for i, byte in enumerate(nan):
        h = ((h ^ (0 if 112 <= i < 120 else byte)) * 1099511628211) % 2 ** 64
    nan[112:120] = struct.pack("<Q", h)
    fmi2_blob = blob[:6] + b"2" + blob[7:]  # magic PKMFMU3S -> PKMFMU2S
    for bad, says in [(bytes(flipped), "checksum"), (truncated, "truncated or damaged"),
                      (fmi2_blob, "not an FMU state"), (bytes(nan), "not finite")]:
        n = len(b.log)
        try:
            state = b.f.deserializeFMUState(bad)
            with pytest.raises(FMICallException):
                b.f.setFMUState(state)
        except FMICallException:
            pass
        assert any(st == 3 and says in msg for st, msg in b.log[n:]), (says, b.log[n:])
        assert np.array_equal(b.get("pose"), before)
    b.step(hold)  # and it goes on
    a.close()
    b.close()


def test_refusals_say_the_same_as_fmi2():
    hold = hold_input("6pus")
    p2 = fmu.fmu_path("6pus")
    with fmu.FMUInstance(p2) as f2:
        f2.step(H, tau=hold)
        bad = hold.copy()
        bad[2] = np.nan
        with pytest.raises(fmu.FMUError):
            f2.step(H, tau=bad)
        line2 = f2.log[-1].split("] ", 1)[1]
        with pytest.raises(fmu.FMUError):
            f2.set("leg[1].L", 0.12)
        fixed2 = f2.log[-1].split("] ", 1)[1]
    f3 = Instance(fmu.fmu_path("6pus", fmi=3))
    f3.step(hold)
    with pytest.raises(FMICallException):
        f3.step(bad)
    assert f3.log[-1] == (3, line2.replace("fmi2SetReal", "fmi3SetFloat64")), (f3.log[-1], line2)
    assert "tau[3]" in line2 and "nan" in line2 and "not finite" in line2
    with pytest.raises(FMICallException):
        f3.f.setFloat64([f3.vr["leg[1].L"]], [0.12])
    assert f3.log[-1] == (3, fixed2.replace("fmi2SetReal", "fmi3SetFloat64"))
    f3.close()
    # An array takes exactly its number of values.
    f3 = Instance(fmu.fmu_path("6pus", fmi=3))
    with pytest.raises(FMICallException):
        f3.f.setFloat64([f3.vr["tau"]], [1.0, 2.0])
    assert f3.log[-1] == (3, "fmi3SetFloat64: the 1 variables have 6 values, nValues is 2")
    f3.close()

    # A bad start value fails the end of initialization with the FMI 2.0 message.
    g2 = fmu.FMUInstance(p2, params={"platform.Izz": 9e-4}, initialize=False)
    with pytest.raises(fmu.FMUError):
        g2.initialize()
    init2 = g2.log[-1].split("] ", 1)[1]
    g2.close()
    g3 = Instance(fmu.fmu_path("6pus", fmi=3), params={"platform.Izz": 9e-4}, initialize=False)
    g3.f.enterInitializationMode(startTime=0.0)
    with pytest.raises(FMICallException):
        g3.f.exitInitializationMode()
    assert g3.log[-1] == (3, init2.replace("fmi2ExitInitializationMode", "fmi3ExitInitializationMode"))
    g3.close()


def test_wrong_instantiation_token_is_refused():
    path = fmu.fmu_path("6pus", fmi=3)
    md = read_model_description(str(path))
    log = []
    s = FMU3Slave(guid="{00000000-0000-0000-0000-000000000000}", unzipDirectory=extract(str(path)),
                  modelIdentifier=md.coSimulation.modelIdentifier, instanceName="x")
    with pytest.raises(Exception, match="instantiate"):
        s.instantiate(logMessage=lambda env, st, cat, msg: log.append(msg.decode()))
    assert "instantiation token {00000000" in log[-1] and md.guid in log[-1], log


def test_stroke_limit_ends_the_fmi3_step_with_terminate_simulation_at_the_fmi2_time():
    """At a stroke limit fmi3DoStep returns OK with terminateSimulation and the time of the
    stop (FMI 3.0, fmi3DoStep), the same time and message as FMI 2.0's Discard; earlyReturn
    only where the importer allowed it at instantiation."""
    m = Model("6pus")
    tau = m.gravity_load(m.home())
    tau[0] -= 5.0  # drive slider 1 to its lower stop
    with fmu.FMUInstance(fmu.fmu_path("6pus")) as f2:
        with pytest.raises(fmu.FMUError):
            for _ in range(1000):
                f2.step(H, tau=tau)
        t2 = f2.last_successful_time()
        msg2 = f2.log[-1].split("] ", 1)[1]
    for allowed in (False, True):
        g = Instance(fmu.fmu_path("6pus", fmi=3), early_return=allowed)
        do_step = g.f.dll.fmi3DoStep  # the raw call: the status and every output argument
        B = C.POINTER(C.c_bool)
        do_step.argtypes = [C.c_void_p, C.c_double, C.c_double, C.c_bool, B, B, B, C.POINTER(C.c_double)]
        do_step.restype = C.c_int
        ev, term, early, last = C.c_bool(), C.c_bool(), C.c_bool(), C.c_double()
        g.set("tau", tau)
        t = 0.0
        for _ in range(1000):
            st = do_step(g.f.component, t, H, True, C.byref(ev), C.byref(term), C.byref(early), C.byref(last))
            if st != 0 or term.value:
                break
            t += H
        assert st == 0 and term.value and early.value == allowed and not ev.value
        assert t < last.value < t + H and last.value == t2 and abs(g.get("q")[0]) < 1e-9
        assert g.log[-1][1] == msg2.replace("fmi2DoStep", "fmi3DoStep") and "rail[1].qmin" in g.log[-1][1]
        g.f.terminate()
        g.close()


def test_fmpy_ends_an_fmi3_run_at_the_stroke_limit_quietly_as_an_fmi2_one():
    """fmpy's simulate_fmu stops both FMI versions at the stop without raising, with or
    without early return allowed; the last row is the slider at its lower stop."""
    m = Model("6pus")
    tau = m.gravity_load(m.home())
    tau[0] -= 5.0
    ends = {}
    for fmi, kw in ((2, {}), (3, {}), (3, {"early_return_allowed": True})):
        path = fmu.fmu_path("6pus", fmi=fmi)
        if fmi == 2:
            names = [v.name for v in read_model_description(str(path)).modelVariables if v.causality == "input"]
            start = dict(zip(names, tau))
        else:
            start = {"tau": tau}
        r = simulate_fmu(str(path), stop_time=1.0, output_interval=H, start_values=start,
                         output=["q[1]"] if fmi == 2 else ["q"], **kw)
        q1 = r["q[1]"] if fmi == 2 else r["q"].reshape(len(r), -1)[:, 0]
        ends[(fmi, bool(kw))] = (r["time"][-1], q1[-1])
    lo = Model("6pus").param("rail[1].qmin")
    for key, (t_end, q_end) in ends.items():
        assert t_end < 0.5, (key, t_end)  # stopped, not run to 1 s
        assert abs(q_end - lo) < 2e-3, (key, q_end, lo)


def test_model_exchange_stops_at_the_stroke_limit_like_fmi2():
    m = Model("6pus")
    tau = m.gravity_load(m.home())
    tau[0] -= 5.0
    runs = {}
    for v in (2, 3):
        log = []
        if v == 2:  # through cosim.fmu.simulate, which puts fmpy's FMI 2.0 log proxy back afterwards
            r = fmu.simulate(fmu.fmu_path("6pus"), fmi_type="ModelExchange", stop_time=0.3, step=H, tau=tau,
                             rtol=1e-10, outputs=["q[1]"], logger=lambda *a: log.append(a))
        else:  # FMI 3.0 messages reach the logger directly (no proxy)
            r = simulate_fmu(str(fmu.fmu_path("6pus", fmi=3)), fmi_type="ModelExchange", stop_time=0.3,
                             output_interval=H, start_values={"tau": tau}, relative_tolerance=1e-10,
                             logger=lambda *a: log.append(a), output=["q"])
        lines = [a[-1].decode() for a in log]
        assert any("stopping the simulation" in s and "leg 1" in s for s in lines), lines
        runs[v] = r
    assert runs[3]["time"][-1] < 0.3
    assert runs[3]["time"][-1] == runs[2]["time"][-1]
    assert runs[3]["q"][-1][0] == runs[2]["q[1]"][-1]


def test_closed_pd_loop_with_the_controller_fmu_equals_fmi2():
    """Plant and PD controller FMUs in a loop (the controller samples q, qd at t and holds
    tau over the step), FMI 3.0 against FMI 2.0: the same trajectory, which settles toward
    the reference."""
    m = Model("6pus")
    q0 = m.ik(m.home())
    qref = q0 + 1e-3
    kp, kd = 400.0 * np.eye(6), 40.0 * np.eye(6)

    # FMI 2.0
    with fmu.FMUInstance(fmu.fmu_path("6pus")) as p2, \
            fmu.FMUInstance(str(fmu.fmu_path("6pus")).replace("PKM_6PUS", "PKM_6PUS_CTRL"), name="c",
                            params={"controller.kind": 1,
                                    **{f"kp[{i + 1},{j + 1}]": kp[i, j] for i in range(6) for j in range(6)},
                                    **{f"kd[{i + 1},{j + 1}]": kd[i, j] for i in range(6) for j in range(6)},
                                    "controller.dt": H}) as c2:
        def put(name, values):
            for i, x in enumerate(values):
                c2.set(f"{name}[{i + 1}]", x)

        put("qref", qref)
        q2 = []
        for _ in range(150):
            put("q", p2.vector("q"))
            put("qd", p2.vector("qd"))
            c2.step(H)
            p2.step(H, tau=[c2.get(f"tau[{i + 1}]") for i in range(6)])
            q2.append(p2.vector("q"))
    # FMI 3.0
    p3 = Instance(fmu.fmu_path("6pus", fmi=3))
    c3 = Instance(str(fmu.fmu_path("6pus", fmi=3)).replace("PKM_6PUS", "PKM_6PUS_CTRL"), name="c", initialize=False)
    c3.f.setInt32([c3.vr["controller.kind"]], [1])
    c3.set("kp", kp.ravel())
    c3.set("kd", kd.ravel())
    c3.set("controller.dt", H)
    c3.f.enterInitializationMode(startTime=0.0)
    c3.f.exitInitializationMode()
    c3.set("qref", qref)
    q3 = []
    for _ in range(150):
        c3.set("q", p3.get("q"))
        c3.set("qd", p3.get("qd"))
        c3.step()
        p3.step(c3.get("tau"))
        q3.append(p3.get("q"))
    p3.close()
    c3.close()
    q2, q3 = np.array(q2), np.array(q3)
    assert np.max(np.abs(q3 - q2)) <= 1e-12
    # the loop works: the error to the reference shrinks from 1 mm
    assert np.max(np.abs(q3[-1] - qref)) < 0.5e-3


def _fnv(block: bytes, start: int = 0, h: int = 14695981039346656037) -> int:
    """FNV-1a 64 of a state block with its checksum field (bytes 112..119) read as zero; from
    byte ``start`` on with ``h`` the hash of the bytes before it."""
    for i in range(start, len(block)):
        h = ((h ^ (0 if 112 <= i < 120 else block[i])) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return h


@pytest.mark.parametrize("kind", ["CoSimulation", "ModelExchange"])
def test_corrupted_fmi3_states_are_refused_or_harmless(kind):
    """Every 8-byte word of a good serialized state (initialized, stepped) replaced by NaN, -Inf,
    -1 and 1e300, as it is and sealed with its checksum again, into the instance it
    came from: refused with a logged Error and the instance unchanged byte for byte, or accepted
    and then every output finite or refused (never a non-finite value with OK), and the good
    state always set back.  tests/fmu/test_state_fuzz.py does the same, more widely, to FMI 2.0."""
    hold = hold_input("6pus")
    f = Instance(fmu.fmu_path("6pus", fmi=3), kind=kind)
    if kind == "ModelExchange":
        f.f.updateDiscreteStates()
        f.f.enterContinuousTimeMode()
        f.set("tau", hold)
    else:
        for _ in range(3):
            f.step(hold)
    good = f.f.getFMUState()
    blob = bytes(f.f.serializeFMUState(good))
    assert struct.unpack_from("<Q", blob, 112)[0] == _fnv(blob)  # where the checksum is
    outputs = [v for v, _ in flat(f.md, "output")]
    n_out = sum(f.size[v.name] for v in outputs)
    counts = {"cases": 0, "accepted": 0, "refused": 0}
    prefix = 14695981039346656037  # the hash of the bytes before the word
    for word in range(len(blob) // 8):
        for value in (float("nan"), float("-inf"), -1.0, 1e300):
            bad = bytearray(blob)
            bad[8 * word:8 * word + 8] = struct.pack("<d", value)
            for seal in (False, True):
                if seal:
                    bad[112:120] = struct.pack("<Q", _fnv(bytes(bad), 8 * word, prefix))
                counts["cases"] += 1
                n = len(f.log)
                try:
                    s = f.f.deserializeFMUState(bytes(bad))
                    f.f.setFMUState(s)
                    f.f.freeFMUState(s)
                except FMICallException:
                    counts["refused"] += 1
                    assert any(st == 3 for st, _ in f.log[n:]), "refused without a message"
                    now = f.f.getFMUState()
                    assert bytes(f.f.serializeFMUState(now)) == blob, f"word {word}: changed by a refused state"
                    f.f.freeFMUState(now)
                    continue
                counts["accepted"] += 1
                try:
                    vals = f.f.getFloat64([v.valueReference for v in outputs], n_out)
                    assert np.all(np.isfinite(vals)), f"word {word} = {value}: a non-finite output with OK"
                except FMICallException:
                    pass
                f.f.setFMUState(good)  # must succeed
        prefix = _fnv(blob[:8 * word + 8], 8 * word, prefix)
    f.f.freeFMUState(good)
    f.close()
    assert counts["cases"] == 8 * (len(blob) // 8) and counts["refused"] > counts["cases"] / 2, counts
