#!/usr/bin/env bash
# The README's test command: installs dependencies, builds, runs the whole test suite.
# Real-data tests read $ORPE_DATA_DIR (default ../shared/data) and skip with a message when it is absent.
# Tests listed in tests/KNOWN_FAILURES (open regressions) are excluded and named loudly;
# ORPE_RUN_KNOWN_FAILURES=1 runs them too. ORPE_TEST_EXCLUDE: a further ctest regex of tests to skip
# (the sanitizer run, scripts/test-asan.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install-deps.sh
bash scripts/build.sh
export ORPE_DATA_DIR=${ORPE_DATA_DIR:-$(cd .. && pwd)/shared/data}
exclude=()
patterns=()
if [ "${ORPE_RUN_KNOWN_FAILURES:-0}" != 1 ] && [ -f tests/KNOWN_FAILURES ]; then
  mapfile -t known < <(grep -v '^\s*#' tests/KNOWN_FAILURES | grep -v '^\s*$' || true)
  if ((${#known[@]})); then
    echo "WARNING: excluding ${#known[@]} known failing tests (tests/KNOWN_FAILURES): ${known[*]}"
    patterns+=("$(printf '^%s$|' "${known[@]}" | sed 's/|$//')")
  fi
fi
if [ -n "${ORPE_TEST_EXCLUDE:-}" ]; then
  echo "WARNING: also excluding the tests matching ORPE_TEST_EXCLUDE: $ORPE_TEST_EXCLUDE"
  patterns+=("$ORPE_TEST_EXCLUDE")
fi
if ((${#patterns[@]})); then
  joined=$(printf '%s|' "${patterns[@]}")
  exclude=(-E "${joined%|}")
fi
ctest --test-dir "${ORPE_BUILD_DIR:-build}" --output-on-failure -j "${ORPE_JOBS:-$(nproc)}" "${exclude[@]}" "$@"
