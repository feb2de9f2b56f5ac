"""The line-detection part of the results page's low-texture section (docs/BENCHMARKS.md): recall
and precision of the segment detectors against the structural edges the synthetic world knows.
Used by bench_page.py only (`benchmark_offline.py --page FILE [--sections family]`).

Runs `pl_slam_bench_lines --recall LAYOUT [--bare] --seeds 1,2,3 --exposure E` for every
low-texture layout (tuning and held out), textured and bare, at normal and dim exposure, --jobs
at a time, and tabulates its three detectors: the default edge-chain detector (with its
low-contrast search in images poor in segments and in the empty cells of the others), the same
at its normal thresholds only, and OpenCV's LSD. Outputs (the tool's Markdown per run) under OUT/lines.
"""
import concurrent.futures
import os
import re

SEEDS = "1,2,3"
EXPOSURES = ("normal", "dim")
VARIANTS = ("textured", "bare")
# The tool's detector labels, in its order, and the page's.
DETECTORS = (("edge chain (default", "edge chain (default)"),
             ("edge chain, normal thresholds only", "edge chain, normal thresholds only"),
             ("LSD", "LSD"))
ROW = re.compile(r"^\| (?P<label>[^|]+) \| (?P<frames>\d+) \| (?P<edges>\d+) \| "
                 r"(?P<recall>[\d.]+)% \| (?P<per_frame>[\d.]+) \| (?P<precision>[\d.]+)% \| "
                 r"(?P<ms_median>[\d.]+) / (?P<ms_p95>[\d.]+) \| (?P<with_depth>[\d.]+)% of "
                 r"(?P<steep>\d+) \| (?P<depth_ok>[\d.]+)% \|"
                 r"(?: (?P<offset_median>[\d.]+) / (?P<offset_p90>[\d.]+), "
                 r"(?P<offset_mean>[-+\d.]+) \|| n/a \|)?$")


def parse(text):
    """The tool's table rows: {detector: figures}, counts recovered from its percentages."""
    rows = {}
    for line in text.splitlines():
        m = ROW.match(line.strip())
        if not m:
            continue
        label = next((page for tool, page in DETECTORS if m.group("label").startswith(tool)), None)
        if label is None:
            continue
        frames, edges, steep = int(m.group("frames")), int(m.group("edges")), int(m.group("steep"))
        detections = round(float(m.group("per_frame")) * frames)
        with_depth = round(float(m.group("with_depth")) / 100.0 * steep)
        rows[label] = {
            "frames": frames, "edges": edges,
            "found": round(float(m.group("recall")) / 100.0 * edges),
            "detections": detections,
            "correct": round(float(m.group("precision")) / 100.0 * detections),
            "ms_median": float(m.group("ms_median")), "ms_p95": float(m.group("ms_p95")),
            "steep": steep, "with_depth": with_depth,
            "depth_ok": round(float(m.group("depth_ok")) / 100.0 * with_depth),
            "offset_median": float(m.group("offset_median")) if m.group("offset_median") else None,
            "offset_p90": float(m.group("offset_p90")) if m.group("offset_p90") else None,
            "offset_mean": float(m.group("offset_mean")) if m.group("offset_mean") else None}
    return rows


def run_lines(bo, out, jobs):
    """Every layout x variant x exposure: rows with set, layout, variant, exposure, detector and
    the figures of parse()."""
    family = bo.FAMILIES["lowtex"]
    layouts = [(l, "tuning") for l in family["tuning"]] + [(l, "held-out") for l in family["held_out"]]
    out = os.path.join(out, "lines")
    os.makedirs(out, exist_ok=True)
    jobs_list = [(l, s, v, e) for l, s in layouts for v in VARIANTS for e in EXPOSURES]

    def one(job):
        layout, set_name, variant, exposure = job
        cmd = [os.path.join(bo.BIN, "pl_slam_bench_lines"), "--recall", layout, "--seeds", SEEDS,
               "--exposure", exposure] + (["--bare"] if variant == "bare" else [])
        log = os.path.join(out, "%s_%s_%s.md" % (layout, variant, exposure))
        print("line detection: %s %s %s ..." % (layout, variant, exposure), flush=True)
        bo.run(cmd, log)
        with open(log) as f:
            parsed = parse(f.read())
        if len(parsed) != len(DETECTORS):
            raise RuntimeError("%s: expected %d detector rows in %s" % (" ".join(cmd),
                                                                       len(DETECTORS), log))
        return [dict(r, set=set_name, layout=layout, variant=variant, exposure=exposure,
                     detector=d) for d, r in parsed.items()]

    rows = []
    with concurrent.futures.ThreadPoolExecutor(max_workers=jobs) as pool:
        for r in pool.map(one, jobs_list):
            rows.extend(r)
    return rows


