#!/usr/bin/env bash
# Idempotent set-up on a fresh Debian machine: system packages, the Python virtual
# environment and the CMake build. Every README command calls this first, so a clean
# clone needs nothing installed by hand.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$top"

# install_missing WHAT APT_OPTION PACKAGE...: the Debian packages not installed yet.
install_missing() {
  local what="$1" option="$2"; shift 2
  local missing=() p
  for p in "$@"; do
    dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
  done
  [ ${#missing[@]} -gt 0 ] || return 0
  echo "[bootstrap] installing $what: ${missing[*]}"
  local SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq $option "${missing[@]}" >/dev/null
}

# chromium: the headless browser that tests the interactive HTML reports (tests/report)
install_missing "Debian packages" "" libeigen3-dev libsundials-dev libgtest-dev cmake g++ python3-venv chromium
# The FMUs' other platforms (fmu/platform, docs/fmu.md "Platforms"): the cross compilers for
# x86_64-windows (MinGW-w64, posix threads) and aarch64-linux, and what runs their binaries in
# the tests: Wine and QEMU user mode.  Without recommends: the compilers and emulators only.
install_missing "the FMUs' cross compilers and emulators" --no-install-recommends \
  g++-mingw-w64-x86-64-posix g++-aarch64-linux-gnu wine wine64 qemu-user
# Wine's prefix is made once per user (about half a minute), not inside the first test.
if command -v wine >/dev/null 2>&1 && [ ! -f "${WINEPREFIX:-$HOME/.wine}/system.reg" ]; then
  echo "[bootstrap] creating the Wine prefix ${WINEPREFIX:-$HOME/.wine}"
  WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" wineboot -i >/dev/null 2>&1 || true
  wineserver -w 2>/dev/null || true
fi

PY="${PYTHON:-python3}"
if [ ! -x .venv/bin/python ]; then
  echo "[bootstrap] creating .venv"
  "$PY" -m venv .venv
fi
stamp=.venv/.requirements.sha
want="$(sha256sum requirements.txt pyproject.toml | sha256sum | cut -d' ' -f1)"
if [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  echo "[bootstrap] installing Python requirements"
  .venv/bin/python -m pip install -q --upgrade pip >/dev/null
  .venv/bin/python -m pip install -q -r requirements.txt
  .venv/bin/python -m pip install -q --no-deps -e .
  echo "$want" > "$stamp"
fi

echo "[bootstrap] building (CMake, Release)"
launcher=()
if command -v ccache >/dev/null 2>&1; then  # rebuilds and parallel checkouts share compiles
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >/dev/null
if ! cmake --build build -j"$(nproc)" > build/build.log 2>&1; then
  grep -E -B2 -A8 "error" build/build.log | head -80
  echo "[bootstrap] build failed: full log in build/build.log" >&2
  exit 1
fi
