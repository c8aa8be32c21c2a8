#!/usr/bin/env bash
# The README's main-job command: set up (idempotent), then the end-to-end demo.
set -euo pipefail
top="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$top"
./scripts/bootstrap.sh
exec .venv/bin/cosim demo "$@"
