#!/usr/bin/env bash
# ctest `asan_budget`: scripts/test-asan.sh's wall-clock budget (ORPE_ASAN_DEADLINE_S), run on the
# stand-in project beside this script instead of the ASan build (docs/FUZZING.md). A cut is named
# loudly and exits 0; a test that ran and failed exits 1, cut or not; a test reaching its own
# timeout is a failure, not a cut.
#   budget_test.sh SOURCE_DIR
set -uo pipefail
src=$1
tmp=$(mktemp -d "${TMPDIR:-/tmp}/orpe_asan_budget.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
export ORPE_JOBS=2 ASAN_BUDGET_FAIL=0 ASAN_BUDGET_BUILD_S=0 ASAN_BUDGET_SLEEP_S=120
unset ORPE_ASAN_TEST_TIMEOUT_S ORPE_ASAN_LONG
failures=0
check() {  # check WHAT CONDITION...
  local what=$1
  shift
  if "$@"; then echo "ok: $what"; else echo "FAILED: $what"; failures=$((failures + 1)); fi
}
# run_case NAME SECONDS_TO_DEADLINE: a fresh stand-in build; output in $tmp/NAME.log, status in $rc.
run_case() {
  local dir=$tmp/$1
  cmake -S "$src/tests/support/asan_budget" -B "$dir" -G Ninja > /dev/null
  ORPE_ASAN_BUILD_DIR=$dir ORPE_ASAN_DEADLINE_S=$(($(date +%s) + $2)) \
    bash "$src/scripts/test-asan.sh" > "$tmp/$1.log" 2>&1
  rc=$?
  echo "--- case $1 (deadline in $2 s): exit status $rc"
  cat "$tmp/$1.log"
}
has() { grep -q -- "$2" "$tmp/$1.log"; }
listed() { grep -qx -- "    $2" "$tmp/$1/asan_not_run.txt" 2> /dev/null; }

# First with room to spare; its duration (the script's own steps: install-deps, the no-op builds, the
# listing) sets how far ahead the deadlines of the cut cases must be for the quick test to run first,
# so that a loaded machine does not make the test flaky.
start=$(date +%s)
ASAN_BUDGET_SLEEP_S=0 run_case clean 600
check "within the budget: exit 0" test "$rc" = 0
check "within the budget: no warning" test "$(has clean "WARNING: the ASan" && echo y)" = ""
check "within the budget: all 5 tests passed" has clean "100% tests passed, 0 tests failed out of 5"
check "within the budget: the parameterised and the disabled test are not named as cut" \
  test "$(ls "$tmp/clean/asan_not_run.txt" 2> /dev/null)" = ""
margin=$((2 * ($(date +%s) - start) + 6))

run_case spent -10
check "budget spent before the build: exit 0" test "$rc" = 0
check "budget spent before the build: a warning" has spent "WARNING: the ASan + UBSan pass was cut"
check "budget spent before the build: says nothing ran" has spent "nothing ran"

ASAN_BUDGET_BUILD_S=60 run_case build 3
check "build cut: exit 0" test "$rc" = 0
check "build cut: says the build was stopped" has build "the ASan build was stopped after"
check "build cut: says no test ran" has build "before its first step finished: no test ran"

run_case tests "$margin"
check "tests cut: exit 0" test "$rc" = 0
check "tests cut: a warning" has tests "WARNING: the ASan + UBSan pass was cut"
check "tests cut: slow_a listed as not run" listed tests slow_a
check "tests cut: slow_b listed as not run" listed tests slow_b
check "tests cut: late listed as not run" listed tests late
check "tests cut: the parameterised test listed by its name" listed tests "Terms/Param.Case/Icp"
check "tests cut: the disabled test not listed" test "$(listed tests disabled_one && echo y)" = ""
check "tests cut: fail_one (it passed) not listed" test "$(listed tests fail_one && echo y)" = ""

ASAN_BUDGET_FAIL=1 run_case failed "$margin"
check "a failure beside a cut: exit 1" test "$rc" = 1
check "a failure beside a cut: named" has failed "fail_one (Failed)"
check "a failure beside a cut: the cut is named too" listed failed late

ORPE_ASAN_TEST_TIMEOUT_S=2 run_case hang 600
check "a test's own timeout: exit 1" test "$rc" = 1
check "a test's own timeout: a failure, not a cut" has hang "slow_a (Timeout)"
check "a test's own timeout: no cut warning" test "$(has hang "WARNING: the ASan" && echo y)" = ""


echo "$failures checks failed"
test "$failures" = 0
