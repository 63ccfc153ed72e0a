#!/usr/bin/env bash
# The test suite once more under AddressSanitizer + UndefinedBehaviorSanitizer (CI, after the normal
# suite; docs/FUZZING.md): the `asan` preset (g++, RelWithDebInfo, -fsanitize=address,undefined, no
# benchmarks) built into build-asan/ (or $ORPE_ASAN_BUILD_DIR), then scripts/test.sh's ctest run with
# every ASan / LeakSanitizer / UBSan report fatal. Excluded here (and only here):
#  - install_consumer: builds a separate consumer project against the installed static libraries,
#    which are instrumented while the consumer is not (it would not link); it tests packaging, which
#    the normal suite covers.
#  - the tests labelled `long` (tests/LONG_TESTS: the long end-to-end and real-data pipeline tests),
#    so that the pass fits the CI's time; the normal suite runs them. ORPE_ASAN_LONG=1 runs them too.
set -euo pipefail
cd "$(dirname "$0")/.."
export ORPE_PRESET=asan
export ORPE_BUILD_DIR=${ORPE_ASAN_BUILD_DIR:-build-asan}
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:detect_stack_use_after_return=0:strict_string_checks=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
export ORPE_TEST_EXCLUDE=${ORPE_TEST_EXCLUDE:-^install_consumer$}
labels=(-LE long)
if [ "${ORPE_ASAN_LONG:-0}" = 1 ]; then labels=(); fi
bash scripts/test.sh "${labels[@]}" "$@"
