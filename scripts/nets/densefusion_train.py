#!/usr/bin/python3
"""Trains DenseFusion's PoseNet (and optionally PoseRefineNet) on `orpe synth` scenes, for orpe's
`pose.backend=densefusion` (src/orpe/nets/densefusion_estimator.h). Debian's python3-torch; run with
/usr/bin/python3. The network is orpe's own PyTorch port of the C++ one (the reference's structure
and parameter names, re-derived; no reference code), trained with DenseFusion's loss (per-point
ADD-S weighted by the confidence, minus w log c). docs/NETWORKS.md, docs/RESULTS.md.

  selfcheck  this port against the committed equivalence fixture of the reference implementation
             (tests/nets/data/densefusion_small.pt): must agree to 1e-4.
  train      /usr/bin/python3 scripts/nets/densefusion_train.py train --train DIR1,DIR2,... \\
                 --test DIR --out PREFIX --minutes 30 --batch 16 --points 64 --max-views 0
             writes PREFIX_posenet.pt (orpe's tensor file: pose.densefusion_model), PREFIX_pose_model.pth
             (the reference's state_dict format), the loss log, and the ADD-S on the held-out scene of
             the untrained and the trained network.
  eval       ADD-S of a PoseNet file on a held-out scene.

Input contract (the C++ back-end's, tools/eval_ycb.py's): box of the visible mask snapped to
40, 80, ... px, mask pixels with depth, num_points chosen, crop RGB 0..255 ImageNet-normalised.
"""
import argparse
import collections
import glob
import json
import math
import os
import sys
import time

import numpy as np
import torch
import torch.nn.functional as F
from PIL import Image
from torch import nn

MEAN = np.array([0.485, 0.456, 0.406], np.float32)
STD = np.array([0.229, 0.224, 0.225], np.float32)
BORDERS = [-1, 40, 80, 120, 160, 200, 240, 280, 320, 360, 400, 440, 480, 520, 560, 600, 640, 680]


# ----------------------------------------------------------------------------- parameters
def posenet_parameters(num_obj):
    p = []
    cnn = "cnn.model.module."
    p.append((cnn + "feats.conv1.weight", (64, 3, 7, 7)))
    inp, planes = 64, [64, 128, 256, 512]
    for l in range(4):
        for b in range(2):
            pre = f"{cnn}feats.layer{l + 1}.{b}"
            p.append((pre + ".conv1.weight", (planes[l], inp if b == 0 else planes[l], 3, 3)))
            p.append((pre + ".conv2.weight", (planes[l], planes[l], 3, 3)))
            if b == 0 and inp != planes[l]:
                p.append((pre + ".downsample.0.weight", (planes[l], inp, 1, 1)))
        inp = planes[l]
    for s in range(4):
        p.append((f"{cnn}psp.stages.{s}.1.weight", (512, 512, 1, 1)))
    p += [(cnn + "psp.bottleneck.weight", (1024, 2560, 1, 1)), (cnn + "psp.bottleneck.bias", (1024,))]
    for u, (i, o) in enumerate(((1024, 256), (256, 64), (64, 64))):
        pre = f"{cnn}up_{u + 1}.conv."
        p += [(pre + "1.weight", (o, i, 3, 3)), (pre + "1.bias", (o,)), (pre + "2.weight", (1,))]
    p += [(cnn + "final.0.weight", (32, 64, 1, 1)), (cnn + "final.0.bias", (32,)),
          (cnn + "classifier.0.weight", (256, 256)), (cnn + "classifier.0.bias", (256,)),
          (cnn + "classifier.2.weight", (21, 256)), (cnn + "classifier.2.bias", (21,))]
    p += point_feature_parameters(256)
    head_in, head_out, last = [1408, 640, 256, 128], [640, 256, 128], [4 * num_obj, 3 * num_obj, num_obj]
    for layer in range(4):
        for h in range(3):
            out = head_out[layer] if layer < 3 else last[h]
            name = f"conv{layer + 1}_{'rtc'[h]}"
            p += [(name + ".weight", (out, head_in[layer], 1)), (name + ".bias", (out,))]
    return p


def point_feature_parameters(conv5_in):
    p = []
    for name, shape in (("conv1", (64, 3, 1)), ("conv2", (128, 64, 1)), ("e_conv1", (64, 32, 1)),
                        ("e_conv2", (128, 64, 1)), ("conv5", (512, conv5_in, 1)), ("conv6", (1024, 512, 1))):
        p += [(f"feat.{name}.weight", shape), (f"feat.{name}.bias", (shape[0],))]
    return p


