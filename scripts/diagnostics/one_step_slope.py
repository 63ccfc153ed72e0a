#!/usr/bin/env python3
"""One-step tracking bias: the regression slope of the estimated on the true relative motion.

Reads a trajectory written by `orpe_bench_slam_ate --gt-map --trajectory EST.txt` (each frame's pose
as tracked from the previous frame's ground-truth pose) and the ground truth. For every frame i > 0
the estimated relative motion inv(G[i-1]) E[i] is compared with the true one inv(G[i-1]) G[i], in
the previous camera's frame. Prints the least-squares slope est/gt of the translation (all axes
pooled and per axis; x = sideways), the turn ratio (slope of the rotation vectors, pooled) and the
mean one-step translation error (docs/SLAM.md, "Photometric term near depth edges", session 18).

Needs numpy only (/usr/bin/python3 on Debian: python3-numpy).
Usage: scripts/diagnostics/one_step_slope.py EST.txt GT.txt [--skip 1]
Rows are matched by order (both files list the same frames), not by timestamp.
"""
import argparse

import numpy as np


def quat_to_matrix(qx, qy, qz, qw):
    q = np.array([qw, qx, qy, qz]) / np.linalg.norm([qw, qx, qy, qz])
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def rotvec(R):
    c = np.clip((np.trace(R) - 1) / 2, -1.0, 1.0)
    angle = np.arccos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    if angle < 1e-9:
        return v / 2
    return v * angle / (2 * np.sin(angle))


def load_tum(path):
    poses = []
    for r in np.loadtxt(path, comments="#", ndmin=2):
        T = np.eye(4)
        T[:3, :3] = quat_to_matrix(*r[4:8])  # TUM order: tx ty tz qx qy qz qw
        T[:3, 3] = r[1:4]
        poses.append(T)
    return poses


def slope(est, gt):
    return float(est.ravel() @ gt.ravel() / max(gt.ravel() @ gt.ravel(), 1e-18))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("est")
    ap.add_argument("gt")
    ap.add_argument("--skip", type=int, default=1,
                    help="leave out the first N frames (frame 0 starts the map; default 1)")
    a = ap.parse_args()
    est, gt = load_tum(a.est), load_tum(a.gt)
    n = min(len(est), len(gt))
    te, tg, re, rg = [], [], [], []
    for i in range(max(1, a.skip), n):
        P = np.linalg.inv(gt[i - 1])
        E, G = P @ est[i], P @ gt[i]
        te.append(E[:3, 3]), tg.append(G[:3, 3])
        re.append(rotvec(E[:3, :3])), rg.append(rotvec(G[:3, :3]))
    te, tg, re, rg = map(np.array, (te, tg, re, rg))
    err = np.linalg.norm(te - tg, axis=1)
    print(f"{len(te)} one-step motions")
    print(f"translation slope {slope(te, tg):.3f} (x {slope(te[:, 0], tg[:, 0]):.3f}, "
          f"y {slope(te[:, 1], tg[:, 1]):.3f}, z {slope(te[:, 2], tg[:, 2]):.3f})")
    print(f"turn est/gt {slope(re, rg):.3f}")
    print(f"one-step translation error mean {err.mean() * 1e3:.2f} mm, "
          f"rotation error mean {np.degrees(np.linalg.norm(re - rg, axis=1)).mean():.3f} deg")


if __name__ == "__main__":
    main()
