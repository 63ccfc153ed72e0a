#!/usr/bin/python3
"""Cross-checks `orpe eval traj` against a transcription of the TUM RGB-D benchmark's Python tools.

Not a CI test (needs numpy: Debian's python3-numpy). Generates random ground-truth / estimated TUM
trajectory pairs (rigid offset, noise, drift, timestamp jitter, dropped and repeated stamps, shuffled
lines), runs the orpe binary with --json, and compares with:
  - associate.py: read_file_list + associate (greedy, one-to-one, |a - b| < 0.02),
  - evaluate_ate.py: align() (SVD, rotation only) and the error statistics,
  - RPE with a fixed frame delta as evo defines it, E_i = (Q_i^-1 Q_{i+d})^-1 (P_i^-1 P_{i+d}).

Usage: bench/eval_crosscheck_tum.py build/bin/orpe [cases]
"""
import json
import os
import random
import subprocess
import sys
import tempfile

import numpy as np


# ---- associate.py (TUM), adapted to Python 3 only where Python 2 idioms fail ----
def read_file_list(filename):
    with open(filename) as f:
        data = f.read()
    lines = data.replace(",", " ").replace("\t", " ").split("\n")
    lst = [[v.strip() for v in line.split(" ") if v.strip() != ""]
           for line in lines if len(line) > 0 and line[0] != "#"]
    lst = [(float(l[0]), l[1:]) for l in lst if len(l) > 1]
    return dict(lst)


def associate(first_list, second_list, offset, max_difference):
    first_keys = list(first_list.keys())
    second_keys = list(second_list.keys())
    potential_matches = [(abs(a - (b + offset)), a, b)
                         for a in first_keys
                         for b in second_keys
                         if abs(a - (b + offset)) < max_difference]
    potential_matches.sort()
    matches = []
    for diff, a, b in potential_matches:
        if a in first_keys and b in second_keys:
            first_keys.remove(a)
            second_keys.remove(b)
            matches.append((a, b))
    matches.sort()
    return matches


# ---- evaluate_ate.py (TUM): align(model, data), model = estimate, data = ground truth ----
def align(model, data):
    model_zerocentered = model - model.mean(1, keepdims=True)
    data_zerocentered = data - data.mean(1, keepdims=True)
    W = np.zeros((3, 3))
    for column in range(model.shape[1]):
        W += np.outer(model_zerocentered[:, column], data_zerocentered[:, column])
    U, d, Vh = np.linalg.svd(W.transpose())
    S = np.identity(3)
    if np.linalg.det(U) * np.linalg.det(Vh) < 0:
        S[2, 2] = -1
    rot = U @ S @ Vh
    trans = data.mean(1, keepdims=True) - rot @ model.mean(1, keepdims=True)
    model_aligned = rot @ model + trans
    alignment_error = model_aligned - data
    trans_error = np.sqrt(np.sum(np.multiply(alignment_error, alignment_error), 0))
    return rot, trans, trans_error


