#!/usr/bin/python3
"""Trains a small torchvision Mask R-CNN (maskrcnn_export.py's `small`: a 3-level 64-channel backbone, no
pretrained weights) on `orpe synth` scenes for orpe's `segmentation.backend=maskrcnn`, in minutes on a CPU.
Debian's python3-torch / python3-torchvision; run with /usr/bin/python3. docs/NETWORKS.md, docs/RESULTS.md.

  /usr/bin/python3 scripts/nets/maskrcnn_train.py --train DIR1,DIR2,... --out PREFIX --minutes 10
  -> PREFIX.pth (state_dict) and PREFIX_untrained.pth (the initial weights), PREFIX_loss.txt; then
  /usr/bin/python3 scripts/nets/maskrcnn_export.py export --arch small --min-size 120 --max-size 160 \\
      --checkpoint PREFIX.pth --classes obj_000001,obj_000002,obj_000003 --out PREFIX.pt

Labels 1..N are the datasets' obj_ids in increasing order (the --classes order of the export).
"""
import argparse
import glob
import json
import os
import sys
import time

import numpy as np
import torch
from PIL import Image

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from maskrcnn_export import small_maskrcnn  # noqa: E402


def load_scene(root, stride, min_px):
    scene = sorted(glob.glob(os.path.join(root, "test", "*")))[0]
    gt = json.load(open(os.path.join(scene, "scene_gt.json")))
    info = json.load(open(os.path.join(scene, "scene_gt_info.json")))
    items = []
    for im in sorted(gt, key=int)[::stride]:
        rgb = np.array(Image.open(os.path.join(scene, "rgb", f"{int(im):06d}.png")).convert("RGB"))
        masks, labels = [], []
        for k, (g, inf) in enumerate(zip(gt[im], info[im])):
            if inf["px_count_visib"] < min_px:
                continue
            m = np.array(Image.open(os.path.join(scene, "mask_visib", f"{int(im):06d}_{k:06d}.png")).convert("L")) > 0
            masks.append(m)
            labels.append(g["obj_id"])
        items.append((rgb, masks, labels))
    return items


def target(masks, labels, label_of, h, w):
    boxes = []
    for m in masks:
        ys, xs = np.where(m)
        boxes.append([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1])
    return {"boxes": torch.tensor(boxes, dtype=torch.float32).view(-1, 4),
            "labels": torch.tensor([label_of[l] for l in labels], dtype=torch.int64),
            "masks": torch.from_numpy(np.array(masks, dtype=np.uint8).reshape(-1, h, w))}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--train", required=True, help="comma-separated `orpe synth` dataset folders")
    p.add_argument("--out", required=True, help="output prefix")
    p.add_argument("--minutes", type=float, default=10)
    p.add_argument("--stride", type=int, default=2, help="every n-th frame of each scene")
    p.add_argument("--min-px", type=int, default=50, help="instances with fewer visible pixels are ignored")
    p.add_argument("--min-size", type=int, default=120, help="network input shorter side (px)")
    p.add_argument("--max-size", type=int, default=160, help="network input longer side at most (px)")
    p.add_argument("--init", default="", help="start from this state_dict (continue a run)")
    p.add_argument("--lr", type=float, default=5e-4)
    p.add_argument("--batch", type=int, default=2)
    p.add_argument("--log-every", type=int, default=10)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--seed", type=int, default=1)
    args = p.parse_args()
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    rng = np.random.default_rng(args.seed)
    dirs = [d for d in args.train.split(",") if d]
    obj_ids = sorted(int(os.path.basename(f)[4:10]) for f in glob.glob(os.path.join(dirs[0], "models", "obj_*.ply")))
    label_of = {o: i + 1 for i, o in enumerate(obj_ids)}
    data = [it for d in dirs for it in load_scene(d, args.stride, args.min_px)]
    data = [it for it in data if it[1]]
    h, w = data[0][0].shape[:2]
    print(f"data: {len(data)} images from {len(dirs)} scenes ({w}x{h}), classes {obj_ids}", flush=True)
    model = small_maskrcnn(len(obj_ids) + 1, min_size=args.min_size, max_size=args.max_size)
    torch.save(model.state_dict(), args.out + "_untrained.pth")
    if args.init:  # continue a run
        model.load_state_dict(torch.load(args.init))
    model.train()
    opt = torch.optim.Adam(model.parameters(), lr=args.lr)
    log = open(args.out + "_loss.txt", "w")
    log.write(f"# --init {args.init}\n" if args.init else "")
    log.write("# step seconds total classifier box_reg mask objectness rpn_box_reg (running means)\n")
    step, start = 0, time.time()
    acc = np.zeros(6)
    while time.time() - start < 60 * args.minutes:
        batch = [data[i] for i in rng.choice(len(data), args.batch, replace=False)]
        images, targets = [], []
        for rgb, masks, labels in batch:
            if rng.random() < 0.5:  # horizontal flip
                rgb, masks = rgb[:, ::-1], [m[:, ::-1] for m in masks]
            images.append(torch.from_numpy(np.ascontiguousarray(rgb)).permute(2, 0, 1).float() / 255)
            targets.append(target([np.ascontiguousarray(m) for m in masks], labels, label_of, h, w))
        losses = model(images, targets)
        total = sum(losses.values())
        opt.zero_grad()
        total.backward()
        torch.nn.utils.clip_grad_norm_(model.parameters(), 10.0)
        opt.step()
        step += 1
        acc += [float(total)] + [float(losses[k]) for k in ("loss_classifier", "loss_box_reg", "loss_mask",
                                                             "loss_objectness", "loss_rpn_box_reg")]
        if step % args.log_every == 0:
            line = f"{step} {time.time() - start:.0f} " + " ".join(f"{v:.4f}" for v in acc / args.log_every)
            print("step " + line, flush=True)
            log.write(line + "\n")
            log.flush()
            acc[:] = 0
    torch.save(model.state_dict(), args.out + ".pth")
    print(f"trained {step} steps ({step * args.batch} images) in {time.time() - start:.0f} s -> {args.out}.pth")


if __name__ == "__main__":
    main()
