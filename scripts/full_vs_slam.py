#!/usr/bin/env python3
"""Speed of the full pipeline against SLAM alone, on the same frames in the same run (issue #15).

For each scene, runs `orpe run --mode slam` and `orpe run --mode full` back to back (alternating, ROUNDS
times), reads their summary.json, and prints the time per frame of each stage and the ratio full / slam
(the figure that survives the load of a shared machine; also within the full run, all stages over its own
SLAM stage, which is immune to the load changing between the two runs). Processing time = timing_ms.per_frame.pipeline
(every stage; no image decoding, no output writing); wall = the whole command; cpu = the whole command's CPU
time over all its threads (user + system), the figure least sensitive to other processes.

  python3 scripts/full_vs_slam.py --dataset ../shared/data/ycbv --scenes 0000,0001,0002 --out /tmp/fvs \\
      [--set section.key=value ...] [--rounds 1]

Python 3 standard library only. Exit status 1 when a run fails.
"""
import argparse
import json
import os
import resource
import subprocess
import sys

# model_loading: object models loaded on their class's first estimate (inside pipeline, in no stage).
STAGES = ["read", "slam", "semantic", "render_views", "single_view", "ekf", "model_loading", "pipeline"]


def run(orpe, dataset, scene, mode, out, sets):
    cmd = [orpe, "run", "--mode", mode, "--dataset", dataset, "--out", out,
           "--set", f"dataset.scene={scene}", "--set", "pipeline.progress_every_n_frames=0"]
    for s in sets:
        cmd += ["--set", s]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if res.returncode != 0:
        sys.stderr.write(res.stdout)
        sys.exit(f"command failed ({res.returncode}): {' '.join(cmd)}")
    with open(os.path.join(out, "summary.json")) as f:
        js = json.load(f)
    # CPU time of the whole command (all threads; survives the load better than wall time).
    js["cpu_ms"] = 1000.0 * (after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
    return js


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--scenes", default="0000,0001,0002")
    ap.add_argument("--out", required=True, help="scratch folder for the runs")
    ap.add_argument("--orpe", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin", "orpe"))
    ap.add_argument("--set", action="append", default=[], dest="sets", help="passed to both runs")
    ap.add_argument("--rounds", type=int, default=1, help="slam/full pairs per scene")
    args = ap.parse_args()
    orpe = os.path.abspath(args.orpe)

    totals = {m: {s: 0.0 for s in STAGES + ["wall", "cpu"]} for m in ("slam", "full")}
    frames = {"slam": 0, "full": 0}
    counts = {}
    for scene in [s for s in args.scenes.split(",") if s]:
        for r in range(args.rounds):
            for mode in ("slam", "full"):
                out = os.path.join(args.out, f"{scene}_{mode}_{r}")
                js = run(orpe, args.dataset, scene, mode, out, args.sets)
                n = js["frames"] if "frames" in js else js["counts"]["frames"]
                frames[mode] += n
                for s in STAGES:
                    totals[mode][s] += js["timing_ms"]["total"].get(s, 0.0)
                totals[mode]["wall"] += js["timing_ms"]["total"]["wall"]
                totals[mode]["cpu"] += js["cpu_ms"]
                if mode == "full":
                    for k, v in js.get("counts", {}).items():
                        if isinstance(v, (int, float)):
                            counts[k] = counts.get(k, 0) + v
    print("| stage (ms per frame) | slam | full |")
    print("| --- | ---: | ---: |")
    for s in STAGES + ["wall", "cpu"]:
        print(f"| {s} | {totals['slam'][s] / frames['slam']:.1f} | {totals['full'][s] / frames['full']:.1f} |")
    proc = {m: totals[m]["pipeline"] / frames[m] for m in totals}
    wall = {m: totals[m]["wall"] / frames[m] for m in totals}
    print(f"\nframes: {frames['full']} per mode; full: {1000 / proc['full']:.2f} frames/s processing, "
          f"{1000 / wall['full']:.2f} frames/s wall; slam: {1000 / proc['slam']:.2f} / {1000 / wall['slam']:.2f}")
    print(f"ratio full / slam: {proc['full'] / proc['slam']:.2f} (processing), "
          f"{wall['full'] / wall['slam']:.2f} (wall); within the full run, all stages / its slam "
          f"stage: {totals['full']['pipeline'] / totals['full']['slam']:.2f}; CPU time (whole command, all "
          f"threads) {totals['full']['cpu'] / totals['slam']['cpu']:.2f}")
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")
    keys = ["single_view_estimates", "single_view_from_prior", "single_view_skipped", "single_view_reused"]
    print("full run counts: " + ", ".join(f"{k} {counts[k]}" for k in keys if k in counts))


if __name__ == "__main__":
    main()
