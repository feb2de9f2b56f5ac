#!/usr/bin/python3
"""How honest the odometry's covariance is: its pose error against the covariance it states.

Reads pl_slam_offline output folders (odometry.csv: every frame's odom pose, the ~odom topic's,
with its covariance's standard deviations; groundtruth.tum) and, at every frame, compares the
odom pose's error against the truth with the covariance the odometry states for it:

  error  = the odom pose against the truth (the odom frame is the camera at the first frame)
  sigma  = sqrt(trace of the covariance), position and rotation apart
  z      = error / sigma

For an honest covariance z^2 is 1 on average (a Gaussian error in three axes has a median z of
0.89) and z > 3 is rare: z > 3 means the covariance claims a certainty the pose does not have,
what a consumer fusing ~odom must never be told. Figures for tracked frames, lost frames and
the last frame of each gap (the pose tracking resumes from), per folder and pooled. The ground
truth must give the left camera's poses, as it does for pl_slam_generate's sequences (EuRoC's
is the body's: its lever arm adds to the position error).

  /usr/bin/python3 scripts/odom_consistency.py RUN_DIR [RUN_DIR ...] [--json FILE]
"""
import argparse
import json
import math
import os
import sys

import numpy as np


def quat_to_rot(qx, qy, qz, qw):
    n = math.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    x, y, z, w = qx / n, qy / n, qz / n, qw / n
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def rotation_angle(R):
    return math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))


def read_odometry(path):
    rows = []
    with open(path) as f:
        header = f.readline().strip().split(",")
        for line in f:
            fields = line.strip().split(",")
            if len(fields) != len(header):
                raise ValueError("%s: malformed row: %s" % (path, line.strip()))
            v = dict(zip(header, fields))
            sd = [float(v[k]) for k in ("sd_x", "sd_y", "sd_z", "sd_rx", "sd_ry", "sd_rz")]
            rows.append({
                "stamp": float(v["stamp"]), "lost": v["state"] != "TRACKING",
                "p": np.array([float(v["tx"]), float(v["ty"]), float(v["tz"])]),
                "R": quat_to_rot(float(v["qx"]), float(v["qy"]), float(v["qz"]), float(v["qw"])),
                "var_p": sum(s * s for s in sd[:3]), "var_r": sum(s * s for s in sd[3:])})
    return rows


def read_tum(path):
    poses = {}
    with open(path) as f:
        for line in f:
            if not line.strip() or line.startswith("#"):
                continue
            v = [float(x) for x in line.split()]
            poses[round(v[0], 4)] = (np.array(v[1:4]), quat_to_rot(*v[4:8]))
    return poses


PARTS = (("tracked", "tracked frames"), ("lost", "lost frames"), ("gap_ends", "gap ends"))


def analyse(run_dir):
    """Per part, (z position, z rotation, error m, error rad, sigma m, sigma rad) per frame."""
    rows = read_odometry(os.path.join(run_dir, "odometry.csv"))
    gt = read_tum(os.path.join(run_dir, "groundtruth.tum"))
    out = {key: [] for key, _ in PARTS}
    first = gt.get(round(rows[0]["stamp"], 4)) if rows else None
    if first is None:
        return out
    for k, r in enumerate(rows):
        g = gt.get(round(r["stamp"], 4))
        if g is None:
            continue
        p_true = first[1].T @ (g[0] - first[0])
        R_true = first[1].T @ g[1]
        e_p = float(np.linalg.norm(r["p"] - p_true))
        e_r = rotation_angle(r["R"].T @ R_true)
        s_p, s_r = math.sqrt(max(r["var_p"], 1e-18)), math.sqrt(max(r["var_r"], 1e-18))
        z = (e_p / s_p, e_r / s_r, e_p, e_r, s_p, s_r)
        if not r["lost"]:
            out["tracked"].append(z)
            continue
        out["lost"].append(z)
        if k + 1 == len(rows) or not rows[k + 1]["lost"]:
            out["gap_ends"].append(z)
    return out


def summary(z):
    """Median z, share beyond 3 sigma, median error and sigma, per part."""
    out = {}
    for key, _ in PARTS:
        zs = z.get(key, [])
        if not zs:
            out[key] = {"n": 0}
            continue
        a = np.array(zs)
        out[key] = {"n": len(zs), "median_z_position": float(np.median(a[:, 0])),
                    "median_z_rotation": float(np.median(a[:, 1])),
                    "over3_position": float(np.mean(a[:, 0] > 3.0)),
                    "over3_rotation": float(np.mean(a[:, 1] > 3.0)),
                    "median_error_m": float(np.median(a[:, 2])),
                    "median_error_deg": math.degrees(float(np.median(a[:, 3]))),
                    "median_sigma_m": float(np.median(a[:, 4])),
                    "median_sigma_deg": math.degrees(float(np.median(a[:, 5])))}
    return out


def report(name, s):
    lines = [name]
    for key, label in PARTS:
        p = s[key]
        if not p["n"]:
            lines.append("  %-14s none" % label)
            continue
        lines.append("  %-14s %5d: median z %.2f / %.2f, z > 3 %.1f%% / %.1f%% (median error "
                     "%.3f m / %.2f deg, sigma %.3f m / %.2f deg)" % (
                         label, p["n"], p["median_z_position"], p["median_z_rotation"],
                         100 * p["over3_position"], 100 * p["over3_rotation"],
                         p["median_error_m"], p["median_error_deg"], p["median_sigma_m"],
                         p["median_sigma_deg"]))
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="pl_slam_offline output folders")
    ap.add_argument("--json", default="", help="write the pooled and per-run figures here")
    ap.add_argument("--quiet", action="store_true", help="only the pooled figures")
    args = ap.parse_args()
    pooled, per_run = {}, {}
    for run in args.runs:
        for f in ("odometry.csv", "groundtruth.tum"):
            if not os.path.isfile(os.path.join(run, f)):
                sys.exit("odom_consistency: %s has no %s" % (run, f))
        try:
            z = analyse(run)
        except (ValueError, KeyError, IndexError) as e:
            sys.exit("odom_consistency: %s: %s" % (run, e))
        for key, zs in z.items():
            pooled.setdefault(key, []).extend(zs)
        per_run[run] = summary(z)
        if not args.quiet:
            print(report(run, per_run[run]))
    total = summary(pooled)
    print(report("all %d runs (position / rotation)" % len(args.runs), total))
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"pooled": total, "runs": per_run}, f, indent=1)


if __name__ == "__main__":
    main()
