"""The results page, docs/BENCHMARKS.md: `benchmark_offline.py --page FILE` runs everything the
page needs with the binaries of the workspace and writes the page. Used by benchmark_offline.py
only; the static part (what the figures mean) is kept here, the design decisions in
bench_page_decisions.py.

    /usr/bin/python3 scripts/benchmark_offline.py --page docs/BENCHMARKS.md --jobs 2 \\
        [--family-data DIR]     # optional: reuse rendered family sequences

--sections accuracy,speed,family,street reruns only those parts (the others from the last run's
results, OUT/page_results.json); --report-only rewrites the page from those results. A workspace
built from an export of one commit (PL_SLAM_WS, with the commit in src/pl_slam/.source_commit)
is reported as that commit; otherwise the page names the commit and the uncommitted code files.

Runs, in this order (outputs under --out, default output/bench_page):
  accuracy: every sequence x {vo, map, slam}, points + lines, plus points-only and lines-only
            vo and slam; the room rendered with three laps (map, slam; memory logged);
            mapping in line (deterministic), --jobs runs at a time;
  speed:    every sequence, slam, points + lines, frames fed at the recording's rate
            (--realtime, mapping and loop closing in their threads), two runs each, one at a time;
  family:   the low-texture family (--family lowtex defaults), then again rendered dim and
            bright (--generate-args '--exposure dim|bright', points + lines) and with low
            detector thresholds (STRESS, points + lines), and at world seeds no tuning used
            (FRESH_SEEDS, points + lines), --jobs runs at a time; the line
            detectors' recall and precision against the family's structural edges
            (scripts/bench_page_lines.py);
  street:   the street family as slam and as VO, points and points + lines, --jobs runs at a
            time; pl_slam_bench_depth's disparity bias; one live run (scripts/bench_page_street.py).

--family-data DIR holds the rendered sequences of both families (lowtex_* and street_* folders).
"""
import argparse
import concurrent.futures
import csv
import datetime
import json
import os
import platform
import subprocess
import textwrap

import bench_page_decisions
import bench_page_lines
import bench_page_street

SECTIONS = ("accuracy", "speed", "family", "street")
EXPOSURES = ("dim", "bright")  # pl_slam_generate --exposure presets the family is also run at
# The low-threshold stress run: FAST 7 everywhere (default: 20, 7 only in empty cells) and the
# low-contrast line search's Canny thresholds for every segment.
STRESS = ("tracker.points.fast_threshold=7,tracker.points.min_fast_threshold=7,"
          "tracker.lines.canny_low=15,tracker.lines.canny_high=30")
# World seeds of the low-texture family that no tuning used: every layout rendered anew.
FRESH_SEEDS = "4,5,6"
# ATE targets of the low-texture family, % of the path (issue: textured and bare layouts).
ATE_TARGET_PCT = {"textured": 0.05, "bare": 0.3}


def git(*cmd):
    try:
        return subprocess.run(["git"] + list(cmd), cwd=ROOT_HOLDER[0], capture_output=True,
                              text=True, check=True).stdout.rstrip()
    except (OSError, subprocess.CalledProcessError):
        return ""


ROOT_HOLDER = [""]


def machine():
    model, mem = platform.processor() or platform.machine(), ""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem = ", %.0f GB RAM" % (int(line.split()[1]) / 1024.0 / 1024.0)
                    break
    except OSError:
        pass
    osname = ""
    try:
        with open("/etc/os-release") as f:
            for line in f:
                if line.startswith("PRETTY_NAME="):
                    osname = ", " + line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return "%s, %d cores%s%s" % (model, os.cpu_count() or 0, mem, osname)


def length(m, metres=None):
    """A length in mm, or in m (metres=True, or None and at least 10 cm)."""
    if m != m:
        return "-"
    return "%.3f m" % m if (m >= 0.1 if metres is None else metres) else "%.1f mm" % (1000.0 * m)


def unit(rs):
    """Metres for a row when one of its results is at least 10 cm."""
    return any(r and "failed" not in r and r["coverage"] >= 0.5 and r["ate"] >= 0.1 for r in rs)


def pct(v):
    return "-" if v != v else "%.2f%%" % v


def ms(v):
    return "-" if v != v else "%.1f" % v


