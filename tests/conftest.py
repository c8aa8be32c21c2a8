"""Fixtures shared by test folders, and how the suite runs in parallel (pytest-xdist,
``scripts/test.sh``: ``-n auto --dist loadgroup``).

In parallel, a test module whose tests share a module-scoped fixture (a recording, a fresh
clone, FMUs unzipped) runs whole on one worker, so that the fixture is made once; the other
tests are handed out one by one.  The modules of ``SERIAL`` (and any module using
``build_restored``) are one group, run one after the other on one worker, first: they share
what no tmp folder separates.  ``cosim fmu <file>.toml`` configures the checkout's build
directory with other platforms for the time of its build, and CMake then deletes every FMI 3.0
FMU until it is packed again (``cosim.fmu._repack_fmi3``), so no test may read
``build/fmu/fmi3`` meanwhile; the Wine runs share one wineserver kept 60 s after its last
client (``tests/fmu/platform_host.py``); the browser runs share chromium's profile."""
import os
import shutil

import pytest

#: what ``cosim fmu <file>.toml`` makes in the build directory for the tests' description files
#: (my_stewart.toml, my_pendulum.toml, the README's my_delta.toml): named PKM_MY_* and my_*
MADE_FOR_TESTS = ("fmu/PKM_MY_*", "fmu/*/PKM_MY_*", "fmu_described/my_*", "fmu_platform/*/*PKM_MY_*",
                  "fmu_platform/*/CMakeFiles/PKM_MY_*")

#: the modules run one after the other on one worker, first (see the module's docstring):
#: those that build FMUs of description files, read the FMI 3.0 FMUs, run Wine or chromium
SERIAL = ("test_readme.py", "fmu/test_cosim_fmu.py", "fmu/test_fmi3.py", "fmu/test_fmi3_host.py",
          "fmu/test_fuzz.py", "fmu/test_platforms.py", "report/test_html.py")
SERIAL_GROUP = "serial"
#: session fixtures that start something per worker, and the group of the tests using them:
#: the sweep tests' LocalCluster (two worker processes) started once
ONE_WORKER = {"cluster": "dask-cluster"}


def _module(item) -> str:
    return item.nodeid.split("::", 1)[0]


def _shares_a_module_fixture(item) -> bool:
    return any(defs and defs[-1].scope in ("module", "package", "class")
               for defs in item._fixtureinfo.name2fixturedefs.values())


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the marks
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist: the groups above (``xdist_group`` marks, ``--dist loadgroup``), the
    serial group first, then the modules made whole, then the tests handed out one by one
    (``--no-loadscope-reorder`` keeps this order: the longest work first, the small tests
    last to even out the workers' ends)."""
    if not os.environ.get("PYTEST_XDIST_WORKER"):
        return
    serial = {_module(i) for i in items
              if _module(i).removeprefix("tests/") in SERIAL or "build_restored" in i.fixturenames}
    whole = {_module(i) for i in items if _shares_a_module_fixture(i)} - serial
    rank = {}
    for i in items:
        m = _module(i)
        started = [g for f, g in ONE_WORKER.items() if f in i.fixturenames]
        if m in serial:
            i.add_marker(pytest.mark.xdist_group(SERIAL_GROUP))
            rank[i.nodeid] = 0
        elif m in whole:
            i.add_marker(pytest.mark.xdist_group(m))
            rank[i.nodeid] = 1
        elif started:
            i.add_marker(pytest.mark.xdist_group(started[0]))
            rank[i.nodeid] = 1
        else:
            rank[i.nodeid] = 2
    items.sort(key=lambda i: rank[i.nodeid])  # stable: the collection's order within a rank


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
