#!/usr/bin/env python3
"""Offline accuracy and speed benchmark: runs pl_slam_offline on the synthetic sequences
(rendered on first use) and on ../shared/datasets' sequences (skipped with a message when
absent), scores each with pl_slam_evaluate (SE(3)-aligned ATE, RPE, coverage) and prints a
Markdown table for docs/BENCHMARKS.md, plus per-stage timing medians.

    scripts/benchmark_offline.py [--out DIR] [--only NAME,NAME] [--repeat N]
                                 [--modes points,lines,points_lines] [--set K=V,...]
                                 [--variants vo,map,slam] [--realtime] [--sequential]

Variants: vo = visual odometry alone (mapping.enabled=false), map = local mapping without
loop closing (loop.enabled=false), slam = everything. --sequential runs mapping in line
(deterministic accuracy); --realtime feeds frames at the recording's rate (live-like timing
with mapping in its own thread).

Needs a built workspace (scripts/setup.sh). Standard library only; Debian's python3.
"""
import argparse
import csv
import json
import os
import platform
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.join(os.environ.get("PL_SLAM_WS", os.path.join(ROOT, ".ws")), "devel", "lib", "pl_slam")
SHARED = os.path.join(ROOT, "..", "shared", "datasets")

SYNTHETIC = ["room", "corridor", "fast_turn"]
VARIANTS = {"vo": "mapping.enabled=false", "map": "loop.enabled=false", "slam": ""}
REAL = [("euroc_mh01", os.path.join(SHARED, "euroc_mh01_f100-249")),
        ("kitti_clip_a", os.path.join(SHARED, "kitti_clip_a"))]