def pose44(v):
    """TUM line values tx ty tz qx qy qz qw -> 4x4 (quaternion normalised, as evaluate_rpe.py)."""
    t = np.array(v[0:3], dtype=float)
    q = np.array(v[3:7], dtype=float)
    q /= np.linalg.norm(q)
    x, y, z, w = q
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    T = np.identity(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def reference(gt_file, est_file, delta):
    first_list = read_file_list(gt_file)
    second_list = read_file_list(est_file)
    matches = associate(first_list, second_list, 0.0, 0.02)
    first_xyz = np.array([[float(v) for v in first_list[a][0:3]] for a, b in matches]).T
    second_xyz = np.array([[float(v) for v in second_list[b][0:3]] for a, b in matches]).T
    rot, trans, trans_error = align(second_xyz, first_xyz)
    ate = {"pairs": len(matches),
           "rmse": float(np.sqrt(np.dot(trans_error, trans_error) / len(trans_error))),
           "mean": float(np.mean(trans_error)), "median": float(np.median(trans_error)),
           "std": float(np.std(trans_error)), "min": float(np.min(trans_error)),
           "max": float(np.max(trans_error))}
    Q = [pose44([float(v) for v in first_list[a]]) for a, b in matches]
    P = [pose44([float(v) for v in second_list[b]]) for a, b in matches]
    t_err, r_err = [], []
    for i in range(len(matches) - delta):
        E = np.linalg.inv(np.linalg.inv(Q[i]) @ Q[i + delta]) @ (np.linalg.inv(P[i]) @ P[i + delta])
        t_err.append(np.linalg.norm(E[:3, 3]))
        r_err.append(np.degrees(np.arccos(np.clip((np.trace(E[:3, :3]) - 1) / 2, -1, 1))))
    t_err, r_err = np.array(t_err), np.array(r_err)
    rpe = {"count": len(t_err), "rmse": float(np.sqrt(np.mean(t_err ** 2))),
           "rot_rmse_deg": float(np.sqrt(np.mean(r_err ** 2)))}
    return ate, rpe


# ---- random test cases ----
def random_rotation(rng, scale):
    v = rng.normal(0, scale, 3)
    angle = np.linalg.norm(v)
    if angle < 1e-12:
        return np.identity(3)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.identity(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def quat_xyzw(R):
    w = np.sqrt(max(0.0, 1 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = np.sqrt(max(0.0, 1 + R[0, 0] - R[1, 1] - R[2, 2])) / 2
    y = np.sqrt(max(0.0, 1 - R[0, 0] + R[1, 1] - R[2, 2])) / 2
    z = np.sqrt(max(0.0, 1 - R[0, 0] - R[1, 1] + R[2, 2])) / 2
    x = np.copysign(x, R[2, 1] - R[1, 2])
    y = np.copysign(y, R[0, 2] - R[2, 0])
    z = np.copysign(z, R[1, 0] - R[0, 1])
    return x, y, z, w


def write_tum(path, stamped, rng_py):
    lines = []
    for t, T in stamped:
        x, y, z, w = quat_xyzw(T[:3, :3])
        lines.append("%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f" % (t, *T[:3, 3], x, y, z, w))
    if rng_py.random() < 0.5:
        rng_py.shuffle(lines)
    with open(path, "w") as f:
        f.write("# timestamp tx ty tz qx qy qz qw\n" + "\n".join(lines) + "\n")


def make_case(seed, folder):
    rng = np.random.default_rng(seed)
    rng_py = random.Random(seed)
    n = int(rng.integers(50, 1500))
    offset = np.identity(4)
    offset[:3, :3] = random_rotation(rng, 1.5)
    offset[:3, 3] = rng.normal(0, 3, 3)
    T = np.identity(4)
    gt, est = [], []
    drift = rng.normal(0, 0.002, 3)
    for i in range(n):
        step = np.identity(4)
        step[:3, :3] = random_rotation(rng, 0.03)
        step[:3, 3] = rng.normal(0, 0.02, 3)
        T = T @ step
        t = 1e9 * (seed % 2) + 1305031102.0 + i / 30.0  # sometimes large Unix-like stamps
        if rng.random() > 0.05:
            gt.append((t, T.copy()))
        if rng.random() > 0.1:
            noise = np.identity(4)
            noise[:3, :3] = random_rotation(rng, 0.01)
            noise[:3, 3] = rng.normal(0, 0.01, 3)
            P = offset @ T @ noise
            P[:3, 3] += drift * i
            est.append((t + rng.uniform(-0.025, 0.025), P))
            if rng.random() < 0.03:  # a repeated stamp: TUM keeps the last line
                est.append((round(est[-1][0], 6), P @ noise))
    gt_path = os.path.join(folder, "gt_%d.txt" % seed)
    est_path = os.path.join(folder, "est_%d.txt" % seed)
    write_tum(gt_path, gt, rng_py)
    write_tum(est_path, est, rng_py)
    return gt_path, est_path


def main():
    orpe = sys.argv[1] if len(sys.argv) > 1 else "build/bin/orpe"
    cases = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    worst = {"ate": 0.0, "ate_stats": 0.0, "rpe": 0.0, "rpe_rot_deg": 0.0}
    pair_mismatch = 0
    with tempfile.TemporaryDirectory() as folder:
        for seed in range(cases):
            gt_path, est_path = make_case(seed, folder)
            delta = 1 + seed % 4
            out = os.path.join(folder, "out.json")
            subprocess.run([orpe, "-q", "eval", "traj", gt_path, est_path, "--delta", str(delta),
                            "--json", out], check=True, stdout=subprocess.DEVNULL)
            with open(out) as f:
                mine = json.load(f)
            ate, rpe = reference(gt_path, est_path, delta)
            m = mine["ate"]["translation_m"]
            if mine["pairs"] != ate["pairs"]:
                pair_mismatch += 1
            worst["ate"] = max(worst["ate"], abs(m["rmse"] - ate["rmse"]))
            for k in ("mean", "median", "std", "min", "max"):
                worst["ate_stats"] = max(worst["ate_stats"], abs(m[k] - ate[k]))
            worst["rpe"] = max(worst["rpe"], abs(mine["rpe"]["translation_m"]["rmse"] - rpe["rmse"]))
            worst["rpe_rot_deg"] = max(worst["rpe_rot_deg"],
                                       abs(mine["rpe"]["rotation_deg"]["rmse"] - rpe["rot_rmse_deg"]))
            print("case %2d: %4d pairs (ref %4d), ATE rmse %.9f (ref %.9f), RPE d=%d rmse %.9f (ref %.9f)"
                  % (seed, mine["pairs"], ate["pairs"], m["rmse"], ate["rmse"], delta,
                     mine["rpe"]["translation_m"]["rmse"], rpe["rmse"]))
    print("max |difference|: ATE rmse %.3g m, ATE mean/median/std/min/max %.3g m, RPE rmse %.3g m, "
          "RPE rot rmse %.3g deg; pair-count mismatches: %d"
          % (worst["ate"], worst["ate_stats"], worst["rpe"], worst["rpe_rot_deg"], pair_mismatch))
    ok = pair_mismatch == 0 and worst["ate"] < 1e-6 and worst["ate_stats"] < 1e-6 and worst["rpe"] < 1e-6
    print("OK" if ok else "MISMATCH")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
