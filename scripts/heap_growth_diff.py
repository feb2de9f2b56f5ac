#!/usr/bin/env python3
"""Compares the bytes two processes held, per call stack (scripts/heap_growth.sh).

Inputs are heaptrack_print flame-graph stack files with the "leaked" cost (frames separated by
';', the innermost last, then a space and the bytes). Stacks are keyed by their innermost
pl_slam frames (so the library internals below them merge), addresses without a symbol
become '?' (they differ between runs), and the sites whose held bytes changed most are
printed, plus the total and the bytes held in OpenCV's thread-local storage. Standard library
only; Debian's python3.

    scripts/heap_growth_diff.py EARLY_STACKS LATE_STACKS [--depth 2] [--top 25]
"""
import argparse
import collections
import re
import sys


def load(path, depth):
    sites = collections.Counter()
    tls = 0
    try:
        lines = open(path, errors="replace").read().splitlines()
    except OSError as e:
        sys.exit("heap_growth_diff.py: %s: cannot read (%s)" % (path, e))
    for line in lines:
        stack, _, count = line.rpartition(" ")
        if not stack or not count.isdigit():
            continue
        frames = [re.sub(r"0x[0-9a-f]+", "?", re.sub(r" \(.*\)$", "", f))
                  for f in stack.split(";") if f]
        ours = [f for f in frames if "pl_slam" in f or "Run(" in f]
        key = " <- ".join(reversed(ours[-depth:])) if ours else "(outside pl_slam)"
        key += "  @ " + (frames[-1][:60] if frames else "?")
        sites[key] += int(count)
        if "TLSDataContainer" in stack:
            tls += int(count)
    return sites, tls


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("early")
    ap.add_argument("late")
    ap.add_argument("--depth", type=int, default=2)
    ap.add_argument("--top", type=int, default=25)
    a = ap.parse_args()
    e, e_tls = load(a.early, a.depth)
    l, l_tls = load(a.late, a.depth)
    print("held: %.2f MB -> %.2f MB (%+.2f MB); OpenCV thread-local storage %.3f -> %.3f MB"
          % (sum(e.values()) / 2**20, sum(l.values()) / 2**20,
             (sum(l.values()) - sum(e.values())) / 2**20, e_tls / 2**20, l_tls / 2**20))
    changes = sorted(((l[k] - e[k], k) for k in set(e) | set(l)), key=lambda x: -abs(x[0]))
    print("largest changes per site (KB; a site inside a frame's detection or a local BA at")
    print("the moment of the kill shows up as noise of either sign):")
    for delta, key in changes[:a.top]:
        print("%9.1f  %s" % (delta / 1024.0, key[:300]))


if __name__ == "__main__":
    main()
