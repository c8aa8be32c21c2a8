"""How :func:`cosim.fmu.build` makes FMUs with CMake (see ``docs/fmu.md``, "cosim fmu").

A robot the toolkit lists: its targets in the project's build directory, built in that
build's own configuration (nothing is configured again).

A description file anywhere: its FMUs in a build tree of their own,
``<build>/fmu_descriptions/<ID>/`` (the CMake project ``fmu/described``), made from the
project's build: its fmu_gen and core (``libpkm_static.a``; for each other platform, the
objects its cross build compiled) are brought up to date there, and only the FMU layer
compiles in the tree.  The finished ``.fmu`` files are copied into the project's build
(``fmu/``, ``fmu/fmi3/``, ``fmu/source/``), each by one rename, so that a reader sees the
old file or the new one.  The project's build is never configured again, so none of its
FMUs is removed or replaced.

Two runs at once: the project's build is brought up to date under one lock
(``fmu_descriptions/.project.lock``), each tree built under its own (``<ID>.lock``), so two
description files build at once and the same one twice waits for the first.
"""
from __future__ import annotations

import fcntl
import filecmp
import os
import re
import shutil
import subprocess
from contextlib import contextmanager
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
#: the platforms an FMU may carry binaries for (``cosim.fmu.PLATFORMS``): the build machine's first
PLATFORMS = ("linux64", "win64", "aarch64-linux")


@contextmanager
def _locked(path: Path):
    """An exclusive lock on ``path`` (created) for the time of the block."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _cmake_build(b: Path, targets, jobs: int) -> None:
    subprocess.run(["cmake", "--build", str(b), "-j", str(jobs), "--target", *targets], check=True,
                   stdout=subprocess.DEVNULL)


def _configure(source: Path, b: Path, values: dict) -> None:
    """Configure the build directory ``b`` of the CMake project ``source`` (with ``-D`` values).
    A configuration that fails leaves no ``CMakeCache.txt``: CMake writes the cache before it
    stops, and a cache with the values asked for would pass for a finished configuration, so the
    next run would build a tree that has no build files instead of configuring it again."""
    try:
        subprocess.run(["cmake", "-S", str(source), "-B", str(b), *(f"-D{k}={v}" for k, v in values.items())],
                       check=True, stdout=subprocess.DEVNULL)
    except BaseException:  # a failure or ctrl-C: either can stop CMake between the cache and the build files
        (b / "CMakeCache.txt").unlink(missing_ok=True)
        raise


def configure_project(b: Path, values: dict | None = None) -> None:
    """Configure the project's build directory ``b`` (with ``-D`` values)."""
    _configure(REPO, b, {"CMAKE_BUILD_TYPE": "Release", **(values or {})})


def cache_values(b: Path, defaults: dict) -> dict:
    """The values of some variables in a build directory's ``CMakeCache.txt`` (``defaults``
    for those it does not set, or when there is none)."""
    out = dict(defaults)
    cache = b / "CMakeCache.txt"
    if cache.exists():
        for line in cache.read_text(errors="replace").splitlines():
            name, sep, value = line.partition("=")
            key = name.split(":", 1)[0]
            if sep and key in out:
                out[key] = value
    return out


def fmu_targets(ident: str) -> list[str]:
    """The CMake targets of a robot's FMUs: plant and controller, FMI 2.0, source-code, FMI 3.0."""
    return [f"{ident}_fmu", f"{ident}_CTRL_fmu", f"{ident}_source_fmu", f"{ident}_CTRL_source_fmu",
            f"{ident}_fmu3", f"{ident}_CTRL_fmu3"]


def build_listed(ident: str, b: Path, jobs: int) -> None:
    """A listed robot's FMUs in the project's build, in its own configuration."""
    with _locked(b / "fmu_descriptions" / ".project.lock"):
        if not (b / "CMakeCache.txt").exists():
            configure_project(b)
        _cmake_build(b, fmu_targets(ident), jobs)


def project_platforms(b: Path) -> list[str]:
    """The platforms besides linux64 the project's build ``b`` makes binaries for."""
    settings = (b / "fmu" / "described" / "build_settings.cmake").read_text()
    m = re.search(r'^set\(PKM_MAIN_FMU_PLATFORMS "([^"]*)"\)', settings, flags=re.M)
    return [p for p in m.group(1).split(";") if p] if m else []


def _project_ready(b: Path, platforms, jobs: int) -> list[str]:
    """Bring up to date what a description file's tree takes from the project's build ``b``:
    fmu_gen, the core, and the core of each platform of ``platforms`` but linux64 (None: every
    platform ``b`` makes), configuring ``b`` first when it never was.  Returns those
    platforms; raises FileNotFoundError for one ``b`` does not make."""
    with _locked(b / "fmu_descriptions" / ".project.lock"):
        if not (b / "CMakeCache.txt").exists():
            configure_project(b)
        _cmake_build(b, ["pkm_static", "fmu_gen"], jobs)  # configures again only if its CMakeLists changed
        made = project_platforms(b)
        extra = made if platforms is None else [p for p in PLATFORMS[1:] if p in platforms]
        for p in extra:
            if p not in made:
                raise FileNotFoundError(f"{b} makes no {p} binary: its cross compiler was not installed when the "
                                        f"build was configured (scripts/bootstrap.sh installs them)")
            sub = b / "fmu_platform" / p
            if (sub / "CMakeCache.txt").exists():
                _cmake_build(sub, ["pkm_core"], jobs)
            if not (sub / "pkm_core_objects.txt").exists():
                _cmake_build(b, [f"pkm_fmu_{p}"], jobs)  # the platform's build never ran: the project's own
    return extra


def _publish(src: Path, dst: Path) -> None:
    """Copy ``src`` to ``dst`` by one rename (a reader of ``dst`` sees the old file or the
    new one), unless ``dst`` holds the same bytes already."""
    if dst.exists() and filecmp.cmp(src, dst, shallow=False):
        return
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.{os.getpid()}.tmp")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def build_description(desc: Path, ident: str, b: Path, jobs: int, platforms) -> None:
    """A description file's FMUs in ``<b>/fmu_descriptions/<ident>``, copied into ``<b>/fmu``.
    ``platforms``: the binaries to make (linux64 always; None: those of the project's build)."""
    extra = _project_ready(b, platforms, jobs)
    tree = b / "fmu_descriptions" / ident
    wanted = {"PKM_MAIN_BUILD": str(b.resolve()), "PKM_DESCRIPTION": str(desc),
              "PKM_FMU_PLATFORMS": ";".join(extra) or "none"}
    with _locked(b / "fmu_descriptions" / f"{ident}.lock"):
        if cache_values(tree, dict.fromkeys(wanted, "")) != wanted:
            _configure(REPO / "fmu" / "described", tree, wanted)
        _cmake_build(tree, fmu_targets(ident), jobs)
        for sub in ("", "fmi3", "source"):
            for name in (f"{ident}.fmu", f"{ident}_CTRL.fmu"):
                _publish(tree / "fmu" / sub / name, b / "fmu" / sub / name)
