"""The results page, docs/BENCHMARKS.md: `benchmark_offline.py --page FILE` runs everything the
page needs with the binaries of the workspace and writes the page. Used by benchmark_offline.py
only; the static part (what the figures mean, the design decisions) is kept here.

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
            detector thresholds (STRESS, points + lines), --jobs runs at a time; the line
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

import bench_page_lines
import bench_page_street

SECTIONS = ("accuracy", "speed", "family", "street")
EXPOSURES = ("dim", "bright")  # pl_slam_generate --exposure presets the family is also run at
# The low-threshold stress run: FAST 7 everywhere (default: 20, 7 only in empty cells) and the
# low-contrast line search's Canny thresholds for every segment.
STRESS = ("tracker.points.fast_threshold=7,tracker.points.min_fast_threshold=7,"
          "tracker.lines.canny_low=15,tracker.lines.canny_high=30")
# ATE targets of the low-texture family, % of the path (issue: textured and bare layouts).
ATE_TARGET_PCT = {"textured": 0.05, "bare": 0.3}

# Measured design choices behind the defaults: (title, text). Figures are those measured for
# the decision (their commands and sequences as stated); the tables of the page are current.
DESIGN_DECISIONS = [
    ("A line residual weighs 8 points' (`tracker.line_weight`, `mapping.line_weight`)",
     "A segment's distance to its fitted line is measured along the whole edge, so it is more "
     "precise than a corner. Chosen from 1 / 3 / 5 / 8 with the same weight in tracking and "
     "mapping: room VO 6.5 / 5.2 / 3.8 / 2.9 mm, fast_turn VO drift 1.28 / 1.20 / 1.01 / 0.62 %; "
     "EuRoC within 0.6 mm for every weight."),
    ("Each pose is refined against the last keyframe (`tracker.track_keyframe`)",
     "The keyframe's stereo features are matched to the frame directly, so errors add up per "
     "keyframe instead of per frame. Together with line weight 8 it took the room's VO from 16.3 "
     "to 2.9 mm and fast_turn's drift from 2.27 to 0.62 %, for 0.2-0.7 ms per frame "
     "(`keyframe_match`). The refinement replaces the chain of frame-to-frame poses outright. "
     "Tried and not kept: comparing the two by their covariances and keeping the chain along "
     "a direction the refinement leaves weaker (walking up to a textured wall, features "
     "clustered on one poster put one refined frame 3.5 cm and 0.8 deg off). It took the "
     "textured wall seeds 1 and 3 from 0.08 to 0.06 % of the path, but the shared KITTI clip's "
     "slam from 0.505 to 0.579 m, and with `--doffs 1.28` its VO from 0.080 to 0.119 m: the "
     "covariances leave out stereo depth noise, so under forward motion the chain looked more "
     "certain along the road than it is. Keeping the chain only where the refinement is 4-25 "
     "times weaker in variance restored KITTI but lost most of the wall's gain. Weighing both "
     "with their stereo depths' noise (depth noise 1, as below) and refusing a refinement "
     "beyond `tracker.keyframe_max_correction` before weighing kept the wall's gain (and the "
     "held-out doorway textured seed 1 0.057 -> 0.050 %), but the street family's VO median "
     "went from 0.037 to 0.041 m (tuning) and 0.059 to 0.064 m (held out), and the KITTI "
     "clip's slam with its offset from 0.10 to 0.21 m (without the guard a 0.01 px change of "
     "the offset already moves that figure between 0.10 and 0.18 m)."),
    ("Tracking against the local map is on, and conservative (`mapping.track_local_map`)",
     "The local-map pose replaces the frame-to-frame one only with at least as many inliers and "
     "a correction under 2 cm / 0.25 deg. Replacing it whenever it succeeded made fast_turn worse "
     "than VO (10.6 mm; 4.2 mm with the correction cap) and the corridor too (5.7 against VO's "
     "5.0 mm; 4.5 mm with the inlier rule)."),
    ("No keyframe merely because mapping is idle (`tracker.keyframes.idle_min_frames` 0)",
     "ORB-SLAM's rule helps where the map lost to VO (corridor, six renderings, 2.45 -> 1.52 mm; "
     "KITTI with its offset 1.65 -> 1.11 %) but costs the loop-closed room (1.4 -> 1.6 mm), "
     "pushes the room's live local BA median from 42 to 64 ms and doubles the map over six laps "
     "(154 -> 281 MB resident). A one-key option, off by default."),
    ("The observed-endpoint line residual only in lines-only mode (`mapping.ba.line_residual` auto)",
     "Distances of the observed segment's endpoints to the landmark's projected line do not "
     "depend on where the landmark's extent lies. Lines only it wins everywhere (corridor, six "
     "renderings, 1.75 -> 1.52 mm; room 4.25 -> 3.80 mm); with points it helps the corridor "
     "(2.45 -> 1.97 mm) and costs the room (2.53 -> 2.93 mm), so points + lines keeps the "
     "paper's projected-endpoint form. Measured again on both families (slam, points + "
     "lines), the observed form meets more of their targets: low-texture textured runs "
     "within 0.05 % of the path 9 -> 9 of 12 tuning and 0 -> 2 of 6 held out, bare runs "
     "within 0.3 % 5 -> 6 of 6 held out, though its medians are mixed (tuning textured 4.2 "
     "-> 3.4 mm, tuning bare 2.3 -> 4.4 mm, held-out textured 5.5 -> 6.1 mm); "
     "street median 0.025 -> 0.023 m tuning and 0.043 -> 0.032 m held out, runs losing to VO "
     "4 + 1 -> 2 + 1 (all three straight drives worse: 0.025 / 0.025 / 0.050 -> 0.042 / 0.034 "
     "/ 0.063 m). It costs the room (1.4 -> 1.7 mm) and the shared KITTI clip (0.505 -> "
     "0.640 m), which must not get worse, so the default stays."),
    ("No global bundle adjustment at the end of a run",
     "Tried on five runs (textured corner s1, wall s1, spin s1, straight s2 and street "
     "junction s2): one global bundle adjustment of 20 iterations over every keyframe once "
     "the last is mapped. Points + lines, keyframe ATE 9.2 / 3.3 / 3.3 / 2.8 / 22.0 -> 12.1 / "
     "2.2 / 3.9 / 4.2 / 28.3 mm; points only 35.3 / 13.4 / 6.3 / 10.4 / 51.6 -> 35.3 / 12.6 "
     "/ 6.3 / 10.0 / 52.9 mm. Optimised longer, the line terms move the map away from the "
     "truth on four of the five; with the observed-endpoint residual less so (5.5 / 4.3 / "
     "3.9 / 2.7 / 30.3 mm). The next decision measures where the optimum lies."),
    ("How far a map's optimum is from the truth, against what noise explains (`pl_slam_bench_ba`)",
     "The tool solves a saved map (`pl_slam_offline --set mapping.threaded=false --save-map "
     "M`) as one bundle adjustment started at the true keyframe poses, once with the map's "
     "observations and three times with simulated ones (the exact image of each "
     "truth-fitted landmark plus Gaussian noise of the real observations' size at the truth: "
     "0.26-0.32 px for points, 0.34-0.39 px for lines, whitened). Keyframe ATE of the map / "
     "of the optimum with its own observations / of the simulated optima: street straight "
     "s3 50.6 / 45.8 / 43-66 mm and street junction s2 22.0 / 24.9 / 21-29 mm (VO, points + "
     "lines: 42.5 and 15.2 mm): the map is as good as its observations' noise allows, and "
     "whether slam or VO ends closer on such a drive is chance; street curve s3 39.0 / 38.4 "
     "/ 16-22 mm and textured corner s1 12.3 / 12.6 / 2.3-4.4 mm: there the observations "
     "carry more than noise. On the corner (map before the row search below, its own "
     "observations 9.3 mm) it is the points' image positions: with the points simulated and "
     "the lines real (`--simulate points`) the optimum is 3.6-5.7 mm, with the lines "
     "simulated 6.7-8.0 mm, with the real positions and simulated disparities 7.2-8.0 mm, "
     "and removing observations or landmarks with large residuals at the truth does not "
     "help. Re-placing each observation by aligning an 11 x 11 patch of the landmark's "
     "first view to it (translation only) moves observations by 0.85 px on average and takes "
     "that optimum from 9.3 to 6.4 mm: detections of the "
     "same corner do not land on the same surface point from different views; the next "
     "decision builds that alignment into mapping."),
    ("Point observations aligned to the landmark's first view (`mapping.align_points`)",
     "Each point landmark keeps a 13 x 13 patch of its reference keyframe's image; a new "
     "keyframe's observation of it is moved to where that patch aligns (translation, "
     "zero-mean intensities scaled to the same contrast, ZNCC at least 0.8, at most 2.5 px), "
     "unless the view would stretch, shear or turn the patch by over 8 %, and bundle "
     "adjustment uses the moved position. In the room about a fifth of the observations are "
     "aligned, by 0.65 px (median). Textured corner seeds 1-3: 10.4 / 6.6 / 5.5 -> 10.3 / 6.1 "
     "/ 5.8 mm. Low-texture family, points + lines, median ATE: tuning textured 4.2 -> 4.0 mm, tuning "
     "bare 4.5 -> 3.2 mm, held-out textured 7.3 -> 6.8 mm, held-out bare 5.7 -> 6.0 mm. "
     "Accuracy sequences: corridor 1.84 -> 1.51 mm, fast_turn 2.03 -> 1.92 mm, KITTI clip "
     "0.505 -> 0.489 m, but the room 1.45 -> 1.52 mm and EuRoC 3.50 -> 3.54 mm; street family, "
     "slam, points + lines, median 0.025 -> 0.028 m tuning, 0.043 -> 0.037 m held out (points "
     "only 0.051 -> 0.056 and 0.067 -> 0.073 m). Allowing warps up to 20 % aligns more but "
     "does no better (tuning textured 4.4 mm, held-out bare 8.1 mm); a first form that "
     "neither scaled the contrast nor looked at the warp, only at a depth ratio within 0.8 "
     "to 1.25, took corner seed 1 to 5.8 mm but the room to 1.59 mm and fast_turn to 2.26 "
     "mm. The room and the street must not get worse, so it stays off. Measured again with "
     "the second bundle-adjustment pass: corridor 2.4 -> 1.6 mm, room and EuRoC unchanged, "
     "KITTI clip 0.509 -> 0.515 m, low-texture family per-run ATE ratio 0.93 tuning / 1.02 "
     "held out (geometric mean), but street slam median 0.018 -> 0.019 m tuning and 0.026 -> "
     "0.035 m held out, junction s1 above its VO: still off then. It is on since the "
     "disparity is fitted on its own (next decision), which needs it."),
    ("A stereo point's disparity is a residual of its own in bundle adjustment "
     "(`mapping.ba.disparity_sigma` 1 px), with point alignment on",
     "The stereo matcher refines a point's disparity at full resolution on its own (robust "
     "sigma 0.07 px on the street family against ~0.3 px for a corner's position), so the "
     "right column, the left one minus that disparity, is not a second independent "
     "measurement of the left position, as the former third residual (the right column, "
     "with the left image's standard deviation) took it: that counted the column twice and "
     "gave the depth half the information. Now a stereo point is its left-image position "
     "(2 residuals) and its disparity (1 residual, standard deviation 1 px at every octave, "
     "the left image's at octave 0), each with its own Huber loss and gate: a wrong "
     "disparity (an occluding edge in the stereo patch) leaves the second pass and the left "
     "observation stays (test AWrongDisparityLeavesItsLeftObservationInTheMap). Alone it "
     "helps the low-texture tuning layouts (geometric mean of the per-run ATE ratio 0.90), "
     "points-only driving and the KITTI clip (0.509 -> 0.429 m), but the held-out bare office "
     "seed 3 goes from 4.1 to 14.4 mm (Sim3 scale 1.0059; held-out ratio 1.13): with depths "
     "held by stereo, the corner detector's view-dependent offsets (previous decisions) move "
     "the poses instead. With `mapping.align_points` as well (the default now): low-texture "
     "family, points + lines, ratio 0.88 tuning / 0.99 held out, textured tuning runs within "
     "0.05 % of the path 7 -> 9 of 12; low-threshold stress run ratio 0.98 / 0.91; street "
     "family, slam, points + lines, median 0.018 / 0.026 -> 0.019 / 0.025 m (tuning / held "
     "out, ratio 1.03), slam no worse than VO on 14 -> 13 of 15 drives (junction s1 0.019 "
     "against 0.017 m); points only median 0.049 / 0.075 -> 0.054 / 0.067 m (ratio 0.95). "
     "Accuracy sequences: corridor 2.4 -> 1.5 mm, KITTI clip 0.509 -> 0.495 m, EuRoC 3.5 -> "
     "3.4 mm, fast_turn 1.9 -> 1.8 mm, room 1.6 mm. A disparity standard deviation of 0.33 px "
     "(the matcher's precision in the left image's units) makes the KITTI clip 0.70 m and "
     "the street family worse (ratio 1.06, alone). Local BA "
     "time is about the same (corridor median 20 -> 21 ms). The combination was chosen after "
     "the held-out office showed the failure of the disparity alone, so for it the held-out "
     "layouts are a weaker check."),
    ("Frame-to-frame matches placed by patch alignment: an option, off "
     "(`tracker.point_matching.f2f_align_max_shift` 0)",
     "With the option at 1.5 px, each frame-to-frame and keyframe point match is measured where "
     "the reference image's 11 x 11 patch around the reference keypoint aligns in the current "
     "image (the alignment `mapping.align_points` uses, within 1.5 px of the detected corner, "
     "and only where the predicted motion warps the patch by at most 8 %). In the room the "
     "aligned positions lie 0.045 px from the true image of the surface point (median of 1753 "
     "matches, test AnAlignedPatchFollowsTheSurfaceCloserThanTheDetectedCorner), the detected "
     "corners 0.64 px; fast_turn's frame chain without keyframe refinement goes from 1.80 to "
     "1.33 mm over 120 frames. The whole system does not follow: low-texture family, points + "
     "lines, lost frames 312 -> 278 (tuning bare) and 201 -> 195 (held-out bare), but median "
     "ATE tuning textured 3.8 -> 4.9 mm and held-out textured 5.2 -> 6.1 mm (bare 4.5 -> 4.3 "
     "and 6.0 -> 6.0 mm); accuracy sequences room 1.4 -> 2.0 mm, corridor 1.8 -> 2.1 mm, "
     "fast_turn 2.0 -> 1.9 mm, EuRoC 3.5 -> 3.5 mm, KITTI clip 0.50 -> 0.55 m; street family, "
     "VO, points + lines, median 0.037 -> 0.040 m tuning and 0.059 -> 0.066 m held out. "
     "Without the warp limit the low-texture family loses 270 frames (tuning bare) and its "
     "held-out textured median drops to 4.3 mm, but the corridor goes to 2.8 mm, fast_turn to "
     "2.6 mm and the street's VO medians to 0.051 / 0.074 m; aligning only in frames with fewer "
     "than 150 matches takes the corridor to 5.4 mm. The corridor's VO improves (2.0 -> 1.7 mm) "
     "while its slam gets worse: local mapping still adjusts the detected corners, and with "
     "`mapping.align_points` as well the corridor stays at 2.7 mm. Sequences that must be no "
     "worse would be worse, so it stays off."),
    ("Segments searched again at low contrast where a textured image has none "
     "(`tracker.lines.low_contrast_cell` 64)",
     "The low-contrast line search ran only in images poor in segments, so a faint door frame "
     "beside a poster stayed unseen: on the textured tuning layouts the default found fewer "
     "structural edges than LSD (`pl_slam_bench_lines --recall`, seeds 1-3: corner 67.7 / "
     "71.3 %, straight 70.4 / 75.9 %, spin 60.6 / 69.0 %, wall 67.3 / 74.0 %; dim exposure "
     "37-54 %). Searching again at the low-contrast thresholds in the 64 px cells no first "
     "segment crosses, and adding what it finds, gives 69.6 / 71.0 / 65.5 / 69.7 % (dim 54-63 "
     "%) for 0.2-0.5 ms per image (LSD 20-25 ms); bare layouts unchanged (the whole image is "
     "searched there already). Cells of 32 / 48 / 64 px, textured tuning runs: median ATE ratio "
     "to before 0.93 / 0.86 / 0.87, runs over 0.05 % of the path 3 -> 2 / 2 / 1; held out with "
     "64: ratio 0.86, 4 -> 3. Not when the first search fills `tracker.lines.max_lines`: every "
     "street frame does, and there the added faint segments only displaced stronger ones "
     "(street slam median ATE 1.12x, 11 of 15 drives worse); with that rule the street family, "
     "room, EuRoC and KITTI figures are unchanged and the textured tuning runs 0.91x (2 over "
     "the target), held out 0.86x (3)."),
    ("Pieces of one edge are joined on their common least-squares line",
     "The edge-chain detector cuts an edge into pieces at junctions and weak spots (a dashed "
     "lane marking: one piece per dash) and joins collinear ones. The joined segment used to "
     "take the length-weighted mean of the pieces' own directions: on a dashed edge of 30 px "
     "pieces at 20 deg from the rows that tilts it by 0.5 deg, its ends 0.6 px off the edge "
     "(test JoinedPiecesOfADashedEdgeLieOnTheirCommonLine; now under 0.25 px). Stereo crosses "
     "the rows, so an offset across a segment becomes 1 / sin(angle) times as much disparity "
     "error: near ground lines running into the view (curb and lane edges from 6 to 40 m) had "
     "their far end 1.5-1.8 px of disparity too large, a tilted 3D line that the keyframe "
     "refinement (two frames apart at driving speed) turned into a pitch bias. Street family, "
     "VO, lines only: straight seeds 1-3, mean pitch error -2.2 / -0.7 / -1.6 -> -0.8 / +0.1 / "
     "-0.6 mdeg per frame and ATE 0.188 / 0.104 / 0.150 -> 0.081 / 0.037 / 0.038 m. Now the "
     "joined segment lies on the least-squares line of all its pieces (each a uniform run of "
     "edge points), and a piece is offered its neighbours again while it grows, so a dashed "
     "edge becomes one segment. Points + lines: low-texture family median ATE tuning textured "
     "3.75 -> 3.68 mm, tuning bare 4.48 -> 3.36 mm, held-out textured 5.25 -> 4.43 mm, held-out "
     "bare 6.02 -> 4.56 mm, textured runs within 0.05 % of the path 7 -> 9 of 12 (tuning) and "
     "2 -> 2 of 6 (held out); street family median ATE, VO 0.037 -> 0.032 m (tuning) and 0.059 "
     "-> 0.053 m (held out), slam 0.025 -> 0.021 m and 0.043 -> 0.045 m. Worse on single "
     "sequences: corridor 1.8 -> 2.8 mm, room 1.4 -> 1.5 mm, the KITTI clip 0.499 -> 0.537 m "
     "(with `--doffs 1.28`: slam 0.100 -> 0.121 m, VO 0.080 -> 0.071 m); fast_turn 2.0 and "
     "EuRoC 3.5 -> 3.4 mm. The corridor rendered with seeds 1-6 (`pl_slam_generate --scene "
     "corridor --world-seed N --seed N`) gives 1.4 / 3.3 / 1.9 / 1.8 / 1.9 / 4.6 mm before and "
     "2.0 / 1.8 / 1.8 / 1.7 / 1.8 / 6.1 mm after (median 1.9 -> 1.8 mm): a single rendering's "
     "figure moves within that spread. The join only on the least-squares line, without "
     "joining again: corridor 2.7 mm, KITTI 0.573 m, the low-texture medians within 0.3 mm and "
     "the street medians within 4 mm of these, 7 of 12 tuning textured runs within 0.05 %."),
    ("Line residuals use the whole reference segment, also where it leaves the image",
     "The tracker's line residual is the distance of the reference segment's projected "
     "endpoints to the line fitted in the current image. On the held-out avenue (a double "
     "solid centre line) visual odometry drifts sideways: mean yaw error -1.15 / -0.85 mdeg "
     "per frame and 0.87 / 0.68 mm per frame to the right (seeds 1 / 2); the same drive "
     "rendered with a single centre line gives -0.11 mdeg. Evaluated at the true motion, the "
     "pull comes from the left road lines whose endpoint falls outside the current image: "
     "leaving out the lines with an endpoint outside it moves the Gauss-Newton step from the "
     "truth from -0.49 to +0.05 mm sideways and from +0.79 to -0.05 mdeg of yaw per frame "
     "(avenue seed 1), though it adds a pitch push of its own. Tried: clipping the reference "
     "segment to the part the predicted pose shows in the image (a results-page run). Street "
     "family VO, points + lines: median ATE 0.032 -> 0.025 m (tuning) and 0.053 -> 0.032 m "
     "(held out), 12 of 15 drives better, avenue seeds 1-3 0.137 / 0.092 / 0.080 -> 0.102 / "
     "0.054 / 0.041 m; slam unchanged (its street poses come from the local map and the "
     "keyframe refinement), so the held-out slam median no longer beat VO's (0.045 against "
     "0.032 m); corridor 1.8 -> 1.6 mm VO, 2.8 -> 2.6 mm slam; KITTI clip slam 0.537 -> "
     "0.528 m. But fast_turn VO 3.0 -> 4.4 mm (keyframe refinement no longer helps there: "
     "4.4 against 3.4 mm without it), the KITTI clip's VO with `--doffs 1.28` 0.071 -> 0.099 m, "
     "and the low-texture family's tuning medians 3.68 -> 3.84 mm (textured) and 3.40 -> 4.37 "
     "mm (bare). Clipping only beyond 20 px outside the image keeps fast_turn at 3.0 mm but "
     "loses the street gain (VO 0.027 / 0.040 m); clipping at the consensus pose instead of "
     "the prediction leaves fast_turn at 4.4 mm. Also tried, with mapping: clipping in the "
     "keyframe-insertion refinement (street slam medians 0.021 -> 0.029 m tuning, 0.045 -> "
     "0.033 m held out), in bundle adjustment (the residual taken at fixed fractions along the "
     "landmark: 0.024 and 0.041 m, room 1.8 mm), and, with the keyframe-insertion clipping, "
     "the observed-endpoint residual in bundle adjustment (0.021 and 0.032 m, but the KITTI "
     "clip 0.596 m). None was kept."),
    ("Point detection ranks ORB's candidates itself",
     "OpenCV's ORB measures the orientation of every candidate in the pool (oversample 8: "
     "about 5700 on a street image), of which bucketing keeps 800. The detector ranks the "
     "pool as ORB does (FAST per level, the border, the 2n best FAST scores, then Harris), "
     "measures orientations only for the keypoints kept and lets OpenCV compute their "
     "descriptors: keypoints, orientations and descriptors are bit for bit OpenCV's (test "
     "KeepsWhatOpenCvOrbKeeps; both families' figures unchanged). Detection per image, one "
     "thread, both versions on the same images: street straight s1 4.6 -> 3.7 ms, street "
     "avenue s2 5.8 -> 4.5 ms, textured corner s2 3.0 -> 2.3 ms, bare wall s1 1.7 -> 1.3 ms. "
     "Tried and not kept: dropping candidates whose smaller structure-tensor eigenvalue is "
     "under twice what the image's noise alone gives (the noise from the lower quartile of "
     "|gx| per level). The low-threshold stress run (FAST 7, Canny 15 / 30) did not change "
     "(563 -> 565 lost frames, the same runs over twice the default ATE) and the default "
     "family got slightly worse (median ATE tuning textured 4.2 -> 4.4 mm, held-out textured "
     "5.5 -> 5.9 mm)."),
    ("Stereo points found along the row in poor images (`tracker.point_matching.row_search_*`)",
     "Where descriptor matching gives an image fewer than 150 stereo points, each left "
     "keypoint without a partner (the right image's detector missed that corner) is searched "
     "along its row by ZNCC of an 11 x 11 patch over the disparity range and kept at ZNCC "
     "0.9 or more and 0.2 above every column over 2 px away, then refined as the others. Over "
     "a bare corner and a bare corridor their disparities are as accurate as the descriptor "
     "matches' (median error 0.124 / 0.142 against 0.119 / 0.130 px). Low-texture family, "
     "points + lines: lost frames, bare layouts, 333 -> 313 (tuning) and 217 -> 199 (held "
     "out), textured unchanged (0 and 43); runs within target, textured 9 -> 8 of 12 tuning "
     "and 0 -> 1 of 6 held out, bare 9 -> 9 of 12 and 5 -> 6 of 6; median ATE tuning textured "
     "4.2 -> 4.2 mm, tuning bare 2.3 -> 4.5 mm, held-out textured 5.5 -> 7.3 mm. The street "
     "drives rarely have so few stereo points (slam medians unchanged), the accuracy "
     "sequences neither (corridor 1.9 -> 1.8 mm, the others equal). Searching in every image "
     "(ZNCC margin 0.1) lost 305 + 196 frames but met fewer targets (textured 8 of 12 "
     "tuning); margin 0.1 with ZNCC 0.95, 304 tuning frames, textured 7 of 12. In a poor "
     "image it costs about 1 ms (textured corner s1, stereo stage 0.5 -> 1.7 ms when "
     "searching every image)."),
    ("Copies of one corner counted as its rivals (`tracker.point_matching.same_corner_radius` "
     "off)",
     "A sharp corner looks alike at every scale, so each is often detected two to four times, "
     "at several pyramid levels or at neighbouring pixels, and the stereo and frame-to-frame "
     "ratio tests count those copies as rivals. Where corners are few (a light switch on a "
     "bare wall) that refuses nearly every match (a bare-wall frame: 3 of 49 keypoints with "
     "depth and 1 frame-to-frame match; 7 and 5 with copies within 4 px not counted). Measured "
     "with 4 px against the defaults (a full results-page run): low-texture family, points + "
     "lines, lost frames 555 -> 508 (bare walls 102 / 93 / 116 -> 91 / 94 / 91, held-out "
     "bare office s2 46 -> 35), median ATE tuning textured 4.2 -> 4.8 mm, held-out textured "
     "7.3 -> 5.4 mm, bare unchanged; street family, 11 % more stereo points at the same "
     "disparity error (0.070 -> 0.073 px), VO points + lines better on 11 of 15 drives "
     "(median 0.037 -> 0.033 m tuning, 0.059 -> 0.039 m held out), slam better on 8 and worse "
     "on 7 (median 0.025 -> 0.032 m tuning, 0.043 -> 0.043 m held out), so slam's median no "
     "longer beats VO's on the held-out drives; accuracy sequences, room 1.45 -> 1.30 mm, "
     "corridor 1.84 -> 1.17 mm, EuRoC 3.50 -> 3.48 mm, KITTI 0.505 -> 0.502 m, but fast_turn "
     "2.03 -> 2.30 mm (2.16 mm with 2.5 px). Two targets that hold today (fast_turn no worse; "
     "slam's held-out street median below VO's) would no longer hold, so it stays off. Also "
     "tried: only in images where the plain tests leave fewer than 150 matches (room 1.61 mm, "
     "KITTI 0.555 m); dropping detections within 3 px of a stronger one before bucketing "
     "(lost frames 508 -> 635: the copies also carried inliers); one frame-to-frame match per "
     "corner (room 1.30 -> 1.67 mm)."),
    ("A guided frame-to-frame search is kept unless searching everywhere finds more; no "
     "estimate is kept with a standard deviation over the relaxed gate's",
     "Where the constant-velocity prediction gives fewer than twice `tracker.min_inliers` point "
     "matches (fewer than `tracker.min_inliers` segments), the tracker also searches every "
     "current feature, since the prediction may be wrong after a sudden change of motion. That "
     "search used to replace the guided matches whatever their number; where a poor view "
     "repeats itself (seams along a wall, copies of one pattern) it refuses most of them to the "
     "ratio test and threw away the matches the prediction had told apart (tests "
     "APredictionThatTellsCopiesApartIsNotReplacedBySearchingEverywhere). The search with more "
     "matches is kept. A few more frames then reach `tracker.min_inliers` with all their "
     "inliers in a small part of the view, and such an estimate, kept, becomes the motion "
     "model of the frames after it (a windowed turn, WhileLostTheRotationComesFromTheFramesOwnMatches: "
     "3.6 deg heading error at the end of the gap before, 6.5 deg with the guided matches "
     "kept), so a frame-to-frame estimate whose standard deviation exceeds "
     "`tracker.relaxed_max_deviation` (5 cm) or `tracker.relaxed_max_deviation_deg` (3 deg) "
     "is no longer kept whatever its inliers (2.6 deg). Both together, low-texture family, "
     "points + lines: median ATE tuning textured 4.2 -> 3.8 mm, held-out textured 7.3 -> 5.2 "
     "mm, textured runs within 0.05 % of the path 7 -> 7 of 12 tuning and 0 -> 2 of 6 held "
     "out, lost frames 313 -> 312 (tuning bare) and 199 -> 201 (held-out bare); the standard "
     "deviation alone changes only the bare walls (6 more lost frames); the street family and "
     "the accuracy sequences are unchanged to the last digit. Also tried: the union of both "
     "searches (within 1 mm of the larger on every run but held-out office bare s3, 9.2 -> "
     "13.2 mm) and, alone, the frame-to-frame ratio test at 0.9 instead of 0.8 (median tuning "
     "textured 4.2 -> 5.5 mm)."),
    ("Tracking fits the current frame's left image only (`tracker.motion.stereo_residual` "
     "off)",
     "With the option on, a point with a stereo match in the current frame is also fitted in "
     "its right image (a third residual, as ORB-SLAM2's stereo reprojection), in frame-to-frame "
     "and keyframe tracking, local-map tracking and keyframe insertion. Measured against the "
     "defaults: street family, points + lines, VO better on 6 drives by more than 10 % and "
     "worse on 1 (median 0.037 -> 0.030 m tuning, 0.059 -> 0.053 m held out), slam median "
     "0.025 -> 0.025 m tuning and 0.043 -> 0.036 m held out, slam no worse than VO on 10 of "
     "15 drives either way; low-texture family, lost frames 556 -> 541, median ATE tuning "
     "textured 4 -> 5 mm, held-out textured 7 -> 6 mm; accuracy sequences, corridor 1.84 -> "
     "1.38 mm and EuRoC 3.50 -> 3.31 mm, but room 1.45 -> 1.62 mm, fast_turn 2.03 -> 2.38 mm "
     "and KITTI 0.505 -> 0.540 m. Three sequences that must be no worse would be worse, so it "
     "stays off. Also tried: refitting only lost frames with it and keeping their motion "
     "along the covariance's eigenvectors tighter than the motion model's (the approach to a "
     "bare wall, not sideways motion against yaw): bare walls 0.67 / 0.68 / 1.15 -> 0.54 / "
     "0.52 / 0.67 m ATE, but points only, the bare corner seed 1 lost 6 -> 17 frames "
     "(0.075 -> 0.268 m) and the held-out bare office seed 3 6 -> 51 (a wrong partial motion "
     "became the model the next frames were gated against), so it was removed."),
    ("Local bundle adjustment over 10 keyframes (`mapping.window`)",
     "On forward motion more optimisation moves the optimum along the travel: a window of 5 "
     "helps KITTI with its offset (1.65 -> 1.45 % drift over 10 m) and costs the corridor "
     "(2.45 -> 3.33 mm over six renderings); 20 gives the corridor 4.70 mm. On the street "
     "family (slam, points + lines, median ATE, tuning / held-out layouts) 5 / 10 / 20 "
     "keyframes give 0.032 / 0.047, 0.025 / 0.043 and 0.026 / 0.042 m; slam loses to VO on 4 "
     "of 9 tuning runs with each."),
    ("Local bundle adjustment solves twice, the second time without the first pass' outliers "
     "(`mapping.ba.second_pass`)",
     "As ORB-SLAM's local BA. The Huber loss leaves a wrong observation a constant pull on the "
     "first solve; the second solve starts from it without the observations the first one "
     "flagged. Street family, slam, points + lines, median ATE tuning / held out 0.021 / "
     "0.045 -> 0.018 / 0.026 m, slam no worse than VO on 7 -> 9 of 9 tuning and 4 -> 5 of 6 "
     "held-out drives (street_curve s1 0.039 -> 0.014 m); points only 0.051 / 0.067 -> 0.049 "
     "/ 0.075 m, within the spread between seeds. Accuracy sequences: corridor 2.8 -> 2.4 mm, "
     "KITTI clip 0.537 -> 0.509 m, fast_turn 2.0 -> 1.9 mm, room 1.5 -> 1.6 mm, EuRoC 3.4 -> "
     "3.5 mm. Low-texture family, points + lines, at default / dim / bright exposure: "
     "geometric mean of the per-run ATE ratio 1.04 / 0.94 / 0.99 on the tuning layouts and "
     "1.04 / 0.96 / 0.80 held out, lost frames unchanged. Ten iterations in one pass instead "
     "gave street_curve s1 0.038 m and junction s1 0.026 m (against 0.039 and 0.021): the gain "
     "is the outliers' removal, not the iterations. Local BA takes twice as long (corridor "
     "median 11 -> 23 ms, in the mapping thread). The outlier gate stays at 0.5 px per unit "
     "(`mapping.ba.outlier_sigma`): with the second pass, 1.0 made the low-texture tuning runs "
     "worse (geometric mean of the per-run ATE ratio 1.28) and 0.35 moved them by 0.90 tuning "
     "/ 1.09 held out."),
    ("Keyframes at driving speed: at the latest every 2 m (`tracker.keyframes.max_translation`)",
     "At 10 m/s that is every second frame at 10 Hz. Street family (as above): 1 / 2 / 4 m "
     "give 0.026 / 0.038, 0.025 / 0.043 and 0.048 / 0.067 m, slam losing to VO on 3 + 2, "
     "4 + 1 and 4 + 3 of the 9 + 6 runs. 1 m takes 39 % more keyframes (straight seed 1: 226 "
     "instead of 163 over 326 frames, local BA median 27 against 19 ms) for a gain within the "
     "spread between seeds, so 2 m stays."),
    ("Trajectory frames blend the corrections of the keyframes around them "
     "(`mapping.interpolate_trajectory`)",
     "A frame's output pose moves with the bundle adjustment's corrections of the keyframes "
     "before and after it, weighted by time. Without the blend (each frame follows its "
     "reference keyframe only) the low-texture family's median ATE, points + lines, rises "
     "from 4.2 to 4.4 mm (tuning textured), 2.3 to 2.7 mm (tuning bare) and 5.5 to 5.9 mm "
     "(held-out textured); the street family's slam medians stay within 0.1 mm. Where a "
     "keyframe's own tracking was off rather than drifting (textured wall seed 1) the blend "
     "moves correct frames towards it: 4.9 mm without, 5.4 mm with."),
    ("Landmarks mapped twice are fused (`mapping.fuse_duplicates`)",
     "Without fusion every revisit maps a copy of what it sees: over the three-lap room the map "
     "keeps 11686 points in 127 keyframes instead of 7423 in 98, for 1.3 against 1.5 mm ATE. "
     "On the street family it costs a little in the tuning layouts (slam median 0.022 -> "
     "0.025 m, 1 -> 4 of 9 runs losing to VO) and nothing held out (0.044 -> 0.043 m, 2 -> 1 "
     "of 6); the map's growth decides."),
    ("Keyframe culling spares the 20 newest keyframes (`mapping.cull_keep_newest`)",
     "In lines-only mode nearly every frame is a keyframe and each was culled as soon as the "
     "next one saw its landmarks; sparing the newest took the lines-only corridor map from "
     "9.18 to 1.75 mm (six renderings), VO 3.23 mm."),
    ("One more global bundle adjustment 5 keyframes after a loop correction (`loop.global_ba_followup`)",
     "Right after the correction only the fused landmarks join the loop's two sides; a follow-up "
     "once the revisit is re-observed took the room from 1.95 to 1.45 mm on one lap and 1.80 to "
     "1.47 mm on three (no loop closing: 2.14 and 6.8 mm)."),
    ("A new keyframe's observations far from their landmarks are left out of its local bundle "
     "adjustment",
     "Where more, noisier corners made the bare corner seed 1 end twice as far off (the "
     "low-threshold run, 23 -> 51 mm) the loss was in mapping, not tracking (as VO the same run "
     "improves, 35 -> 19 mm). At its second corner every frame is a keyframe tracked on 7-13 "
     "inliers, all on one wall 2 m away, and local bundle adjustment moved one of them 9 cm along "
     "the view, where tracking had it within 3 cm: one landmark the keyframe before had put at "
     "0.85 m (a noise corner's wrong stereo match), observed 15 px from its projection, outweighed "
     "the other 15 along that weak direction, and was fitted to 0.65 px, so the outlier test "
     "kept it. Now the new keyframe's observations farther from their projection than the "
     "local-map search reaches (`mapping.search_radius`, 8 px at octave 0) beyond the "
     "keyframe's median residual are left out of the solve and removed (test "
     "LocalBundleAdjustment): that run 51 -> 14 mm; the low-texture family's default runs, "
     "points + lines, are unchanged on the tuning layouts and move on one held-out run (office "
     "textured s1 9.7 -> 8.3 mm), points only on three held-out bare runs (doorway s1 64 -> 75 "
     "mm, office s1 83 -> 49 mm with 12 -> 24 lost frames, office s3 6 -> 7 lost frames), and "
     "rendered dim and bright one frame more is lost (held-out bare office s1, bright); the "
     "street family is unchanged; KITTI 0.505 -> 0.499 m, the "
     "other accuracy sequences unchanged. Tried before it and not kept: (1) tracking's motion "
     "between consecutive keyframes, with its covariance, as a robust term of bundle adjustment: "
     "the low-threshold corner 51 -> 17 mm, room 1.45 -> 1.33, corridor 1.84 -> 1.28, "
     "fast_turn 2.03 -> 1.48 mm, but the KITTI clip 0.505 -> 1.08 m, the street family's slam "
     "points only median 0.051 -> 0.107 m (tuning; slam no worse than VO on 8 -> 4 of 9 drives) "
     "and the held-out bare office seed 3 12.5 -> 28 mm: the term brings back tracking's own "
     "errors, which the map had corrected (its covariance comes from the same features and takes "
     "stereo depth as exact); with 1 cm and 0.1 deg added to its standard deviations, KITTI "
     "1.06 m and the low-threshold corner 49 mm; only for keyframes reached through frames "
     "tracked on fewer than tracker.min_inliers, the low-threshold corner 49 mm; (2) holding "
     "keyframes with fewer than 20 observations fixed: the low-threshold corner 20 mm, but all "
     "six held-out office runs worse (bare seed 3 12.5 -> 40 mm); (3) fusing an estimate kept "
     "by the relaxed gate with the motion model's prediction by their covariances (1.7 cm, 1 "
     "deg per frame): points + lines within 1 mm on the family medians, points only 27 -> 30 "
     "mm (tuning bare)."),
    ("Frame-to-frame tracking takes stereo depths as exact (`tracker.depth_noise` 0)",
     "Whitening each residual along the direction its one-frame stereo depth error moves it "
     "(depth noise 1: a disparity as noisy as the residual) lowers the error of a simulated "
     "1.2 m forward step by 10 % and makes its covariance honest (chi2 mean 8.2 -> 6.5; test "
     "DepthNoise). On the street family it does not carry over: VO median ATE, tuning / held "
     "out, points + lines 0.037 / 0.059 -> 0.080 / 0.063 m, points only 0.093 / 0.059 -> "
     "0.078 / 0.067 m (at 0.3: 0.045 / 0.055 and 0.097 / 0.060 m); slam medians move by under "
     "1 % (the local map carries the pose); the KITTI clip with its offset, VO points + lines "
     "0.080 -> 0.112 m. Bundle adjustment needs no such weight: it fits each landmark to its "
     "left and right observations."),
    ("While lost, the rotation comes from the frame's own matches "
     "(`tracker.lost_rotation_min_inliers` 4)",
     "A frame too poor for a whole estimate (4 or more inliers, fewer than the gates need) is "
     "fitted for its rotation alone about the position the motion model predicts, and kept "
     "within 3 deg of the model's rotation (`tracker.relaxed_max_deviation_deg`: the corners "
     "of one light-switch plate fit a wrong 7 deg roll as tightly as the right one, and the "
     "model then repeated it frame after frame); once the model's 10 frames are over, about "
     "the last position, so a turn while lost is followed. Bare wall seeds 1-3, ATE: 0.79 / "
     "0.68 / 1.22 m with the rotation accepted up to 60 deg from the model's and only within "
     "the model's frames, 0.67 / 0.68 / 1.15 m now; the other runs of the family do not "
     "change. Without it (`lost_rotation_min_inliers` 0) the bare corner seed 1 (6 frames "
     "lost) ends 1.07 % of the path off instead of 0.17 %, while the held-out bare office "
     "seed 1 ends 0.16 % instead of 0.22 %. "
     "Tried and not kept for low contrast: Canny 10 / 20 instead of 15 / 30 for the "
     "low-contrast line search (dim family, tuning layouts: 528 -> 514 lost frames, median "
     "ATE 8.0 -> 9.5 mm) and sub-pixel corner positions (`cv::cornerSubPix`, 5x5 and 9x9: the "
     "textured corner seed 1 from 8.3 to 11.5 and 12.3 mm)."),
    ("Direct alignment before a frame is lost (`tracker.direct.*`)",
     "Where features run out (a door at the end of a dim corridor: 1-2 point matches, 4-5 "
     "stereo segments) the image's faint edges still fix the motion. The last frame with a "
     "pose gives its strongest edge pixels (5 noise standard deviations, the noise estimated "
     "per image outside clipped highlights) with depth from a zero-mean SSD search along the "
     "row, and the frame is "
     "aligned to them photometrically (3-level pyramid, Huber, gain and offset) from the "
     "motion model's prediction. Low-texture family, points + lines, lost frames: dim tuning "
     "textured 61 -> 0, dim tuning bare 460 -> 404 (the bare walls stay lost), held-out "
     "office textured at normal exposure 19 -> 0 (seed 2: 0.85 -> 0.06 % of the path); dim "
     "textured wall seed 3 1.83 -> 0.27 %. An alignment is kept when its rotation standard "
     "deviation (from the reference gradients with their noise taken out) is at most 0.15 "
     "deg: without that gate, views whose few edges let rotation and translation trade off "
     "were accepted 1-4 deg off. That failure showed on the held-out office (63 of 461 "
     "aligned frames over 0.5 deg; the gate refuses 55 of them and keeps 337 of the other "
     "398), so the held-out figures are no independent check of the gate; on the tuning "
     "layouts it keeps 129 of 131 alignments. Tried and not kept: keeping the reference frame "
     "while 70 % of its pixels stay in view (normal exposure: held-out bare lost frames 139 "
     "-> 169, doorway textured seed 3 0.09 -> 1.53 %)."),
    ("A few matches with the motion model as a prior (`tracker.fused_*`)",
     "Walking up to a bare wall, the view holds a light switch: 6-10 point matches within a few "
     "centimetres, which alone trade a turn against a sideways step (too uncertain for any "
     "gate), so those frames were lost and the walk's deceleration was never measured. Right "
     "after a tracked frame, when neither the local map nor direct alignment holds a frame, "
     "its matches are now fitted together with the constant-velocity prediction, whose "
     "covariance is the last motion's own plus 1 cm and 0.5 deg per axis, and the right "
     "image's columns (the switch's distance). Kept when the deviation from the prediction is "
     "within the prior's 99 % bound and the result within the relaxed gate's deviations; the "
     "model then carries the fused motion with its covariance; never a keyframe. Low-texture "
     "family, points + lines, before and after: lost frames tuning 309 -> 187 (bare walls 97 / 93 / 117 -> 59 / "
     "65 / 61), held out 239 -> 237 (bare office seeds 1 and 3 1 -> 0); geometric mean of the "
     "per-run ATE ratio 1.000 tuning, 1.004 held out (bare walls left out); bare walls ATE "
     "0.63 / 0.68 / 0.54 -> 0.15 / 0.98 / 0.31 m (seed 2's error is the turn in front of the "
     "wall, still lost, which sends the walk off in a wrong direction). Points only: lost 404 "
     "-> 310 and 266 -> 261, ATE ratio 0.98 and 0.84. Tried "
     "and not kept: a fixed prior (1 cm, 0.5 deg) without the last motion's covariance: "
     "points-only bare and textured corner seed 3 0.043 -> 0.107 and 0.046 -> 0.092 m (a "
     "relaxed-gate estimate 4 cm and 2.3 deg off became the model, and the fused frames "
     "extended it); keeping the model at the last measured motion through a run of fused "
     "frames: bare wall seed 1 0.17 -> 0.28 m (the deceleration is not followed); weighing the "
     "matches at their own scatter instead of at least 1 px (`tracker.motion."
     "prior_min_sigma_px`): bare wall seeds 1 and 3 0.12 -> 0.20 and 0.31 -> 0.51 m (a "
     "switch's corners move together with the detector's view-dependent offsets); requiring "
     "the fused result within the prior's 1 cm and 0.5 deg: nothing fused on the walls; after a "
     "local-map rescue, resetting the model to the last measured motion (dropping the rotation "
     "the lost frame measured): held-out textured doorway seed 3 under low thresholds 0.008 -> "
     "0.031 m."),
    ("A keyframe refinement outside both estimates' uncertainty is refused "
     "(`tracker.keyframe_max_chi2` 200)",
     "Each frame's pose is re-estimated against the last keyframe, with no consensus stage of "
     "its own, and kept within 5 cm and 2 deg of the frame-to-frame pose. On the bare corner "
     "seed 2 under the low-threshold stress run (FAST 7: noise corners join), one frame's "
     "refinement moved it 4.2 cm and 0.78 deg to the wrong side: that step alone made the run "
     "3.4x its default ATE. The two estimates' covariances put that change at a squared "
     "Mahalanobis distance of 443; accepted refinements measure a median of 1-5 and up to 31 on "
     "the synthetic and low-texture sequences, but between 50 and 100 on street drives with "
     "lines: a bound of 50 refused those and their visual odometry drifted (street_junction s1 "
     "0.0174 -> 0.0311 m, five more drives worse), at 100 and 200 no drive changes. Beyond 200 "
     "the refinement is refused and the frame-to-frame pose kept. Stress run: bare corner seed "
     "2 0.0165 -> 0.0051 m (default 0.0049), per-run ATE ratio 0.955 tuning, 1.027 held out "
     "(held-out bare doorway seed 1 0.030 -> 0.041 % of the path). Defaults: low-texture "
     "family ratio 1.001 tuning, 0.998 held out (office bare seed 1 0.104 -> 0.097 %), no lost "
     "frame more or less; the accuracy sequences and the street family (slam and VO) "
     "unchanged."),
    ("Tracking follows the map through a keyframe already in it",
     "Tracking re-anchored to the last keyframe it handed to mapping. While that keyframe "
     "waited in the mapping queue it was not in the map, so a loop correction applied then "
     "went unseen: local-map tracking pulled the camera into the corrected map, and the whole "
     "correction reached ~odom instead of map -> odom (the live loop-closure test: 2 of 4 runs "
     "with the prior above on, 0 of 4 off). Tracking now follows the newest handed-over keyframe "
     "that is in the map, moving the queued ones it holds with every correction; a queued "
     "keyframe enters the map moved as the keyframe it was tracked from was moved since "
     "(`LocalMapperTest.AQueuedKeyframeMovesWithItsAnchor`: 1 m / 8 deg correction, 0.3 mm off "
     "instead of 77 mm). When a correction lands while a frame is tracked, tracking carries on "
     "in whichever map, old or corrected, the frame's pose came out in. With the prior above on, "
     "no correction reached ~odom in 15 runs of the loop-closure test. Its check that map -> "
     "odom took the correction asked for more than 3 mm; the room's loop correction is now 2-4.4 "
     "mm at the newest keyframe, so the test compares with the correction the status reports "
     "(`loop_correction_m`): the camera's move through map -> odom was 0.95-1.65x it in 8 runs "
     "(the follow-up global bundle adjustment often lands within the frames compared)."),
    ("KITTI clip: the disparity offset is measured, not assumed (`--doffs 1.28`)",
     "`pl_slam_check_stereo` finds the clip's right principal point 1.28 +- 0.31 px from the "
     "images alone, as the ground-truth poses imply (1.29-1.32 px). With it VO drift goes from "
     "7.62 to 1.12 % over 10 m. The tables keep the calibration as shipped and add one row "
     "with the offset."),
    ("KITTI clip: the map's loss to VO follows the intrinsics; no self-calibration",
     "At the clip's ground truth a focal length 0.6 % shorter and a principal point ~5 px away "
     "halve the reprojection cost; with those intrinsics the map beats VO (0.94 against 1.17 % "
     "drift). They come from the clip's own ground truth, so they are a diagnosis, not a "
     "calibration to ship. A self-calibrating bundle adjustment without ground truth was "
     "rejected: it moves fx by -12.9 px and doffs to 1.70 px (2.8-3.1 % drift), and on the "
     "corridor it moves away from the true camera."),
]


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
                   r.get("took", {}), r.get("rerun", []), r.get("exposure"), r.get("lines"))
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
                   "took": took, "rerun": rerun, "exposure": exposure, "lines": lines}, f,
                  indent=1)
    write_page(args, bo, t0, t1, load, seqs, main, mode_seqs, acc, speed, skipped,
               fam_header, fam_runs, fam_summary, out, jobs, times, street, took, rerun, exposure,
               lines)
    print("wrote %s" % args.page)
    return 0


def write_page(args, bo, t0, t1, load, seqs, main, mode_seqs, acc, speed, skipped,
               fam_header, fam_runs, fam_summary, out, jobs, times, street=None, took=None,
               rerun=(), exposure=None, lines=None):
    # A workspace built from an export of one commit (git archive) says which in
    # src/pl_slam/.source_commit; otherwise the binaries are the working tree's.
    exported = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(bo.BIN))),
                            "src", "pl_slam", ".source_commit")
    if os.path.isfile(exported):
        with open(exported) as f:
            full = f.read().strip()
        commit, subject = git("rev-parse", "--short", full) or full[:7], git("log", "-1", "--format=%s", full)
        dirty, untracked = [], []
    else:
        commit = git("rev-parse", "--short", "HEAD") or "unknown"
        subject = git("log", "-1", "--format=%s")
        code = ("src/", "include/", "nodes/", "config/", "vocabulary/", "CMakeLists.txt", "package.xml")
        dirty = [l[3:] for l in git("status", "--porcelain").splitlines() if l[3:].startswith(code)]
        untracked = []
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
        "`scripts/bench_page.py`.")
    add("")
    add("| | |")
    add("|---|---|")
    add("| machine | %s |" % machine())
    add("| date | %s |" % run_dates(t0, t1, times, took or {}, rerun))
    state = "clean" if not dirty and not untracked else "uncommitted changes in %s" % ", ".join(
        "`%s`" % p for p in (dirty + untracked)[:6]) + (" and %d more" % (len(dirty + untracked) - 6)
                                                         if len(dirty + untracked) > 6 else "")
    if len(subject) > 80:
        subject = subject[:80].rsplit(" ", 1)[0] + " ..."
    if os.path.isfile(exported):
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
    for title, text in DESIGN_DECISIONS:
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
