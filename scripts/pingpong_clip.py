#!/usr/bin/env python3
"""Makes a long YCB-Video-layout recording out of a short clip played forwards and backwards.

    scripts/pingpong_clip.py --dataset ../shared/data/ycbv --scenes 0000,0001,0002 --frames 200 --out /tmp/long

The shared YCB-Video clips have 20 frames; the real ones 1,000-2,000. What a pipeline stage costs
once per object (the EKF's start: several global pose searches per object, docs/PIPELINE.md) weighs
on a 20-frame clip as it does not on a recording. This writes OUT/data/SCENE/ for each scene, with `--frames` frames
(symbolic links to the clip's files: colour, depth, labels, meta with the ground-truth poses),
following the clip 1..N, N-1..1, 2..N, ...: the camera goes back and forth along the clip's own
path, so tracking, mapping and the objects are real data, only the path repeats. classes.txt,
keyframe.txt and models/ are linked from the dataset. docs/BENCHMARKS.md, "Session 26".
"""
import argparse
import os
import sys


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--dataset", required=True, help="YCB-Video root (data/, models/, classes.txt)")
    ap.add_argument("--scenes", required=True, help="clip folders under data/, e.g. 0000,0001")
    ap.add_argument("--frames", type=int, default=200, help="frames of the long recording")
    ap.add_argument("--out", required=True, help="new dataset root (must not exist)")
    args = ap.parse_args()
    root = os.path.abspath(args.dataset)
    if os.path.exists(args.out):
        sys.exit(f"{args.out}: exists; give a new folder")
    os.makedirs(os.path.join(args.out, "data"))
    for name in ("classes.txt", "keyframe.txt", "models"):
        if os.path.exists(os.path.join(root, name)):
            os.symlink(os.path.join(root, name), os.path.join(args.out, name))
    for scene in args.scenes.split(","):
        write_scene(os.path.join(root, "data", scene), os.path.join(args.out, "data", scene),
                    args.frames)


def write_scene(clip, out_clip, frames):
    stems = sorted({f.split("-")[0] for f in os.listdir(clip) if f.endswith("-color.png")})
    if len(stems) < 2:
        sys.exit(f"{clip}: fewer than 2 frames (*-color.png)")
    os.makedirs(out_clip)
    order, i, step = [], 0, 1
    while len(order) < frames:
        order.append(i)
        if not 0 <= i + step < len(stems):
            step = -step
        i += step
    files = os.listdir(clip)
    for k, src in enumerate(order):
        for f in files:
            if f.startswith(stems[src] + "-"):
                suffix = f[len(stems[src]):]
                os.symlink(os.path.join(clip, f), os.path.join(out_clip, f"{k + 1:06d}{suffix}"))
    print(f"{out_clip}: {len(order)} frames of {clip} ({len(stems)} frames), back and forth")


if __name__ == "__main__":
    main()
