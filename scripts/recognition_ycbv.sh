#!/usr/bin/env bash
# The model back-end (segmentation.backend=model) on the three shared YCB-Video clips: orpe run
# --mode full per clip, then the pooled pose evaluation (every annotated instance of every
# evaluated frame; a missed object counts as a miss) and the instance checks of orpe eval masks.
#
#   bash scripts/recognition_ycbv.sh [OUT] [extra orpe run args, e.g. --set segmentation.keyframe_every_n_frames=2]
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-/tmp/orpe_recognition_ycbv}
shift || true
DATA=${ORPE_DATA_DIR:-../shared/data}/ycbv
ORPE=build/bin/orpe
mkdir -p "$OUT"
RUNS=()
for s in 0000 0001 0002; do
  rm -rf "$OUT/$s"
  "$ORPE" -q run --dataset "$DATA" --out "$OUT/$s" --mode full --write-masks \
    --set dataset.scene=$s --set segmentation.backend=model "$@" 2> "$OUT/$s.log"
  RUNS+=(--run "$OUT/$s")
done
python3 - "$OUT" <<'PY'
import sys
out = sys.argv[1]
lines = []
for i, s in enumerate(("0000", "0001", "0002")):
    with open(f"{out}/{s}/poses.csv") as f:
        body = f.read().splitlines()
    lines += body if i == 0 else body[1:]
with open(f"{out}/poses_all.csv", "w") as f:
    f.write("\n".join(lines) + "\n")
with open(f"{out}/evaluated_all.txt", "w") as f:
    for s in ("0000", "0001", "0002"):
        f.write(open(f"{out}/{s}/evaluated_frames.txt").read())
PY
"$ORPE" eval poses --dataset "$DATA" --result "$OUT/poses_all.csv" --keyframes "$OUT/evaluated_all.txt" \
  --json "$OUT/poses_eval.json"
"$ORPE" eval masks --dataset "$DATA" "${RUNS[@]}" --json "$OUT/masks_eval.json"
