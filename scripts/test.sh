#!/usr/bin/env bash
# The README's test command: set up (idempotent), then every C/C++ test (ctest) and
# every Python test (pytest, listing its 30 slowest tests), in parallel on every core (pytest-xdist:
# -n auto, the groups of tests/conftest.py).  Exits non-zero on any failure, and on "no tests ran".
# PYTEST_WORKERS=1 runs pytest in one process (the tests in collection order).
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$top"
./scripts/bootstrap.sh
echo "== C/C++ tests (ctest)"
ctest --test-dir build --output-on-failure -j2
echo "== Python tests (pytest)"
set +e
if [ "${PYTEST_WORKERS:-auto}" = 1 ]; then par=(); else par=(-n "${PYTEST_WORKERS:-auto}"); fi
.venv/bin/python -m pytest -q "${par[@]}" --durations=30 "$@"  # the 30 slowest tests: where the time goes
rc=$?
set -e
if [ $rc -eq 5 ]; then echo "pytest collected no tests: failing"; exit 1; fi
exit $rc