def refiner_parameters(num_obj):
    p = point_feature_parameters(384)
    for name, shape in (("conv1_r", (512, 1024)), ("conv1_t", (512, 1024)), ("conv2_r", (128, 512)),
                        ("conv2_t", (128, 512)), ("conv3_r", (4 * num_obj, 128)), ("conv3_t", (3 * num_obj, 128))):
        p += [(name + ".weight", shape), (name + ".bias", (shape[0],))]
    return p


class Params(nn.Module):
    """Parameters by the reference's names ('.' stored as '__', the converted file's buffer names)."""

    def __init__(self, plist, init="default"):
        super().__init__()
        self.names = [n for n, _ in plist]
        self.p = nn.ParameterDict()
        for name, shape in plist:
            t = torch.empty(shape)
            fan_in = t.numel() // shape[0] if len(shape) > 1 else None
            with torch.no_grad():
                if name.endswith("2.weight") and len(shape) == 1:  # PReLU
                    t.fill_(0.25)
                elif fan_in:  # PyTorch's default conv / linear init
                    t.uniform_(-1 / math.sqrt(fan_in), 1 / math.sqrt(fan_in))
                else:  # biases: of the weight's fan-in, as PyTorch does
                    w = dict(plist)[name[:-4] + "weight"]
                    bound = 1 / math.sqrt(int(np.prod(w)) // w[0])
                    t.uniform_(-bound, bound)
            self.p[name.replace(".", "__")] = nn.Parameter(t)

    def __call__(self, name):
        return self.p[name.replace(".", "__")]

    def state(self):
        return collections.OrderedDict((n, self(n).detach().clone()) for n in self.names)


# ----------------------------------------------------------------------------- networks
def conv2d(x, w, b=None, stride=1, pad=0, dil=1):
    """F.conv2d, always on oneDNN: with one thread PyTorch 1.13 sends 1x1 convolutions to the BLAS,
    and Debian's default libblas is the reference (netlib) one, ~20x slower (measured: a 2560 -> 1024
    1x1 convolution on 10 x 10, 142 ms against 7.5 ms). Same arithmetic up to rounding (selfcheck)."""
    if x.dtype != torch.float32 or not torch.backends.mkldnn.is_available():
        return F.conv2d(x, w, b, stride, pad, dil)
    return torch.mkldnn_convolution(x, w, b, [pad, pad], [stride, stride], [dil, dil], 1)


def basic_block(P, x, pre, stride, dil, downsample):
    out = F.relu(conv2d(x, P(pre + ".conv1.weight"), None, stride, dil, dil))
    out = conv2d(out, P(pre + ".conv2.weight"), None, 1, dil, dil)
    res = conv2d(x, P(pre + ".downsample.0.weight"), None, stride) if downsample else x
    return F.relu(out + res)


def pspnet(P, img):
    f = "cnn.model.module.feats."
    x = F.max_pool2d(F.relu(conv2d(img, P(f + "conv1.weight"), None, 2, 3)), 3, 2, 1)
    for l, (stride, dil) in enumerate(zip((1, 2, 1, 1), (1, 1, 2, 4))):
        pre = f"{f}layer{l + 1}"
        x = basic_block(P, x, pre + ".0", stride, 1, l > 0)
        x = basic_block(P, x, pre + ".1", 1, dil, False)
    c = "cnn.model.module."
    h, w = x.shape[2], x.shape[3]
    priors = [F.interpolate(conv2d(F.adaptive_avg_pool2d(x, s), P(f"{c}psp.stages.{k}.1.weight")),
                            size=(h, w), mode="bilinear", align_corners=False)
              for k, s in enumerate((1, 2, 3, 6))]
    x = F.relu(conv2d(torch.cat(priors + [x], 1), P(c + "psp.bottleneck.weight"), P(c + "psp.bottleneck.bias")))
    for u in (1, 2, 3):
        pre = f"{c}up_{u}.conv."
        x = F.interpolate(x, size=(2 * x.shape[2], 2 * x.shape[3]), mode="bilinear", align_corners=True)
        x = F.prelu(conv2d(x, P(pre + "1.weight"), P(pre + "1.bias"), 1, 1), P(pre + "2.weight"))
    return F.log_softmax(conv2d(x, P(c + "final.0.weight"), P(c + "final.0.bias")), 1)


def c1d(P, name, x):
    """A 1x1 Conv1d on [B, C, n], as a 2-D convolution (oneDNN, see conv2d)."""
    return conv2d(x[..., None], P(name + ".weight")[..., None], P(name + ".bias"))[..., 0]


def point_features(P, x, emb, refiner):
    a, e = F.relu(c1d(P, "feat.conv1", x)), F.relu(c1d(P, "feat.e_conv1", emb))
    pf1 = torch.cat([a, e], 1)
    a, e = F.relu(c1d(P, "feat.conv2", a)), F.relu(c1d(P, "feat.e_conv2", e))
    pf2 = torch.cat([a, e], 1)
    g = F.relu(c1d(P, "feat.conv5", torch.cat([pf1, pf2], 1) if refiner else pf2))
    g = F.relu(c1d(P, "feat.conv6", g))
    return pf1, pf2, F.avg_pool1d(g, x.shape[2])


def posenet(P, num_obj, img, cloud, choose, obj):
    """img [1,3,h,w], cloud [1,n,3], choose [1,n] -> rotation [n,4], translation [n,3], confidence [n], emb."""
    n = cloud.shape[1]
    emb = torch.gather(pspnet(P, img).view(1, 32, -1), 2, choose.view(1, 1, n).repeat(1, 32, 1))
    return posenet_heads(P, num_obj, emb, cloud, obj) + (emb,)


def posenet_heads(P, num_obj, emb, cloud, obj):
    """PointNet, dense fusion and the heads on the gathered colour embedding emb [1,32,n]."""
    rot, trans, conf = posenet_heads_batch(P, num_obj, emb, cloud, torch.tensor([obj]))
    return rot[0], trans[0], conf[0]


def posenet_heads_batch(P, num_obj, emb, cloud, obj):
    """B views at once: emb [B,32,n], cloud [B,n,3], obj [B] (class indices) -> rotation [B,n,4],
    translation [B,n,3], confidence [B,n]. Every view is independent (the global feature pools over
    its own points)."""
    b, n = cloud.shape[0], cloud.shape[1]
    pf1, pf2, g = point_features(P, cloud.transpose(2, 1), emb, False)
    ap = torch.cat([pf1, pf2, g.repeat(1, 1, n)], 1)
    heads = []
    for hd, dims in enumerate((4, 3, 1)):
        y = ap
        for layer in range(1, 5):
            y = c1d(P, f"conv{layer}_{'rtc'[hd]}", y)
            if layer < 4:
                y = F.relu(y)
        if hd == 2:
            y = torch.sigmoid(y)
        heads.append(y.view(b, num_obj, dims, n)[torch.arange(b), obj].transpose(1, 2))
    return heads[0], heads[1], heads[2][..., 0]


def quat_to_mat(q):
    """q [..., 4] (w, x, y, z), normalised -> [..., 3, 3]."""
    q = q / q.norm(dim=-1, keepdim=True)
    w, x, y, z = q.unbind(-1)
    return torch.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
                        2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                        2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1).view(*q.shape[:-1], 3, 3)


