"""Seeded fuzzing of a plant FMU (FMI 2.0 or 3.0) through fmpy's low-level classes.

    python fuzz_driver.py <fmu> <seed> <cases>

Each case instantiates the FMU, sets random parameters, starts and inputs (ordinary values
and hostile ones: huge, tiny, denormal, NaN, inf, negative), runs a random sequence of
doStep (odd step sizes), reads of every output, get/set state and, for Model Exchange, set
continuous states and get derivatives and event indicators.  A call may fail with an FMI
status (that is the FMU refusing bad input); what must never happen is a value that is not
finite coming back with status OK.  An exception that is not an FMI status is a fault of
this driver and stops it (exit 3), so a call that cannot even be made is not counted as a
refusal.  Prints one summary line (JSON) and exits 1 if a non-finite value came back with
OK; a crash kills the process (the test runs it in a subprocess and checks the exit code).
"""
import ctypes
import json
import math
import sys

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException

HOSTILE = [0.0, -0.0, 1.0, -1.0, 1e308, -1e308, 1e200, -1e200, 5e-324, -5e-324, 1e-300, float("nan"), float("inf"),
           float("-inf"), 1e6, -1e6, 1e3]
STEPS = [1e-3, 1e-3, 1e-3, 2e-3, 0.0, 5e-324, 1e-300, 1e-12, 1e-15, 0.05, 0.5, -1e-3, float("nan"), float("inf")]


def carray(values):
    return (ctypes.c_double * len(values))(*values)


class Calls:
    """The calls of a case, on an FMI 2.0 or 3.0 instance (what differs is in the subclasses)."""

    def do_step(self, t, h):
        self.f.doStep(t, h)

    def set_states(self, x):
        self.f.setContinuousStates(carray(x), len(x))

    def derivatives(self, n):
        dx = carray([0.0] * n)
        self.get_derivatives(dx, n)
        return list(dx)

    def indicators(self, n):
        z = carray([0.0] * n)
        self.f.getEventIndicators(z, n)
        return list(z)


class Fmi2(Calls):
    def __init__(self, md, unzip, me, name, callbacks):
        from fmpy.fmi2 import FMU2Model, FMU2Slave

        cls = FMU2Model if me else FMU2Slave
        ident = (md.modelExchange if me else md.coSimulation).modelIdentifier
        self.f = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier=ident, instanceName=name)
        self.f.instantiate(callbacks=callbacks, loggingOn=False)
        self.get_derivatives = getattr(self.f, "getDerivatives", None)

    def set(self, refs, values):
        self.f.setReal(refs, values)

    def get(self, refs, n):
        return self.f.getReal(refs)

    def initialize(self, tol):
        self.f.setupExperiment(tol, 0.0)
        self.f.enterInitializationMode()
        self.f.exitInitializationMode()

    def to_continuous_time(self):
        self.f.enterEventMode()
        self.f.newDiscreteStates()
        self.f.enterContinuousTimeMode()

    def state_roundtrip(self):
        s = self.f.getFMUstate()
        self.f.setFMUstate(s)
        self.f.freeFMUstate(s)


class Fmi3(Calls):
    def __init__(self, md, unzip, me, name, callbacks):
        from fmpy.fmi3 import FMU3Model, FMU3Slave

        cls = FMU3Model if me else FMU3Slave
        ident = (md.modelExchange if me else md.coSimulation).modelIdentifier
        self.f = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier=ident, instanceName=name)
        self.f.instantiate(loggingOn=False, logMessage=callbacks)
        self.get_derivatives = getattr(self.f, "getContinuousStateDerivatives", None)

    def set(self, refs, values):
        self.f.setFloat64(refs, values)

    def get(self, refs, n):
        return self.f.getFloat64(refs, n)

    def initialize(self, tol):
        self.f.enterInitializationMode(tolerance=tol, startTime=0.0)
        self.f.exitInitializationMode()

    def to_continuous_time(self):
        self.f.updateDiscreteStates()
        self.f.enterContinuousTimeMode()

    def state_roundtrip(self):
        s = self.f.getFMUState()
        self.f.setFMUState(s)
        self.f.freeFMUState(s)


def quiet_logger(fmi3: bool):
    """A logger that keeps nothing (the refusals are expected; fmpy's default logger would
    print each one): FMI 2.0 callbacks, or the FMI 3.0 log function (fmpy keeps it alive)."""
    if fmi3:
        return lambda *a: None
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(lambda *a: None)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


