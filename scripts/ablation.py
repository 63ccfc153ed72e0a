#!/usr/bin/env python3
"""The paper's ablation table (Table II) on a dataset, in Markdown.

Runs the five pose configurations (DF, DF-PM, DF-PM-PD, DF-PM-PD-PC, Object-RPE) on every scene, scores
them with `orpe eval poses` (ADD-S AUC, ADD(-S) AUC, ADD-S < 2 cm per class and pooled, over the
evaluated frames), and adds the per-object reconstruction error of the semantic map (`orpe eval recon`).

  python3 scripts/ablation.py --dataset ../shared/data/ycbv --scenes 0000,0001,0002 --out /tmp/abl \
      --set segmentation.gt_degrade=false

By default the five configurations run in one pass per scene (`orpe run --ablation all`: SLAM and the
semantic map are shared, single-view estimates are reused where the inputs are identical); --separate
runs `orpe run` once per configuration instead (same results, slower). Besides the five rows the table
has "Object-RPE (final)": the final fused world pose of each object moved into every evaluated frame
(poses_final.csv) -- what the whole sequence says, not a causal per-frame estimate.

Writes OUT/ablation.md (the tables), OUT/ablation.json (all figures), OUT/report.html (the tables, bar charts
of the pooled and per-class scores, and links to the `orpe report` page of each scene's run: report_page.py),
per scene OUT/<scene>/ (run outputs) and per configuration OUT/eval/<name>.json. Python 3 standard library
only.
"""
import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import report_page  # noqa: E402

CONFIGS = ["DF", "DF-PM", "DF-PM-PD", "DF-PM-PD-PC", "Object-RPE"]
FINAL = "Object-RPE (final)"


def run(cmd, quiet=False):
    """Runs cmd; its output goes to stderr (progress), or is kept and shown only on failure (quiet)."""
    print("+ " + " ".join(cmd), file=sys.stderr, flush=True)
    res = subprocess.run(cmd, stdout=subprocess.PIPE if quiet else sys.stderr,
                         stderr=subprocess.STDOUT if quiet else None, text=True)
    if res.returncode != 0:
        if quiet and res.stdout:
            sys.stderr.write(res.stdout)
        sys.exit(f"command failed ({res.returncode}): {' '.join(cmd)}")


def merge_csv(paths, out_path):
    header = "scene_id,im_id,obj_id,score,R,t,time"
    rows = []
    for p in paths:
        with open(p) as f:
            for line in f:
                line = line.strip()
                if line and not line.startswith("scene_id"):
                    rows.append(line)
    with open(out_path + ".tmp", "w") as f:
        f.write(header + "\n" + "".join(r + "\n" for r in rows))
    os.replace(out_path + ".tmp", out_path)
    return len(rows)


