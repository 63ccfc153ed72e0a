#!/usr/bin/env bash
# The README's test command: installs dependencies, builds, runs the whole test suite.
# Real-data tests read $ORPE_DATA_DIR (default ../shared/data) and skip with a message when it is absent.
# Tests listed in tests/KNOWN_FAILURES (open regressions) are excluded and named loudly;
# ORPE_RUN_KNOWN_FAILURES=1 runs them too.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
export ORPE_DATA_DIR=${ORPE_DATA_DIR:-$(cd .. && pwd)/shared/data}
exclude=()
if [ "${ORPE_RUN_KNOWN_FAILURES:-0}" != 1 ] && [ -f tests/KNOWN_FAILURES ]; then
  mapfile -t known < <(grep -v '^\s*#' tests/KNOWN_FAILURES | grep -v '^\s*$' || true)
  if ((${#known[@]})); then
    echo "WARNING: excluding ${#known[@]} known failing tests (tests/KNOWN_FAILURES): ${known[*]}"
    pattern=$(printf '^%s$|' "${known[@]}")
    exclude=(-E "${pattern%|}")
  fi
fi
ctest --test-dir "${ORPE_BUILD_DIR:-build}" --output-on-failure -j "${ORPE_JOBS:-$(nproc)}" "${exclude[@]}" "$@"
