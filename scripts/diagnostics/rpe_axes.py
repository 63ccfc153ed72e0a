#!/usr/bin/env python3
"""Per-axis relative pose error of a TUM trajectory against ground truth, in the camera frame.

For every window of DELTA frames, compares the estimated relative motion with the ground-truth one and
prints, per camera axis, the least-squares slope est/gt (1 = motion estimated at the right size; < 1 =
under-estimated), the RMS of the ground-truth motion, the RMS error and the mean (bias) error. Used to
find systematic tracking biases (docs/SLAM.md, "Open: 7-Scenes accuracy").

Needs Debian's python3-numpy and python3-scipy (not installed by scripts/install-deps.sh):
  apt-get install python3-numpy python3-scipy
Usage: scripts/diagnostics/rpe_axes.py EST.txt GT.txt [--delta 10]
Rows are matched by order (both files list the same frames), not by timestamp.
"""
import argparse

import numpy as np
from scipy.spatial.transform import Rotation


def load_tum(path):
    rows = np.loadtxt(path, comments="#")
    poses = []
    for r in rows:
        T = np.eye(4)
        T[:3, :3] = Rotation.from_quat(r[4:8]).as_matrix()  # TUM order qx qy qz qw
        T[:3, 3] = r[1:4]
        poses.append(T)
    return poses


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("est")
    ap.add_argument("gt")
    ap.add_argument("--delta", type=int, default=10)
    a = ap.parse_args()
    est, gt = load_tum(a.est), load_tum(a.gt)
    n = min(len(est), len(gt))
    if n <= a.delta:
        raise SystemExit(f"need more than {a.delta} poses, got {n}")
    te, tg, re, rg = [], [], [], []
    for i in range(n - a.delta):
        E = np.linalg.inv(est[i]) @ est[i + a.delta]
        G = np.linalg.inv(gt[i]) @ gt[i + a.delta]
        te.append(E[:3, 3]), tg.append(G[:3, 3])
        re.append(Rotation.from_matrix(E[:3, :3]).as_rotvec())
        rg.append(Rotation.from_matrix(G[:3, :3]).as_rotvec())
    te, tg, re, rg = map(np.array, (te, tg, re, rg))
    print(f"{n} poses, windows of {a.delta} frames")
    print("axis | trans slope | gt rms mm | err rms mm | bias mm || rot slope | gt rms deg | err rms deg | bias deg")
    for k, name in enumerate("xyz"):
        ts = te[:, k] @ tg[:, k] / max(tg[:, k] @ tg[:, k], 1e-12)
        rs = re[:, k] @ rg[:, k] / max(rg[:, k] @ rg[:, k], 1e-12)
        rms = lambda x: np.sqrt(np.mean(x ** 2))
        print(f"  {name}  | {ts:11.3f} | {rms(tg[:, k]) * 1e3:9.1f} | {rms(te[:, k] - tg[:, k]) * 1e3:10.1f} | "
              f"{np.mean(te[:, k] - tg[:, k]) * 1e3:7.2f} || {rs:9.3f} | {np.degrees(rms(rg[:, k])):10.2f} | "
              f"{np.degrees(rms(re[:, k] - rg[:, k])):11.3f} | {np.degrees(np.mean(re[:, k] - rg[:, k])):8.4f}")


if __name__ == "__main__":
    main()
