#!/usr/bin/env bash
# The CPU training demonstrations of docs/RESULTS.md ("Networks trained on synthetic scenes", issue #16):
# 3 objects, `orpe synth` scenes at 320 x 240, DenseFusion's PoseNet and a small Mask R-CNN trained for minutes,
# then run through orpe's C++ back-ends on held-out scenes and scored.
#   bash scripts/nets/train_demo.sh OUT [DF_MINUTES] [MRCNN_MINUTES]
# Steps can be re-run one by one (each is a plain command below). Runs niced; minutes of CPU each.
set -euo pipefail
OUT=${1:?output folder}
DF_MIN=${2:-30}
MR_MIN=${3:-14}
ORPE=${ORPE:-build/bin/orpe}
PY=/usr/bin/python3
N="nice -n 10 env OMP_WAIT_POLICY=passive"
mkdir -p "$OUT"
# Three object models: from two default (warehouse-set) scenes; the same --models for every scene keeps obj_ids.
for s in 1 2; do $N $ORPE synth --out "$OUT/s$s" --seed $s --frames 2 --objects 3 --width 320 --height 240 \
    --preview-stride 0 > /dev/null; done
M=$OUT/s1/models/obj_000002.ply,$OUT/s1/models/obj_000003.ply,$OUT/s2/models/obj_000002.ply
for s in 11 12 13 14 15 16 17 18 21 22; do
  $N $ORPE synth --out "$OUT/t$s" --seed $s --frames 40 --objects 3 --models $M --model-unit-m 0.001 \
      --width 320 --height 240 --preview-stride 0 > /dev/null
done
# 8 more placements for DenseFusion (session 9): 20 frames each
for s in 31 32 33 34 35 36 37 38; do
  $N $ORPE synth --out "$OUT/t$s" --seed $s --frames 20 --objects 3 --models $M --model-unit-m 0.001 \
      --width 320 --height 240 --preview-stride 0 > /dev/null
done
TRAIN=$(ls -d "$OUT"/t1? | paste -sd,)   # t11..t18 train; t21 (DenseFusion) and t22 (Mask R-CNN) held out
DF_TRAIN=$(ls -d "$OUT"/t1? "$OUT"/t3? | paste -sd,)
# DenseFusion PoseNet (frozen colour CNN: its embeddings of every training view computed once; 16 views x
# 64 points per step, +-5 cm translation noise, Adam 1e-3 with warm-up and a cosine decay over DF_MIN
# minutes or 4000 steps, whichever ends first)
$N $PY scripts/nets/densefusion_train.py train --train "$DF_TRAIN" --test "$OUT/t21" --out "$OUT/df" \
    --minutes "$DF_MIN" --steps 4000 --test-stride 2 --max-views 0 --threads 1 --batch 16 --points 64 \
    --shift-m 0.05 --lr 1e-3 --warmup 50 --log-every 50 --eval-every 250 --cache "$OUT/df_cache.pt"
# Mask R-CNN (small backbone), exported for the C++ back-end
$N $PY scripts/nets/maskrcnn_train.py --train "$TRAIN" --out "$OUT/mrcnn" --minutes "$MR_MIN" --log-every 10
for m in mrcnn mrcnn_untrained; do
  $PY scripts/nets/maskrcnn_export.py export --arch small --min-size 120 --max-size 160 \
      --checkpoint "$OUT/$m.pth" --classes 1,2,3 --out "$OUT/$m.pt"
done
# C++: Mask R-CNN masks on the held-out scene t22, scored against the ground truth
for m in mrcnn mrcnn_untrained; do
  $N $ORPE run --dataset "$OUT/t22" --out "$OUT/run_$m" --mode semantic --write-masks \
      --set segmentation.backend=maskrcnn --set segmentation.maskrcnn_model="$OUT/$m.pt" \
      --set segmentation.maskrcnn_threads=1 --set segmentation.min_score=0.2
  $ORPE eval masks --dataset "$OUT/t22" --run "$OUT/run_$m"
done
# C++: DenseFusion poses on the held-out scene t21 (orpe's pipeline, ground-truth segmentation), scored
for m in df_posenet df_untrained_posenet; do
  for last in 11 39; do  # the first 12 frames (session 8's comparison) and all 40
    R=$OUT/run_${m}_f$last
    $N $ORPE run --dataset "$OUT/t21" --out "$R" --mode full --set dataset.last_frame=$last \
        --set pipeline.pose_every_n_keyframes=3 --ablation DF-PM-PD --ablation DF-PM-PD-PC \
        --set pose.backend=densefusion --set pose.densefusion_model="$OUT/$m.pt" \
        --set pose.densefusion_iterations=0 --set pose.densefusion_num_points=100
    for v in DF-PM-PD DF-PM-PD-PC; do
      $ORPE eval poses --dataset "$OUT/t21" --result "$R/ablation/$v/poses.csv" --keyframes "$R/evaluated_frames.txt"
    done
  done
done
