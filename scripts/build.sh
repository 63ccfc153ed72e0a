#!/usr/bin/env bash
# Configures and builds orpe (Release, warnings as errors) into build/ (or $ORPE_BUILD_DIR).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${ORPE_BUILD_DIR:-build}
PRESET=${ORPE_PRESET:-release}
if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  cmake --preset "$PRESET" -B "$BUILD_DIR"
fi
cmake --build "$BUILD_DIR" -j "${ORPE_JOBS:-$(nproc)}" "$@"