def size(v):
    return int(np.prod([int(d.start) for d in v.dimensions])) if getattr(v, "dimensions", None) else 1


def main(path: str, seed: int, cases: int) -> int:
    rng = np.random.default_rng(seed)
    md = read_model_description(path)
    fmi3 = md.fmiVersion.startswith("3")
    unzip = extract(path)
    reals = [v for v in md.modelVariables if v.type in ("Real", "Float64")]
    params = [v for v in reals if v.causality == "parameter"]
    inputs = [v for v in reals if v.causality == "input"]
    outputs = [v for v in reals if v.causality == "output"]
    out_refs = [v.valueReference for v in outputs]
    n_out = sum(size(v) for v in outputs)
    nx, nz = md.numberOfContinuousStates, md.numberOfEventIndicators
    stats = {"cases": 0, "calls": 0, "refused": 0, "ok_nonfinite": 0, "me_cases": 0, "derivatives_ok": 0,
             "examples": []}

    def value(v):
        """size(v) values for variable v: hostile ones or its start values perturbed."""
        starts = str(v.start).split() if v.start is not None else ["0"] * size(v)
        out = []
        for s in starts:
            if rng.random() < 0.5:
                out.append(float(rng.choice(HOSTILE)))
            else:
                out.append(float(s) * (1 + 0.2 * rng.standard_normal()) + 1e-3 * rng.standard_normal())
        return out

    def call(fn, *args):
        stats["calls"] += 1
        try:
            return True, fn(*args)
        except FMICallException:  # a refusal (Discard/Error) is an allowed outcome
            stats["refused"] += 1
            return False, None

    def check(where, values):
        vals = np.asarray(values, float)
        if not np.all(np.isfinite(vals)):
            stats["ok_nonfinite"] += 1
            if len(stats["examples"]) < 5:
                stats["examples"].append(f"{where}: values {np.flatnonzero(~np.isfinite(vals))[:3].tolist()}")

    me = md.modelExchange is not None
    logger = quiet_logger(fmi3)
    for case in range(cases):
        use_me = me and rng.random() < 0.25
        f = (Fmi3 if fmi3 else Fmi2)(md, unzip, use_me, f"fuzz{case}", logger)
        stats["cases"] += 1
        stats["me_cases"] += use_me
        try:
            for v in rng.choice(params, size=min(len(params), int(rng.integers(0, 4))), replace=False):
                call(f.set, [v.valueReference], value(v))
            tol = float(rng.choice([1e-6, 1e-8, 1.0, 2.0, 0.0, -1.0, float("nan"), 1e-12]))
            ok, _ = call(f.initialize, tol if rng.random() < 0.5 else None)
            if not ok:
                continue
            ok, vals = call(f.get, out_refs, n_out)
            if ok:
                check("after init", vals)
            t = 0.0
            if use_me:
                call(f.to_continuous_time)
            for _ in range(int(rng.integers(3, 12))):
                r = rng.random()
                if r < 0.3 and inputs:
                    v = inputs[int(rng.integers(len(inputs)))]
                    call(f.set, [v.valueReference], value(v))
                elif r < 0.7 and not use_me:
                    h = float(rng.choice(STEPS))
                    ok, _ = call(f.do_step, t, h)
                    if ok and math.isfinite(h):
                        t += h
                elif r < 0.7 and use_me:
                    x = rng.choice(HOSTILE, size=nx) if rng.random() < 0.5 else rng.normal(0, 0.05, nx)
                    call(f.set_states, [float(a) for a in x])
                    ok, der = call(f.derivatives, nx)
                    if ok:
                        stats["derivatives_ok"] += 1
                        check("derivatives", der)
                    ok, z = call(f.indicators, nz)
                    if ok:
                        check("event indicators", z)
                elif r < 0.85 and not use_me:
                    call(f.state_roundtrip)
                ok, vals = call(f.get, out_refs, n_out)
                if ok:
                    check("outputs", vals)
        finally:
            try:
                f.f.terminate()
            except FMICallException:  # terminate from an error state may be refused
                pass
            f.f.freeInstance()
    print(json.dumps(stats))
    return 1 if stats["ok_nonfinite"] else 0


if __name__ == "__main__":
    try:
        code = main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
    except Exception as e:  # noqa: BLE001 - a call this driver could not make: its own fault
        print(f"fuzz driver fault: {type(e).__name__}: {e}", file=sys.stderr)
        code = 3
    raise SystemExit(code)
