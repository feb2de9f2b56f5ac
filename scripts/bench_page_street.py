"""The street section of the results page (docs/BENCHMARKS.md): forward driving. Used by
bench_page.py only (`benchmark_offline.py --page FILE [--sections street]`).

Runs (outputs under OUT/street):
  family: the street family (benchmark_offline.py --family street: three tuning and two held-out
          layouts, world seeds 1,2,3), points only and points + lines, once as slam (the
          defaults, OUT/street/slam) and once as VO (mapping.enabled=false, OUT/street/vo),
          mapping in line, --jobs runs at a time; both share the renders (--family-data DIR,
          PL_SLAM_FAMILY_DATA or OUT/street/data);
  depth:  pl_slam_bench_depth, signed disparity error per feature type and depth bin, on the
          street drives (DEPTH_FRAMES frames per drive) and on the KITTI 2015 pair of
          ../shared/datasets/stereo_disparity_gt (skipped with a message when absent);
  live:   street_straight seed 1, slam, points + lines, frames fed at the recording's rate
          (--realtime, mapping in its own thread), one run.

The targets (forward driving) are checked on every run, tuning and held-out layouts apart; the
page lists every run that misses one, with its figures.
"""
import argparse
import datetime
import os
import re
import subprocess

FAMILY = "street"
# (name on the page, extra --set options): the systems compared.
SYSTEMS = (("slam", ""), ("VO", "mapping.enabled=false"))
MODES = ("points_lines", "points")
MODE_LABEL = {"points_lines": "points + lines", "points": "points only"}
SEEDS = "1,2,3"
SCALE_TOL = 0.001  # Sim3 scale within 0.1 % of 1
DRIFT_MAX = 0.5  # translation drift, % of distance over the longest segment
SPEED_MEDIAN_MAX = 25.0  # tracking median, ms
DEPTH_FRAMES = 10  # frames per drive scored by pl_slam_bench_depth (its default is 20)
LIVE = ("street_straight", 1)
ATE = "%.4f"  # metres
FEATURES = ("points, one surface", "points near an occlusion", "line endpoints, steep",
            "line endpoints, shallow", "line endpoints, flat")


def fmt(v, pattern):
    return "-" if v != v else pattern % v


def unrendered(data_root, layouts, seeds):
    """How many of the family's sequences are not rendered yet."""
    return sum(1 for l in layouts for s in seeds
               if not os.path.isdir(os.path.join(data_root, "%s_default_s%d" % (l, s), "mav0")))


def run_family(args, bo, out, jobs, data_root):
    """Every street run as slam and as VO: family_run rows with "system" added."""
    rows = []
    for system, extra in SYSTEMS:
        fam = argparse.Namespace(**vars(args))
        fam.family, fam.out, fam.out_given = FAMILY, os.path.join(out, system.lower()), True
        fam.modes, fam.seeds, fam.family_variants = ",".join(MODES), SEEDS, "default"
        fam.layouts, fam.max_frames, fam.generate_args = "", 0, ""
        fam.threaded, fam.jobs, fam.family_data = False, jobs, data_root
        fam.set = ",".join(filter(None, [args.set, extra]))
        print("street family, %s ..." % system, flush=True)
        for r in bo.run_family(fam)[0]:
            r["system"] = system
            rows.append(r)
    return rows


def run_depth(bo, out):
    """pl_slam_bench_depth's Markdown on the streets and on the KITTI 2015 pair."""
    family = bo.FAMILIES[FAMILY]
    tool = os.path.join(bo.BIN, "pl_slam_bench_depth")
    res = {"frames": DEPTH_FRAMES, "street": "", "kitti": "", "kitti_skipped": ""}

    def markdown(cmd, name):
        print("depth: %s ..." % name, flush=True)
        with open(os.path.join(out, "depth_%s.log" % name), "w") as log:
            r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=log, text=True)
        if r.returncode != 0:
            return "`%s` failed (exit %d; see %s)." % (os.path.basename(tool), r.returncode,
                                                       os.path.join(out, "depth_%s.log" % name))
        return r.stdout

    res["street"] = markdown([tool, "--street", ",".join(family["tuning"] + family["held_out"]),
                              "--seeds", SEEDS, "--frames", str(DEPTH_FRAMES)], "street")
    gt = os.path.join(bo.SHARED, "stereo_disparity_gt")
    if os.path.isdir(gt):
        res["kitti"] = markdown([tool, "--gt", gt], "kitti")
    else:
        res["kitti_skipped"] = ("KITTI 2015 pair skipped: %s not found (real datasets live "
                                "beside the repository on developer machines only)" %
                                os.path.relpath(gt, bo.ROOT))
        print(res["kitti_skipped"], flush=True)
    return res


