#!/usr/bin/python3
"""ATE of option variants over several renderings (seeds) of one synthetic scene.

One rendering is one draw of the image noise and texture; a difference between two variants
that does not hold over several seeds is noise. Usage, from the repository root after a build:

  /usr/bin/python3 tools/experiments/seed_sweep.py --scene corridor --seeds 1-6 \\
      --variant vo=mapping.enabled=false,loop.enabled=false \\
      --variant map=mapping.threaded=false,loop.enabled=false

Renderings go to output/seeds/<scene>_s<seed> (made when missing), runs to
output/seeds/runs/<variant>_<seed>. Prints the SE(3)-aligned ATE (mm) per seed and the mean.
"""
import argparse
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from benchmark_offline import BIN, run  # noqa: E402  (the benchmark's binaries and runner)


def seeds_of(text):
    out = []
    for part in text.split(","):
        if "-" in part:
            a, b = part.split("-")
            out.extend(range(int(a), int(b) + 1))
        else:
            out.append(int(part))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scene", default="corridor", choices=["room", "corridor", "fast_turn"])
    ap.add_argument("--seeds", default="1-6", help="e.g. 1-6 or 1,3,5")
    ap.add_argument("--variant", action="append", required=True,
                    help="NAME=K=V[,K=V...]: options given to pl_slam_offline --set")
    ap.add_argument("--out", default=os.path.join(ROOT, "output", "seeds"))
    args = ap.parse_args()
    for tool in ("pl_slam_generate", "pl_slam_offline", "pl_slam_evaluate"):
        if not os.path.exists(os.path.join(BIN, tool)):
            sys.exit("seed_sweep: %s not built in %s (run scripts/setup.sh)" % (tool, BIN))
    variants = []
    for v in args.variant:
        if "=" not in v:
            sys.exit("seed_sweep: --variant %r must be NAME=K=V[,K=V...]" % v)
        name, sets = v.split("=", 1)
        variants.append((name, sets))
    try:
        sweep(args, variants, seeds_of(args.seeds))
    except RuntimeError as e:  # a tool failed; run() put the command and its log tail in e
        sys.exit("seed_sweep: %s" % e)


def sweep(args, variants, seeds):
    os.makedirs(os.path.join(args.out, "runs"), exist_ok=True)
    ate_re = re.compile(r"ATE SE3\s+rmse\s+([0-9.eE+-]+) m")
    print("%-12s %s   mean" % ("variant", " ".join("s%-5d" % s for s in seeds)))
    for name, sets in variants:
        values = []
        for s in seeds:
            data = os.path.join(args.out, "%s_s%d" % (args.scene, s))
            if not os.path.isdir(os.path.join(data, "mav0")):
                run([os.path.join(BIN, "pl_slam_generate"), "--scene", args.scene, "--seed",
                     str(s), "--euroc", data], data + ".log")
            out = os.path.join(args.out, "runs", "%s_%d" % (name, s))
            run([os.path.join(BIN, "pl_slam_offline"), data, "--out", out, "--quiet", "--set",
                 sets], out + ".log")
            report = subprocess.run(
                [os.path.join(BIN, "pl_slam_evaluate"), "--est", out + "/trajectory.tum", "--gt",
                 out + "/groundtruth.tum"], capture_output=True, text=True).stdout
            m = ate_re.search(report)
            if not m:
                sys.exit("seed_sweep: no ATE in the evaluation of %s" % out)
            values.append(float(m.group(1)) * 1e3)
        print("%-12s %s   %.2f" % (name, " ".join("%-6.1f" % v for v in values),
                                    sum(values) / len(values)))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