def cell(r, drift=True, metres=None):
    """ATE (drift) of one result, with coverage when frames were lost."""
    if r is None:
        return "-"
    if "failed" in r:
        return "failed"
    if r["coverage"] < 0.5:
        return "lost (%.0f%% of frames tracked)" % (100 * r["coverage"])
    text = length(r["ate"], metres)
    if drift and r["drift"] == r["drift"]:
        text += " (%s)" % pct(r["drift"])
    if r["coverage"] < 0.999:
        text += ", %.0f%% of frames" % (100 * r["coverage"])
    return text


def make_page(args, bo):
    ROOT_HOLDER[0] = bo.ROOT
    t0 = datetime.datetime.now(datetime.timezone.utc)
    out = args.out if args.out_given else os.path.join(bo.ROOT, "output", "bench_page")
    saved = os.path.join(out, "page_results.json")
    if args.report_only:  # rewrite the page from the last run's results
        with open(saved) as f:
            r = json.load(f)
        acc = {tuple(k.split("|")): v for k, v in r["acc"].items()}
        write_page(args, bo, datetime.datetime.fromisoformat(r["t0"]),
                   datetime.datetime.fromisoformat(r["t1"]), r["load"], r["seqs"], r["main"],
                   r["mode_seqs"], acc, r["speed"], r["skipped"], r["fam_header"], r["fam_runs"],
                   r["fam_summary"], out, r.get("jobs", 2), r.get("times", {}), r.get("street"),
                   r.get("took", {}), r.get("rerun", []), r.get("exposure"), r.get("lines"),
                   r.get("source"))
        print("wrote %s from %s" % (args.page, saved))
        return 0
    # --sections reruns only some parts; the others come from the last run's results.
    sections = set(filter(None, args.sections.split(","))) or set(SECTIONS)
    if sections - set(SECTIONS):
        raise SystemExit("unknown --sections %s (%s)" % (",".join(sections - set(SECTIONS)),
                                                         ",".join(SECTIONS)))
    prev = None
    if sections != set(SECTIONS):
        if not os.path.isfile(saved):
            raise SystemExit("--sections needs an earlier full run's %s" % saved)
        with open(saved) as f:
            prev = json.load(f)
    times = dict(prev.get("times", {})) if prev else {}
    # Minutes per section, and the sections rerun on their own after the last full run.
    took = dict(prev.get("took", {})) if prev else {}
    rerun = sorted(set(prev.get("rerun", [])) | sections) if prev else []

    def now():
        return datetime.datetime.now(datetime.timezone.utc).isoformat()

    def minutes(since):
        return (datetime.datetime.now(datetime.timezone.utc) -
                datetime.datetime.fromisoformat(since)).total_seconds() / 60.0

    source = binaries_source(bo)  # before the runs: the code they measure
    data = os.path.join(out, "data")
    os.makedirs(data, exist_ok=True)
    jobs = max(1, args.jobs)

    # Sequences: (key, label, folder, extra runner args).
    seqs = []
    for scene, loops in [(name, 1) for name in bo.SYNTHETIC] + [("room_x3", 3)]:
        d = os.path.join(data, scene)
        if not os.path.isdir(os.path.join(d, "mav0")):
            print("rendering synthetic %s ..." % scene, flush=True)
            cmd = [os.path.join(bo.BIN, "pl_slam_generate"), "--scene", scene.split("_x")[0],
                   "--euroc", d]
            if loops > 1:
                cmd += ["--loops", str(loops)]
            bo.run(cmd, os.path.join(out, "generate_%s.log" % scene))
        seqs.append((scene, scene, d, []))
    skipped = []
    for name, path in bo.REAL:
        if not os.path.isdir(path):
            skipped.append("%s (%s not found: real datasets live beside the repository on "
                           "developer machines only)" % (name, os.path.relpath(path, bo.ROOT)))
            print("skipped " + skipped[-1], flush=True)
            continue
        seqs.append((name, name, path, []))
        if name.startswith("kitti"):
            seqs.append((name + "_doffs1.28", name + ", `--doffs 1.28`", path, ["--doffs", "1.28"]))
    main = [s for s in seqs if s[0] != "room_x3"]
    mode_seqs = [s for s in main if "doffs" not in s[0]]
    speed_seqs = mode_seqs
    by_key = {s[0]: s for s in seqs}

    # Accuracy: mapping in line, deterministic; several runs at a time.
    acc_out = os.path.join(out, "accuracy")
    todo = [(s, v, "points_lines", []) for s in main for v in ("vo", "map", "slam")]
    todo += [(s, v, m, []) for s in mode_seqs for v in ("vo", "slam") for m in ("points", "lines")]
    todo += [(by_key["room_x3"], "map", "points_lines", []),
             (by_key["room_x3"], "slam", "points_lines", ["--memory-every", "240"])]

    def accuracy(job):
        (key, _, path, extra), variant, mode, more = job
        overrides = ",".join(filter(None, [bo.VARIANTS[variant], args.set, "mapping.threaded=false"]))
        print("accuracy: %s (%s, %s) ..." % (key, variant, mode), flush=True)
        try:
            return bo.bench(key, path, acc_out, 1, mode, overrides, False, variant, False,
                            extra + more)
        except RuntimeError as e:
            print("  FAILED: %s" % str(e).splitlines()[0], flush=True)
            return {"name": key, "variant": variant, "mode": mode, "failed": str(e)}

    if "accuracy" in sections:
        times["accuracy"] = now()
        with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
            acc = {(r["name"], r["variant"], r["mode"]): r for r in pool.map(accuracy, todo)}
        took["accuracy"] = minutes(times["accuracy"])
    else:
        acc = {tuple(k.split("|")): v for k, v in prev["acc"].items()}

    # Speed: one run at a time, frames at the recording's rate, two runs per sequence.
    speed_out = os.path.join(out, "speed")
    if "speed" in sections:
        times["speed"] = now()
    load = [os.getloadavg()[0]]
    speed = [] if "speed" in sections else prev["speed"]
    for key, label, path, extra in (speed_seqs if "speed" in sections else []):
        print("speed: %s ..." % key, flush=True)
        try:
            speed.append((label, bo.bench(key, path, speed_out, 2, "points_lines", args.set,
                                          False, "slam", True, extra)))
        except RuntimeError as e:
            print("  FAILED: %s" % str(e).splitlines()[0], flush=True)

    load = load + [os.getloadavg()[0]] if "speed" in sections else prev["load"]
    if "speed" in sections:
        took["speed"] = minutes(times["speed"])

    # The low-texture family, rendered sequences reused when given.
    fam_args = argparse.Namespace(**vars(args))
    fam_args.family, fam_args.out, fam_args.out_given = "lowtex", os.path.join(out, "family"), True
    fam_args.modes, fam_args.seeds, fam_args.family_variants = "points,points_lines", "1,2,3", "textured,bare"
    fam_args.layouts, fam_args.max_frames, fam_args.generate_args = "", 0, ""
    fam_args.threaded = False
    if "family" in sections:
        times["family"] = now()
        fam_rows, fam_header, fam_runs, fam_summary = bo.run_family(fam_args)
        # The same family dim and bright, points + lines only.
        exposure = {"normal": [r for r in fam_rows if r["mode"] == "points_lines"]}
        for preset in EXPOSURES:
            ex_args = argparse.Namespace(**vars(fam_args))
            ex_args.out = os.path.join(out, "family_" + preset)
            ex_args.modes, ex_args.generate_args = "points_lines", "--exposure " + preset
            exposure[preset] = bo.run_family(ex_args)[0]
        st_args = argparse.Namespace(**vars(fam_args))
        st_args.out, st_args.modes = os.path.join(out, "family_stress"), "points_lines"
        st_args.set = ",".join(filter(None, [args.set, STRESS]))
        exposure["stress"] = bo.run_family(st_args)[0]
        fr_args = argparse.Namespace(**vars(fam_args))
        fr_args.out, fr_args.modes = os.path.join(out, "family_fresh"), "points_lines"
        fr_args.seeds = FRESH_SEEDS
        exposure["fresh"] = bo.run_family(fr_args)[0]
        lines = bench_page_lines.run_lines(bo, out, jobs)
        took["family"] = minutes(times["family"])
    else:
        fam_header, fam_runs, fam_summary = prev["fam_header"], prev["fam_runs"], prev["fam_summary"]
        exposure, lines = prev.get("exposure"), prev.get("lines")

    # The street family (slam and VO), disparity bias and one live run.
    if "street" in sections:
        times["street"] = now()
        street = bench_page_street.run_street(args, bo, out, jobs)
        took["street"] = minutes(times["street"])
    else:
        street = prev.get("street")

    t1 = datetime.datetime.now(datetime.timezone.utc)
    if prev:  # the duration of the last full run
        t0, t1 = (datetime.datetime.fromisoformat(prev[k]) for k in ("t0", "t1"))
    failed = [k for k, r in acc.items() if "failed" in r]
    if len(failed) * 2 > len(acc) or not speed:
        print("not writing %s: %d of %d accuracy runs failed%s (broken binaries? see the "
              "offline.log files under %s)" % (args.page, len(failed), len(acc),
                                               ", no speed run succeeded" if not speed else "", out))
        return 1
    with open(saved, "w") as f:
        json.dump({"t0": t0.isoformat(), "t1": t1.isoformat(), "load": load, "seqs": seqs,
                   "main": main, "mode_seqs": mode_seqs,
                   "acc": {"|".join(k): v for k, v in acc.items()}, "speed": speed,
                   "skipped": skipped, "fam_header": fam_header, "fam_runs": fam_runs,
                   "fam_summary": fam_summary, "jobs": jobs, "times": times, "street": street,
                   "took": took, "rerun": rerun, "exposure": exposure, "lines": lines,
                   "source": source}, f, indent=1)
    write_page(args, bo, t0, t1, load, seqs, main, mode_seqs, acc, speed, skipped,
               fam_header, fam_runs, fam_summary, out, jobs, times, street, took, rerun, exposure,
               lines, source)
    print("wrote %s" % args.page)
    return 0