def run_live(args, bo, out, data_root):
    """One --realtime run (mapping threaded) of street_straight seed 1: bench()'s result."""
    layout, seed = LIVE
    name = "%s_s%d" % (layout, seed)
    print("street live: %s ..." % name, flush=True)
    load = os.getloadavg()[0]
    try:
        r = bo.bench(name, os.path.join(data_root, "%s_default_s%d" % (layout, seed)),
                     os.path.join(out, "live"), 1, "points_lines", args.set, False, "slam", True)
    except RuntimeError as e:
        print("  FAILED: %s" % str(e).splitlines()[0], flush=True)
        return {"name": name, "failed": str(e).splitlines()[0], "load": [load]}
    r["load"] = [load, os.getloadavg()[0]]
    with open(os.path.join(r["dir"], "offline.log")) as f:
        found = re.search(r" (\d+x\d+), fx=", f.read())
    r["resolution"] = found.group(1) if found else ""
    return r


def run_street(args, bo, out, jobs):
    """Everything the street section shows (JSON-able)."""
    out = os.path.join(out, FAMILY)
    os.makedirs(out, exist_ok=True)
    family = bo.FAMILIES[FAMILY]
    data_root = (args.family_data or os.environ.get("PL_SLAM_FAMILY_DATA")
                 or os.path.join(out, "data"))
    t0 = datetime.datetime.now(datetime.timezone.utc)
    to_render = unrendered(data_root, family["tuning"] + family["held_out"],
                           [int(s) for s in SEEDS.split(",")])
    rows = run_family(args, bo, out, jobs, data_root)
    depth = run_depth(bo, out)
    live = run_live(args, bo, out, data_root)
    minutes = (datetime.datetime.now(datetime.timezone.utc) - t0).total_seconds() / 60.0
    return {"rows": rows, "depth": depth, "live": live, "minutes": minutes,
            "to_render": to_render, "jobs": jobs, "tuning": family["tuning"],
            "held_out": family["held_out"], "evaluate_args": family.get("evaluate_args", [])}


# ---- the page's text --------------------------------------------------------------------


def run_name(r):
    return "%s s%d" % (r["layout"], r["seed"])


def config(system, mode):
    return "%s, %s" % (system, MODE_LABEL[mode])


def ok(r):
    return r is not None and not r["failed"]


