#!/usr/bin/env bash
# Runs one libFuzzer target of fuzz/ (docs/FUZZING.md), niced, on a work corpus outside the repo
# seeded from fuzz/corpus/NAME; findings are written to the work folder's artifacts/.
#   bash scripts/fuzz.sh NAME [RUNS=1000000] [MAX_SECONDS=0 (no limit)] [extra libFuzzer flags]
#   bash scripts/fuzz.sh --merge NAME [MAX_FILES=30]   # minimised new inputs -> fuzz/corpus/NAME
# Needs the fuzz build: bash scripts/install-deps.sh --fuzz; cmake --preset fuzz;
# cmake --build build-fuzz --target orpe_fuzz_NAME. ORPE_FUZZ_BUILD_DIR=build-fuzz-fast runs the
# preset fuzz-fast's binary instead (UBSan only, no ASan: for a target ASan slows down too much,
# docs/FUZZING.md; replay its work corpus through build-fuzz afterwards).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN_DIR=${ORPE_FUZZ_BUILD_DIR:-build-fuzz}/bin
WORK=${ORPE_FUZZ_WORK:-/dev/shm/orpe_fuzz_work}
export TMPDIR=${TMPDIR:-/dev/shm}  # the targets' scratch files (tmpfs: no disk traffic per input)
# A UBSan report is a finding: stop at it (UBSan alone, as in the fuzz-fast build, would print and go on).
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
if [ "${1:-}" = --merge ]; then
  name=$2
  max_files=${3:-30}
  min="$WORK/$name/min"
  rm -rf "$min"
  mkdir -p "$min"
  cp "fuzz/corpus/$name"/* "$min/"
  # The work corpus's inputs that add coverage over the committed corpus; the smallest (at most
  # max_files, each <= 1 KiB) are committed as min-<sha1>.
  nice -n 10 "$BIN_DIR/orpe_fuzz_$name" -merge=1 "$min" "$WORK/$name/corpus" 2>&1 |
    grep -E "MERGE-OUTER: [0-9]+ new files" || true
  for f in $(ls -Sr "$min"); do
    if [ -e "fuzz/corpus/$name/$f" ] || [ "$(stat -c %s "$min/$f")" -gt 1024 ]; then continue; fi
    ((max_files-- > 0)) || break
    cp "$min/$f" "fuzz/corpus/$name/min-$f"
  done
  ls "fuzz/corpus/$name" | wc -l | xargs echo "fuzz/corpus/$name: files:"
  exit 0
fi
name=$1
runs=${2:-1000000}
secs=${3:-0}
shift $(($# < 3 ? $# : 3))
mkdir -p "$WORK/$name/corpus" "$WORK/$name/artifacts"
nice -n "${ORPE_FUZZ_NICE:-10}" "$BIN_DIR/orpe_fuzz_$name" -runs="$runs" -max_total_time="$secs" -max_len=4096 \
  -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 -print_final_stats=1 \
  -artifact_prefix="$WORK/$name/artifacts/" "$@" "$WORK/$name/corpus" "fuzz/corpus/$name"