def binaries_source(bo):
    """Which code the workspace's binaries are: {"commit", "subject", "dirty", "exported"}. A
    workspace built from an export of one commit (git archive) says which in
    src/pl_slam/.source_commit; otherwise the binaries are the working tree's, with the
    uncommitted code files listed."""
    exported = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(bo.BIN))),
                            "src", "pl_slam", ".source_commit")
    if os.path.isfile(exported):
        with open(exported) as f:
            full = f.read().strip()
        return {"commit": git("rev-parse", "--short", full) or full[:7],
                "subject": git("log", "-1", "--format=%s", full), "dirty": [], "exported": True}
    code = ("src/", "include/", "nodes/", "config/", "vocabulary/", "CMakeLists.txt", "package.xml")
    return {"commit": git("rev-parse", "--short", "HEAD") or "unknown",
            "subject": git("log", "-1", "--format=%s"),
            "dirty": [l[3:] for l in git("status", "--porcelain").splitlines()
                      if l[3:].startswith(code)],
            "exported": False}


def write_page(args, bo, t0, t1, load, seqs, main, mode_seqs, acc, speed, skipped,
               fam_header, fam_runs, fam_summary, out, jobs, times, street=None, took=None,
               rerun=(), exposure=None, lines=None, source=None):
    # The code measured: recorded when the runs started, so --report-only names it too.
    source = source or binaries_source(bo)
    commit, subject, dirty = source["commit"], source["subject"], source["dirty"]
    page_rel = os.path.relpath(os.path.abspath(args.page), bo.ROOT)
    cmd = "/usr/bin/python3 scripts/benchmark_offline.py --page %s --jobs %d" % (page_rel, jobs)
    if args.set:
        cmd += " --set %s" % args.set
    L = []
    add = L.append
    add("# Benchmarks")
    add("")
    add("Measured accuracy and speed of pl_slam with its default configuration. This page is "
        "generated: every table below comes from one run of")
    add("")
    add("```bash")
    add(cmd)
    add("```")
    add("")
    add("which renders the synthetic sequences on first use, runs `pl_slam_offline` on every "
        "sequence and scores it with `pl_slam_evaluate` (outputs under `output/bench_page/`; "
        "`--family-data DIR` reuses already rendered low-texture and street sequences). Do not "
        "edit the tables by hand; the design decisions at the end are kept in "
        "`scripts/bench_page_decisions.py`.")
    add("")
    add("| | |")
    add("|---|---|")
    add("| machine | %s |" % machine())
    add("| date | %s |" % run_dates(t0, t1, times, took or {}, rerun))
    state = "clean" if not dirty else "uncommitted changes in %s" % ", ".join(
        "`%s`" % p for p in dirty[:6]) + (" and %d more" % (len(dirty) - 6) if len(dirty) > 6 else "")
    if len(subject) > 80:
        subject = subject[:80].rsplit(" ", 1)[0] + " ..."
    if source["exported"]:
        add("| commit | `%s` (%s); binaries built from a clean export of it |" % (
            commit, subject.replace("|", "/")[:90]))
    else:
        add("| commit | `%s` (%s); working tree %s |" % (commit, subject.replace("|", "/")[:90], state))
        add("| binaries | `%s` |" % os.path.relpath(bo.BIN, bo.ROOT))
    if args.set:
        add("| option overrides | `%s` |" % args.set)
    if skipped:
        add("| skipped | %s |" % "; ".join(skipped))
    add("")
    add("ATE: RMSE of the translation after SE(3) alignment to the ground truth. Drift: "
        "translation error in % of distance over the longest segment length (1, 2, 5 or 10 m) "
        "that fits the sequence. Variants: **vo** = visual odometry alone "
        "(`mapping.enabled=false`), **map** = with local mapping (`loop.enabled=false`), "
        "**slam** = everything. Synthetic sequences: `pl_slam_generate` defaults (752x480, "
        "noise 2 grey levels, seed 1), exact ground truth; `euroc_mh01` is frames 100-249 of "
        "EuRoC MH01, `kitti_clip_a` 51 frames of KITTI odometry (1241x376).")
    add("")

    # (a) accuracy per sequence and variant.
    add("## Accuracy")
    add("")
    add("Points + lines, mapping in line with tracking (`--set mapping.threaded=false`, "
        "deterministic). ATE, and in brackets the drift over the segment length given.")
    add("")
    add("| sequence | frames | path | VO | map | slam | drift segment | keyframes (slam) |")
    add("|---|---|---|---|---|---|---|---|")
    for key, label, _, _ in main:
        rs = [acc.get((key, v, "points_lines")) for v in ("vo", "map", "slam")]
        ok = [r for r in rs if r and "failed" not in r]
        if not ok:
            add("| %s | failed | | | | | | |" % label)
            continue
        u = unit(rs)
        add("| %s | %d | %.1f m | %s | %s | %s | %g m | %s |" % (
            label, ok[0]["frames"], ok[0]["length"], cell(rs[0], True, u), cell(rs[1], True, u),
            cell(rs[2], True, u),
            ok[0]["drift_len"], "-" if not rs[2] or "failed" in rs[2] else "%g" % rs[2]["keyframes"]))
    add("")

    # (b) points vs lines vs both.
    add("## Points, lines, both")
    add("")
    add("`--mode points | lines | points_lines`, otherwise as above. ATE; coverage where frames "
        "were lost.")
    add("")
    add("| sequence | VO points | VO lines | VO points + lines | slam points | slam lines | slam points + lines |")
    add("|---|---|---|---|---|---|---|")
    for key, label, _, _ in mode_seqs:
        rs = [acc.get((key, v, m)) for v in ("vo", "slam") for m in ("points", "lines", "points_lines")]
        u = unit(rs)
        add("| %s | %s |" % (label, " | ".join(cell(r, False, u) for r in rs)))
    add("")

    # (c) speed per stage.
    add("## Speed")
    add("")
    add("slam, points + lines, frames fed at the recording's rate (`--realtime`: 20 Hz, KITTI "
        "10 Hz) with local mapping and loop closing in their own threads on the %d cores, two "
        "runs per sequence, one at a time; the machine's load average was %s of the speed runs "
        "(on a shared machine, compare speeds within one run). Per-frame tracking time (`SlamSystem::Process`, from `timing.csv`; reading "
        "and rectifying the images excluded) and its stages, median / p95 in ms; local BA per "
        "keyframe." % (os.cpu_count() or 0, "%.1f at the start and %.1f at the end" % tuple(load[:2])
                       if len(load) > 1 else "%.1f at the start" % load[0]))
    add("")
    if speed:
        stages = [k for k in speed[0][1]["stages"]]
        add("| sequence | tracking median / p95 / IQR | %s | local BA median / p95 | keyframes dropped |" %
            " | ".join("`%s`" % s for s in stages))
        add("|---|---|%s---|---|" % ("---|" * len(stages)))
        for label, r in speed:
            add("| %s | %s / %s / %s | %s | %s / %s | %g |" % (
                label, ms(r["median_ms"]), ms(r["p95_ms"]), ms(r["spread_ms"]),
                " | ".join("%s / %s" % (ms(r["stages"].get(s, float("nan"))),
                                        ms(r["stages_p95"].get(s, float("nan")))) for s in stages),
                ms(r["ba_median"]), ms(r["ba_p95"]), r["dropped"]))
        add("")
        add("Stages: `features` detection and description in both images (in parallel), `stereo` "
            "matching, `matching` frame to frame, `motion` estimation, `keyframe` decision, "
            "`local_map` tracking against the local map, `keyframe_match` refinement against "
            "the last keyframe. Targets: tracking median <= 25 ms, p95 <= 40 ms; local BA "
            "median < 60 ms.")
    else:
        add("No speed run succeeded.")
    add("")

    # (d) loop closing.
    add("## Loop closing")
    add("")
    add("The room walked once and three times (`pl_slam_generate --scene room --loops 3`), "
        "points + lines, sequential; loops and corrections from the runner's summary.")
    add("")
    add("| sequence | frames | map ATE | slam ATE | map / slam | loops detected / corrected | "
        "global BAs merged | correction median ms | keyframes kept (inserted, culled) |")
    add("|---|---|---|---|---|---|---|---|---|")
    for key, label in (("room", "room, one lap"), ("room_x3", "room, three laps")):
        m, s = acc.get((key, "map", "points_lines")), acc.get((key, "slam", "points_lines"))
        if not m or not s or "failed" in m or "failed" in s:
            add("| %s | failed | | | | | | | |" % label)
            continue
        st = s["map"]
        add("| %s | %d | %s | %s | %.2fx | %g / %g | %g | %s | %g (%g, %g) |" % (
            label, s["frames"], length(m["ate"]), length(s["ate"]), m["ate"] / s["ate"],
            st["loops"], st["corrected"], st["global_ba"], ms(st["correction_ms"]),
            st["keyframes"], st["inserted"], st["culled"]))
    add("")

    # (e) memory.
    add("## Memory")
    add("")
    mem = os.path.join(out, "accuracy", "slam", "points_lines", "room_x3", "run0", "memory.csv")
    if os.path.isfile(mem):
        add("Room, three laps, slam, sequential (`--memory-every 240`): resident memory, heap "
            "in use and map size. Long threaded runs: [reliability.md](reliability.md).")
        add("")
        add("| frame | resident MB | heap MB | keyframes | point landmarks | line landmarks |")
        add("|---|---|---|---|---|---|")
        with open(mem) as f:
            for row in csv.DictReader(f):
                add("| %s | %.0f | %.0f | %s | %s | %s |" % (
                    row["frame"], float(row["rss_mb"]), float(row.get("heap_mb") or "nan"),
                    row["keyframes"], row["points"], row["lines"]))
    else:
        add("Not measured in this run.")
    add("")

    # (f) the low-texture family.
    add("## Low-texture family")
    add("")
    add("`--family lowtex`: six generated low-texture layouts (four for tuning, two held out: "
        "for checking, never for tuning), each textured and bare (no posters, floor tiles, "
        "ceiling grid, lights or wall seams), three world seeds; points only against points + "
        "lines, mapping in line. Lost frames: frames without a pose; of them, those with fewer "
        "than %d features with depth (points and segments with a stereo match, noise corners "
        "included: tracker.relaxed_min_inliers, the fewest inliers a counting gate accepts) held "
        "too little for any such gate. ATE over the frames with a pose (m and %% of the path); "
        "rotation drift from RPE per metre over the longest segment." % bo.FEW_WITH_DEPTH)
    add("")
    add("Summary (medians over runs; failed runs count as lost frames, not in ATE medians):")
    add("")
    L.extend(fam_summary)
    add("")
    add("<details><summary>Every run</summary>")
    add("")
    add(fam_header.replace("family lowtex: layouts ", "Layouts: ") + ".")
    add("")
    L.extend(fam_runs)
    add("")
    add("</details>")
    add("")
    L.extend(exposure_lines(bo, exposure))
    L.extend(stress_lines(bo, exposure))
    L.extend(fresh_lines(bo, exposure))
    L.extend(bench_page_lines.lines_lines(bo, lines))

    # (g) the street family.
    L.extend(bench_page_street.street_lines(bo, street))

    # (h) design decisions.
    add("## Design decisions")
    add("")
    add("What was measured when choosing the defaults, and what was tried and rejected; "
        "figures as measured for the decision (sequential runs; \"six renderings\" are the "
        "corridor rendered with seeds 1-6).")
    add("")
    for title, text in bench_page_decisions.DESIGN_DECISIONS:
        add("- **%s.** %s" % (title, text))
    add("")
    with open(args.page, "w") as f:
        f.write("\n".join(wrap(l) for l in L))