# ----------------------------------------------------------------------------- data
def snap(size, image_size):
    for a, b in zip(BORDERS[:-1], BORDERS[1:]):
        if a < size < b:
            size = b
            break
    size = (size + 7) // 8 * 8
    return min(size, image_size // 8 * 8)


def place(lo, hi, size, limit):
    c = (lo + hi) // 2
    a, b = c - size // 2, c + size // 2
    if a < 0:
        a, b = 0, b - a
    if b > limit:
        a, b = a - (b - limit), limit
    return a, b


def crop_box(mask):
    rows, cols = np.where(mask.any(1))[0], np.where(mask.any(0))[0]
    rmin, rmax, cmin, cmax = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    r = place(rmin, rmax, snap(rmax - rmin, mask.shape[0]), mask.shape[0])
    c = place(cmin, cmax, snap(cmax - cmin, mask.shape[1]), mask.shape[1])
    return r[0], r[1], c[0], c[1]


def load_points(path):
    return np.loadtxt(path, dtype=np.float32)


def read_png(scene, folder, stem, mode=None):
    """A BOP image as an array (16-bit depth stays uint16)."""
    im = Image.open(os.path.join(scene, folder, stem + ".png"))
    return np.array(im.convert(mode) if mode else im)


def load_scene(root, min_visib=0.2, min_pixels=50):
    """Samples of one `orpe synth` dataset: per frame and visible object, its crop and ground truth."""
    scene = sorted(glob.glob(os.path.join(root, "test", "*")))[0]
    gt = json.load(open(os.path.join(scene, "scene_gt.json")))
    info = json.load(open(os.path.join(scene, "scene_gt_info.json")))
    cams = json.load(open(os.path.join(scene, "scene_camera.json")))
    samples = []
    for im in sorted(gt, key=int):
        rgb = read_png(scene, "rgb", f"{int(im):06d}", "RGB")
        raw = read_png(scene, "depth", f"{int(im):06d}")
        depth = raw.astype(np.float32) * float(cams[im]["depth_scale"]) / 1000.0  # metres
        K = np.array(cams[im]["cam_K"], np.float64).reshape(3, 3)
        for k, (g, inf) in enumerate(zip(gt[im], info[im])):
            if inf["visib_fract"] < min_visib:
                continue
            mask = read_png(scene, "mask_visib", f"{int(im):06d}_{k:06d}", "L") > 0
            valid = mask & (depth > 0)
            if valid.sum() < min_pixels:
                continue
            rmin, rmax, cmin, cmax = crop_box(mask)
            sub = valid[rmin:rmax, cmin:cmax].reshape(-1).nonzero()[0]
            crop = (rgb[rmin:rmax, cmin:cmax].astype(np.float32) - MEAN) / STD
            vs, us = np.divmod(sub, cmax - cmin)
            z = depth[rmin:rmax, cmin:cmax].reshape(-1)[sub]
            cloud = np.stack([(us + cmin - K[0, 2]) * z / K[0, 0], (vs + rmin - K[1, 2]) * z / K[1, 1], z], 1)
            samples.append({"obj_id": g["obj_id"], "crop": np.ascontiguousarray(crop.transpose(2, 0, 1)),
                            "choose_all": sub, "cloud_all": cloud.astype(np.float32),
                            "R": np.array(g["cam_R_m2c"], np.float32).reshape(3, 3),
                            "t": np.array(g["cam_t_m2c"], np.float32) / 1000.0, "frame": int(im)})
    return samples


def choose_points(s, n, rng):
    m = len(s["choose_all"])
    idx = np.sort(rng.choice(m, n, replace=False)) if m > n else np.arange(n) % m
    return s["choose_all"][idx], s["cloud_all"][idx]


def tensors(s, n, rng):
    choose, cloud = choose_points(s, n, rng)
    return (torch.from_numpy(s["crop"])[None], torch.from_numpy(cloud)[None],
            torch.from_numpy(choose.astype(np.int64))[None])


# ----------------------------------------------------------------------------- loss / metric
def adds(pred_pts, gt_pts):
    """Mean over predicted points of the distance to the nearest ground-truth point."""
    return torch.cdist(pred_pts, gt_pts).min(-1)[0].mean(-1)


def loss_fn(rot, trans, conf, cloud, model_pts, R, t, w=0.015):
    """DenseFusion's loss on B views: rot [B,n,4], trans [B,n,3] (offsets from the points), conf [B,n],
    cloud [B,n,3], model_pts [B,m,3], R [B,3,3], t [B,3] -> (mean of dis * c - w log c, dis [B,n]),
    dis = per point, the mean distance of its posed model points to the nearest ground-truth one (the
    nearest found without gradient, then the distance to it differentiated, as the reference's knn).
    Broadcast products, no matmul: Debian's reference BLAS made the batched matmuls the slowest part."""
    b, n, m = rot.shape[0], rot.shape[1], model_pts.shape[1]
    pred = (quat_to_mat(rot)[:, :, None] * model_pts[:, None, :, None, :]).sum(-1) + (cloud + trans)[:, :, None]
    target = (R[:, None] * model_pts[:, :, None, :]).sum(-1) + t[:, None]  # [B,m,3]
    with torch.no_grad():
        near = torch.cdist(pred.reshape(b, n * m, 3), target, compute_mode="donot_use_mm_for_euclid_dist").argmin(-1)
    matched = torch.gather(target, 1, near[..., None].expand(-1, -1, 3)).view(b, n, m, 3)
    dis = (pred - matched).norm(dim=-1).mean(-1)
    return (dis * conf - w * torch.log(conf)).mean(), dis


def best_pose(rot, trans, conf, cloud):
    """The reference evaluation's pick on one view (rot [n,4], cloud [n,3]): the most confident point."""
    i = int(torch.argmax(conf))
    return quat_to_mat(rot[i]), cloud[i] + trans[i]


def view_inputs(P, samples, n, seed=3):
    """Per held-out view, as the C++ back-end: n chosen pixels, their colour embedding [32,n] (one CNN
    pass over the crop) and cloud [n,3]."""
    rng = np.random.default_rng(seed)
    out = []
    with torch.no_grad():
        for s in samples:
            img, cloud, choose = tensors(s, n, rng)
            emb = torch.gather(pspnet(P, img).view(1, 32, -1), 2, choose.view(1, 1, n).repeat(1, 32, 1))
            out.append((emb[0], cloud[0]))
    return out


def evaluate(P, num_obj, samples, models, index_of, inputs, batch=16):
    """ADD-S over each model's points of the most confident point's pose (no refiner); `inputs` from
    view_inputs (the colour CNN must be the one they were computed with)."""
    out = {"adds": [], "centroid_adds": [], "per_obj": collections.defaultdict(list)}
    with torch.no_grad():
        for i in range(0, len(samples), batch):
            chunk, ins = samples[i:i + batch], inputs[i:i + batch]
            obj = torch.tensor([index_of[s["obj_id"]] for s in chunk])
            rot, trans, conf = posenet_heads_batch(P, num_obj, torch.stack([e for e, _ in ins]),
                                                   torch.stack([c for _, c in ins]), obj)
            for j, s in enumerate(chunk):
                cloud = ins[j][1]
                R, t = best_pose(rot[j], trans[j], conf[j], cloud)
                m = models[s["obj_id"]]
                gt = m @ torch.from_numpy(s["R"]).T + torch.from_numpy(s["t"])
                d = float(adds((m @ R.T + t)[None], gt[None]))
                c = float(adds((m + cloud.mean(0))[None], gt[None]))  # identity rotation at the centroid
                out["adds"].append(d)
                out["centroid_adds"].append(c)
                out["per_obj"][s["obj_id"]].append(d)
    return out


def summary(name, ev):
    a = np.array(ev["adds"])
    c = np.array(ev["centroid_adds"])
    per = ", ".join(f"obj {k}: {100 * np.mean(v):.1f} cm" for k, v in sorted(ev["per_obj"].items()))
    return (f"{name}: ADD-S mean {100 * a.mean():.2f} cm, median {100 * np.median(a):.2f} cm, "
            f"< 2 cm {100 * (a < 0.02).mean():.0f} %, < 1 cm {100 * (a < 0.01).mean():.0f} % ({per}); "
            f"[baseline: identity rotation at the cloud centroid: mean {100 * c.mean():.2f} cm, "
            f"< 2 cm {100 * (c < 0.02).mean():.0f} %] over {len(a)} views")


# ----------------------------------------------------------------------------- file formats
def save_orpe(state, path):
    m = nn.Module()
    for k, v in state.items():
        m.register_buffer(k.replace(".", "__"), v.float().contiguous())
    torch.jit.script(m).save(path)


def load_orpe(path, plist):
    m = torch.jit.load(path)
    buffers = dict(m.named_buffers())
    P = Params(plist)
    with torch.no_grad():
        for name, shape in plist:
            P(name).copy_(buffers[name.replace(".", "__")])
    return P


def dataset_models(root):
    models = {}
    for f in sorted(glob.glob(os.path.join(root, "models", "obj_*_points.xyz"))):
        models[int(os.path.basename(f)[4:10])] = torch.from_numpy(load_points(f))
    return models


# ----------------------------------------------------------------------------- commands
def cmd_selfcheck(args):
    fx = dict(torch.jit.load(args.fixture).named_buffers())
    n, num_obj, h, w, obj, seed = [int(v) for v in fx["meta"].tolist()]
    lines = [l.split() for l in open(os.path.splitext(args.fixture)[0] + ".names.txt") if l.strip()]
    plist = posenet_parameters(num_obj)
    assert [l[0] for l in lines[:len(plist)]] == [p[0] for p in plist], "parameter names differ"
    P = Params(plist)
    torch.manual_seed(seed)
    with torch.no_grad():
        for l in lines[:len(plist)]:  # the fixture's seeded weights, in the reference's order
            p = P(l[0])
            std = 1.0 / np.sqrt(p.numel() / p.shape[0]) if p.dim() > 1 else 0.1
            p.normal_(0.0, float(std))
        rot, trans, conf, emb = posenet(P, num_obj, fx["img"][None], fx["cloud"][None],
                                        fx["choose"].long()[None], obj)
    worst = 0.0
    for name, ours in (("rotation", rot), ("translation", trans), ("confidence", conf), ("embedding", emb[0])):
        ref = fx[name]
        err = float(((ours - ref).abs() / ref.abs().clamp(min=1)).max())
        worst = max(worst, err)
        print(f"selfcheck {name}: max relative error {err:.2e}")
    if worst > 1e-4:
        sys.exit("selfcheck FAILED: the training network is not the reference's")
    print("selfcheck ok: the training network equals the reference implementation on the fixture")
    # The batched heads (training, evaluation): 16 different views at once = each view alone.
    b = 16
    clouds = torch.stack([fx["cloud"] + 0.01 * k for k in range(b)])
    embs = torch.stack([emb[0].roll(k, 1) for k in range(b)])
    objs = torch.arange(b) % num_obj
    with torch.no_grad():
        batch = posenet_heads_batch(P, num_obj, embs, clouds, objs)
        err = max(float(((batch[h][k] - posenet_heads(P, num_obj, embs[k:k + 1], clouds[k:k + 1],
                                                       int(objs[k]))[h]).abs()).max())
                  for k in range(b) for h in range(3))
    print(f"selfcheck batched heads ({b} views): max difference to one view at a time {err:.2e}")
    if err > 1e-4:
        sys.exit("selfcheck FAILED: the batched heads mix views")


def frozen_embeddings(P, train, args, rng):
    """The colour CNN stays at its initialisation: per training view, the embedding of --pool of its
    valid pixels, computed once and cached in --cache. A cache of the first k views (the same scenes
    first, the same seed) is used for them and extended: the random draws are the same either way."""
    t0 = time.time()
    cache = torch.load(args.cache) if args.cache and os.path.exists(args.cache) else []
    if len(cache) > len(train):
        sys.exit(f"{args.cache}: {len(cache)} views cached, {len(train)} loaded (delete it)")
    with torch.no_grad():
        for i, s in enumerate(train):
            keep = rng.choice(len(s["choose_all"]), min(args.pool, len(s["choose_all"])), replace=False)
            if i < len(cache):
                s["pool_emb"], s["pool_cloud"] = cache[i]
            else:
                emb = pspnet(P, torch.from_numpy(s["crop"])[None]).view(32, -1)
                s["pool_emb"] = emb[:, torch.from_numpy(s["choose_all"][keep].astype(np.int64))].clone()
                s["pool_cloud"] = torch.from_numpy(s["cloud_all"][keep])
            del s["crop"]
    if args.cache and len(cache) < len(train):
        torch.save([(s["pool_emb"], s["pool_cloud"]) for s in train], args.cache)
    print(f"colour embeddings of {len(train)} views (frozen CNN): {time.time() - t0:.0f} s", flush=True)


def training_batch(P, num_obj, train, index_of, args, rng):
    """--batch random views, --points random points of each -> the heads' outputs, the (shifted)
    clouds, the views and their shifts."""
    views = [train[i] for i in rng.choice(len(train), args.batch, replace=len(train) < args.batch)]
    embs, clouds = [], []
    for s in views:
        if args.train_cnn:
            img, cloud, choose = tensors(s, args.points, rng)
            emb = torch.gather(pspnet(P, img).view(1, 32, -1), 2, choose.view(1, 1, -1).repeat(1, 32, 1))[0]
            cloud = cloud[0]
        else:
            m = s["pool_cloud"].shape[0]
            idx = torch.from_numpy(rng.choice(m, args.points, replace=False) if m > args.points
                                   else np.arange(args.points) % m)
            emb, cloud = s["pool_emb"][:, idx], s["pool_cloud"][idx]
        embs.append(emb)
        clouds.append(cloud)
    # The reference's training noise (datasets/ycb/dataset.py, add_noise): one random translation of the
    # cloud and of the target pose per view, here uniform in +-shift_m per axis.
    shifts = torch.from_numpy(rng.uniform(-args.shift_m, args.shift_m, (len(views), 3)).astype(np.float32))
    clouds = torch.stack(clouds) + shifts[:, None]
    obj = torch.tensor([index_of[s["obj_id"]] for s in views])
    return posenet_heads_batch(P, num_obj, torch.stack(embs), clouds, obj), clouds, views, shifts


def learning_rate(args, step, elapsed_s=0.0):
    """Linear warm-up over --warmup steps, then a cosine from --lr down to --lr * --lr-final; the
    cosine's progress is that of the steps or of the wall-time budget --minutes, whichever is further
    (on a shared machine the budget, not the step count, often ends the run)."""
    if step < args.warmup:
        return args.lr * (step + 1) / args.warmup
    x = min(1.0, max((step - args.warmup) / max(1, args.steps - args.warmup), elapsed_s / (60 * args.minutes)))
    return args.lr * (args.lr_final + (1 - args.lr_final) * 0.5 * (1 + math.cos(math.pi * x)))


def cmd_train(args):
    torch.manual_seed(args.seed)
    torch.set_num_threads(args.threads)
    if args.batch < 16 and args.threads == 1:
        print("warning: --batch < 16 with one thread: the backward pass runs on the slow BLAS", flush=True)
    rng = np.random.default_rng(args.seed)
    train_dirs = [d for d in args.train.split(",") if d]
    models = dataset_models(train_dirs[0])
    index_of = {obj_id: i for i, obj_id in enumerate(sorted(models))}
    num_obj = len(models)
    t0 = time.time()
    train = [s for d in train_dirs for s in load_scene(d)]
    if args.max_views and len(train) > args.max_views:
        train = [train[i] for i in sorted(rng.choice(len(train), args.max_views, replace=False))]
    test = load_scene(args.test)[:: args.test_stride]
    print(f"data: {len(train)} training views from {len(train_dirs)} scenes, {len(test)} held-out views "
          f"({time.time() - t0:.1f} s); {num_obj} objects", flush=True)
    loss_models = torch.stack([v[torch.from_numpy(rng.choice(len(v), args.loss_model_points, replace=False))]
                               for _, v in sorted(models.items())])
    P = Params(posenet_parameters(num_obj))
    save_orpe(P.state(), args.out + "_untrained_posenet.pt")
    test_in = view_inputs(P, test, args.eval_points)
    ev0 = evaluate(P, num_obj, test, models, index_of, test_in)
    print(summary("untrained", ev0), flush=True)
    if args.init:  # continue a run: its weights (the frozen CNN is the same initialisation)
        P = load_orpe(args.init, posenet_parameters(num_obj))
        print(summary("start (" + args.init + ")", evaluate(P, num_obj, test, models, index_of, test_in)),
              flush=True)
    if not args.train_cnn:
        for name, p in P.p.items():
            p.requires_grad_(not name.startswith("cnn__"))
        frozen_embeddings(P, train, args, rng)
    opt = torch.optim.Adam([p for p in P.parameters() if p.requires_grad], lr=args.lr)
    log = open(args.out + "_loss.txt", "a" if args.init else "w")
    if not args.init:
        log.write("# step wall_s cpu_s lr loss mean_point_adds_m best_point_adds_m heldout_adds_m "
                  "(running means over the last --log-every steps; held-out: mean ADD-S, --eval-every)\n")
    start, cpu0, acc = time.time(), time.process_time(), np.zeros(3)
    step = 0
    while step < args.steps and time.time() - start < 60 * args.minutes:
        for g in opt.param_groups:
            g["lr"] = lr = learning_rate(args, step, time.time() - start)
        (rot, trans, conf), clouds, views, shifts = training_batch(P, num_obj, train, index_of, args, rng)
        obj = torch.tensor([index_of[s["obj_id"]] for s in views])
        loss, dis = loss_fn(rot, trans, conf, clouds, loss_models[obj],
                            torch.from_numpy(np.stack([s["R"] for s in views])),
                            torch.from_numpy(np.stack([s["t"] for s in views])) + shifts)
        opt.zero_grad()
        loss.backward()
        opt.step()
        step += 1
        best = dis.detach().gather(1, conf.detach().argmax(1, keepdim=True))
        acc += [float(loss), float(dis.mean()), float(best.mean())]
        if step % args.log_every == 0 or step == args.steps:
            held = ""
            if args.eval_every and (step % args.eval_every == 0 or step == args.steps):
                if args.train_cnn:
                    test_in = view_inputs(P, test, args.eval_points)
                held = f" {np.mean(evaluate(P, num_obj, test, models, index_of, test_in)['adds']):.5f}"
                save_orpe(P.state(), args.out + "_posenet.pt")
            k = step % args.log_every or args.log_every
            line = (f"{step} {time.time() - start:.0f} {time.process_time() - cpu0:.0f} "
                    f"{lr:.2e} " + " ".join(f"{v / k:.5f}" for v in acc) + held)
            print("step " + line, flush=True)
            log.write(line + "\n")
            log.flush()
            acc[:] = 0
    trained = P.state()
    save_orpe(trained, args.out + "_posenet.pt")
    torch.save(trained, args.out + "_pose_model.pth")
    if args.train_cnn:
        test_in = view_inputs(P, test, args.eval_points)
    ev1 = evaluate(P, num_obj, test, models, index_of, test_in)
    print(f"trained {step} steps of {args.batch} views x {args.points} points in {time.time() - start:.0f} s "
          f"wall, {time.process_time() - cpu0:.0f} s CPU")
    print(summary("untrained", ev0))
    print(summary("trained", ev1))


def cmd_eval(args):
    models = dataset_models(args.test)
    num_obj = len(models)
    index_of = {obj_id: i for i, obj_id in enumerate(sorted(models))}
    P = load_orpe(args.model, posenet_parameters(num_obj))
    test = load_scene(args.test)[:: args.test_stride]
    print(summary(args.model, evaluate(P, num_obj, test, models, index_of, view_inputs(P, test, args.points))))


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    c = sub.add_parser("selfcheck")
    c.add_argument("--fixture", default="tests/nets/data/densefusion_small.pt")
    c.set_defaults(func=cmd_selfcheck)
    t = sub.add_parser("train")
    t.add_argument("--train", required=True, help="comma-separated `orpe synth` dataset folders")
    t.add_argument("--test", required=True, help="held-out `orpe synth` dataset (same --models)")
    t.add_argument("--out", required=True, help="output prefix")
    t.add_argument("--minutes", type=float, default=60, help="stop earlier when this wall time is spent")
    t.add_argument("--points", type=int, default=100, help="chosen points per view (pose.densefusion_num_points)")
    t.add_argument("--train-cnn", action="store_true",
                   help="train the colour CNN too (a GPU's job); default: frozen at its initialisation")
    t.add_argument("--init", default="", help="start from this PoseNet file (continue a run)")
    t.add_argument("--cache", default="", help="frozen CNN: file of the views' embeddings (written once, reused)")
    t.add_argument("--pool", type=int, default=400, help="frozen CNN: pixels kept per view to choose from")
    t.add_argument("--max-views", type=int, default=300, help="training views used (0 = all)")
    t.add_argument("--eval-points", type=int, default=100, help="chosen points per held-out view")
    t.add_argument("--loss-model-points", type=int, default=100)
    t.add_argument("--steps", type=int, default=2000, help="optimiser steps (the schedule's length)")
    t.add_argument("--batch", type=int, default=16, help="views per optimiser step; >= 16 keeps the "
                   "backward pass of the 1x1 convolutions on oneDNN (below, PyTorch 1.13 with one thread "
                   "runs it on the BLAS: 2.5 s against 0.2 s per step measured)")
    t.add_argument("--shift-m", type=float, default=0.05,
                   help="training noise: random translation of each view's cloud and target, +- m per axis")
    t.add_argument("--lr", type=float, default=1e-3, help="Adam's peak learning rate")
    t.add_argument("--lr-final", type=float, default=0.01, help="final learning rate / --lr (cosine)")
    t.add_argument("--warmup", type=int, default=50, help="steps of linear warm-up")
    t.add_argument("--log-every", type=int, default=25)
    t.add_argument("--eval-every", type=int, default=250, help="held-out ADD-S every N steps (0 = end only)")
    t.add_argument("--test-stride", type=int, default=2)
    t.add_argument("--threads", type=int, default=1)
    t.add_argument("--seed", type=int, default=1)
    t.set_defaults(func=cmd_train)
    e = sub.add_parser("eval")
    e.add_argument("--model", required=True)
    e.add_argument("--test", required=True)
    e.add_argument("--points", type=int, default=100)
    e.add_argument("--test-stride", type=int, default=2)
    e.set_defaults(func=cmd_eval)
    args = p.parse_args()
    args.func(args)


if __name__ == "__main__":
    main()