def fmt(v, digits=1):
    return "-" if v is None else f"{v:.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", required=True, help="dataset folder (YCB-Video root, BOP / orpe synth scene)")
    ap.add_argument("--scenes", default="", help="comma-separated scenes (YCB video 0000, BOP scene); "
                    "empty = the dataset's default scene")
    ap.add_argument("--out", required=True, help="output folder")
    ap.add_argument("--orpe", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin", "orpe"),
                    help="orpe binary (default build/bin/orpe)")
    ap.add_argument("--set", action="append", default=[], dest="sets",
                    help="section.key=value passed to orpe run and orpe eval (repeatable)")
    ap.add_argument("--config", default="", help="JSON config passed to orpe run and orpe eval")
    ap.add_argument("--separate", action="store_true", help="one orpe run per configuration")
    ap.add_argument("--configs", default=",".join(CONFIGS),
                    help="comma-separated subset of the configurations (default: all five)")
    ap.add_argument("--reuse", action="store_true", help="skip runs whose outputs exist")
    ap.add_argument("--no-recon", action="store_true", help="skip the reconstruction error")
    ap.add_argument("--title", default="", help="heading of the Markdown output")
    args = ap.parse_args()

    orpe = os.path.abspath(args.orpe)
    if not os.path.isfile(orpe):
        sys.exit(f"orpe binary not found: {orpe} (build first: bash scripts/build.sh)")
    os.makedirs(args.out, exist_ok=True)
    common = []
    if args.config:
        common += ["--config", args.config]
    for s in args.sets:
        common += ["--set", s]
    scenes = [s for s in args.scenes.split(",") if s] or [""]
    configs = [c for c in args.configs.split(",") if c]
    for c in configs:
        if c not in CONFIGS:
            sys.exit(f"unknown configuration {c} (expected some of {', '.join(CONFIGS)})")
    with_final = "Object-RPE" in configs
    cols = configs + ([FINAL] if with_final else [])
    t0 = time.time()

    # 1. Runs.
    poses = {c: [] for c in cols}
    evaluated = []
    run_dirs = []
    for scene in scenes:
        scene_args = ["--set", f"dataset.scene={scene}"] if scene else []
        sdir = os.path.join(args.out, scene or "scene")
        run_dirs.append((scene, sdir))
        if not args.separate:
            done = os.path.isfile(os.path.join(sdir, "summary.json"))
            if not (args.reuse and done):
                abl = []
                for c in (["Object-RPE"] if with_final else []) + [c for c in configs if c != "Object-RPE"]:
                    abl += ["--ablation", c]
                run([orpe, "run", "--dataset", args.dataset, "--out", sdir, "--overwrite", "--mode", "full"] + abl +
                    common + scene_args)
            for c in configs:
                poses[c].append(os.path.join(sdir, "ablation", c, "poses.csv"))
            if with_final:
                poses[FINAL].append(os.path.join(sdir, "ablation", "Object-RPE", "poses_final.csv"))
            evaluated.append(os.path.join(sdir, "evaluated_frames.txt"))
        else:
            for c in configs:
                cdir = os.path.join(sdir, c)
                if not (args.reuse and os.path.isfile(os.path.join(cdir, "summary.json"))):
                    run([orpe, "run", "--dataset", args.dataset, "--out", cdir, "--overwrite", "--mode", "full",
                         "--ablation", c] + common + scene_args)
                poses[c].append(os.path.join(cdir, "ablation", c, "poses.csv"))
                if c == "Object-RPE":
                    poses[FINAL].append(os.path.join(cdir, "ablation", c, "poses_final.csv"))
            evaluated.append(os.path.join(sdir, configs[0], "evaluated_frames.txt"))
            run_dirs[-1] = (scene, os.path.join(sdir, configs[0]))

    # 2. Pose evaluation over the evaluated frames of all scenes.
    eval_dir = os.path.join(args.out, "eval")
    os.makedirs(eval_dir, exist_ok=True)
    keyframes = os.path.join(eval_dir, "evaluated_frames.txt")
    lines = []
    for p in evaluated:
        with open(p) as f:
            lines += [l for l in f.read().splitlines() if l.strip()]
    if not lines:
        sys.exit("no evaluated frames (no segmentation keyframe?)")
    with open(keyframes, "w") as f:
        f.write("\n".join(lines) + "\n")
    results = {}
    for c in cols:
        name = c.replace(" ", "_").replace("(", "").replace(")", "")
        merged = os.path.join(eval_dir, name + "_poses.csv")
        merge_csv(poses[c], merged)
        js = os.path.join(eval_dir, name + ".json")
        run([orpe, "-q", "eval", "poses", "--dataset", args.dataset, "--result", merged, "--keyframes",
             keyframes, "--json", js] + common, quiet=True)
        with open(js) as f:
            results[c] = json.load(f)

    # 3. Reconstruction error per object (same semantic map for every configuration).
    recon = {}  # class id -> list of mean errors (m) over objects / scenes
    recon_rows = []
    if not args.no_recon:
        for scene, rdir in run_dirs:
            scene_args = ["--set", f"dataset.scene={scene}"] if scene else []
            js = os.path.join(eval_dir, f"recon_{scene or 'scene'}.json")
            run([orpe, "-q", "eval", "recon", "--dataset", args.dataset, "--run", rdir, "--register",
                 "--json", js] + common + scene_args, quiet=True)
            with open(js) as f:
                r = json.load(f)
            for o in r["objects"]:
                recon_rows.append(dict(o, scene=scene))
                if o["mean_mm"] is not None:
                    recon.setdefault(o["class_id"], []).append((o["mean_mm"], o["median_mm"]))

    # 4. Tables.
    names = {}
    for c in results.values():
        for k in c["classes"]:
            names[k["class_id"]] = (k["name"], k["symmetric"], k["instances"])
    def cell(c, cls, key):
        r = results[c]
        row = r["all"] if cls is None else next((k for k in r["classes"] if k["class_id"] == cls), None)
        if row is None:
            return None
        v = row[key]
        return v * 100 if key.endswith("_below") else v

    def recon_cell(cls):
        vals = [m for (m, _) in recon.get(cls, [])] if cls is not None else \
            [m for v in recon.values() for (m, _) in v]
        return sum(vals) / len(vals) if vals else None

    md = []
    title = args.title or f"Ablation on {args.dataset}" + (f" (scenes {args.scenes})" if args.scenes else "")
    md.append(f"### {title}\n")
    md.append("Pooled over all evaluated frames (ADD-S AUC / ADD(-S) AUC / ADD-S < 2 cm, percent):\n")
    md.append("| configuration | ADD-S AUC | ADD(-S) AUC | ADD-S < 2 cm | instances | estimated |")
    md.append("| --- | ---: | ---: | ---: | ---: | ---: |")
    for c in cols:
        a = results[c]["all"]
        md.append(f"| {c} | {a['adds_auc']:.1f} | {a['add_s_auc']:.1f} | {a['adds_below'] * 100:.1f} | "
                  f"{a['instances']} | {a['estimated']} |")
    for key, label in [("adds_auc", "ADD-S AUC"), ("add_s_auc", "ADD(-S) AUC"), ("adds_below", "ADD-S < 2 cm (%)")]:
        md.append(f"\n{label} per class" + (" (recon: surfel-to-model distance of the semantic map's "
                                            "object surfels at the ground-truth pose, mm: mean over "
                                            "objects of the per-object mean (median))"
                                            if key == "adds_auc" and recon else "") + ":\n")
        head = "| class | " + " | ".join(cols) + (" | recon (mm) |" if key == "adds_auc" and recon else " |")
        md.append(head)
        md.append("| --- |" + " ---: |" * (len(cols) + (1 if key == "adds_auc" and recon else 0)))
        for cls in sorted(names):
            nm, sym, _ = names[cls]
            line = f"| {nm}{' *' if sym else ''} | " + " | ".join(fmt(cell(c, cls, key)) for c in cols)
            if key == "adds_auc" and recon:
                med = [g for (_, g) in recon.get(cls, []) if g is not None]
                line += f" | {fmt(recon_cell(cls))}" + (f" ({fmt(sum(med) / len(med))})" if med else "")
            md.append(line + " |")
        line = "| **ALL** | " + " | ".join(fmt(cell(c, None, key)) for c in cols)
        if key == "adds_auc" and recon:
            med = [g for v in recon.values() for (_, g) in v if g is not None]
            line += f" | {fmt(recon_cell(None))}" + (f" ({fmt(sum(med) / len(med))})" if med else "")
        md.append(line + " |")
    md.append("\n`*` symmetric class (ADD(-S) uses ADD-S). DF = the single-view estimator in use "
              "(model-based registration, geometry only: DF-PM-PD and DF-PM-PD-PC coincide). "
              f"Wall time {time.time() - t0:.0f} s.")
    text = "\n".join(md) + "\n"
    with open(os.path.join(args.out, "ablation.md"), "w") as f:
        f.write(text)
    with open(os.path.join(args.out, "ablation.json"), "w") as f:
        json.dump({"dataset": args.dataset, "scenes": scenes, "sets": args.sets,
                   "pose": {c: {k: results[c][k] for k in ("all", "classes")} for c in cols},
                   "reconstruction": recon_rows}, f, indent=1)
    write_report(args, orpe, common, text, results, cols, names, run_dirs)
    print(text)


def write_report(args, orpe, common, text, results, cols, names, run_dirs):
    """OUT/report.html: the tables, bar charts of the scores, and each scene run's `orpe report` page."""
    pooled = report_page.bar_chart(
        "Pooled over the evaluated frames (percent)", ["ADD-S AUC", "ADD(-S) AUC", "ADD-S < 2 cm"],
        {c: [results[c]["all"]["adds_auc"], results[c]["all"]["add_s_auc"], results[c]["all"]["adds_below"] * 100]
         for c in cols}, "percent", y_max=100)
    classes = sorted(names)
    per_class = report_page.bar_chart(
        "ADD-S AUC per class", [names[k][0] for k in classes],
        {c: [next((r["adds_auc"] for r in results[c]["classes"] if r["class_id"] == k), None) for k in classes]
         for c in cols}, "ADD-S AUC", width=max(760, 90 * len(classes) + 230), y_max=100)
    runs = [(f"scene {scene or '(default)'}", rdir, ["--dataset", args.dataset]) for scene, rdir in run_dirs]
    links = report_page.orpe_reports(orpe, runs)
    report_page.write(os.path.join(args.out, "report.html"), "Ablation", text, [pooled, per_class], links)


if __name__ == "__main__":
    main()
