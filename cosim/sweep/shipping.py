"""FMU shipping: the driver scatters an FMU's bytes, each worker keeps them in a local cache
keyed by their SHA-256 (:mod:`cosim.sweep`); each case instantiates its own FMU from there,
in the worker process and thread that runs it."""
from __future__ import annotations

import hashlib
import os
import tempfile
from pathlib import Path

from .errors import SweepError

_FMU_CACHE: dict = {}


def fmu_cache_dir() -> Path:
    """Worker-local folder of shipped FMUs: ``$PKM_SWEEP_FMU_CACHE`` or ``<tmp>/pkm-sweep-fmu``."""
    return Path(os.environ.get("PKM_SWEEP_FMU_CACHE", Path(tempfile.gettempdir()) / "pkm-sweep-fmu"))


def materialise_fmu(sha256: str, name: str, data: bytes | None) -> Path:
    """The local path of the FMU with this SHA-256, written from ``data`` if needed.

    The file goes to ``fmu_cache_dir()/<sha256[:16]>/<name>`` through a temporary file
    and an atomic rename, so several worker processes on one host may do it at once.
    A cached file is checked once per process; one whose checksum differs (damaged,
    half written by a killed process) is rewritten.
    """
    if sha256 in _FMU_CACHE and _FMU_CACHE[sha256].exists():
        return _FMU_CACHE[sha256]
    d = fmu_cache_dir() / sha256[:16]
    path = d / name
    if not (path.exists() and _sha256(path.read_bytes()) == sha256):
        if data is None:
            raise SweepError(f"FMU {name} (sha256 {sha256[:16]}) is not on this worker and was not shipped")
        if _sha256(data) != sha256:
            raise SweepError(f"FMU {name}: the shipped bytes do not match their checksum {sha256[:16]}")
        d.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=d, suffix=".part")
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    _FMU_CACHE[sha256] = path
    return path


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()