def pct(a, b):
    return "-" if b == 0 else "%.1f%%" % (100.0 * a / b)


def lines_lines(bo, rows):
    """The Markdown of the line-detection subsection."""
    L = ["### Line detection", ""]
    if not rows:
        return L + ["Not measured in this run.", ""]
    L.append("`pl_slam_bench_lines --recall LAYOUT [--bare] --seeds %s --exposure normal|dim` on "
             "every layout of the family: every 5th frame, a visible structural edge (door "
             "frames, baseboards, rails, shelves, room corners; at least the detector's minimum "
             "length) counts as found when detections within 2 px and 3 deg cover half of it, "
             "and a detection is correct when half of it lies on such an edge. Texture "
             "(posters, tiles) has no recorded edges, so precision is meaningful on the bare "
             "variant only. Detection time per image on one thread (the tracker detects the two "
             "images in parallel), median over the layouts' medians; steep: correct detections "
             "over the stereo matcher's angle limit, and how many of them got a stereo depth, "
             "within 0.5 px of the rendered disparity at both ends. Endpoint offset: how far "
             "the correct detections' endpoints lie from their edge's line (median and 90th "
             "percentile of the size, mean signed towards the edge's brighter side), the median "
             "over the layouts' figures." % SEEDS)
    L.append("")
    L.append("| set | variant | exposure | detector | edges | recall | detections / frame | "
             "precision | ms / image | steep with stereo depth | depth within 0.5 px | "
             "endpoint offset, px |")
    L.append("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for set_name in ("tuning", "held-out"):
        for variant in VARIANTS:
            for exposure in EXPOSURES:
                for _, detector in DETECTORS:
                    rs = [r for r in rows if r["set"] == set_name and r["variant"] == variant and
                          r["exposure"] == exposure and r["detector"] == detector]
                    if not rs:
                        continue

                    def total(k):
                        return sum(r[k] for r in rs)

                    def med(k):
                        v = [r[k] for r in rs if r.get(k) is not None]
                        return bo.median(v) if v else None

                    offset = ("-" if med("offset_median") is None else "%.2f / %.2f, %+.2f" % (
                        med("offset_median"), med("offset_p90"), med("offset_mean")))
                    L.append("| %s | %s | %s | %s | %d | %s | %.1f | %s | %.2f | %s | %s | %s |" % (
                        set_name, variant, exposure, detector, total("edges"),
                        pct(total("found"), total("edges")),
                        total("detections") / max(1, total("frames")),
                        pct(total("correct"), total("detections")),
                        bo.median([r["ms_median"] for r in rs]),
                        pct(total("with_depth"), total("steep")),
                        pct(total("depth_ok"), total("with_depth")), offset))
    L.append("")
    # Where the default finds fewer edges than LSD: layout by layout.
    by = {}
    for r in rows:
        by.setdefault((r["layout"], r["variant"], r["exposure"]), {})[r["detector"]] = r
    default, lsd = DETECTORS[0][1], DETECTORS[2][1]
    below = ["%s %s %s %s against %s" % (k[0], k[1], k[2],
                                         pct(d[default]["found"], d[default]["edges"]),
                                         pct(d[lsd]["found"], d[lsd]["edges"]))
             for k, d in sorted(by.items()) if default in d and lsd in d and
             d[default]["found"] < d[lsd]["found"]]
    L.append("Layouts where the default detector finds fewer edges than LSD (recall, default "
             "against LSD): %s." % ("; ".join(below) if below else "none"))
    L.append("")
    return L