def run(cmd, log):
    with open(log, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        with open(log) as f:
            tail = f.read()[-2000:]
        raise RuntimeError("%s failed (exit %d):\n%s" % (" ".join(cmd), r.returncode, tail))


def percentile(values, q):
    if not values:
        return float("nan")
    v = sorted(values)
    return v[min(len(v) - 1, int(q * (len(v) - 1) + 0.5))]


def num(v):
    """JSON null (a metric that does not apply) as NaN."""
    return float("nan") if v is None else float(v)


def map_stats(log):
    """Keyframes, local BA median and p95 (ms), loops from the runner's summary lines."""
    stats = {"keyframes": float("nan"), "ba_median": float("nan"), "ba_p95": float("nan"),
             "loops": float("nan"), "dropped": float("nan")}
    with open(log) as f:
        for line in f:
            words = line.replace(",", " ").replace(";", " ").replace("(", " ").replace(")", " ").split()
            if line.startswith("map:"):
                stats["keyframes"] = float(words[1])
                stats["dropped"] = float(words[words.index("dropped") - 1])
                i = words.index("BA")
                stats["ba_median"] = float(words[i + 2])
                stats["ba_p95"] = float(words[i + 5])
            elif line.startswith("loops:"):
                stats["loops"] = float(words[1])
    return stats


def bench(name, source, out, repeat, mode, overrides, report_only=False, variant="slam",
          realtime=False):
    runs = []
    for k in range(repeat):
        d = os.path.join(out, variant, mode, name, "run%d" % k)
        if report_only:
            if not os.path.isfile(os.path.join(d, "timing.csv")):
                raise RuntimeError("%s: no earlier run to report" % d)
            runs.append(d)
            continue
        os.makedirs(d, exist_ok=True)
        cmd = [os.path.join(BIN, "pl_slam_offline"), source, "--out", d, "--quiet", "--mode", mode]
        if overrides:
            cmd += ["--set", overrides]
        if realtime:
            cmd += ["--realtime"]
        run(cmd, os.path.join(d, "offline.log"))
        runs.append(d)
    d = runs[0]
    run([os.path.join(BIN, "pl_slam_evaluate"), "--est", os.path.join(d, "trajectory.tum"),
         "--gt", os.path.join(d, "groundtruth.tum"), "--frame-times", os.path.join(d, "frames.txt"),
         "--align", "se3", "--json", os.path.join(d, "eval.json"),
         "--plot", os.path.join(out, variant, mode, name + ".png"),
         "--name", "%s (%s, %s)" % (name, variant, mode)],
        os.path.join(d, "eval.log"))
    with open(os.path.join(d, "eval.json")) as f:
        ev = json.load(f)
    totals, stages = [], {}
    for d in runs:
        with open(os.path.join(d, "timing.csv")) as f:
            for row in csv.DictReader(f):
                totals.append(float(row["total_ms"]))
                for k, v in row.items():
                    if k.endswith("_ms") and k != "total_ms":
                        stages.setdefault(k[:-3], []).append(float(v))
    rpe1 = next((r for r in ev["rpe_frames"] if r["delta"] == 1), None)
    drift = [r for r in ev["rpe_distance"] if r["segments"] > 0]
    ms = map_stats(os.path.join(runs[0], "offline.log"))
    return {
        "name": name,
        "variant": variant,
        "mode": mode,
        "keyframes": ms["keyframes"],
        "ba_median": ms["ba_median"],
        "ba_p95": ms["ba_p95"],
        "loops": ms["loops"],
        "dropped": ms["dropped"],
        "frames": ev["coverage"]["frames"],
        "coverage": num(ev["coverage"]["ratio"]),
        "length": num(ev["gt_path_length_m"]),
        "ate": num(ev["ate"]["translation_m"]["rmse"]),
        "rpe1_t": num(rpe1["translation_m"]["rmse"]) if rpe1 else float("nan"),
        "rpe1_r": num(rpe1["rotation_deg"]["rmse"]) if rpe1 else float("nan"),
        "drift": num(drift[-1]["translation_pct"]) if drift else float("nan"),
        "drift_len": num(drift[-1]["length_m"]) if drift else float("nan"),
        "median_ms": statistics.median(totals),
        "p95_ms": percentile(totals, 0.95),
        "spread_ms": percentile(totals, 0.75) - percentile(totals, 0.25),
        "stages": {k: statistics.median(v) for k, v in stages.items()},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "bench"))
    ap.add_argument("--only", default="")
    ap.add_argument("--repeat", type=int, default=1, help="runs per sequence for timing")
    ap.add_argument("--modes", default="points,points_lines", help="tracker feature modes to compare")
    ap.add_argument("--set", default="", help="option overrides passed to pl_slam_offline --set")
    ap.add_argument("--report-only", action="store_true", help="tabulate the runs already in --out")
    ap.add_argument("--variants", default="slam", help="vo, map, slam (see above)")
    ap.add_argument("--realtime", action="store_true", help="feed frames at the recording's rate")
    ap.add_argument("--sequential", action="store_true", help="mapping in line (deterministic)")
    args = ap.parse_args()
    only = set(filter(None, args.only.split(",")))
    os.makedirs(args.out, exist_ok=True)

    sequences = []
    for scene in SYNTHETIC:
        if only and scene not in only:
            continue
        data = os.path.join(args.out, "data", scene)
        if not args.report_only and not os.path.isdir(os.path.join(data, "mav0")):
            print("rendering synthetic %s ..." % scene, flush=True)
            run([os.path.join(BIN, "pl_slam_generate"), "--scene", scene, "--euroc", data],
                os.path.join(args.out, "generate_%s.log" % scene))
        sequences.append((scene, data))
    for name, path in REAL:
        if only and name not in only:
            continue
        if not os.path.isdir(path):
            print("skipped %s: %s not found (real datasets live beside the repository on "
                  "developer machines only)" % (name, path))
            continue
        sequences.append((name, path))

    results = []
    for name, path in sequences:
        for variant in args.variants.split(","):
            overrides = ",".join(filter(None, [VARIANTS[variant], args.set,
                                               "mapping.threaded=false" if args.sequential else ""]))
            for mode in args.modes.split(","):
                print("running %s (%s, %s) ..." % (name, variant, mode), flush=True)
                try:
                    results.append(bench(name, path, args.out, args.repeat, mode, overrides,
                                         args.report_only, variant, args.realtime))
                except RuntimeError as e:
                    print("  FAILED: %s" % str(e).splitlines()[0])

    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    print()
    print("machine: %s, %d cores, %s" % (platform.node(), os.cpu_count(), platform.processor() or platform.machine()))
    print()
    print("| sequence | variant | mode | frames | coverage | path m | ATE RMSE m (SE3) | RPE/frame m | RPE/frame deg | drift % (longest seg) | tracking median ms | p95 ms | IQR ms | keyframes | local BA median / p95 ms | loops |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in results:
        print("| %s | %s | %s | %d | %.1f%% | %.1f | %.4f | %.4f | %.3f | %.2f (%g m) | %.1f | %.1f | %.1f | %g | %.0f / %.0f | %g |" % (
            r["name"], r.get("variant", "slam"), r["mode"], r["frames"], 100 * r["coverage"], r["length"],
            r["ate"], r["rpe1_t"], r["rpe1_r"], r["drift"], r["drift_len"], r["median_ms"], r["p95_ms"],
            r["spread_ms"], r.get("keyframes", float("nan")), r.get("ba_median", float("nan")),
            r.get("ba_p95", float("nan")), r.get("loops", float("nan"))))
    print()
    print("per-stage median ms:")
    for r in results:
        print("  %-12s %-5s %-13s %s" % (r["name"], r.get("variant", "slam"), r["mode"],
                                        ", ".join("%s %.1f" % kv for kv in r["stages"].items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
