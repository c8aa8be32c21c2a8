#!/usr/bin/env bash
# The README's test command: set up (idempotent), then every C/C++ test (ctest) and
# every Python test (pytest, listing its 30 slowest tests).  Exits non-zero on any failure, and on "no tests ran".
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$top"
./scripts/bootstrap.sh
echo "== C/C++ tests (ctest)"
ctest --test-dir build --output-on-failure -j2
echo "== Python tests (pytest)"
set +e
.venv/bin/python -m pytest -q --durations=30 "$@"  # the 30 slowest tests: where the time goes
rc=$?
set -e
if [ $rc -eq 5 ]; then echo "pytest collected no tests: failing"; exit 1; fi
exit $rc
