#!/usr/bin/env bash
# CPU time per call of a ResNet-50-FPN Mask R-CNN (torchvision's maskrcnn_resnet50_fpn, untrained:
# the time does not depend on the weights) on one YCB-Video frame, C++ (orpe_bench_maskrcnn_speed,
# LibTorch + orpe's operators) beside Python (the same TorchScript file, torchvision's operators),
# same threads, in the same run. docs/BENCHMARKS.md.
#   bash scripts/nets/maskrcnn_bench.sh [BUILD_DIR] [THREADS] [REPEATS]
set -euo pipefail
cd "$(dirname "$0")/../.."
build=${1:-build}
threads=${2:-2}
repeats=${3:-3}
data=${ORPE_DATA_DIR:-../shared/data}
image=$data/ycbv/data/0000/000001-color.png
tmp=$(mktemp -d "${TMPDIR:-/tmp}/orpe_maskrcnn_bench.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
classes=$(seq -s, 1 21)
/usr/bin/python3 scripts/nets/maskrcnn_export.py export --classes "$classes" --out "$tmp/r50.pt" \
  --min-size 480 --max-size 640 2> /dev/null
"$build/bin/orpe_bench_maskrcnn_speed" --model "$tmp/r50.pt" --image "$image" --threads "$threads" \
  --repeats "$repeats"
/usr/bin/python3 scripts/nets/maskrcnn_export.py bench --model "$tmp/r50.pt" --image "$image" \
  --threads "$threads" --repeats "$repeats" 2> /dev/null
