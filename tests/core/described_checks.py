"""Checks shared by the tests of described robots (test_described.py, test_described_axes.py)
and oracle_6pus.py: random states near the home pose, the relative difference, one clear error
of a bad description.  A plain module beside them: pytest puts this folder on ``sys.path``, and
so does running oracle_6pus.py as a script."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def rel(a, b):
    """Largest absolute difference relative to the largest magnitude of ``a``."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.abs(a - b).max() / max(1e-300, np.abs(a).max())


def samples(m, n, seed):
    """Poses near home (up to 10 mm, 3 deg, inside the strokes), rates and accelerations."""
    rng = np.random.default_rng(seed)
    ang = np.array([u == "rad" for u in m.facts.pose_units])
    step = np.where(ang, 0.05, 0.01)
    X = np.empty((0, m.ndof))
    while len(X) < n:
        cand = m.home() + rng.uniform(-1, 1, (4 * n, m.ndof)) * step
        _, status = m.ik(cand, errors="status")
        X = np.vstack([X, cand[status == 0]])
        step = step * 0.7
    X = X[:n]
    XD = rng.normal(size=(n, m.ndof)) * np.where(ang, 0.3, 0.05)
    XDD = rng.normal(size=(n, m.ndof)) * np.where(ang, 3.0, 1.0)
    return X, XD, XDD


def assert_one_clear_error(path, line, words) -> str:
    """``Model(path)`` raises an ArgumentError of one line that names ``path:line`` and each of
    ``words``; returns its message."""
    import pytest

    from cosim.core import Model
    from cosim.errors import ArgumentError

    with pytest.raises(ArgumentError) as e:
        Model(path)
    msg = str(e.value)
    assert f"{path}:{line}:" in msg, msg
    for w in words:
        assert w in msg, (w, msg)
    assert "\n" not in msg
    return msg


def run_oracle(script, *args):
    """Runs tests/core/<script> (oracle_quattro.py) with PKM_LIB at libpkm_oracle.so, the library
    with the hand-written oracles the C++ tests link; asserts it printed "ok"."""
    lib = Path(os.environ.get("PKM_BUILD_DIR", REPO / "build")) / "lib" / "libpkm_oracle.so"
    assert lib.exists(), f"{lib} is missing: cmake builds it with the core (target pkm_oracle)"
    r = subprocess.run([sys.executable, str(Path(__file__).with_name(script)), *args], cwd=REPO,
                       env=dict(os.environ, PKM_LIB=str(lib)), capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and r.stdout.strip() == "ok", r.stdout + r.stderr
