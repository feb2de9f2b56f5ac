#!/usr/bin/env python3
"""Judges a soak run (scripts/soak.sh): reads DIR/memory.csv (pl_slam_offline --memory-every)
and DIR/frames.txt + DIR/trajectory.tum, prints the table for docs/reliability.md and fails
(exit 1) when
  - resident memory did not plateau: over the second half of the run it grew by more than 5%
    of its value at the half-way point,
  - the mapping queue exceeded its bound (mapping.queue_size, 4 by default),
  - a frame has no pose (coverage below 100%).
Standard library only; Debian's python3.

    scripts/soak_report.py OUTPUT_DIR [--queue-size N] [--max-growth 0.05]
"""
import argparse
import csv
import os
import sys


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--queue-size", type=int, default=4)
    ap.add_argument("--max-growth", type=float, default=0.05)
    a = ap.parse_args()
    path = os.path.join(a.out, "memory.csv")
    try:
        with open(path) as f:
            rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]
    except (OSError, ValueError, KeyError) as e:
        sys.exit("soak_report.py: %s: cannot read (%s)" % (path, e))
    if len(rows) < 4:
        sys.exit("soak_report.py: %s: %d rows, need at least 4" % (path, len(rows)))
    heap = all("heap_mb" in r for r in rows)
    print("| frame | resident MB |%s keyframes | point landmarks | line landmarks | culled keyframes | mapping queue |"
          % (" heap in use MB |" if heap else ""))
    print("|---|---|%s---|---|---|---|---|" % ("---|" if heap else ""))
    for r in rows:
        print("| %d | %.1f |%s %d | %d | %d | %d | %d |" % (
            r["frame"], r["rss_mb"], (" %.1f |" % r["heap_mb"]) if heap else "", r["keyframes"],
            r["points"], r["lines"], r["culled_keyframes"], r["mapping_queue"]))
    half = rows[len(rows) // 2 - 1]
    last = rows[-1]
    growth = (last["rss_mb"] - half["rss_mb"]) / half["rss_mb"]
    kf_growth = (last["keyframes"] - half["keyframes"]) / max(1.0, half["keyframes"])
    max_queue = max(r["mapping_queue"] for r in rows)
    with open(os.path.join(a.out, "frames.txt")) as f:
        frames = sum(1 for line in f if line.strip())
    with open(os.path.join(a.out, "trajectory.tum")) as f:
        posed = sum(1 for line in f if line.strip() and not line.startswith("#"))
    print()
    print("second half (frames %d -> %d): resident memory %+.1f%% (%.1f -> %.1f MB), keyframes %+.1f%% (%d -> %d)"
          % (half["frame"], last["frame"], 100 * growth, half["rss_mb"], last["rss_mb"],
             100 * kf_growth, half["keyframes"], last["keyframes"]))
    if heap:
        # One sample can land in a local BA or a loop correction (several MB of scratch), so
        # compare the lowest samples (what stays held) of the two quarters of the second half.
        second = rows[len(rows) // 2 - 1:]
        q = max(1, len(second) // 2)
        early, late = min(r["heap_mb"] for r in second[:q]), min(r["heap_mb"] for r in second[-q:])
        print("heap in use, lowest sample, first vs last quarter of the run: %.1f -> %.1f MB (%+.1f MB)"
              % (early, late, late - early))
    print("mapping queue max %d (bound %d); frames %d, with pose %d" % (max_queue, a.queue_size, frames, posed))
    failures = []
    if growth > a.max_growth:
        failures.append("resident memory grew %.1f%% over the second half (limit %.0f%%)"
                        % (100 * growth, 100 * a.max_growth))
    if max_queue > a.queue_size:
        failures.append("mapping queue reached %d (bound %d)" % (max_queue, a.queue_size))
    if posed < frames:
        failures.append("%d of %d frames without pose" % (frames - posed, frames))
    if failures:
        print("soak: FAILED: " + "; ".join(failures))
        return 1
    print("soak: passed (plateau, bounded queue, full coverage)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
