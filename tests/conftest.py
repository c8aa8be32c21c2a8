"""Fixtures shared by test folders, and how the suite runs in parallel (pytest-xdist,
``scripts/test.sh``: ``-n auto``).

In parallel, the tests are handed out to the workers in units (:func:`unit`): a test module
with a module-scoped fixture (a recording, a fresh clone, FMUs unzipped) runs whole on one
worker, so that the fixture is made once; the other tests are handed out one by one.  The
modules of ``SERIAL`` are one unit, run one after the other on one worker, first: they share
a program's state that no tmp folder separates.  The Wine runs share one wineserver kept 60 s
after its last client (``tests/fmu/platform_host.py``); the browser runs share chromium's
profile (the README's tour takes a screenshot with it).  The tests using the sweep tests'
LocalCluster are one unit too (the cluster, two worker processes, started once).  The tests
that make FMUs of description files (``cosim fmu <file>.toml``) run beside the others: each
file's FMUs build in a tree of their own and the build directory's FMUs stay in place
(``cosim/_fmu_build.py``)."""
import functools
import os
import re
import shutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: the modules run one after the other on one worker, first (see the module's docstring):
#: those that run Wine or chromium
SERIAL = ("tests/test_readme.py", "tests/fmu/test_fmi3_host.py", "tests/fmu/test_platforms.py",
          "tests/report/test_html.py")


@functools.cache
def _module_unit(module: str) -> str | None:
    """The unit of a whole module (``"serial"``, the module itself) or None (one by one)."""
    text = (ROOT / module).read_text() if (ROOT / module).is_file() else ""
    if module in SERIAL:
        return "serial"
    if re.search(r"def test_\w+\([^)]*\b(client|cluster)\b", text):  # tests/sweep/conftest.py's LocalCluster
        return "dask-cluster"
    if re.search(r"""scope=["'](module|package|class)["']""", text):
        return module
    return None


def unit(nodeid: str) -> str:
    """The unit of work a test belongs to under pytest-xdist (see the module's docstring)."""
    module = nodeid.split("::", 1)[0]
    return _module_unit(module) or nodeid


def _rank(nodeid: str) -> int:
    u = unit(nodeid)
    return 0 if u == "serial" else 1 if u != nodeid else 2


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Under pytest-xdist, the order the units are handed out in: the serial unit first, then
    the whole modules, then the tests one by one (the longest work first, the small tests last
    to even out the workers' ends)."""
    if os.environ.get("PYTEST_XDIST_WORKER"):
        items.sort(key=lambda i: _rank(i.nodeid))  # stable: the collection's order within a rank


@pytest.hookimpl(optionalhook=True)  # an xdist hook: without the plugin (-p no:xdist) the suite still runs
def pytest_xdist_make_scheduler(config, log):
    """The units of :func:`unit`, handed out in the workers' collection order, when the tests
    are distributed by pytest-xdist's default (``-n N``: ``--dist load``)."""
    if config.getvalue("dist") != "load":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class UnitScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid):
            return unit(nodeid)

    config.option.loadscopereorder = False
    return UnitScheduling(config, log)


@pytest.fixture(scope="module")
def build_restored(request):
    """The checkout's build directory as it was before the module's tests: the FMUs it made
    of description files removed afterwards, those named in the module's ``FMUS_MADE``
    (``"PKM_MY_DELTA"``: the FMI 2.0, FMI 3.0 and source-code FMUs, plant and controller, in
    ``build/fmu``, and their tree ``build/fmu_descriptions/<ID>``), when they were not there
    before."""
    from cosim import fmu

    b = fmu.build_dir()
    patterns = [f"{where}/{ident}*" for ident in request.module.FMUS_MADE
                for where in ("fmu", "fmu/*", "fmu_descriptions")]
    before = {p for pat in patterns for p in b.glob(pat)}
    yield
    for p in sorted({p for pat in patterns for p in b.glob(pat)} - before, reverse=True):
        if p.is_dir() and not p.is_symlink():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
