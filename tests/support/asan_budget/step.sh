#!/usr/bin/env bash
# The stand-in project's build step and tests (CMakeLists.txt beside it), driven by the environment.
case $1 in
  build) sleep "${ASAN_BUDGET_BUILD_S:-0}" ;;
  fail) test "${ASAN_BUDGET_FAIL:-0}" != 1 ;;
  sleep) sleep "${ASAN_BUDGET_SLEEP_S:-60}" ;;
esac
