#!/usr/bin/env python3
"""ADD(-S) vs ADD-S on synthetic textured scenes (issue 15's synthetic colour target).

For every seed: `orpe synth --symmetries appearance` (table scene, noise on: the printed boxes, cartons and
labelled cans are not symmetric in appearance, so ADD(-S) scores them with ADD), then `orpe run --mode full`
with default settings (degraded gt detections) and once more with the colour ranking off
(`pose_registration.colour_enabled=false`), each scored by `orpe eval poses` over its evaluated frames
(instances at least --min-visible visible).

  python3 scripts/synth_textured.py --out /tmp/synth_textured --seeds 1,2,3

Writes OUT/synth_textured.md and OUT/synth_textured.json. Python 3 standard library only.
"""
import argparse
import json
import os
import subprocess
import sys
import time


def run(cmd):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stdout}")
    return r.stdout


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True)
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--objects", type=int, default=5)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--span-deg", type=float, default=120)
    ap.add_argument("--min-visible", type=float, default=0.1)
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin"))
    ap.add_argument("--configs", default="colour,no colour",
                    help="comma-separated subset of: colour (the default evidence, the Lambert fit), no colour, "
                         "plain ncc, local contrast (pose_registration.colour_evidence=ncc / local_contrast)")
    ap.add_argument("--set", action="append", default=[], dest="sets", help="section.key=value for orpe run")
    args = ap.parse_args()
    orpe = os.path.join(os.path.abspath(args.bin), "orpe")
    os.makedirs(args.out, exist_ok=True)
    seeds = [int(s) for s in args.seeds.split(",") if s]
    known = {"colour": [], "no colour": ["--set", "pose_registration.colour_enabled=false"],
             "plain ncc": ["--set", "pose_registration.colour_evidence=ncc"],
             "local contrast": ["--set", "pose_registration.colour_evidence=local_contrast"]}
    names = [c.strip() for c in args.configs.split(",") if c.strip()]
    for c in names:
        if c not in known:
            sys.exit(f"--configs: unknown configuration '{c}' (known: {', '.join(known)})")
    configs = {c: known[c] for c in names}
    sets = sum((["--set", s] for s in args.sets), [])
    t0 = time.time()
    results = {}
    for seed in seeds:
        scene = os.path.join(args.out, f"seed{seed}", "000000")
        if not os.path.isfile(os.path.join(scene, "models", "models_info.json")):
            run([orpe, "synth", "--out", scene, "--seed", str(seed), "--frames", str(args.frames), "--objects",
                 str(args.objects), "--scene", "table", "--width", str(args.width), "--height", str(args.height),
                 "--span-deg", str(args.span_deg), "--preview-stride", "0", "--symmetries", "appearance"])
        results[seed] = {}
        for name, extra in configs.items():
            rdir = os.path.join(args.out, f"seed{seed}", "run_" + name.replace(" ", "_"))
            run([orpe, "-q", "run", "--dataset", scene, "--out", rdir, "--overwrite", "--mode", "full",
                 "--set", "pipeline.progress_every_n_frames=0"] + extra + sets)
            js = os.path.join(rdir, "eval.json")
            run([orpe, "-q", "eval", "poses", "--dataset", scene, "--result", os.path.join(rdir, "poses.csv"),
                 "--keyframes", os.path.join(rdir, "evaluated_frames.txt"), "--json", js,
                 "--set", f"eval_pose.min_visible_fraction={args.min_visible}"])
            with open(js) as f:
                results[seed][name] = json.load(f)
            a = results[seed][name]["all"]
            print(f"seed {seed} {name}: ADD-S {a['adds_auc']:.1f} ADD(-S) {a['add_s_auc']:.1f}", flush=True)
    md = [f"Synthetic textured scenes (table, {args.objects} objects, {args.frames} frames at {args.width}x{args.height}, "
          f"{args.span_deg:g} deg arc, noise on, `--symmetries appearance`, degraded gt detections, Object-RPE per frame)\n",
          "| seed | colour ranking | ADD-S AUC | ADD(-S) AUC | gap | estimated / instances |",
          "| ---: | --- | ---: | ---: | ---: | ---: |"]
    mean = {}
    for name in configs:
        for seed in seeds:
            a = results[seed][name]["all"]
            md.append(f"| {seed} | {name} | {a['adds_auc']:.1f} | {a['add_s_auc']:.1f} | "
                      f"{a['adds_auc'] - a['add_s_auc']:.1f} | {a['estimated']}/{a['instances']} |")
        m_s = sum(results[s][name]["all"]["adds_auc"] for s in seeds) / len(seeds)
        m_a = sum(results[s][name]["all"]["add_s_auc"] for s in seeds) / len(seeds)
        mean[name] = {"adds_auc": m_s, "add_s_auc": m_a}
        md.append(f"| mean | {name} | {m_s:.1f} | {m_a:.1f} | {m_s - m_a:.1f} | |")
    md.append(f"\nWall time {time.time() - t0:.0f} s.")
    text = "\n".join(md) + "\n"
    with open(os.path.join(args.out, "synth_textured.md"), "w") as f:
        f.write(text)
    with open(os.path.join(args.out, "synth_textured.json"), "w") as f:
        json.dump({"args": vars(args), "per_seed": {str(s): results[s] for s in seeds}, "mean": mean}, f, indent=1)
    print(text)


if __name__ == "__main__":
    main()
