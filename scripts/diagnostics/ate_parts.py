#!/usr/bin/env python3
"""What an ATE is made of: per-axis, slow (drift, map bends) and fast (per-frame jitter) parts.

Aligns an estimated TUM trajectory to the ground truth (rigid, Umeyama without scale, rows matched by
timestamp) and prints the ATE RMSE, its RMS per world axis, its RMS per block of frames, and its split
into a slow part (the error averaged over a window of frames) and a fast part (the rest). Loop closure
can take away a slow part that grows along the path; it cannot take away the fast part nor a slow part
that comes and goes (docs/SLAM.md, "Session 24: what the loop-closed room's error is made of").

Needs numpy only (/usr/bin/python3 on Debian: python3-numpy).
Usage: scripts/diagnostics/ate_parts.py GT.txt EST.txt [EST2.txt ...] [--window 31] [--block 100]
"""
import argparse

import numpy as np


def load_tum(path):
    rows = {}
    with open(path) as f:
        for n, line in enumerate(f, 1):
            if line.startswith('#') or not line.strip():
                continue
            v = line.split()
            if len(v) != 8:
                raise SystemExit(f'{path}:{n}: expected 8 columns (t tx ty tz qx qy qz qw), got {len(v)}')
            rows[round(float(v[0]), 6)] = np.array([float(x) for x in v[1:4]])
    return rows


def aligned_error(gt, est):
    """Per-frame position error (N x 3, metres) of est after the rigid fit onto gt."""
    keys = sorted(k for k in est if k in gt)
    if len(keys) < 3:
        raise SystemExit('fewer than 3 timestamps in common with the ground truth')
    A = np.array([gt[k] for k in keys])
    B = np.array([est[k] for k in keys])
    ma, mb = A.mean(0), B.mean(0)
    U, _, Vt = np.linalg.svd((B - mb).T @ (A - ma))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(Vt.T @ U.T))
    R = Vt.T @ D @ U.T
    return (R @ (B - mb).T).T + ma - A


def rms_mm(e):
    return 1000 * np.sqrt((np.linalg.norm(e, axis=-1) ** 2).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('gt')
    ap.add_argument('est', nargs='+')
    ap.add_argument('--window', type=int, default=31, help='frames averaged into the slow part')
    ap.add_argument('--block', type=int, default=100, help='frames per block of the profile')
    a = ap.parse_args()
    gt = load_tum(a.gt)
    for path in a.est:
        E = aligned_error(gt, load_tum(path))
        k = a.window
        kernel = np.ones(k) / k
        slow = np.stack([np.convolve(E[:, i], kernel, mode='same') for i in range(3)], 1)
        inner = slice(k, len(E) - k) if len(E) > 3 * k else slice(None)
        axes = 1000 * np.sqrt((E ** 2).mean(0))
        print(f'{path}: {len(E)} frames, ATE {rms_mm(E):.2f} mm; per axis x {axes[0]:.2f} y {axes[1]:.2f} '
              f'z {axes[2]:.2f} mm; slow {rms_mm(slow[inner]):.2f} mm, fast {rms_mm((E - slow)[inner]):.2f} mm '
              f'(window {k} frames)')
        blocks = [f'{i}:{rms_mm(E[i:i + a.block]):.1f}' for i in range(0, len(E), a.block)]
        print(f'  ATE per block of {a.block} frames (first frame: mm): ' + ' '.join(blocks))


if __name__ == '__main__':
    main()
