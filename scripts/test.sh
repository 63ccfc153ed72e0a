#!/usr/bin/env bash
# The README's test command: installs dependencies, builds, runs the whole test suite.
# Real-data tests read $ORPE_DATA_DIR (default ../shared/data) and skip with a message when it is absent.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
export ORPE_DATA_DIR=${ORPE_DATA_DIR:-$(cd .. && pwd)/shared/data}
ctest --test-dir "${ORPE_BUILD_DIR:-build}" --output-on-failure -j "${ORPE_JOBS:-$(nproc)}" "$@"
