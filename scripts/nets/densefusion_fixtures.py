#!/usr/bin/python3
"""DenseFusion equivalence fixtures and checkpoint conversion for orpe (src/orpe/nets/densefusion.h).
Debian's python3-torch; run with /usr/bin/python3.

  fixtures  runs the REFERENCE implementation (lib/network.py of a fetched copy of
            github.com/j96w/DenseFusion, given by --reference; never copied into orpe) with seeded
            weights on a small random input and writes what orpe's C++ network must reproduce:
            /usr/bin/python3 scripts/nets/densefusion_fixtures.py fixtures --reference DIR \\
                --out tests/nets/data/densefusion_small.pt
            Weights are not stored (21 M parameters): both sides draw them from LibTorch's generator,
            torch.manual_seed(seed) then, in state_dict order, normal_(0, 1/sqrt(fan_in)) (0.1 for 1-D
            tensors); the file keeps the parameter names and shapes, so the C++ side checks both.
  convert   an official checkpoint (pose_model_*.pth or pose_refine_model_*.pth, a state_dict) -> a file
            of its tensors by name that orpe loads (DenseFusionSpec::posenet_path / refiner_path):
            /usr/bin/python3 scripts/nets/densefusion_fixtures.py convert pose_model.pth --out posenet.pt
"""
import argparse
import copy
import os
import sys

import numpy as np
import torch
from torch import nn


def tensors_module(tensors):
    m = nn.Module()
    for k, v in tensors.items():
        m.register_buffer(k.replace(".", "__"), v.contiguous())
    return torch.jit.script(m)


def seeded(model, seed):
    torch.manual_seed(seed)
    with torch.no_grad():
        for name, p in model.state_dict().items():
            std = 1.0 / np.sqrt(p.numel() / p.shape[0]) if p.dim() > 1 else 0.1
            p.normal_(0.0, float(std))
    return model.eval()


def cmd_fixtures(args):
    sys.path.insert(0, args.reference)
    from lib.network import PoseNet, PoseRefineNet  # the reference code, read at generation time
    from lib.transformations import quaternion_matrix, quaternion_from_matrix
    torch.set_num_threads(1)
    n, num_obj, h, w, obj = args.points, 3, 32, 40, 1
    est = seeded(PoseNet(num_points=n, num_obj=num_obj), args.seed)
    ref = seeded(PoseRefineNet(num_points=n, num_obj=num_obj), args.seed + 1)
    g = torch.Generator().manual_seed(args.seed + 2)
    img = torch.randn(1, 3, h, w, generator=g)
    cloud = torch.randn(1, n, 3, generator=g) * 0.05 + torch.tensor([0.02, -0.01, 0.8])
    choose = torch.randperm(h * w, generator=g)[:n].view(1, 1, n)
    index = torch.LongTensor([obj])
    with torch.no_grad():
        pred_r, pred_t, pred_c, emb = est(img, cloud, choose, index)
        # tools/eval_ycb.py's selection and refinement loop, as the reference evaluates
        r = pred_r / torch.norm(pred_r, dim=2).view(1, n, 1)
        which = torch.max(pred_c.view(1, n), 1)[1]
        my_r = r[0][which[0]].view(-1).numpy()
        my_t = (cloud.view(n, 1, 3) + pred_t.view(n, 1, 3))[which[0]].view(-1).numpy()
        before = np.append(my_r, my_t)
        for _ in range(2):
            T = torch.from_numpy(my_t.astype(np.float32)).view(1, 3).repeat(n, 1).view(1, n, 3)
            my_mat = quaternion_matrix(my_r)
            R = torch.from_numpy(my_mat[:3, :3].astype(np.float32)).view(1, 3, 3)
            my_mat[0:3, 3] = my_t
            r2, t2 = ref(torch.bmm(cloud - T, R).contiguous(), emb, index)
            r2 = r2.view(1, 1, -1)
            r2 = r2 / torch.norm(r2, dim=2).view(1, 1, 1)
            m2 = quaternion_matrix(r2.view(-1).numpy())
            m2[0:3, 3] = t2.view(-1).numpy()
            mf = np.dot(my_mat, m2)
            rf = copy.deepcopy(mf)
            rf[0:3, 3] = 0
            my_r = quaternion_from_matrix(rf, True)
            my_t = np.array([mf[0][3], mf[1][3], mf[2][3]])
    final_R = quaternion_matrix(my_r)[:3, :3]
    names = [f"{k} {' '.join(map(str, v.shape))}" for k, v in list(est.state_dict().items()) +
             list(ref.state_dict().items())]
    out = {"img": img[0], "cloud": cloud[0], "choose": choose.view(-1).float(),
           "meta": torch.tensor([n, num_obj, h, w, obj, args.seed], dtype=torch.float32),
           "rotation": pred_r[0], "translation": pred_t[0], "confidence": pred_c[0, :, 0],
           "embedding": emb[0], "before_refinement": torch.from_numpy(before).float(),
           "final_R": torch.from_numpy(final_R).double(), "final_t": torch.from_numpy(my_t).double()}
    tensors_module(out).save(args.out)
    with open(os.path.splitext(args.out)[0] + ".names.txt", "w") as f:
        f.write("\n".join(names) + "\n")
    print(f"fixtures: {len(names)} tensors ({sum(1 for _ in est.state_dict())} PoseNet), best point "
          f"{int(which[0])}, final t {my_t}")


