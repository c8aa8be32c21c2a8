"""Fixtures shared by test folders."""
import shutil

import pytest

#: what ``cosim fmu <file>.toml`` makes in the build directory for the tests' description files
#: (my_stewart.toml, my_pendulum.toml, the README's my_delta.toml): named PKM_MY_* and my_*
MADE_FOR_TESTS = ("fmu/PKM_MY_*", "fmu/*/PKM_MY_*", "fmu_described/my_*", "fmu_platform/*/*PKM_MY_*",
                  "fmu_platform/*/CMakeFiles/PKM_MY_*")


@pytest.fixture(scope="module")
def build_restored():
    """The checkout's build directory as it was before the module's tests: the FMUs they made of
    description files (PKM_MY_*) removed, and PKM_FMU_DESCRIPTIONS and PKM_FMU_PLATFORMS of its
    CMakeCache.txt set back (``cosim fmu`` sets them back itself when it ends normally; a run
    stopped in the middle of a cross build leaves them changed)."""
    from cosim import fmu

    b = fmu.build_dir()
    keys = {"PKM_FMU_DESCRIPTIONS": "", "PKM_FMU_PLATFORMS": "auto"}
    cache = fmu._cache_values(b, keys)
    before = {p for pat in MADE_FOR_TESTS for p in b.glob(pat)}
    yield
    for p in sorted({p for pat in MADE_FOR_TESTS for p in b.glob(pat)} - before, reverse=True):
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    now = fmu._cache_values(b, keys)
    back = {k: v for k, v in cache.items() if now[k] != v}
    if back:
        fmu._configure_build(b, back)
        if "PKM_FMU_PLATFORMS" in back:
            fmu._repack_fmi3(b, 2)
