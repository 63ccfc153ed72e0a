#!/usr/bin/env python3
"""Multi-view fusion vs single view on synthetic wide-baseline scenes (issue 6's synthetic target).

For every seed: `orpe synth` (table scene, noise on, a camera arc of --span-deg around it), then
`orpe run --mode full --ablation all` (degraded `gt` detections, the default), then `orpe eval poses`
of each configuration over the same evaluated frames, counting only ground-truth instances at least
--min-visible visible (synthetic scenes list objects outside the view too; BOP uses 0.1). One extra
row replays the EKF offline (orpe_bench_ekf_replay) without the map-held poses of objects too small
for a single-view estimate (`pipeline.ekf_report_min_mask_px=0`): the EKF on exactly the objects the
single-view rows estimate.

  python3 scripts/synth_fusion.py --out /tmp/synth_fusion --seeds 1,2,3,4,5,6

Writes OUT/synth_fusion.md (per seed and mean over seeds), OUT/synth_fusion.json and OUT/report.html (the
tables, bar charts of ADD-S AUC per seed and of the means, links to each seed's `orpe report` page); per seed
OUT/seed<N>/000000 (the scene), OUT/seed<N>/run (run outputs), OUT/seed<N>/eval/*.json.
Python 3 standard library only.
"""
import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import ablation  # noqa: E402  (its run() helper)
import report_page  # noqa: E402

CONFIGS = ["DF", "DF-PM", "DF-PM-PD-PC", "Object-RPE"]
EKF_ONLY = "Object-RPE, estimated objects only"
FINAL = "Object-RPE (final)"
BASE = "DF-PM-PD-PC"