def target_rows(bo, rows, set_name):
    """Table rows and misses (lines) of the four targets on one set of layouts."""
    table, misses = [], []
    by = {(r["system"], r["mode"], r["layout"], r["seed"]): r for r in rows if r["set"] == set_name}
    runs = sorted({(r["layout"], r["seed"]) for r in rows if r["set"] == set_name})

    def add(target, what, meeting, total, figures, verdict, missed):
        table.append("| %s | %s | %s | %d / %d | %s | %s |" % (
            set_name, target, what, meeting, total, figures, verdict))
        if missed:
            misses.append("- %s, %s, %s: %s." % (set_name, target, what, "; ".join(missed)))

    for target, key, good, pattern in (
            ("Sim3 scale within %g%% of 1" % (100 * SCALE_TOL), "sim3_scale",
             lambda v: abs(v - 1.0) <= SCALE_TOL, "%.5f"),
            ("drift under %g%% of distance" % DRIFT_MAX, "drift_pct", lambda v: v < DRIFT_MAX,
             "%.3f%%")):
        for system, _ in SYSTEMS:
            for mode in MODES:
                rs = [by.get((system, mode) + k) for k in runs]
                rs = [r for r in rs if r is not None]
                if not rs:
                    continue
                meet = [r for r in rs if ok(r) and r[key] == r[key] and good(r[key])]
                scored = [r for r in rs if ok(r) and r[key] == r[key]]
                dev = (lambda r: abs(r[key] - 1.0)) if key == "sim3_scale" else (lambda r: r[key])
                worst = max(scored, key=dev) if scored else None
                figures = ("worst %s (%s)" % (pattern % worst[key], run_name(worst))
                           if worst else "-")
                missed = [run_name(r) + " " + (pattern % r[key] if ok(r) and r[key] == r[key]
                                               else "failed") for r in rs if r not in meet]
                verdict = "missed: %d outside" % (len(rs) - len(meet)) if missed else "met"
                add(target, config(system, mode), len(meet), len(rs), figures, verdict, missed)

    comparisons = [("slam ATE <= VO ATE, lower median", MODE_LABEL[m], ("slam", m), ("VO", m))
                   for m in MODES]
    comparisons += [("points + lines ATE <= points only ATE, lower median", s,
                     (s, "points_lines"), (s, "points")) for s, _ in SYSTEMS]
    for target, what, a_key, b_key in comparisons:
        pairs = [(k, by.get(a_key + k), by.get(b_key + k)) for k in runs]
        pairs = [p for p in pairs if p[1] is not None and p[2] is not None]
        if not pairs:
            continue
        meet = {k for k, a, b in pairs if ok(a) and (not ok(b) or a["ate"] <= b["ate"])}
        med_a = bo.median([a["ate"] for _, a, _ in pairs if ok(a)])
        med_b = bo.median([b["ate"] for _, _, b in pairs if ok(b)])
        better = med_a < med_b
        figures = "median %s against %s m" % (fmt(med_a, ATE), fmt(med_b, ATE))
        missed = ["%s %s against %s m" % (run_name(a), fmt(a["ate"], ATE) if ok(a) else "failed",
                                          fmt(b["ate"], ATE) if ok(b) else "failed")
                  for k, a, b in pairs if k not in meet]
        why = (["%d worse" % (len(pairs) - len(meet))] if len(meet) < len(pairs) else []) + (
            [] if better else ["median not lower"])
        verdict = "missed: " + ", ".join(why) if why else "met"
        if not better:
            missed.append("median %s against %s m" % (fmt(med_a, ATE), fmt(med_b, ATE)))
        add(target, what, len(meet), len(pairs), figures, verdict, missed)
    return table, misses


def longest_segment(evaluate_args):
    """The longest RPE segment the family's pl_slam_evaluate flags ask for ("100 m")."""
    args = list(evaluate_args)
    if "--rpe-lengths" in args[:-1]:
        return args[args.index("--rpe-lengths") + 1].split(",")[-1] + " m"
    return "longest segment"


def per_run_lines(rows, evaluate_args):
    """The every-run table."""
    order = {s: i for i, (s, _) in enumerate(SYSTEMS)}
    lines = ["| set | layout | seed | mode | system | frames | lost | path m | ATE m (SE3) | "
             "Sim3 scale | drift %% (%s) | rot drift deg/m |" % longest_segment(evaluate_args),
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["set"] != "tuning", r["layout"], r["seed"],
                                         MODES.index(r["mode"]), order[r["system"]])):
        head = "| %s | %s | %d | %s | %s | %d | %d |" % (
            r["set"], r["layout"], r["seed"], MODE_LABEL[r["mode"]], r["system"], r["frames"],
            r["lost"])
        if r["failed"]:
            lines.append(head + " - | FAILED: %s | | | |" % r["failed"].replace("|", "/"))
            continue
        lines.append(head + " %.1f | %s | %s | %s | %s |" % (
            r["length"], fmt(r["ate"], ATE), fmt(r["sim3_scale"], "%.5f"),
            fmt(r["drift_pct"], "%.3f"), fmt(r["rot_drift"], "%.4f")))
    return lines


