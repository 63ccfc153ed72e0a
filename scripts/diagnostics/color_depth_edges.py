#!/usr/bin/env python3
"""Estimates where the colour camera sits relative to the depth camera of an unregistered RGB-D sequence
(7-Scenes layout: frame-NNNNNN.{color.jpg,depth.png}, depth in mm), without ground truth: depth
discontinuities (the near side of jumps > 5 cm) are projected into the colour image for candidate colour
focal lengths, baselines and principal-point shifts, and scored by the colour image's (blurred) gradient
magnitude there. The best candidates are printed; "registered" (colour = depth camera) is printed for
comparison. Findings on the shared 7-Scenes sequence are in docs/SLAM.md.

Needs Debian's python3-numpy and python3-opencv (not installed by scripts/install-deps.sh).
Usage: scripts/diagnostics/color_depth_edges.py [DIR] [--depth-f 585] [--every 25]
"""
import argparse
import os

import cv2
import numpy as np


def main():
    default_dir = os.path.join(os.environ.get("ORPE_DATA_DIR", "../shared/data"), "7scenes-seq")
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir", nargs="?", default=default_dir)
    ap.add_argument("--depth-f", type=float, default=585.0, help="depth focal length (px)")
    ap.add_argument("--every", type=int, default=25, help="use every n-th of frames 0..499")
    a = ap.parse_args()
    if not os.path.isdir(a.dir):
        raise SystemExit(f"{a.dir}: no such folder (set ORPE_DATA_DIR or pass the sequence folder)")
    fd, cx, cy = a.depth_f, 320.0, 240.0
    frames = []
    for i in range(0, 500, a.every):
        dpath, cpath = f"{a.dir}/frame-{i:06d}.depth.png", f"{a.dir}/frame-{i:06d}.color.jpg"
        d, c = cv2.imread(dpath, cv2.IMREAD_UNCHANGED), cv2.imread(cpath, cv2.IMREAD_GRAYSCALE)
        if d is None or c is None:
            break
        d = d.astype(np.float32)
        d[d >= 65535] = 0
        d /= 1000.0
        c = cv2.GaussianBlur(c.astype(np.float32), (5, 5), 1.5)
        g = np.hypot(cv2.Sobel(c, cv2.CV_32F, 1, 0), cv2.Sobel(c, cv2.CV_32F, 0, 1))
        g = cv2.GaussianBlur(g, (0, 0), 2.0)
        valid = d > 0
        edge = np.zeros_like(valid)
        for du, dv in [(1, 0), (0, 1), (-1, 0), (0, -1)]:
            nd = np.roll(np.roll(d, dv, 0), du, 1)
            nv = np.roll(np.roll(valid, dv, 0), du, 1)
            edge |= valid & nv & (nd - d > 0.05)
        v, u = np.nonzero(edge)
        z = d[v, u]
        frames.append((np.stack([(u - cx) / fd * z, (v - cy) / fd * z, z], 1), g))
    if not frames:
        raise SystemExit(f"{a.dir}: no frame-NNNNNN.depth.png / .color.jpg pairs")
    h, w = frames[0][1].shape

    def score(f, tx, ty, du, dv):
        s, n = 0.0, 0
        for X, g in frames:
            u = np.round(f * (X[:, 0] + tx) / X[:, 2] + cx + du).astype(int)
            v = np.round(f * (X[:, 1] + ty) / X[:, 2] + cy + dv).astype(int)
            ok = (u >= 0) & (u < w) & (v >= 0) & (v < h)
            s += g[v[ok], u[ok]].sum()
            n += ok.sum()
        return s / max(n, 1)

    results = []
    for f in range(500, 611, 5):
        for tx in np.arange(-0.05, 0.0501, 0.005):
            for ty in (-0.005, 0.0, 0.005):
                for du in (-4, -2, 0, 2, 4):
                    for dv in (-4, -2, 0, 2, 4):
                        results.append((score(f, tx, ty, du, dv), f, tx, ty, du, dv))
    results.sort(reverse=True)
    print(f"{len(frames)} frames; score = mean colour gradient at projected depth edges")
    for r in results[:10]:
        print("score %.2f  colour f %d px  t_color_depth (%.3f, %.3f, 0) m  principal point shift (%d, %d) px" % r)
    print("registered (f %.0f, t 0): score %.2f" % (fd, score(fd, 0, 0, 0, 0)))


if __name__ == "__main__":
    main()
