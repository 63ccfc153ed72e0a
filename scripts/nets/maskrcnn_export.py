#!/usr/bin/python3
"""Exports a torchvision Mask R-CNN to TorchScript for orpe's `maskrcnn` segmentation back-end, and
generates the equivalence fixtures of its tests. Debian's python3-torch / python3-torchvision
(scripts/install-deps.sh); run with /usr/bin/python3 (a pyenv python has no torch).

  export    a trained torchvision Mask R-CNN (state_dict checkpoint) -> TorchScript file + class map
            /usr/bin/python3 scripts/nets/maskrcnn_export.py export --arch maskrcnn_resnet50_fpn \
                --checkpoint model.pth --classes 002_master_chef_can,003_cracker_box --out maskrcnn.pt
            writes maskrcnn.pt (with the metadata file orpe_maskrcnn.json inside: the class count) and
            maskrcnn.classes.txt (network label -> dataset class, one `label class` line each).
  fixtures  the tiny seeded model of the tests, its input and torchvision's outputs on it, and random
            inputs/outputs of torchvision::nms and torchvision::roi_align (tests/nets/data):
            /usr/bin/python3 scripts/nets/maskrcnn_export.py fixtures --out-dir tests/nets/data
  bench     times a TorchScript file in Python (the peer of bench/maskrcnn_speed.cpp;
            scripts/nets/maskrcnn_bench.sh runs both)

The C++ side (src/orpe/nets) registers its own torchvision::nms / torchvision::roi_align, so no
torchvision library is needed at run time. docs/NETWORKS.md.
"""
import argparse
import collections
import json
import os
import sys

import torch
import torchvision
from torch import nn
from torchvision.models.detection import MaskRCNN
from torchvision.models.detection.anchor_utils import AnchorGenerator
from torchvision.models.detection.faster_rcnn import FastRCNNPredictor, TwoMLPHead
from torchvision.models.detection.mask_rcnn import MaskRCNNHeads, MaskRCNNPredictor
from torchvision.ops import MultiScaleRoIAlign

METADATA = "orpe_maskrcnn.json"


def save_scripted(model, path, num_classes):
    """Scripts `model` (eval mode) and saves it with orpe's metadata file inside."""
    model.eval()
    scripted = torch.jit.script(model)
    meta = {"format": 1, "num_classes": num_classes, "torchvision": torchvision.__version__}
    torch.jit.save(scripted, path, _extra_files={METADATA: json.dumps(meta)})
    return scripted


def write_class_map(path, classes):
    with open(path, "w") as f:
        f.write("# network label -> dataset class (id or name); label 0 is the background\n")
        for label, name in enumerate(classes, start=1):
            f.write(f"{label} {name}\n")


def cmd_export(args):
    classes = [c for c in args.classes.split(",") if c]
    if not classes:
        sys.exit("export: --classes must name at least one dataset class")
    num_classes = len(classes) + 1  # + background
    if args.arch == "small":
        model = small_maskrcnn(num_classes, args.min_size, args.max_size)
    else:
        builder = getattr(torchvision.models.detection, args.arch)
        model = builder(weights=None, weights_backbone=None, num_classes=num_classes,
                        min_size=args.min_size, max_size=args.max_size)
    if args.checkpoint:
        state = torch.load(args.checkpoint, map_location="cpu")
        if isinstance(state, dict) and "model" in state:
            state = state["model"]  # torchvision references/detection checkpoints
        model.load_state_dict(state)
    else:
        print("export: no --checkpoint, exporting UNTRAINED weights", file=sys.stderr)
    save_scripted(model, args.out, num_classes)
    write_class_map(os.path.splitext(args.out)[0] + ".classes.txt", classes)
    print(f"wrote {args.out} ({num_classes} classes incl. background)")


class TinyBackbone(nn.Module):
    """Two feature levels (stride 4 and 8), 8 channels: the fixtures' stand-in for ResNet-FPN."""

    def __init__(self):
        super().__init__()
        self.level0 = nn.Sequential(nn.Conv2d(3, 8, 3, stride=2, padding=1), nn.ReLU(),
                                    nn.Conv2d(8, 8, 3, stride=2, padding=1), nn.ReLU())
        self.level1 = nn.Sequential(nn.Conv2d(8, 8, 3, stride=2, padding=1), nn.ReLU())
        self.out_channels = 8

    def forward(self, x):
        f0 = self.level0(x)
        return collections.OrderedDict([("0", f0), ("1", self.level1(f0))])


class SmallBackbone(nn.Module):
    """Three feature levels (stride 4, 8, 16), 64 channels, no normalisation: a backbone light enough to
    train from scratch on a CPU in minutes (scripts/nets/maskrcnn_train.py; `--arch small`)."""

    def __init__(self, c=64):
        super().__init__()
        def conv(i, o, s=1):
            return [nn.Conv2d(i, o, 3, stride=s, padding=1), nn.ReLU()]
        self.level0 = nn.Sequential(*conv(3, 16, 2), *conv(16, 32, 2), *conv(32, c))
        self.level1 = nn.Sequential(*conv(c, c, 2), *conv(c, c))
        self.level2 = nn.Sequential(*conv(c, c, 2), *conv(c, c))
        self.out_channels = c

    def forward(self, x):
        f0 = self.level0(x)
        f1 = self.level1(f0)
        return collections.OrderedDict([("0", f0), ("1", f1), ("2", self.level2(f1))])


