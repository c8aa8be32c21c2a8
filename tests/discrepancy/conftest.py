"""Recordings for the discrepancy-engine tests, simulated once per test run.

Closed-loop runs of the core plants (cosim.discrepancy.runs.closed_loop) with effects
set in the plant: the engine must find what the plant holds, so the expected values
come from the plant's parameters, never from the engine.
"""
import copy

import pytest
from disc_helpers import COMBINED, SUBSET, run
from run_once import shared_once

from cosim.discrepancy import blind


@pytest.fixture(scope="session")
def clean_runs():
    return {r: run(r) for r in ("6pus", "quattro")}


@pytest.fixture(scope="session")
def combined_runs():
    return {r: run(r, COMBINED[r]) for r in ("6pus", "quattro")}


@pytest.fixture(scope="session")
def short_cfg():
    cfg = copy.deepcopy(blind.load_config())
    cfg["general"]["duration"] = 7.2  # the held-out 30 % then holds a sweep and a slow phase
    cfg["general"]["two_effects"] = 0.0
    return cfg


@pytest.fixture(scope="session")
def blind_subset(tmp_path_factory, short_cfg):
    """The subset's recordings (one directory) and answer keys (another)."""
    def make():
        rec_dir = tmp_path_factory.mktemp("blind_cases")
        key_dir = tmp_path_factory.mktemp("blind_keys")
        out = {}
        for robot, hidden, seed in SUBSET:
            name = f"{robot}_{'+'.join(hidden) or 'clean'}_{seed}"
            out[name] = blind.make_case(blind.CaseSpec(name, robot, hidden, seed), rec_dir, key_dir, short_cfg)
        return out

    return shared_once(tmp_path_factory, "blind_subset", make)  # once, also under pytest-xdist
