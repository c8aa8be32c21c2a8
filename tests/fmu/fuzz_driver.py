"""Seeded fuzzing of a plant FMU through fmpy's low-level FMU2Slave / FMU2Model calls.

    python fuzz_driver.py <fmu> <seed> <cases>

Each case instantiates the FMU, sets random parameters, starts and inputs (ordinary values
and hostile ones: huge, tiny, denormal, NaN, inf, negative), runs a random sequence of
doStep (odd step sizes), getReal, get/set state and, for Model Exchange, set continuous
states and get derivatives.  A call may fail (that is the FMU refusing bad input); what
must never happen is a value that is not finite coming back with status OK.  Prints one
summary line (JSON) and exits 1 if that happened; a crash kills the process (the test
runs it in a subprocess and checks the exit code).
"""
import json
import math
import sys

import numpy as np
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Model, FMU2Slave

HOSTILE = [0.0, -0.0, 1.0, -1.0, 1e308, -1e308, 1e200, -1e200, 5e-324, -5e-324, 1e-300, float("nan"), float("inf"),
           float("-inf"), 1e6, -1e6, 1e3]
STEPS = [1e-3, 1e-3, 1e-3, 2e-3, 0.0, 5e-324, 1e-300, 1e-12, 1e-15, 0.05, 0.5, -1e-3, float("nan"), float("inf")]


def quiet_callbacks():
    """FMI callbacks whose logger keeps nothing (the refusals are expected; fmpy's default
    logger would print each one).  Kept alive by the caller."""
    from fmpy import calloc, free
    from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                           fmi2CallbackLoggerTYPE)

    cb = fmi2CallbackFunctions()
    cb.logger = fmi2CallbackLoggerTYPE(lambda *a: None)
    cb.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    cb.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    return cb


def main(path: str, seed: int, cases: int) -> int:
    rng = np.random.default_rng(seed)
    md = read_model_description(path)
    unzip = extract(path)
    reals = [v for v in md.modelVariables if v.type == "Real"]
    params = [v for v in reals if v.causality == "parameter"]
    inputs = [v for v in reals if v.causality == "input"]
    outputs = [v for v in reals if v.causality == "output"]
    out_refs = [v.valueReference for v in outputs]
    stats = {"cases": 0, "calls": 0, "refused": 0, "ok_nonfinite": 0, "examples": []}

    def value(v):
        if rng.random() < 0.5:
            return float(rng.choice(HOSTILE))
        start = float(v.start) if v.start is not None else 0.0
        return start * (1 + 0.2 * rng.standard_normal()) + 1e-3 * rng.standard_normal()

    def call(fn, *args):
        stats["calls"] += 1
        try:
            r = fn(*args)
            return True, r
        except Exception:  # noqa: BLE001 - a refusal (Discard/Error) is an allowed outcome
            stats["refused"] += 1
            return False, None

    def check(where, values):
        vals = np.asarray(values, float)
        if not np.all(np.isfinite(vals)):
            stats["ok_nonfinite"] += 1
            if len(stats["examples"]) < 5:
                bad = [outputs[i].name for i in np.flatnonzero(~np.isfinite(vals))[:3]]
                stats["examples"].append(f"{where}: {bad}")

    me = md.modelExchange is not None
    callbacks = quiet_callbacks()
    for case in range(cases):
        use_me = me and rng.random() < 0.25
        cls = FMU2Model if use_me else FMU2Slave
        ident = (md.modelExchange if use_me else md.coSimulation).modelIdentifier
        f = cls(guid=md.guid, unzipDirectory=unzip, modelIdentifier=ident, instanceName=f"fuzz{case}")
        f.instantiate(callbacks=callbacks, loggingOn=False)
        stats["cases"] += 1
        try:
            for v in rng.choice(params, size=min(len(params), int(rng.integers(0, 4))), replace=False):
                call(f.setReal, [v.valueReference], [value(v)])
            tol = float(rng.choice([1e-6, 1e-8, 1.0, 2.0, 0.0, -1.0, float("nan"), 1e-12]))
            call(f.setupExperiment, tol if rng.random() < 0.5 else None, 0.0)
            ok_init, _ = call(f.enterInitializationMode)
            ok_exit, _ = call(f.exitInitializationMode)
            if not (ok_init and ok_exit):
                continue
            ok, vals = call(f.getReal, out_refs)
            if ok:
                check("after init", vals)
            t = 0.0
            if use_me:
                call(f.enterEventMode)
                call(f.newDiscreteStates)
                call(f.enterContinuousTimeMode)
            for _ in range(int(rng.integers(3, 12))):
                r = rng.random()
                if r < 0.3 and inputs:
                    v = inputs[int(rng.integers(len(inputs)))]
                    call(f.setReal, [v.valueReference], [value(v)])
                elif r < 0.7 and not use_me:
                    h = float(rng.choice(STEPS))
                    ok, _ = call(f.doStep, t, h)
                    if ok and math.isfinite(h):
                        t += h
                elif r < 0.7 and use_me:
                    n = len(md.modelVariables) and 2 * len(inputs)
                    x = rng.choice(HOSTILE, size=n) if rng.random() < 0.5 else rng.normal(0, 0.05, n)
                    call(f.setContinuousStates, np.asarray(x, float), n)
                    ok, der = call(f.getDerivatives, n)
                    if ok:
                        check("derivatives", der)
                elif r < 0.85 and not use_me:
                    ok, s = call(f.getFMUstate)
                    if ok:
                        call(f.setFMUstate, s)
                        call(f.freeFMUstate, s)
                ok, vals = call(f.getReal, out_refs)
                if ok:
                    check("outputs", vals)
        finally:
            try:
                f.terminate()
            except Exception:  # noqa: BLE001 - terminate from an error state may be refused
                pass
            f.freeInstance()
    print(json.dumps(stats))
    return 1 if stats["ok_nonfinite"] else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3])))
