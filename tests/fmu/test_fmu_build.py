"""How ``cosim fmu`` drives CMake (``cosim/_fmu_build.py``): a configuration that fails is made
again on the next run, not taken for finished."""
import subprocess
from pathlib import Path

import pytest

from cosim import _fmu_build

REPO = Path(__file__).resolve().parents[2]


def test_a_description_tree_whose_configuration_failed_is_configured_again(tmp_path, monkeypatch):
    # the project's build left out: tmp_path is no project build, so the tree's configuration fails
    # (CMake writes the cache with the values asked for before it stops)
    monkeypatch.setattr(_fmu_build, "_project_ready", lambda b, platforms, jobs: [])
    tree = tmp_path / "fmu_descriptions" / "PKM_LINEAR_DELTA"
    for _ in range(2):
        with pytest.raises(subprocess.CalledProcessError) as failed:
            _fmu_build.build_description(REPO / "robots" / "linear_delta.toml", "PKM_LINEAR_DELTA", tmp_path, 1,
                                         ["linux64"])
        # the configuration ran again, not a build of a tree without build files
        assert failed.value.cmd[:2] == ["cmake", "-S"], failed.value.cmd
        assert not (tree / "CMakeCache.txt").exists()