def depth_blocks(text):
    """pl_slam_bench_depth's output as [(scene heading, preamble, [(feature, table lines)])]."""
    blocks = []
    for line in text.splitlines():
        if line.startswith("## "):
            blocks.append([line[3:].strip(), [], []])
        elif not blocks:
            continue
        elif line.startswith("### "):
            blocks[-1][2].append([line[4:].strip(), []])
        elif blocks[-1][2]:
            blocks[-1][2][-1][1].append(line)
        elif line.strip():
            blocks[-1][1].append(line)
    return blocks


def depth_summary(blocks):
    """One row per scene and feature type: pl_slam_bench_depth's all-depths row."""
    lines = ["| scene | feature | n | median err px | robust sigma px | > 1 px from median | "
             "depth bias (median) | error model (within 1 px of the median) |",
             "|---|---|---|---|---|---|---|---|"]
    for scene, _, features in blocks:
        for title, body in features:
            if not title.startswith(FEATURES):
                continue
            cells = next((l.strip("|").split("|") for l in body if l.startswith("| **all**")), None)
            model = next((l.split(":", 1)[1].strip() for l in body
                          if l.startswith("error model")), "-")
            if not cells or len(cells) < 9:
                continue
            c = [x.strip() for x in cells]
            lines.append("| %s | %s | %s | %s | %s | %s | %s%% | %s |" % (
                scene, title.split(" (")[0], c[1], c[4], c[5], c[6], c[8], model))
    return lines if len(lines) > 2 else []


def depth_details(blocks, keep):
    """The full tables of the scenes whose heading starts with one of keep."""
    lines = []
    for scene, preamble, features in blocks:
        if not scene.startswith(keep):
            continue
        lines += ["#### " + scene, ""] + preamble + [""]
        for title, body in features:
            body = [l for i, l in enumerate(body) if l.strip() or (i and body[i - 1].strip())]
            lines += ["**%s**" % title, ""] + body + ([""] if body and body[-1].strip() else [])
    return lines


def depth_lines(depth):
    """The disparity bias subsection."""
    L = ["### Disparity bias", ""]
    street, kitti = depth_blocks(depth["street"]), depth_blocks(depth["kitti"])
    first = next((l for l in (depth["street"] + "\n").splitlines() if l.strip()), "")
    L += ["`pl_slam_bench_depth --street <the five layouts> --seeds %s --frames %d` (frames "
          "spread evenly over each drive) and `pl_slam_bench_depth --gt "
          "../shared/datasets/stereo_disparity_gt` (the KITTI 2015 pair with its ground-truth "
          "disparities): the stereo matcher's disparity against the true one at every scored "
          "feature. %s" % (SEEDS, depth["frames"],
                           first if not first.startswith(("#", "|")) else ""), ""]
    if depth["kitti_skipped"]:
        L += [depth["kitti_skipped"] + ".", ""]
    summary = depth_summary([b for b in street if b[0].startswith("street scenes")] + kitti)
    if not street or not summary:  # an output this page cannot read: as printed
        return L + ["```", depth["street"].strip(), depth["kitti"].strip(), "```", ""]
    pair = ", and the KITTI 2015 pair" if kitti else ""
    L += ["All depths (the street drives pooled%s):" % pair, ""] + summary + [""]
    L += ["<details><summary>Per depth bin: the street drives pooled%s</summary>" % (
        ", the KITTI 2015 pair" if kitti else ""), ""]
    L += depth_details(street, ("street scenes",)) + depth_details(kitti, ("",))
    L += ["</details>", "", "<details><summary>Per street layout (all depths)</summary>", ""]
    L += depth_summary([b for b in street if not b[0].startswith("street scenes")])
    L += ["", "</details>", ""]
    return L


