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

Scene families (--family lowtex): every layout of the family x {textured, bare} x world
seeds (--seeds, default 1,2,3), rendered with pl_slam_generate on first use, run with each
mode in --modes, mapping in line (deterministic; --threaded to run it in its own thread).
One row per run: frames, frames with a pose, lost frames (frames.txt stamps without a
trajectory.tum pose) and the longest run of them, ground-truth path length, SE(3)-aligned ATE
RMSE over the frames with a pose (m and % of the path), translation and rotation drift (RPE
per metre over the longest segment evaluated), then median ATE and lost frames per mode, tuning and held-out layouts
apart (held-out layouts are for checking, never for tuning):

    scripts/benchmark_offline.py --family lowtex [--seeds 1,2,3] [--family-variants textured,bare]
                                 [--layouts NAME,...] [--max-frames N] [--jobs J] [--out DIR]
                                 [--generate-args '--exposure dim'] [--set K=V,...]

Needs a built workspace (scripts/setup.sh). Standard library only; Debian's python3.
"""
import argparse
import concurrent.futures
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


# Scene families: tuning layouts (tune the tracker on these) and held-out layouts (check on
# these, never tune on them).
FAMILIES = {
    "lowtex": {
        "tuning": ["lowtex_corner", "lowtex_straight", "lowtex_spin", "lowtex_wall"],
        "held_out": ["lowtex_doorway", "lowtex_office"],
    },
}


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


def read_stamps(path):
    """First column of a TUM trajectory or frames.txt, as rounded nanoseconds."""
    out = []
    if not os.path.isfile(path):
        return out
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line and not line.startswith("#"):
                out.append(int(round(float(line.split()[0]) * 1e9)))
    return out


def gt_path_length(path):
    """Length (m) of the whole ground-truth path of a TUM file (lost frames included)."""
    length, last = 0.0, None
    with open(path) as f:
        for line in f:
            w = line.split()
            if not w or w[0].startswith("#"):
                continue
            p = [float(x) for x in w[1:4]]
            if last is not None:
                length += sum((a - b) ** 2 for a, b in zip(p, last)) ** 0.5
            last = p
    return length


def family_run(layout, variant, seed, mode, data, out, overrides):
    """One pl_slam_offline run of a family sequence; the row of the family table."""
    name = "%s_%s_s%d" % (layout, variant, seed)
    d = os.path.join(out, "runs", mode, name)
    os.makedirs(d, exist_ok=True)
    row = {"layout": layout, "variant": variant, "seed": seed, "mode": mode, "name": name,
           "frames": 0, "tracked": 0, "lost": 0, "gap": 0, "length": float("nan"),
           "ate": float("nan"), "ate_pct": float("nan"), "rot_drift": float("nan"),
           "drift_pct": float("nan"), "failed": ""}
    cmd = [os.path.join(BIN, "pl_slam_offline"), data, "--out", d, "--quiet", "--mode", mode]
    if overrides:
        cmd += ["--set", overrides]
    try:
        run(cmd, os.path.join(d, "offline.log"))
    except RuntimeError as e:
        row["failed"] = "offline: " + str(e).splitlines()[0][-120:]
        return row
    frames = read_stamps(os.path.join(d, "frames.txt"))
    posed = set(read_stamps(os.path.join(d, "trajectory.tum")))
    row["frames"] = len(frames)
    row["tracked"] = sum(1 for t in frames if t in posed)
    row["lost"] = row["frames"] - row["tracked"]
    gap = longest = 0
    for t in frames:
        gap = 0 if t in posed else gap + 1
        longest = max(longest, gap)
    row["gap"] = longest
    if row["tracked"] < 2:
        row["failed"] = "fewer than 2 frames tracked"
        return row
    try:
        run([os.path.join(BIN, "pl_slam_evaluate"), "--est", os.path.join(d, "trajectory.tum"),
             "--gt", os.path.join(d, "groundtruth.tum"), "--frame-times", os.path.join(d, "frames.txt"),
             "--align", "se3", "--json", os.path.join(d, "eval.json"),
             "--plot", os.path.join(d, "plot.png"), "--name", "%s (%s)" % (name, mode)],
            os.path.join(d, "eval.log"))
        with open(os.path.join(d, "eval.json")) as f:
            ev = json.load(f)
    except (RuntimeError, ValueError) as e:
        row["failed"] = "evaluate: " + str(e).splitlines()[0][-120:]
        return row
    row["length"] = gt_path_length(os.path.join(d, "groundtruth.tum"))
    row["ate"] = num(ev["ate"]["translation_m"]["rmse"])
    row["ate_pct"] = 100.0 * row["ate"] / row["length"] if row["length"] > 0 else float("nan")
    drift = [r for r in ev["rpe_distance"] if r["segments"] > 0]
    if drift:
        row["rot_drift"] = num(drift[-1].get("rotation_deg_per_m"))
        row["drift_pct"] = num(drift[-1].get("translation_pct"))
    return row


def median(values):
    v = [x for x in values if x == x]
    return statistics.median(v) if v else float("nan")


def run_family(args):
    family = FAMILIES[args.family]
    layouts = [(l, "tuning") for l in family["tuning"]] + [(l, "held-out") for l in family["held_out"]]
    if args.layouts:
        keep = set(args.layouts.split(","))
        layouts = [(l, s) for l, s in layouts if l in keep]
    seeds = [int(x) for x in args.seeds.split(",") if x]
    variants = [v for v in args.family_variants.split(",") if v]
    modes = [m for m in args.modes.split(",") if m]
    out = args.out if args.out_given else os.path.join(ROOT, "output", "bench_" + args.family)
    os.makedirs(out, exist_ok=True)
    overrides = ",".join(filter(None, [args.set, "" if args.threaded else "mapping.threaded=false"]))
    role = dict(layouts)

    # Render every sequence once (all modes share it).
    sequences = []
    for layout, _ in layouts:
        for variant in variants:
            for seed in seeds:
                name = "%s_%s_s%d" % (layout, variant, seed)
                suffix = ("_f%d" % args.max_frames if args.max_frames else "") + (
                    "_" + "_".join(w.lstrip("-") for w in args.generate_args.split())
                    if args.generate_args else "")
                data = os.path.join(out, "data", name + suffix)
                sequences.append((layout, variant, seed, data))

    def render(item):
        layout, variant, seed, data = item
        if os.path.isdir(os.path.join(data, "mav0")):
            return
        cmd = [os.path.join(BIN, "pl_slam_generate"), "--scene", layout, "--euroc", data,
               "--world-seed", str(seed), "--seed", str(seed)]
        if variant == "bare":
            cmd.append("--bare")
        elif variant != "textured":
            raise RuntimeError("unknown variant %s (textured, bare)" % variant)
        if args.max_frames:
            cmd += ["--frames", str(args.max_frames)]
        cmd += args.generate_args.split()
        os.makedirs(os.path.dirname(data), exist_ok=True)
        run(cmd, data + ".generate.log")

    print("rendering %d sequences ..." % len(sequences), flush=True)
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        list(pool.map(render, sequences))

    jobs = [(layout, variant, seed, mode, data) for layout, variant, seed, data in sequences for mode in modes]
    print("running %d runs (%s) ..." % (len(jobs), overrides or "default options"), flush=True)

    def one(job):
        row = family_run(job[0], job[1], job[2], job[3], job[4], out, overrides)
        print("  %-32s %-12s lost %3d/%3d  ATE %.3f m%s" % (row["name"], row["mode"], row["lost"], row["frames"],
                                                          row["ate"], ("  FAILED " + row["failed"]) if row["failed"] else ""),
              flush=True)
        return row

    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        rows = list(pool.map(one, jobs))
    for r in rows:
        r["set"] = role[r["layout"]]
    with open(os.path.join(out, "family_results.json"), "w") as f:
        json.dump(rows, f, indent=1)

    lines = []
    lines.append("family %s: layouts %s; variants %s; seeds %s; modes %s; options: %s; rendering: %s" % (
        args.family, ", ".join("%s (%s)" % lr for lr in layouts), ",".join(variants), args.seeds,
        ",".join(modes), overrides or "defaults", args.generate_args or "scene defaults"))
    lines.append("")
    lines.append("| set | layout | variant | seed | mode | frames | tracked | lost | longest gap | path m | ATE m | ATE % path | drift % | rot drift deg/m |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in sorted(rows, key=lambda r: (r["set"] != "tuning", r["layout"], r["variant"] != "textured", r["seed"], r["mode"])):
        if r["failed"]:
            lines.append("| %s | %s | %s | %d | %s | %d | %d | %d | %d | - | FAILED: %s | | | |" % (
                r["set"], r["layout"], r["variant"], r["seed"], r["mode"], r["frames"], r["tracked"],
                r["lost"], r["gap"], r["failed"]))
            continue
        lines.append("| %s | %s | %s | %d | %s | %d | %d | %d | %d | %.1f | %.3f | %.2f | %.2f | %.3f |" % (
            r["set"], r["layout"], r["variant"], r["seed"], r["mode"], r["frames"], r["tracked"], r["lost"],
            r["gap"], r["length"], r["ate"], r["ate_pct"], r["drift_pct"], r["rot_drift"]))
    lines.append("")
    lines.append("summary (medians over runs; failed runs count as lost frames, not in ATE medians):")
    lines.append("")
    lines.append("| set | variant | mode | runs | failed | lost frames (total) | runs with loss | median ATE m | median ATE % | median rot drift deg/m |")
    lines.append("|---|---|---|---|---|---|---|---|---|---|")
    for set_name in ("tuning", "held-out"):
        for variant in variants + ["all"]:
            for mode in modes:
                rs = [r for r in rows if r["set"] == set_name and r["mode"] == mode and
                      (variant == "all" or r["variant"] == variant)]
                if not rs:
                    continue
                ok = [r for r in rs if not r["failed"]]
                lines.append("| %s | %s | %s | %d | %d | %d | %d | %.3f | %.2f | %.3f |" % (
                    set_name, variant, mode, len(rs), len(rs) - len(ok),
                    sum(r["lost"] for r in ok) + sum(r["frames"] or 0 for r in rs if r["failed"]),
                    sum(1 for r in rs if r["lost"] > 0 or r["failed"]),
                    median([r["ate"] for r in ok]), median([r["ate_pct"] for r in ok]),
                    median([r["rot_drift"] for r in ok])))
    text = "\n".join(lines)
    print()
    print(text)
    with open(os.path.join(out, "family_table.md"), "w") as f:
        f.write(text + "\n")
    return 0


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
    ap.add_argument("--family", choices=sorted(FAMILIES), help="run a scene family instead (see above)")
    ap.add_argument("--seeds", default="1,2,3", help="family: world seeds")
    ap.add_argument("--family-variants", default="textured,bare", help="family: textured, bare")
    ap.add_argument("--layouts", default="", help="family: only these layouts")
    ap.add_argument("--max-frames", type=int, default=0, help="family: cap every sequence (0 = whole walk)")
    ap.add_argument("--jobs", type=int, default=1, help="family: renders / runs at a time")
    ap.add_argument("--generate-args", default="",
                    help="family: extra pl_slam_generate flags, e.g. '--exposure dim --blur 1.0'")
    ap.add_argument("--threaded", action="store_true", help="family: mapping in its own thread")
    args = ap.parse_args()
    args.out_given = any(a == "--out" or a.startswith("--out=") for a in sys.argv[1:])
    if args.family:
        return run_family(args)
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
