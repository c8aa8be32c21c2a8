"""The platform-force stage's columns of unit forces (cosim.discrepancy.platform_force.unit_columns),
made on the residual pipeline's scratch model, equal those of a copy of the model with the unit
force set, bit for bit, whatever the scratch model was moved to before."""
from types import SimpleNamespace

import numpy as np

from cosim.core import Model
from cosim.discrepancy.platform_force import UNIT_KEYS, unit_columns
from cosim.discrepancy.residuals import Pipeline


def test_the_unit_forces_columns_are_those_of_a_model_copy_with_the_force_set(clean_runs):
    pipe = Pipeline(clean_runs["6pus"], Model("6pus"))
    pipe.evaluate({"payload.m": 0.05, "rail[1].coulomb": 0.02})  # the scratch model moved before
    eng = SimpleNamespace(pipe=pipe, R0=np.zeros((len(pipe.idx), pipe.nd)))
    cols, raw = unit_columns(eng, UNIT_KEYS)
    motion = (pipe.x_f, pipe.xd_f, pipe.xdd_f)
    base = pipe.model.mechanism_inverse_dynamics(*motion)
    for k in UNIT_KEYS:
        m = pipe.model.copy()
        m.set_params({k: pipe.model.param(k) + 1.0})
        efforts = m.mechanism_inverse_dynamics(*motion) - base
        assert np.array_equal(raw[k], efforts), k
        assert np.array_equal(cols[k], -pipe.S(efforts)[pipe.idx], equal_nan=True), k
        assert np.any(efforts != 0), k  # each unit force moves the efforts
    assert pipe.model.params() == pipe.nominal  # the pipeline's model untouched