def live_lines(live):
    """The threaded speed run."""
    L = ["### Tracking time, live", ""]
    if "failed" in live:
        return L + ["The `--realtime` run of %s failed: %s" % (live["name"], live["failed"]), ""]
    load = live["load"]
    L += ["One run of %s (slam, points + lines, defaults) with frames fed at the recording's rate "
          "(`--realtime`) and local mapping and loop closing in their own threads, on a shared "
          "machine with %d cores (load average %s): one run, not a distribution over runs. The "
          "family runs above map in line, so their tracking times are not live figures." % (
              "%s seed %d" % LIVE, os.cpu_count() or 0,
              "%.1f at the start, %.1f at the end" % tuple(load[:2]) if len(load) > 1
              else "%.1f" % load[0]), ""]
    L += ["| sequence | resolution | frames | tracking median / p95 ms | `features` median / p95 "
          "| local BA median / p95 ms | keyframes dropped | ATE m (SE3) | target: median <= %g ms |"
          % SPEED_MEDIAN_MAX, "|---|---|---|---|---|---|---|---|---|"]
    st, st95 = live["stages"].get("features", float("nan")), live["stages_p95"].get(
        "features", float("nan"))
    L.append("| %s | %s | %d | %s / %s | %s / %s | %s / %s | %g | %s | %s |" % (
        live["name"], live.get("resolution") or "-", live["frames"], fmt(live["median_ms"], "%.1f"),
        fmt(live["p95_ms"], "%.1f"), fmt(st, "%.1f"), fmt(st95, "%.1f"),
        fmt(live["ba_median"], "%.1f"), fmt(live["ba_p95"], "%.1f"), live["dropped"],
        fmt(live["ate"], ATE),
        "met" if live["median_ms"] <= SPEED_MEDIAN_MAX else "missed (%.1f ms)" % live["median_ms"]))
    return L + [""]


def lost_line(rows):
    """The runs with frames without a pose (or failed)."""
    lost = ["%s (%s): %s" % (run_name(r), config(r["system"], r["mode"]), "failed" if r["failed"]
                             else "%d of %d" % (r["lost"], r["frames"]))
            for r in rows if r["lost"] or r["failed"]]
    return "Lost frames: %s." % ("; ".join(lost) if lost else
                                 "none; every run has a pose for every frame")


def street_lines(bo, street):
    """The street section of the page (Markdown lines); street is run_street's result."""
    L = ["## Street family", ""]
    if not street:
        return L + ["Not in the saved results; `--sections street` runs it.", ""]
    rows = street["rows"]
    n_runs = len({(r["layout"], r["seed"]) for r in rows})
    L += ["`--family street`: generated forward drives rendered with KITTI's camera, %s for "
          "tuning and %s held out (for checking, never for tuning), world seeds %s: %d drives, "
          "each run four ways: slam (defaults) and VO (`--set mapping.enabled=false`), points + "
          "lines and points only (`--mode points`); mapping in line (deterministic). ATE after "
          "SE(3) alignment; Sim3 scale: the scale of the similarity alignment; drift: RPE "
          "translation in %% of distance over the longest segment (`%s`); lost: frames without "
          "a pose. These %d runs, the disparity bias and the live run took %.0f minutes, "
          "%d runs at a time, %s." % (
              ", ".join(street["tuning"]), ", ".join(street["held_out"]), SEEDS, n_runs,
              " ".join(street["evaluate_args"]) or "pl_slam_evaluate defaults", len(rows),
              street["minutes"], street["jobs"],
              "every drive already rendered" if not street["to_render"]
              else "%d drives rendered first" % street["to_render"]), ""]
    L += ["Targets, on every run: Sim3 scale within %g%% of 1; drift under %g%% of distance; "
          "slam no worse than VO (ATE), better on the median; points + lines no worse than "
          "points only, better on the median. Runs meeting each, tuning and held-out layouts "
          "apart:" % (100 * SCALE_TOL, DRIFT_MAX), ""]
    L += ["| set | target | configuration | runs meeting | figures | verdict |",
          "|---|---|---|---|---|---|"]
    misses = []
    for set_name in ("tuning", "held-out"):
        t, m = target_rows(bo, rows, set_name)
        L += t
        misses += m
    L += [""]
    L += (["Misses (run, figure):", ""] + misses if misses else ["Every run meets every target."])
    L += [""]
    L += [lost_line(rows), ""]
    L += ["<details><summary>Every run</summary>", ""]
    L += per_run_lines(rows, street["evaluate_args"])
    L += ["", "</details>", ""]
    L += depth_lines(street["depth"])
    L += live_lines(street["live"])
    return L
