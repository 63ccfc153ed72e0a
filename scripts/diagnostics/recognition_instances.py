#!/usr/bin/env python3
"""What each map instance of a `scripts/recognition_synth.sh` run lies on, and what became of each
target object: per seed, the final instances (instances.json) against the ground truth of the
synthetic scene (instance/ and distractor/ images of `orpe synth`), summed over the projected
instance images the run wrote (`--write-masks`, masks/NNNNNN_projected.png).

Per instance: its class, the share of its projected pixels on each target object, each distractor
and the background -- a spurious instance is a distractor, a fragment of a target (a second
instance on it) or background. Per target object: its instances, and per keyframe the class of the
detection covering most of it (masks/NNNNNN_input.png), so a miss, a wrong class or a merge with a
neighbour shows. Reads ground truth: a diagnosis of a finished run, never part of the back-end.

Needs numpy and PIL (Debian python3-numpy, python3-pil).
Usage: /usr/bin/python3 scripts/diagnostics/recognition_instances.py OUT [SEED...]
"""
import json
import os
import sys
from collections import Counter, defaultdict

import numpy as np
from PIL import Image


def load(path):
    return np.array(Image.open(path))


def seed_report(seed_dir):
    data, run = os.path.join(seed_dir, "data"), os.path.join(seed_dir, "run")
    info = json.load(open(os.path.join(data, "synth_info.json")))
    names = {o["obj_id"]: o["name"] for o in info["objects"]}
    target = {o["instance_label"]: o for o in info["objects"]}
    distractor = {d["label"]: d for d in info["distractors"]}
    inst = {i["id"]: i for i in json.load(open(os.path.join(run, "instances.json")))["instances"]}
    index = json.load(open(os.path.join(run, "masks", "index.json")))
    scene = os.path.join(data, "test", "000000")
    on = defaultdict(Counter)  # instance -> ("t", label) / ("d", label) / ("bg",) -> px
    target_px = Counter()
    per_frame = defaultdict(list)  # target label -> [class of the covering detection or '-']
    for fr in index["frames"]:
        f = fr["frame"]
        gt = load(os.path.join(scene, "instance", f"{f:06d}.png")).astype(np.int64)
        dpath = os.path.join(scene, "distractor", f"{f:06d}.png")
        dis = load(dpath).astype(np.int64) if os.path.exists(dpath) else np.zeros_like(gt)
        proj = load(os.path.join(run, "masks", fr["projected"]["file"])).astype(np.int64)
        det = load(os.path.join(run, "masks", fr["input"]["file"])).astype(np.int64)
        det_class = {int(k): v for k, v in fr["input"]["classes"].items()}
        for lab in np.unique(gt):
            if lab == 0:
                continue
            m = gt == lab
            target_px[lab] += int(m.sum())
            if m.sum() < 100:
                per_frame[lab].append("s")  # too small to be scored
                continue
            d = Counter(det[m].tolist())
            d.pop(0, None)
            best = d.most_common(1)
            if best and best[0][1] >= 0.3 * m.sum():
                per_frame[lab].append(str(det_class.get(best[0][0], "?")))
            else:
                per_frame[lab].append("-")
        for i in np.unique(proj):
            if i == 0:
                continue
            m = proj == i
            for lab, n in Counter(gt[m].tolist()).items():
                if lab:
                    on[int(i)][("t", lab)] += n
            bgm = m & (gt == 0)
            for lab, n in Counter(dis[bgm].tolist()).items():
                on[int(i)][("d", lab) if lab else ("bg",)] += n
    ev = json.load(open(os.path.join(seed_dir, "masks_eval.json")))["instances"]
    print(f"== {os.path.basename(seed_dir)}: {ev['objects_with_correct_class']} of "
          f"{ev['objects']} right, spurious {ev['spurious_instances']}")
    owner = {}
    for i, c in sorted(on.items()):
        tot = sum(c.values())
        k, n = c.most_common(1)[0]
        owner[i] = k
        parts = ", ".join(
            f"{lbl(k2, target, distractor)} {100 * n2 / tot:.0f}%" for k2, n2 in c.most_common(3))
        ii = inst.get(i, {})
        print(f"  instance {i}: class {ii.get('class_id')} {names.get(ii.get('class_id'), '?')}"
              f" det {ii.get('detections')}/{ii.get('detections', 0) + ii.get('missed_keyframes', 0)}"
              f" h {ii.get('height_above_support_m', 0):.3f}: {parts}")
    for lab, o in sorted(target.items()):
        mine = [i for i, k in owner.items() if k == ("t", lab)]
        classes = [inst[i]["class_id"] for i in mine if i in inst]
        ok = len(mine) == 1 and classes == [o["obj_id"]]
        print(f"  target {lab} {o['name']} (class {o['obj_id']}), {target_px[lab]} px: instances "
              f"{mine} classes {classes} {'ok' if ok else 'LOST'}; per keyframe "
              f"{' '.join(per_frame[lab])}")


def lbl(k, target, distractor):
    if k[0] == "t":
        return f"target {k[1]} ({target[k[1]]['name']})"
    if k[0] == "d":
        d = distractor[k[1]]
        return f"distractor {k[1]} ({d['name']} {' x '.join(f'{s:.2f}' for s in d['size_m'])})"
    return "background"


def main():
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    out = sys.argv[1]
    seeds = sys.argv[2:] or sorted(
        d[4:] for d in os.listdir(out) if d.startswith("seed") and os.path.isdir(os.path.join(out, d)))
    for s in seeds:
        seed_report(os.path.join(out, f"seed{s}"))


if __name__ == "__main__":
    main()
