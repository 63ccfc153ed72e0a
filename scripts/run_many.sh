#!/usr/bin/env bash
# Scale-out (docs/SCALING.md): one `orpe run` per sequence, several at a time under GNU parallel
# (Debian's `parallel`); each sequence is one process with its own output folder, so nothing here
# schedules or shares state. The runs' poses.csv files are merged by `orpe eval poses --result A
# --result B ...`.
#
#   scripts/run_many.sh --out DIR [--jobs N] [--threads T] SEQUENCE... [-- ORPE RUN ARGS...]
#
# Writes DIR/<sequence folder name>/ (the run's outputs) and DIR/joblog.tsv (GNU parallel's job log:
# exit code and time per sequence). Exits non-zero when any run failed (the others still finish).
# --threads: OMP_NUM_THREADS per run (default: cores / jobs, at least 1).
set -euo pipefail
ORPE=${ORPE:-"$(cd "$(dirname "$0")/.." && pwd)/build/bin/orpe"}
out="" jobs=2 threads="" seqs=() extra=()
while (($#)); do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --threads) threads=$2; shift 2 ;;
    --) shift; extra=("$@"); break ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) seqs+=("$1"); shift ;;
  esac
done
if [ -z "$out" ] || ((${#seqs[@]} == 0)); then
  echo "usage: $0 --out DIR [--jobs N] [--threads T] SEQUENCE... [-- ORPE RUN ARGS...]" >&2
  exit 2
fi
command -v parallel >/dev/null || { echo "error: GNU parallel is not installed (apt install parallel; scripts/install-deps.sh)" >&2; exit 2; }
[ -x "$ORPE" ] || { echo "error: $ORPE not found: build first (scripts/build.sh) or set ORPE" >&2; exit 2; }
declare -A seen
for s in "${seqs[@]}"; do
  [ -d "$s" ] || { echo "error: $s: not a folder" >&2; exit 2; }
  name=$(basename "$(cd "$s" && pwd)")
  [ -z "${seen[$name]:-}" ] || { echo "error: two sequences named $name: their outputs would collide" >&2; exit 2; }
  seen[$name]=1
done
if [ -z "$threads" ]; then threads=$(( $(nproc) / jobs )); ((threads >= 1)) || threads=1; fi
mkdir -p "$out"
export ORPE OUT_DIR="$out" OMP_NUM_THREADS="$threads"
# One job per sequence: orpe run --dataset SEQ --out OUT/NAME EXTRA..., its log in OUT/NAME.log.
run_one() {
  local seq=$1 name
  shift
  name=$(basename "$(cd "$seq" && pwd)")
  "$ORPE" run --dataset "$seq" --out "$OUT_DIR/$name" "$@" > "$OUT_DIR/$name.log" 2>&1
}
export -f run_one
SHELL=$(command -v bash) parallel -q --jobs "$jobs" --joblog "$out/joblog.tsv" --halt never \
  run_one {1} "${extra[@]}" ::: "${seqs[@]}"
