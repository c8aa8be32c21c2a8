#!/usr/bin/env bash
# Idempotent set-up on a fresh Debian machine: system packages, the Python virtual
# environment and the CMake build (the core, its tests and the FMUs). Every README command
# calls this first, so a clean clone needs nothing installed by hand. It says what it is
# doing, how far it is (packages counted, the build in per cent, the FMUs packed) and how
# long each step took; a second run finds everything done and takes seconds.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$top"

t_all=$SECONDS
t_step=$SECONDS
say() { echo "[bootstrap] $*"; }
step() { t_step=$SECONDS; say "$1/4 $2"; }
took() { local s=$((SECONDS - t_step)); say "    done in $((s / 60)) min $((s % 60)) s"; }

# chromium: the headless browser that tests the interactive HTML reports (tests/report).
# The FMUs' other platforms (fmu/platform, docs/fmu.md "Platforms"): the cross compilers for
# x86_64-windows (MinGW-w64, posix threads) and aarch64-linux, and what runs their binaries in
# the tests: Wine and QEMU user mode (installed without recommends: compilers and emulators only).
apt_pkgs=(libeigen3-dev libsundials-dev libgtest-dev cmake g++ python3-venv chromium)
cross_pkgs=(g++-mingw-w64-x86-64-posix g++-aarch64-linux-gnu wine wine64 qemu-user)
missing=()
missing_cross=()
for p in "${apt_pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
for p in "${cross_pkgs[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing_cross+=("$p")
done
nall=$((${#apt_pkgs[@]} + ${#cross_pkgs[@]}))
nmiss=$((${#missing[@]} + ${#missing_cross[@]}))
all_missing=("${missing[@]}" "${missing_cross[@]}")
step 1 "Debian packages: $nall needed, $nmiss to install${all_missing:+ (${all_missing[*]})}"
# apt_install OPTION PACKAGE...: one line per package as apt unpacks it ("Unpacking chromium (...)")
apt_install() {
  local option="$1"; shift
  local SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  set +e
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y $option "$@" 2>&1 | tee -a /tmp/pkm-cosim-apt.log \
    | awk '/^Unpacking /{n++; printf "[bootstrap]     unpacked %d: %s\n", n, $2; fflush()}'
  local rc=${PIPESTATUS[0]}
  set -e
  if [ "$rc" -ne 0 ]; then tail -20 /tmp/pkm-cosim-apt.log; say "apt-get failed: full log in /tmp/pkm-cosim-apt.log" >&2; exit 1; fi
}
if [ "$nmiss" -gt 0 ]; then
  say "    apt-get update"
  SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -qq
  [ ${#missing[@]} -eq 0 ] || apt_install "" "${missing[@]}"
  [ ${#missing_cross[@]} -eq 0 ] || apt_install --no-install-recommends "${missing_cross[@]}"
  took
fi
# Wine's prefix is made once per user (about half a minute), not inside the first test.
if command -v wine >/dev/null 2>&1 && [ ! -f "${WINEPREFIX:-$HOME/.wine}/system.reg" ]; then
  say "    creating the Wine prefix ${WINEPREFIX:-$HOME/.wine}"
  WINEDEBUG=-all WINEDLLOVERRIDES="mscoree,mshtml=" wineboot -i >/dev/null 2>&1 || true
  wineserver -w 2>/dev/null || true
fi

PY="${PYTHON:-python3}"
stamp=.venv/.requirements.sha
want="$(sha256sum requirements.txt pyproject.toml | sha256sum | cut -d' ' -f1)"
if [ ! -x .venv/bin/python ] || [ ! -f "$stamp" ] || [ "$(cat "$stamp")" != "$want" ]; then
  nreq=$(grep -cvE '^\s*(#|$)' requirements.txt)
  step 2 "Python environment .venv: $nreq requirements (requirements.txt) and their dependencies, a few minutes"
  [ -x .venv/bin/python ] || "$PY" -m venv .venv
  .venv/bin/python -m pip install -q --upgrade pip >/dev/null
  # one line per package pip fetches, counted, then the install
  set +e
  .venv/bin/python -m pip install --progress-bar off -r requirements.txt 2>&1 | tee .venv/pip.log \
    | awk '/^Collecting /{n++; printf "[bootstrap]     %d: %s\n", n, $2; fflush()}
           /^Installing collected packages/{printf "[bootstrap]     installing %d packages\n", n; fflush()}'
  rc=${PIPESTATUS[0]}
  set -e
  [ "$rc" -eq 0 ] || { tail -20 .venv/pip.log; say "pip failed: full log in .venv/pip.log" >&2; exit 1; }
  .venv/bin/python -m pip install -q --no-deps -e . >>.venv/pip.log 2>&1 \
    || { say "pip failed: full log in .venv/pip.log" >&2; exit 1; }
  echo "$want" > "$stamp"
  took
else
  step 2 "Python environment .venv: up to date"
fi

step 3 "building the core, its tests and the FMUs for every platform (CMake, Release, $(nproc) jobs; build/build.log)"
launcher=()
if command -v ccache >/dev/null 2>&1; then  # rebuilds and parallel checkouts share compiles
  launcher=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S . -B build -DCMAKE_BUILD_TYPE=Release "${launcher[@]}" >/dev/null
# The Makefile generator prints "[ 42%] ..." before each action: one line per 10 %, and
# one per FMU packed; the other platforms' builds count from 0 % again, each a part.
set +e
cmake --build build -j"$(nproc)" 2>&1 | tee build/build.log | awk '
  match($0, /^\[ *[0-9]+%\]/) {
    p = substr($0, 2, RLENGTH - 3) + 0
    if (p + 30 < last) { part++; next_p = 0 }
    last = p
    if (p >= next_p) {
      printf "[bootstrap]     build %3d %%%s\n", p, part ? " (part " part + 1 ": another platform)" : ""
      next_p = p - p % 10 + 10; fflush()
    }
  }
  /zipping .*\.fmu/ { n++; f = $NF; sub(/.*\//, "", f); printf "[bootstrap]     FMU %d packed: %s\n", n, f; fflush() }'
rc=${PIPESTATUS[0]}
set -e
if [ "$rc" -ne 0 ]; then
  grep -E -B2 -A8 "error" build/build.log | head -80
  say "build failed: full log in build/build.log" >&2
  exit 1
fi
nfmu=$(ls build/fmu/*.fmu 2>/dev/null | wc -l)
took
step 4 "ready: $nfmu FMUs in build/fmu, the cosim command in .venv/bin/cosim; set-up took $(((SECONDS - t_all) / 60)) min $(((SECONDS - t_all) % 60)) s"