def small_maskrcnn(num_classes, min_size=120, max_size=160):
    """torchvision's MaskRCNN on SmallBackbone, anchors 16-64 px, few proposals: `orpe synth` images resized
    to 160 x 120 inside the network (its transform; masks are pasted back at full size)."""
    anchors = AnchorGenerator(sizes=((16,), (32,), (64,)), aspect_ratios=((0.5, 1.0, 2.0),) * 3)
    box_pool = MultiScaleRoIAlign(["0", "1", "2"], 7, 2)
    mask_pool = MultiScaleRoIAlign(["0", "1", "2"], 14, 2)
    return MaskRCNN(SmallBackbone(), num_classes=None, min_size=min_size, max_size=max_size,
                    rpn_anchor_generator=anchors, rpn_pre_nms_top_n_train=500, rpn_post_nms_top_n_train=200,
                    rpn_pre_nms_top_n_test=300, rpn_post_nms_top_n_test=100, rpn_batch_size_per_image=64,
                    box_batch_size_per_image=64, box_roi_pool=box_pool,
                    box_head=TwoMLPHead(64 * 7 * 7, 256), box_predictor=FastRCNNPredictor(256, num_classes),
                    box_detections_per_img=20, mask_roi_pool=mask_pool,
                    mask_head=MaskRCNNHeads(64, (64, 64), 1), mask_predictor=MaskRCNNPredictor(64, 64, num_classes))


def tiny_maskrcnn(num_classes, seed):
    torch.manual_seed(seed)
    anchors = AnchorGenerator(sizes=((12,), (24,)), aspect_ratios=((0.5, 1.0, 2.0),) * 2)
    box_pool = MultiScaleRoIAlign(["0", "1"], 7, 2, canonical_scale=20, canonical_level=3)
    mask_pool = MultiScaleRoIAlign(["0", "1"], 14, 2, canonical_scale=20, canonical_level=3)
    model = MaskRCNN(TinyBackbone(), num_classes=None, min_size=64, max_size=96,
                     rpn_anchor_generator=anchors, rpn_pre_nms_top_n_test=200,
                     rpn_post_nms_top_n_test=60, box_roi_pool=box_pool,
                     box_head=TwoMLPHead(8 * 7 * 7, 32), box_predictor=FastRCNNPredictor(32, num_classes),
                     box_score_thresh=0.05, box_detections_per_img=6, mask_roi_pool=mask_pool,
                     mask_head=MaskRCNNHeads(8, (8, 8), 1), mask_predictor=MaskRCNNPredictor(8, 8, num_classes))
    with torch.no_grad():  # seeded weights large enough that scores and boxes are well separated
        for name, p in model.named_parameters():
            if p.dim() > 1:
                nn.init.kaiming_normal_(p)
            else:
                p.normal_(0.0, 0.5)
    return model.eval()


def tiny_image(seed, width=64, height=48):
    g = torch.Generator().manual_seed(seed)
    img = 0.2 + 0.1 * torch.rand(3, height, width, generator=g)
    for _ in range(4):  # a few coloured rectangles
        x0, y0 = int(torch.randint(0, width - 16, (1,), generator=g)), int(torch.randint(0, height - 12, (1,), generator=g))
        w, h = int(torch.randint(8, 24, (1,), generator=g)), int(torch.randint(6, 18, (1,), generator=g))
        img[:, y0:y0 + h, x0:x0 + w] = torch.rand(3, 1, 1, generator=g)
    return (img * 255).round().to(torch.uint8)  # the C++ side gets 8-bit RGB


def tensors_module(tensors):
    """A scripted module holding `tensors` as buffers: LibTorch reads it with torch::jit::load."""
    m = nn.Module()
    for k, v in tensors.items():
        m.register_buffer(k, v.contiguous())
    return torch.jit.script(m)


def check_separated(scores, what, min_gap=1e-3):
    s = scores.sort(descending=True).values
    if len(s) > 1 and float((s[:-1] - s[1:]).min()) < min_gap:
        sys.exit(f"fixtures: {what} scores closer than {min_gap}: change the seed")