def cmd_seeded_checkpoints(args):
    """Checkpoints in the official format (state_dicts, torch.save) holding the fixtures' seeded weights,
    built from the names file alone (no reference code needed): the converter test's input."""
    import collections
    lines = [l.split() for l in open(args.names) if l.strip()]
    firsts = [i for i, l in enumerate(lines) if l[0] == "feat.conv1.weight"]
    split = firsts[1]  # PoseNet's tensors, then PoseRefineNet's
    for part, seed, out in ((lines[:split], args.seed, args.posenet), (lines[split:], args.seed + 1, args.refiner)):
        state = collections.OrderedDict((l[0], torch.empty([int(d) for d in l[1:]])) for l in part)
        torch.manual_seed(seed)
        for p in state.values():
            std = 1.0 / np.sqrt(p.numel() / p.shape[0]) if p.dim() > 1 else 0.1
            p.normal_(0.0, float(std))
        torch.save(state, out)


def cmd_bench(args):
    """The reference implementation's CPU time on bench/densefusion_speed.cpp's sizes."""
    import time
    sys.path.insert(0, args.reference)
    from lib.network import PoseNet, PoseRefineNet
    n, h, w = 1000, 120, 160
    est = seeded(PoseNet(num_points=n, num_obj=21), 1)
    ref = seeded(PoseRefineNet(num_points=n, num_obj=21), 2)
    img, cloud = torch.randn(1, 3, h, w), torch.randn(1, n, 3) * 0.05
    choose, index = (torch.arange(n) * 7919 % (h * w)).view(1, 1, n), torch.LongTensor([0])
    with torch.no_grad():
        _, _, _, emb = est(img, cloud, choose, index)
        c0 = time.process_time()
        for _ in range(args.repeats):
            est(img, cloud, choose, index)
        posenet = (time.process_time() - c0) / args.repeats
        c0 = time.process_time()
        for _ in range(args.repeats):
            ref(cloud, emb, index)
        refiner = (time.process_time() - c0) / args.repeats
    print(f"reference (python): PoseNet {1e3 * posenet:.0f} ms CPU/call, refiner pass {1e3 * refiner:.1f} ms")


def cmd_convert(args):
    state = torch.load(args.checkpoint, map_location="cpu")
    if not isinstance(state, dict):
        sys.exit(f"{args.checkpoint}: not a state_dict")
    m = nn.Module()
    for k, v in state.items():
        m.register_buffer(k.replace(".", "__"), v.float().contiguous())
    torch.jit.script(m).save(args.out)
    print(f"wrote {args.out}: {len(state)} tensors, {sum(v.numel() for v in state.values())} values")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="cmd", required=True)
    f = sub.add_parser("fixtures")
    f.add_argument("--reference", required=True, help="a fetched copy of the DenseFusion repository")
    f.add_argument("--out", default="tests/nets/data/densefusion_small.pt")
    f.add_argument("--points", type=int, default=50)
    f.add_argument("--seed", type=int, default=11)
    f.set_defaults(func=cmd_fixtures)
    k = sub.add_parser("seeded-checkpoints")
    k.add_argument("--names", required=True)
    k.add_argument("--seed", type=int, default=11)
    k.add_argument("--posenet", required=True)
    k.add_argument("--refiner", required=True)
    k.set_defaults(func=cmd_seeded_checkpoints)
    b = sub.add_parser("bench")
    b.add_argument("--reference", required=True)
    b.add_argument("--repeats", type=int, default=5)
    b.set_defaults(func=cmd_bench)
    c = sub.add_parser("convert")
    c.add_argument("checkpoint")
    c.add_argument("--out", required=True)
    c.set_defaults(func=cmd_convert)
    args = p.parse_args()
    args.func(args)


if __name__ == "__main__":
    main()