def exposure_lines(bo, exposure):
    """The low-texture family at each exposure, points + lines (Markdown lines)."""
    L = ["### Exposure", ""]
    if not exposure or any(k not in exposure for k in EXPOSURES):
        return L + ["Not measured in this run.", ""]
    L.append("The same family rendered dim (`--generate-args '--exposure dim'`: gain 0.45) and "
             "bright (`'--exposure bright'`: gain 1.4, highlights clip at 255), with the same "
             "image noise (2 grey levels), so dim halves the contrast against the noise; points "
             "+ lines only, otherwise as above (normal: the runs above). ATE target: %s%% of the "
             "path on textured runs, %s%% on bare ones." % (ATE_TARGET_PCT["textured"],
                                                          ATE_TARGET_PCT["bare"]))
    L.append("")
    L.append("| set | variant | exposure | runs | failed | lost frames (total) | runs with loss "
             "| median ATE m | median ATE % | runs over the ATE target |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    presets = ("normal",) + EXPOSURES
    for set_name in ("tuning", "held-out"):
        for variant in ("textured", "bare"):
            for preset in presets:
                rs = [r for r in exposure[preset] if r["set"] == set_name and
                      r["variant"] == variant]
                ok = [r for r in rs if not r["failed"]]
                ate = [r["ate"] for r in ok]
                ate_pct = [r["ate_pct"] for r in ok]
                L.append("| %s | %s | %s | %d | %d | %d | %d | %.3f | %.2f | %d |" % (
                    set_name, variant, preset, len(rs), len(rs) - len(ok),
                    sum(r["lost"] for r in ok) + sum(r["frames"] or 0 for r in rs if r["failed"]),
                    sum(1 for r in rs if r["lost"] > 0 or r["failed"]), bo.median(ate), bo.median(ate_pct),
                    sum(1 for r in rs if r["failed"] or not r["ate_pct"] <= ATE_TARGET_PCT[variant])))
    L.append("")
    # Every run that loses a frame at some exposure, with its lost frames at each.
    by = {p: {(r["layout"], r["variant"], r["seed"]): r for r in exposure[p]} for p in presets}
    keys = sorted(set().union(*by.values()))
    lossy = [k for k in keys if any(k in by[p] and (by[p][k]["lost"] > 0 or by[p][k]["failed"])
                                    for p in presets)]
    if lossy:
        def lost(p, k):
            r = by[p].get(k)
            return "-" if r is None else ("failed" if r["failed"] else str(r["lost"]))
        L.append("Runs losing frames at some exposure (lost frames %s): %s." % (
            " / ".join(presets), "; ".join("%s %s s%d %s" % (k[0], k[1], k[2], " / ".join(
                lost(p, k) for p in presets)) for k in lossy)))
        L.append("")
    return L


def stress_lines(bo, exposure):
    """The low-texture family with low detector thresholds against the defaults (Markdown)."""
    L = ["### Low thresholds", ""]
    if not exposure or "stress" not in exposure or "normal" not in exposure:
        return L + ["Not measured in this run.", ""]
    L.append("More, noisier features must not make the estimate worse: the family again with "
             "`--set %s` (FAST 7 in every grid cell, Canny 15 / 30 for every segment), points + "
             "lines. Target: every frame tracked, ATE within twice the default run's." % STRESS)
    L.append("")
    L.append("| set | variant | runs | failed | lost frames (total) | lost at defaults | "
             "median ATE m | at defaults | runs over 2x the default ATE |")
    L.append("|---|---|---|---|---|---|---|---|---|")
    normal = {(r["layout"], r["variant"], r["seed"]): r for r in exposure["normal"]}
    over = []
    for set_name in ("tuning", "held-out"):
        for variant in ("textured", "bare"):
            rs = [r for r in exposure["stress"] if r["set"] == set_name and
                  r["variant"] == variant]
            pairs = [(r, normal.get((r["layout"], r["variant"], r["seed"]))) for r in rs]
            pairs = [(r, n) for r, n in pairs if n is not None]
            ok = [(r, n) for r, n in pairs if not r["failed"] and not n["failed"]]
            worse = [(r, n) for r, n in ok if r["ate"] > 2.0 * n["ate"]]
            over.extend(worse)
            L.append("| %s | %s | %d | %d | %d | %d | %.3f | %.3f | %d |" % (
                set_name, variant, len(rs), sum(1 for r in rs if r["failed"]),
                sum(r["lost"] for r, _ in ok), sum(n["lost"] for _, n in ok),
                bo.median([r["ate"] for r, _ in ok]), bo.median([n["ate"] for _, n in ok]),
                len(worse) + sum(1 for r in rs if r["failed"])))
    L.append("")
    if over:
        L.append("Over twice the default ATE: %s." % "; ".join(
            "%s %s s%d %.4f against %.4f m" % (r["layout"], r["variant"], r["seed"], r["ate"],
                                               n["ate"]) for r, n in over))
        L.append("")
    return L


def fresh_lines(bo, exposure):
    """The low-texture family at world seeds no tuning used, against seeds 1-3 (Markdown)."""
    L = ["### Fresh seeds", ""]
    if not exposure or "fresh" not in exposure or "normal" not in exposure:
        return L + ["Not measured in this run.", ""]
    L.append("Every layout generated again from world seeds %s (no option was tuned on them), "
             "points + lines, otherwise as above; seeds 1-3: the runs above. ATE target: %s%% of "
             "the path on textured runs, %s%% on bare ones." % (
                 FRESH_SEEDS, ATE_TARGET_PCT["textured"], ATE_TARGET_PCT["bare"]))
    L.append("")
    L.append("| set | variant | seeds | runs | failed | lost frames (total) | runs with loss | "
             "median ATE m | median ATE % | runs over the ATE target |")
    L.append("|---|---|---|---|---|---|---|---|---|---|")
    misses = []
    for set_name in ("tuning", "held-out"):
        for variant in ("textured", "bare"):
            for label, runs in (("1-3", exposure["normal"]), (FRESH_SEEDS, exposure["fresh"])):
                rs = [r for r in runs if r["set"] == set_name and r["variant"] == variant]
                ok = [r for r in rs if not r["failed"]]
                over = [r for r in rs
                        if r["failed"] or not r["ate_pct"] <= ATE_TARGET_PCT[variant]]
                if runs is exposure["fresh"]:
                    misses.extend(over)
                L.append("| %s | %s | %s | %d | %d | %d | %d | %.3f | %.2f | %d |" % (
                    set_name, variant, label, len(rs), len(rs) - len(ok),
                    sum(r["lost"] for r in ok) + sum(r["frames"] or 0 for r in rs if r["failed"]),
                    sum(1 for r in rs if r["lost"] > 0 or r["failed"]),
                    bo.median([r["ate"] for r in ok]), bo.median([r["ate_pct"] for r in ok]),
                    len(over)))
    L.append("")
    if misses:
        L.append("Fresh-seed runs over the ATE target (lost frames, ATE): %s." % "; ".join(
            "%s %s s%d %s" % (r["layout"], r["variant"], r["seed"], "failed" if r["failed"] else
                              "%d, %.3f m (%.2f%%)" % (r["lost"], r["ate"], r["ate_pct"]))
            for r in sorted(misses, key=lambda r: (r["layout"], r["variant"], r["seed"]))))
        L.append("")
    return L


def run_dates(t0, t1, times, took, rerun):
    """When the sections ran and how long the full run (and each section rerun on its own) took."""
    when = [(k, datetime.datetime.fromisoformat(times[k])) for k in SECTIONS if k in times]
    fmt = "%H:%M" if len({w.strftime("%Y-%m-%d") for _, w in when}) <= 1 else "%Y-%m-%d %H:%M"
    if len({w.strftime("%H:%M") for _, w in when}) > 1:
        date = "%s UTC (%s runs started at %s)" % (
            when[0][1].strftime("%Y-%m-%d"), ", ".join(k for k, _ in when),
            ", ".join(w.strftime(fmt) for _, w in when))
    else:
        date = t0.strftime("%Y-%m-%d %H:%M") + " UTC"
    date += "; the full run took %.0f minutes with every sequence already rendered" % (
        (t1 - t0).total_seconds() / 60.0)
    again = ["%s (%s)" % (k, "%.0f minutes" % took[k] if k in took else "time not recorded")
             for k in SECTIONS if k in rerun]
    if again:
        date += "; rerun on their own: " + ", ".join(again)
    return date


def wrap(line):
    """Prose at 100 columns; tables, code, headings and list items' first lines as they are."""
    if len(line) <= 100 or line.startswith(("|", "#", "/usr", "<", "```")):
        return line
    indent = "  " if line.startswith("- ") else ""
    # Never start a line with "+", "-" or "->" (Markdown would read a list item): glue such
    # tokens to the next word.
    glued = "".join(w + ("\0" if w in ("+", "-", "->", "+-") else " ") for w in line.split())
    return textwrap.fill(glued, 100, subsequent_indent=indent, break_long_words=False,
                         break_on_hyphens=False).replace("\0", " ")