def ops_fixtures(seed):
    g = torch.Generator().manual_seed(seed)
    t = {}
    # nms: clustered boxes so that suppression happens, distinct scores.
    centres = torch.rand(12, 2, generator=g) * 100
    c = centres[torch.randint(0, 12, (300,), generator=g)] + torch.randn(300, 2, generator=g) * 4
    wh = 5 + torch.rand(300, 2, generator=g) * 20
    t["nms_boxes"] = torch.cat([c - wh / 2, c + wh / 2], 1)
    t["nms_scores"] = torch.randperm(300, generator=g).float() / 300 + 0.001 * torch.rand(300, generator=g)
    for thr in (0.3, 0.5, 0.7):
        t[f"nms_keep_{int(thr * 10)}"] = torchvision.ops.nms(t["nms_boxes"], t["nms_scores"], thr)
    # roi_align: 2 images x 3 channels x 13 x 17, boxes partly outside, tiny and large.
    t["roi_input"] = torch.randn(2, 3, 13, 17, generator=g)
    n = 24
    xy = torch.rand(n, 2, generator=g) * torch.tensor([80.0, 60.0]) - 8
    wh = torch.rand(n, 2, generator=g) * 50 + 0.2
    batch = torch.randint(0, 2, (n, 1), generator=g).float()
    t["roi_rois"] = torch.cat([batch, xy, xy + wh], 1)
    cases = [(0.25, 5, 4, 2, False), (0.25, 7, 7, -1, False), (0.125, 3, 6, 0, True), (0.25, 9, 9, 2, True)]
    for i, (scale, ph, pw, sr, aligned) in enumerate(cases):
        t[f"roi_params_{i}"] = torch.tensor([scale, ph, pw, sr, float(aligned)], dtype=torch.float64)
        t[f"roi_out_{i}"] = torch.ops.torchvision.roi_align(t["roi_input"], t["roi_rois"], scale, ph, pw, sr, aligned)
    return t


def cmd_fixtures(args):
    os.makedirs(args.out_dir, exist_ok=True)
    torch.set_num_threads(1)
    num_classes = 4
    model = tiny_maskrcnn(num_classes, args.seed)
    path = os.path.join(args.out_dir, "maskrcnn_tiny.pt")
    scripted = save_scripted(model, path, num_classes)
    write_class_map(os.path.join(args.out_dir, "maskrcnn_tiny.classes.txt"), ["1", "2", "3"])
    image = tiny_image(args.seed)
    x = image.float() / 255
    with torch.no_grad():
        ref = model([x])[0]  # the eager torchvision model is the reference
        _, scripted_out = scripted([x])
    if len(ref["scores"]) < 3:
        sys.exit("fixtures: fewer than 3 detections: change the seed")
    check_separated(ref["scores"], "detection")
    for k in ref:
        if not torch.allclose(ref[k].float(), scripted_out[0][k].float(), atol=1e-6):
            sys.exit(f"fixtures: scripted and eager torchvision differ on {k}")
    expected = {"image": image, "boxes": ref["boxes"], "scores": ref["scores"],
                "labels": ref["labels"], "masks": ref["masks"][:, 0]}
    tensors_module(expected).save(os.path.join(args.out_dir, "maskrcnn_tiny_expected.pt"))
    tensors_module(ops_fixtures(args.seed)).save(os.path.join(args.out_dir, "torchvision_ops.pt"))
    print(f"fixtures: {len(ref['scores'])} detections, scores {ref['scores'].tolist()}")


def cmd_bench(args):
    """The Python peer of bench/maskrcnn_speed.cpp: the same TorchScript file and image, torchvision's
    own operators, same thread count."""
    import time
    from torchvision.io import read_image
    if args.threads > 0:
        torch.set_num_threads(args.threads)
    model = torch.jit.load(args.model)
    x = read_image(args.image).float() / 255
    with torch.inference_mode():
        model([x])  # warm-up
        t0, c0 = time.perf_counter(), time.process_time()
        for _ in range(args.repeats):
            _, out = model([x])
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    print(f"python torchvision: {x.shape[2]}x{x.shape[1]}, {args.repeats} calls: wall "
          f"{1e3 * wall / args.repeats:.0f} ms/call, cpu {1e3 * cpu / args.repeats:.0f} ms/call, "
          f"{len(out[0]['scores'])} detections")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export", help="TorchScript file + class map from a torchvision checkpoint")
    e.add_argument("--arch", default="maskrcnn_resnet50_fpn",
                   help="torchvision.models.detection builder (maskrcnn_resnet50_fpn, maskrcnn_resnet50_fpn_v2), "
                        "or small (SmallBackbone: scripts/nets/maskrcnn_train.py)")
    e.add_argument("--checkpoint", default="", help="state_dict (.pth) of that builder with these classes")
    e.add_argument("--classes", required=True, help="comma-separated dataset classes of labels 1..N (ids or names)")
    e.add_argument("--min-size", type=int, default=480, help="network input: shorter side (px)")
    e.add_argument("--max-size", type=int, default=640, help="network input: longer side at most (px)")
    e.add_argument("--out", required=True)
    e.set_defaults(func=cmd_export)
    f = sub.add_parser("fixtures", help="the tests' tiny model, input and torchvision outputs")
    f.add_argument("--out-dir", default="tests/nets/data")
    f.add_argument("--seed", type=int, default=5)
    f.set_defaults(func=cmd_fixtures)
    b = sub.add_parser("bench", help="time a TorchScript file in Python (bench/maskrcnn_speed.cpp's peer)")
    b.add_argument("--model", required=True)
    b.add_argument("--image", required=True)
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--threads", type=int, default=0)
    b.set_defaults(func=cmd_bench)
    args = p.parse_args()
    args.func(args)


if __name__ == "__main__":
    main()