def run(cmd, quiet=True):
    """ablation.run, quiet by default: the command's output is shown only when it fails."""
    ablation.run(cmd, quiet=quiet)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--seeds", default="1,2,3,4,5,6", help="comma-separated synth seeds")
    ap.add_argument("--frames", type=int, default=80)
    ap.add_argument("--objects", type=int, default=6)
    ap.add_argument("--scene", default="table")
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--span-deg", type=float, default=240, help="camera arc around the scene (deg)")
    ap.add_argument("--min-visible", type=float, default=0.1,
                    help="evaluate ground-truth instances at least this visible (eval_pose.min_visible_fraction)")
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin"),
                    help="folder with orpe and orpe_bench_ekf_replay (default build/bin)")
    ap.add_argument("--set", action="append", default=[], dest="sets",
                    help="section.key=value passed to orpe run and the replay (repeatable)")
    ap.add_argument("--reuse", action="store_true", help="skip scenes and runs whose outputs exist")
    args = ap.parse_args()

    bindir = os.path.abspath(args.bin)
    orpe = os.path.join(bindir, "orpe")
    replay = os.path.join(bindir, "orpe_bench_ekf_replay")
    for b in (orpe, replay):
        if not os.path.isfile(b):
            sys.exit(f"binary not found: {b} (build first: bash scripts/build.sh)")
    os.makedirs(args.out, exist_ok=True)
    seeds = [int(s) for s in args.seeds.split(",") if s]
    sets = []
    for s in args.sets:
        sets += ["--set", s]
    eval_sets = ["--set", f"eval_pose.min_visible_fraction={args.min_visible}"]
    rows = [c for c in CONFIGS] + [EKF_ONLY, FINAL]
    t0 = time.time()
    results = {}  # seed -> row -> eval json "all"
    for seed in seeds:
        sdir = os.path.join(args.out, f"seed{seed}")
        scene = os.path.join(sdir, "000000")  # named by its BOP scene id (keyframe lists name it)
        rdir = os.path.join(sdir, "run")
        edir = os.path.join(sdir, "eval")
        os.makedirs(edir, exist_ok=True)
        if not (args.reuse and os.path.isfile(os.path.join(scene, "test", "000000", "scene_gt.json"))):
            run([orpe, "synth", "--out", scene, "--seed", str(seed), "--frames", str(args.frames),
                 "--objects", str(args.objects), "--scene", args.scene, "--width", str(args.width),
                 "--height", str(args.height), "--span-deg", str(args.span_deg), "--preview-stride", "0"])
        if not (args.reuse and os.path.isfile(os.path.join(rdir, "summary.json"))):
            run([orpe, "run", "--dataset", scene, "--out", rdir, "--overwrite", "--mode", "full", "--ablation", "all",
                 "--set", "pipeline.progress_every_n_frames=20"] + sets, quiet=False)
        keyframes = os.path.join(rdir, "evaluated_frames.txt")
        csvs = {c: os.path.join(rdir, "ablation", c, "poses.csv") for c in CONFIGS}
        csvs[FINAL] = os.path.join(rdir, "ablation", "Object-RPE", "poses_final.csv")
        csvs[EKF_ONLY] = os.path.join(edir, "ekf_estimated_only_rows.csv")
        run([replay, "--dataset", scene, "--single-view",
             os.path.join(rdir, "ablation", "Object-RPE", "single_view.csv"), "--out-rows", csvs[EKF_ONLY]] +
            sets + ["--set", "pipeline.ekf_report_min_mask_px=0"])
        results[seed] = {}
        for r in rows:
            js = os.path.join(edir, r.replace(" ", "_").replace(",", "").replace("(", "").replace(")", "") + ".json")
            run([orpe, "-q", "eval", "poses", "--dataset", scene, "--result", csvs[r], "--keyframes", keyframes,
                 "--json", js] + eval_sets)
            with open(js) as f:
                results[seed][r] = json.load(f)["all"]

    def cells(a):
        return f"{a['adds_auc']:.1f} | {a['add_s_auc']:.1f} | {a['adds_below'] * 100:.1f} | {a['estimated']}/{a['instances']}"

    md = [f"### Fusion vs single view: synthetic wide-baseline scenes (`{args.scene}`, {args.objects} objects, "
          f"{args.frames} frames at {args.width}x{args.height}, {args.span_deg:g} deg arc, noise on, degraded gt "
          f"detections; instances >= {args.min_visible:g} visible)\n",
          "| seed | configuration | ADD-S AUC | ADD(-S) AUC | ADD-S < 2 cm (%) | estimated / instances | "
          f"ADD-S AUC gain over {BASE} |",
          "| ---: | --- | ---: | ---: | ---: | ---: | ---: |"]
    for seed in seeds:
        for r in rows:
            a = results[seed][r]
            gain = a["adds_auc"] - results[seed][BASE]["adds_auc"]
            md.append(f"| {seed} | {r} | {cells(a)} | {gain:+.1f} |")
    md.append(f"\nMean over the {len(seeds)} seeds:\n")
    md.append("| configuration | ADD-S AUC | ADD(-S) AUC | ADD-S < 2 cm (%) | gain (min..max over seeds) |")
    md.append("| --- | ---: | ---: | ---: | ---: |")
    mean = lambda xs: sum(xs) / len(xs)
    summary = {}
    for r in rows:
        vals = [results[s][r] for s in seeds]
        gains = [results[s][r]["adds_auc"] - results[s][BASE]["adds_auc"] for s in seeds]
        summary[r] = {"adds_auc": mean([v["adds_auc"] for v in vals]),
                      "add_s_auc": mean([v["add_s_auc"] for v in vals]),
                      "adds_below": mean([v["adds_below"] for v in vals]),
                      "gain": mean(gains), "gain_min": min(gains), "gain_max": max(gains)}
        m = summary[r]
        md.append(f"| {r} | {m['adds_auc']:.1f} | {m['add_s_auc']:.1f} | {m['adds_below'] * 100:.1f} | "
                  f"{m['gain']:+.1f} ({m['gain_min']:+.1f}..{m['gain_max']:+.1f}) |")
    md.append(f"\nWall time {time.time() - t0:.0f} s. Settings: " + (" ".join(args.sets) or "defaults") + ".")
    text = "\n".join(md) + "\n"
    with open(os.path.join(args.out, "synth_fusion.md"), "w") as f:
        f.write(text)
    with open(os.path.join(args.out, "synth_fusion.json"), "w") as f:
        json.dump({"args": vars(args), "per_seed": {str(s): results[s] for s in seeds}, "mean": summary}, f,
                  indent=1)
    charts = [report_page.bar_chart("ADD-S AUC per seed", [f"seed {s}" for s in seeds],
                                    {r: [results[s][r]["adds_auc"] for s in seeds] for r in rows}, "ADD-S AUC",
                                    width=max(760, 110 * len(seeds) + 330), y_max=100),
              report_page.bar_chart(f"Mean over the {len(seeds)} seeds (percent)",
                                    ["ADD-S AUC", "ADD(-S) AUC", "ADD-S < 2 cm"],
                                    {r: [summary[r]["adds_auc"], summary[r]["add_s_auc"],
                                         summary[r]["adds_below"] * 100] for r in rows}, "percent",
                                    width=900, y_max=100)]
    links = report_page.orpe_reports(orpe, [(f"seed {s}", os.path.join(args.out, f"seed{s}", "run"),
                                             ["--dataset", os.path.join(args.out, f"seed{s}", "000000")])
                                            for s in seeds])
    report_page.write(os.path.join(args.out, "report.html"), "Fusion vs single view", text, charts, links)
    print(text)


if __name__ == "__main__":
    main()
