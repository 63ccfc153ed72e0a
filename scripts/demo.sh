#!/usr/bin/env bash
# The README's demo, end to end: dependencies, build, a synthetic scene (orpe synth), the full
# Object-RPE pipeline on it (orpe run --mode full), recognising the objects from their models alone
# (segmentation.backend=model: no labels, no training), and its evaluation (trajectory ATE, 6D pose AUC,
# reconstruction error), a short summary, and the report page of the run (orpe report, docs/REPORT.md),
# whose path it prints last.
#
#   bash scripts/demo.sh                 # outputs in /tmp/orpe_demo (ORPE_DEMO_DIR to change)
#   ORPE_DEMO_FRAMES=120 bash scripts/demo.sh   # a longer sequence
#
# A few minutes on 2 cores once built (the first build takes longer). Environment: ORPE_DEMO_DIR,
# ORPE_DEMO_FRAMES (default 48), ORPE_DEMO_OBJECTS (default 4), ORPE_SKIP_INSTALL=1 to skip the
# dependency check, ORPE_JOBS (build jobs, default 2).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${ORPE_DEMO_DIR:-/tmp/orpe_demo}
FRAMES=${ORPE_DEMO_FRAMES:-48}
OBJECTS=${ORPE_DEMO_OBJECTS:-4}
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
start=$(date +%s)

step() { printf '\n== %s\n' "$*"; }

if [ "${ORPE_SKIP_INSTALL:-0}" != 1 ]; then
  step "dependencies"
  bash scripts/install-deps.sh
fi
step "build"
ORPE_JOBS=${ORPE_JOBS:-2} bash scripts/build.sh --target orpe_cli
ORPE=build/bin/orpe

# A BOP dataset (models/, camera.json at its root); its one scene is test/000000 (BOP scene id 0).
SCENE=$OUT/scene
RUN=$OUT/run
rm -rf "$OUT"
mkdir -p "$OUT"

step "synthetic scene: $FRAMES frames, $OBJECTS objects, sensor noise on (orpe synth)"
"$ORPE" synth --out "$SCENE" --seed 3 --frames "$FRAMES" --objects "$OBJECTS" --scene table \
  --width 320 --height 240 --span-deg $((FRAMES * 3 / 2)) --preview-stride 0

step "Object-RPE: SLAM + recognition of the known models (no ground truth) + semantic mapping + poses + EKF"
"$ORPE" run --dataset "$SCENE" --out "$RUN" --overwrite --mode full --set segmentation.backend=model \
  --set pipeline.progress_every_n_frames=8 | tee "$OUT/run.log"

step "evaluation"
"$ORPE" eval traj "$SCENE/test/000000/groundtruth.txt" "$RUN/trajectory.txt" --json "$OUT/traj.json" | head -2
"$ORPE" eval poses --dataset "$SCENE" --result "$RUN/poses.csv" --keyframes "$RUN/evaluated_frames.txt" \
  --json "$OUT/poses_eval.json"
"$ORPE" eval poses --dataset "$SCENE" --result "$RUN/poses_final.csv" \
  --keyframes "$RUN/evaluated_frames.txt" --json "$OUT/poses_final_eval.json" > /dev/null
"$ORPE" eval recon --dataset "$SCENE" --run "$RUN" --json "$OUT/recon.json"

step "summary"
python3 - "$OUT" "$(($(date +%s) - start))" <<'EOF'
import json, sys
out, seconds = sys.argv[1], sys.argv[2]
load = lambda name: json.load(open(f"{out}/{name}"))
traj, poses, final, recon = load("traj.json"), load("poses_eval.json"), load("poses_final_eval.json"), load("recon.json")
summary = load("run/summary.json")
objects = load("run/objects.json")["objects"]
ate = traj.get("ate", {}).get("translation_m", {}).get("rmse")
print(f"frames {summary['counts']['frames']}, map instances {summary['counts']['instances']}, "
      f"objects with a fused pose {sum(o['valid'] for o in objects)}")
if ate is not None:
    print(f"camera trajectory ATE rmse: {ate * 1000:.1f} mm")
print(f"object poses per frame (Object-RPE, EKF after each frame): ADD-S AUC {poses['all']['adds_auc']:.1f}, "
      f"ADD(-S) AUC {poses['all']['add_s_auc']:.1f}, ADD-S < 2 cm {poses['all']['adds_below'] * 100:.0f} %")
print(f"final fused poses in every frame:                          ADD-S AUC {final['all']['adds_auc']:.1f}")
print(f"reconstruction error of the objects in the map: {recon['mean_mm']:.1f} mm")
print(f"time per frame: {summary['timing_ms']['per_frame']['pipeline']:.0f} ms; demo wall time {seconds} s")
print(f"outputs: {out}/run (trajectory.txt, map.ply, semantic_map.ply, objects.json, poses.csv, summary.json)")
EOF

step "report: map renders, models at the estimated poses, charts, tables (orpe report)"
"$ORPE" -q report --run "$RUN" --dataset "$SCENE" --out "$OUT/report" > /dev/null
echo "report (open it in a browser): $OUT/report/index.html"
