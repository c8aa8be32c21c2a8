"""Shared fixtures of the FMU tests: the built FMU, the core model and a direct core run.

The reference for every trajectory is the core's own integrator (pkm_sim through
ctypes), so the FMU is checked against the code it wraps, not against itself.
"""
import ctypes as C

import numpy as np
import pytest

from cosim import fmu
from cosim._native import lib, pkm_sim_options, ptr
from cosim.core import Model

H = 1e-3  # communication step [s]


@pytest.fixture(scope="session")
def fmu_file():
    # A missing FMU is a failure (the build must produce it), never a skip.
    return fmu.fmu_path("6pus")


@pytest.fixture(scope="session")
def model():
    return Model("6pus")


@pytest.fixture(scope="session")
def hold(model):
    """Efforts [N] that nearly hold the platform at home: a slow, smooth drift."""
    x0 = model.home()
    return model.gravity_load(x0) + 0.05 * np.array([0.3, -0.2, 0.1, 0.25, -0.15, 0.05])


@pytest.fixture(scope="session")
def core_run():
    """The function ``run(model, taus, h, x0, xd0, rtol, atol) -> (t, x, xd)`` below."""
    return _core_run


def _core_run(model, taus, h=H, x0=None, xd0=None, rtol=None, atol=None):
    """States (t, x, xd) after each step of pkm_sim driven directly, the input held per step."""
    o = pkm_sim_options()
    lib.pkm_sim_default_options(C.byref(o))
    if rtol is not None:
        o.rtol = rtol
    if atol is not None:
        o.atol = atol
    err = C.create_string_buffer(1024)
    sim = C.c_void_p(lib.pkm_sim_create(model._m, C.byref(o), err, len(err)))
    assert sim.value, err.value.decode()
    try:
        x = np.array(model.home() if x0 is None else x0, float)
        xd = np.zeros(6) if xd0 is None else np.array(xd0, float)
        assert lib.pkm_sim_reset(sim, 0.0, ptr(x), ptr(xd)) == 0, lib.pkm_sim_error(sim)
        ts, xs, xds = [], [], []
        t = C.c_double()
        for k, tau in enumerate(np.atleast_2d(taus)):
            tau = np.ascontiguousarray(tau, float)
            assert lib.pkm_sim_set_input(sim, ptr(tau)) == 0
            s = lib.pkm_sim_advance(sim, (k + 1) * h)
            assert s == 0, lib.pkm_sim_error(sim).decode()
            lib.pkm_sim_get_state(sim, C.byref(t), ptr(x), ptr(xd))
            ts.append(t.value)
            xs.append(x.copy())
            xds.append(xd.copy())
        return np.array(ts), np.array(xs), np.array(xds)
    finally:
        lib.pkm_sim_destroy(sim)
