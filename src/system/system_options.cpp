// The option table of the whole system: every module option by its dotted key. Adding a field
// to an options struct means adding one line here (and it then works in YAML files, ROS
// parameters and --set overrides alike).
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/error.h"

namespace pl_slam {

OptionTable MakeOptionTable(SystemOptions* options) {
  OptionTable t;
  TrackerOptions& tr = options->tracker;
  t.Add(
      "tracker.mode", [&tr](const std::string& v) { tr.mode = ParseFeatureMode(v); },
      [&tr] { return std::string(FeatureModeName(tr.mode)); },
      "features for tracking: points, lines or points_lines");
  t.Add("tracker.parallel", &tr.parallel, "process the right image in a second thread");
  t.Add("tracker.min_inliers", &tr.min_inliers, "fewer point + line inliers: tracking lost");
  t.Add("tracker.relaxed_min_inliers", &tr.relaxed_min_inliers,
        "fewer than min_inliers but this many are kept when the motion model agrees (also "
        "against the local map while the pose is predicted); without a model (after a loss) "
        "they make one the next frame must agree with (0 = off)");
  t.Add("tracker.relaxed_max_deviation", &tr.relaxed_max_deviation,
        "relaxed gate: largest deviation from the motion model and its sigma; no frame-to-frame "
        "estimate with a larger sigma is kept, m");
  t.Add("tracker.relaxed_max_deviation_deg", &tr.relaxed_max_deviation_deg,
        "relaxed gate: largest deviation from the motion model and its sigma; no frame-to-frame "
        "estimate with a larger sigma is kept, deg");
  t.Add("tracker.max_translation", &tr.max_translation,
        "largest accepted frame-to-frame translation, m");
  t.Add("tracker.max_rotation_deg", &tr.max_rotation_deg,
        "largest accepted frame-to-frame rotation, deg");
  t.Add("tracker.line_weight", &tr.line_weight,
        "information of a line residual relative to a point's");
  t.Add("tracker.depth_noise", &tr.depth_noise,
        "disparity noise of stereo features relative to their pixel noise, weighting "
        "residuals by their depth error under the motion (0 = depths exact, off)");
  t.Add("tracker.track_keyframe", &tr.track_keyframe,
        "refine each pose against the last keyframe (errors add up per keyframe, not per frame)");
  t.Add("tracker.keyframe_min_inlier_ratio", &tr.keyframe_min_inlier_ratio,
        "keyframe inliers per frame-to-frame inlier needed to use that refinement");
  t.Add("tracker.keyframe_max_correction", &tr.keyframe_max_correction,
        "largest accepted keyframe refinement, m");
  t.Add("tracker.keyframe_max_correction_deg", &tr.keyframe_max_correction_deg,
        "largest accepted keyframe refinement, deg");
  t.Add("tracker.keyframe_max_chi2", &tr.keyframe_max_chi2,
        "largest accepted keyframe refinement, squared Mahalanobis distance from the "
        "frame-to-frame pose under both covariances (0 = no check)");
  t.Add("tracker.max_predicted_frames", &tr.max_predicted_frames,
        "while lost the pose follows the motion model for this many frames (0 = off)");
  t.Add("tracker.lost_rotation_min_inliers", &tr.lost_rotation_min_inliers,
        "while lost, the rotation comes from the frame's matches with at least this many "
        "inliers, within relaxed_max_deviation_deg of the model's (0 = the model's)");
  t.Add("tracker.fused_min_inliers", &tr.fused_min_inliers,
        "a frame too poor for its own estimate right after a tracked one is fitted with the "
        "constant-velocity prediction as a prior and kept (flagged prior_fused) with at least "
        "this many inliers agreeing with it (0 = off)");
  t.Add("tracker.fused_sigma", &tr.fused_sigma,
        "that prior: the change of motion per axis and frame it allows, on top of the last "
        "motion's own covariance, m");
  t.Add("tracker.fused_sigma_deg", &tr.fused_sigma_deg, "the same, deg");
  t.Add("tracker.relaxed_prior", &tr.relaxed_prior,
        "a frame the relaxed gate keeps is fitted with that prior too (with fused_min_inliers "
        "on), so the directions its few features leave weak stay near the motion model");

  PointDetectorOptions& p = tr.points;
  t.Add("tracker.points.max_points", &p.max_points, "ORB keypoints kept per image");
  t.Add("tracker.points.grid_cols", &p.grid_cols, "bucketing grid columns");
  t.Add("tracker.points.grid_rows", &p.grid_rows, "bucketing grid rows");
  t.Add("tracker.points.levels", &p.levels, "ORB pyramid levels");
  t.Add("tracker.points.scale_factor", &p.scale_factor, "ORB pyramid scale step");
  t.Add("tracker.points.fast_threshold", &p.fast_threshold, "FAST corner threshold");
  t.Add("tracker.points.min_fast_threshold", &p.min_fast_threshold,
        "FAST threshold of a second search, for the grid cells left empty, when an image has "
        "< max_points corners (= fast_threshold: off)");
  t.Add("tracker.points.oversample", &p.oversample,
        "candidates per kept keypoint before bucketing");

  PointMatchingOptions& pm = tr.point_matching;
  t.Add("tracker.point_matching.max_distance", &pm.max_distance,
        "largest Hamming distance accepted");
  t.Add("tracker.point_matching.stereo_ratio", &pm.stereo_ratio,
        "stereo ratio test: best < ratio * second");
  t.Add("tracker.point_matching.stereo_row_tolerance", &pm.stereo_row_tolerance,
        "stereo row tolerance, px at octave 0");
  t.Add("tracker.point_matching.min_disparity", &pm.min_disparity, "smallest stereo disparity, px");
  t.Add("tracker.point_matching.max_disparity", &pm.max_disparity, "largest stereo disparity, px");
  t.Add("tracker.point_matching.subpixel", &pm.subpixel, "refine disparities by patch correlation");
  t.Add("tracker.point_matching.stereo_min_zncc", &pm.stereo_min_zncc,
        "stereo: ZNCC the 11x11 patches must reach at a match's disparity (0 = no check)");
  t.Add("tracker.point_matching.row_search_below", &pm.row_search_below,
        "images with fewer stereo points from descriptors: keypoints without a right keypoint "
        "are looked for along their row by correlation");
  t.Add("tracker.point_matching.row_search_min_zncc", &pm.row_search_min_zncc,
        "row search: ZNCC a match must reach (0 = no row search)");
  t.Add("tracker.point_matching.row_search_margin", &pm.row_search_margin,
        "row search: ZNCC by which the best column beats every column past its own falling "
        "slopes");
  t.Add("tracker.point_matching.f2f_ratio", &pm.f2f_ratio, "frame-to-frame ratio test");
  t.Add("tracker.point_matching.same_corner_radius", &pm.same_corner_radius,
        "ratio tests: candidates this close to the best (px) are the same corner detected again, "
        "not rivals (0 = all are rivals)");
  t.Add("tracker.point_matching.search_radius", &pm.search_radius,
        "guided frame-to-frame search radius, px");
  t.Add("tracker.point_matching.f2f_align_max_shift", &pm.f2f_align_max_shift,
        "frame to frame and keyframe: a match's current position is where the reference "
        "patch aligns, within this many px of the keypoint, where the predicted motion does "
        "not warp the patch; 0 = keypoints as detected");

  LineDetectorOptions& l = tr.lines;
  t.Add(
      "tracker.lines.detector",
      [&l](const std::string& v) {
        if (v == "edge_chain")
          l.detector = LineDetectorKind::kEdgeChain;
        else if (v == "lsd")
          l.detector = LineDetectorKind::kLsd;
        else
          throw ConfigError("tracker.lines.detector='" + v + "' must be edge_chain or lsd");
      },
      [&l] { return std::string(l.detector == LineDetectorKind::kLsd ? "lsd" : "edge_chain"); },
      "segment detector: edge_chain (fast) or lsd");
  t.Add("tracker.lines.min_length_ratio", &l.min_length_ratio,
        "shortest segment, fraction of min(width, height)");
  t.Add("tracker.lines.max_lines", &l.max_lines, "longest segments kept per image (0 = all)");
  t.Add("tracker.lines.prefer_steep_deg", &l.prefer_steep_deg,
        "under the cap, segments this close to horizontal rank last, deg (0 = by length only)");
  t.Add("tracker.lines.canny_low", &l.canny_low, "edge chain: Canny low threshold");
  t.Add("tracker.lines.canny_high", &l.canny_high, "edge chain: Canny high threshold");
  t.Add("tracker.lines.min_lines", &l.min_lines,
        "edge chain: fewer segments: search again at the low-contrast thresholds (0 = never)");
  t.Add("tracker.lines.low_contrast_canny_low", &l.low_contrast_canny_low,
        "edge chain: Canny low threshold of the low-contrast search");
  t.Add("tracker.lines.low_contrast_canny_high", &l.low_contrast_canny_high,
        "edge chain: Canny high threshold of the low-contrast search");
  t.Add("tracker.lines.low_contrast_cell", &l.low_contrast_cell,
        "edge chain: an image with enough segments, under max_lines, is searched again at the "
        "low-contrast thresholds in the cells of this many px that none crosses (0 = never)");
  t.Add("tracker.lines.max_fit_distance", &l.max_fit_distance,
        "edge chain: distance ending a straight run, px");
  t.Add("tracker.lines.merge_collinear", &l.merge_collinear, "edge chain: join collinear pieces");
  t.Add("tracker.lines.merge_max_gap", &l.merge_max_gap, "merge: largest gap along the line, px");
  t.Add("tracker.lines.merge_max_distance", &l.merge_max_distance,
        "merge: largest endpoint-to-line distance, px");
  t.Add("tracker.lines.merge_max_angle_deg", &l.merge_max_angle_deg,
        "merge: largest direction difference, deg");
  t.Add("tracker.lines.lsd_scale", &l.lsd_scale, "LSD: image scale it works at");

  LineMatchingOptions& lm = tr.line_matching;
  t.Add("tracker.line_matching.max_distance", &lm.max_distance,
        "largest Hamming distance accepted");
  t.Add("tracker.line_matching.stereo_ratio", &lm.stereo_ratio, "stereo ratio test");
  t.Add("tracker.line_matching.stereo_max_angle_deg", &lm.stereo_max_angle_deg,
        "stereo: largest direction difference, deg");
  t.Add("tracker.line_matching.stereo_min_length_ratio", &lm.stereo_min_length_ratio,
        "stereo: shorter / longer length");
  t.Add("tracker.line_matching.stereo_min_row_overlap", &lm.stereo_min_row_overlap,
        "stereo: shared rows / rows of the longer");
  t.Add("tracker.line_matching.min_disparity", &lm.min_disparity,
        "stereo: smallest endpoint disparity, px");
  t.Add("tracker.line_matching.max_disparity", &lm.max_disparity,
        "stereo: largest endpoint disparity, px");
  t.Add("tracker.line_matching.max_disparity_gradient", &lm.max_disparity_gradient,
        "stereo: |d_s - d_e| / length");
  t.Add("tracker.line_matching.min_stereo_angle_deg", &lm.min_stereo_angle_deg,
        "stereo: flatter segments get no depth (but see junction_max_px), deg");
  t.Add("tracker.line_matching.junction_max_px", &lm.junction_max_px,
        "stereo: a flatter segment whose both ends are L junctions with segments that have "
        "depth takes their disparities there, when the right image shows it between the same "
        "junctions within this distance, px (0: off)");
  t.Add("tracker.line_matching.junction_one_end", &lm.junction_one_end,
        "stereo: a flatter segment with an L junction at one end only takes its disparity there "
        "and, at the free end (away from the image border), the column difference of the left "
        "and right segments' endpoints");
  t.Add("tracker.line_matching.f2f_ratio", &lm.f2f_ratio, "frame-to-frame ratio test");
  t.Add("tracker.line_matching.f2f_max_angle_deg", &lm.f2f_max_angle_deg,
        "frame to frame: largest direction difference, deg");
  t.Add("tracker.line_matching.f2f_min_length_ratio", &lm.f2f_min_length_ratio,
        "frame to frame: shorter / longer length");
  t.Add("tracker.line_matching.f2f_max_line_distance", &lm.f2f_max_line_distance,
        "guided: predicted endpoints to line, px");
  t.Add("tracker.line_matching.f2f_max_gap", &lm.f2f_max_gap, "guided: gap between segments, px");

  MotionEstimatorOptions& m = tr.motion;
  t.Add("tracker.motion.max_iterations", &m.max_iterations, "Gauss-Newton iterations per step");
  t.Add("tracker.motion.huber_delta_px", &m.huber_delta_px, "Pseudo-Huber scale, px");
  t.Add("tracker.motion.outlier_chi2", &m.outlier_chi2,
        "outlier threshold, chi2 (2 dof) x robust variance");
  t.Add("tracker.motion.outlier_min_px", &m.outlier_min_px, "outlier threshold floor, px");
  t.Add("tracker.motion.outlier_max_px", &m.outlier_max_px, "outlier threshold ceiling, px");
  t.Add("tracker.motion.min_update", &m.min_update, "convergence: smallest update norm");
  t.Add("tracker.motion.min_relative_cost_change", &m.min_relative_cost_change,
        "convergence: smallest relative cost change");
  t.Add("tracker.motion.min_depth", &m.min_depth,
        "residuals with smaller transformed depth are skipped, m");
  t.Add("tracker.motion.min_inliers", &m.min_inliers,
        "fewer inliers after the second step: failure");
  t.Add("tracker.motion.rank_tolerance", &m.rank_tolerance,
        "smallest normalised Hessian eigenvalue (observability)");
  t.Add("tracker.motion.stereo_residual", &m.stereo_residual,
        "points with a current stereo match are also fitted in the right image");
  t.Add("tracker.motion.min_sigma_px", &m.min_sigma_px,
        "floor on the residual sigma scaling the covariance, px");
  t.Add("tracker.motion.prior_min_sigma_px", &m.prior_min_sigma_px,
        "with a motion prior (tracker.fused_*): the matches' noise is taken as at least this "
        "against it and in the covariance, px");

  ConsensusOptions& c = tr.consensus;
  t.Add("tracker.consensus.enabled", &c.enabled,
        "RANSAC over minimal point / segment sets before the robust refinement");
  t.Add("tracker.consensus.max_hypotheses", &c.max_hypotheses, "minimal sets scored at most");
  t.Add("tracker.consensus.confidence", &c.confidence,
        "stop drawing once a better consensus is this unlikely to be missed");
  t.Add("tracker.consensus.inlier_px", &c.inlier_px,
        "a correspondence supports a hypothesis within this, px");
  t.Add("tracker.consensus.gate_px", &c.gate_px,
        "farther from the consensus pose: left out of the refinement, px");
  t.Add("tracker.consensus.disparity_sigma_px", &c.disparity_sigma_px,
        "stereo disparity noise assumed by the rigidity pre-check, px");

  DirectAlignmentOptions& d = tr.direct;
  t.Add("tracker.direct.enabled", &d.enabled,
        "before a frame is lost: align its image directly to the last frame with a pose");
  t.Add("tracker.direct.max_pixels", &d.max_pixels,
        "reference pixels with stereo depth kept (one per grid cell)");
  t.Add("tracker.direct.min_gradient_sigmas", &d.min_gradient_sigmas,
        "smallest horizontal gradient of a reference pixel, in noise standard deviations");
  t.Add("tracker.direct.levels", &d.levels, "image pyramid levels of the alignment");
  t.Add("tracker.direct.min_pixels", &d.min_pixels, "fewer reference pixels in view: no estimate");
  t.Add("tracker.direct.max_residual", &d.max_residual,
        "largest robust residual sigma accepted, grey levels");
  t.Add("tracker.direct.max_rotation_sigma_deg", &d.max_rotation_sigma_deg,
        "largest rotation standard deviation of an alignment accepted, deg");

  KeyframeSelectorOptions& k = tr.keyframes;
  t.Add("tracker.keyframes.entropy_ratio", &k.entropy_ratio,
        "keyframe when h(kf,cur)/h(kf,kf+1) drops below");
  t.Add("tracker.keyframes.min_frames", &k.min_frames,
        "entropy test from this many frames after a keyframe");
  t.Add("tracker.keyframes.idle_min_frames", &k.idle_min_frames,
        "keyframe this many frames after the last when local mapping is idle (0 = off)");
  t.Add("tracker.keyframes.max_frames", &k.max_frames,
        "keyframe at the latest after this many frames");
  t.Add("tracker.keyframes.min_inliers", &k.min_inliers, "keyframe when inliers drop below");
  t.Add("tracker.keyframes.max_translation", &k.max_translation,
        "keyframe after this translation, m");
  t.Add("tracker.keyframes.max_rotation_deg", &k.max_rotation_deg,
        "keyframe after this rotation, deg");
  t.Add("tracker.keyframes.min_translation", &k.min_translation,
        "entropy and frame-count keyframes only after this translation, m (or the rotation)");
  t.Add("tracker.keyframes.min_rotation_deg", &k.min_rotation_deg,
        "entropy and frame-count keyframes only after this rotation, deg (or the translation)");
  MappingOptions& mp = options->mapping;
  t.Add("mapping.enabled", &mp.enabled, "build a map (off: visual odometry only)");
  t.Add("mapping.threaded", &mp.threaded,
        "local mapping in its own thread (off: in line, deterministic)");
  t.Add("mapping.queue_size", &mp.queue_size, "keyframes waiting for mapping; more are dropped");
  t.Add("mapping.thread_niceness", &mp.thread_niceness,
        "mapping thread and its global BA: nice steps below tracking (0-19)");
  t.Add("mapping.window", &mp.window, "keyframes optimised by local bundle adjustment");
  t.Add("mapping.max_fixed_keyframes", &mp.max_fixed_keyframes,
        "outside keyframes held fixed in local bundle adjustment");
  t.Add("mapping.refine_against_previous", &mp.refine_against_previous,
        "refine a new keyframe's pose against the previous keyframe");
  t.Add("mapping.refine_min_inliers", &mp.refine_min_inliers,
        "inliers needed to accept that refinement");
  t.Add("mapping.refine_max_correction", &mp.refine_max_correction,
        "largest accepted refinement of a keyframe pose, m");
  t.Add("mapping.search_radius", &mp.search_radius, "local-map search radius, px");
  t.Add("mapping.line_triangulation_min_angle_deg", &mp.line_triangulation_min_angle_deg,
        "segments without stereo depth seen by two keyframes are triangulated when their planes "
        "meet at this angle or more, deg (0 = off; 2 lowers ATE in low-texture scenes)");
  t.Add("mapping.line_triangulation_max_depth_baselines",
        &mp.line_triangulation_max_depth_baselines,
        "farthest such triangulated segment, in baselines");
  t.Add("mapping.local_map_keyframes", &mp.local_map_keyframes,
        "covisible keyframes whose landmarks form the local map");
  t.Add("mapping.cull_after_keyframes", &mp.cull_after_keyframes,
        "keyframes after which a landmark seen by < min_observations keyframes is removed");
  t.Add("mapping.min_observations", &mp.min_observations, "see cull_after_keyframes");
  t.Add("mapping.cull_keyframes", &mp.cull_keyframes, "remove redundant keyframes");
  t.Add("mapping.redundant_ratio", &mp.redundant_ratio,
        "keyframe redundant when this share of its landmarks is seen by enough others");
  t.Add("mapping.redundant_min_observers", &mp.redundant_min_observers,
        "other keyframes that count as enough");
  t.Add("mapping.cull_keep_newest", &mp.cull_keep_newest,
        "the newest this many keyframes are never culled");
  t.Add("mapping.stereo_residuals", &mp.stereo_residuals,
        "bundle adjustment also uses the right image of stereo observations (off: only the "
        "fixed keyframes hold the map's scale, and it drifts)");
  t.Add("mapping.stereo_max_depth_baselines", &mp.stereo_max_depth_baselines,
        "points farther than this many baselines: left image only in bundle adjustment (0 = no "
        "limit)");
  t.Add("mapping.line_weight", &mp.line_weight,
        "information of a line residual relative to a point's in mapping");
  t.Add("mapping.align_points", &mp.align_points,
        "bundle adjustment places point observations where the landmark's reference patch "
        "aligns (not at the detected corner)");
  t.Add("mapping.fuse_duplicates", &mp.fuse_duplicates,
        "merge landmarks mapped twice (keyframe vs local map) after insertion");
  t.Add("mapping.interpolate_trajectory", &mp.interpolate_trajectory,
        "trajectory frames blend the corrections of the keyframes before and after them");
  t.Add("mapping.track_local_map", &mp.track_local_map,
        "tracking also matches the local map (bounded drift)");
  t.Add("mapping.track_min_inliers", &mp.track_min_inliers,
        "local-map inliers needed to correct the frame-to-frame pose");
  t.Add("mapping.track_min_inlier_ratio", &mp.track_min_inlier_ratio,
        "local-map inliers per frame-to-frame inlier needed to replace the pose");
  t.Add("mapping.track_max_correction_deg", &mp.track_max_correction_deg,
        "largest accepted local-map rotation correction, deg");
  t.Add("mapping.track_max_correction", &mp.track_max_correction,
        "largest accepted local-map correction, m");
  t.Add("mapping.skip_covered_keyframes", &mp.skip_covered_keyframes,
        "skip a proposed keyframe whose local-map inliers reach this share of the last "
        "keyframe's landmarks (0 never skips)");
  BundleAdjustmentOptions& ba = mp.ba;
  t.Add("mapping.ba.max_iterations", &ba.max_iterations, "Levenberg-Marquardt iterations per pass");
  t.Add("mapping.ba.second_pass", &ba.second_pass, "re-optimise without the first pass' outliers");
  t.Add("mapping.ba.outlier_sigma", &ba.outlier_sigma, "pixels per unit of the chi2 outlier gates");
  t.Add("mapping.ba.disparity_sigma", &ba.disparity_sigma,
        "a stereo point's disparity fitted as its own residual with this standard deviation, px "
        "(0 = the right-image column, with the left image's)");
  t.Add("mapping.ba.point_chi2_mono", &ba.point_chi2_mono, "point outlier threshold, 2 dof");
  t.Add("mapping.ba.point_chi2_stereo", &ba.point_chi2_stereo, "point outlier threshold, 3 dof");
  t.Add("mapping.ba.line_chi2_mono", &ba.line_chi2_mono, "line outlier threshold, 2 dof");
  t.Add("mapping.ba.line_chi2_stereo", &ba.line_chi2_stereo, "line outlier threshold, 4 dof");
  t.Add("mapping.ba.line_extent_weight", &ba.line_extent_weight,
        "holds line endpoints along their line in BA, per metre (0 = off)");
  t.Add("mapping.ba.line_residual", &ba.line_residual,
        "line residual: projected (paper eq. 6), observed (observed endpoints to projected "
        "line) or auto (observed in lines mode)");
  t.Add("mapping.ba.min_depth", &ba.min_depth, "observations closer than this (m) are outliers");
  t.Add("mapping.ba.num_threads", &ba.num_threads, "Ceres threads");
  t.Add("mapping.ba.schur", &ba.schur, "reduced camera system solver: sparse or dense");
  t.Add("mapping.map.covisibility_min_shared", &mp.map.covisibility_min_shared,
        "covisibility edge: shared landmarks at least");
  t.Add("mapping.map.essential_min_shared", &mp.map.essential_min_shared,
        "essential-graph edge: shared landmarks more than");
  LoopClosingOptions& lc = options->loop;
  t.Add("loop.enabled", &lc.enabled, "detect and close loops (needs the vocabulary)");
  t.Add("loop.relocalize", &lc.relocalize, "relocalise in the map after tracking loss");
  t.Add("loop.vocabulary", &lc.vocabulary,
        "folder with orb.plvoc and lbd.plvoc; empty = the package's vocabulary/, relative = "
        "relative to the package");
  t.Add("loop.queue_size", &lc.queue_size, "keyframes waiting for loop detection");
  t.Add("loop.thread_niceness", &lc.thread_niceness,
        "loop-closing thread: nice steps below tracking (0-19)");
  t.Add("loop.min_keyframe_gap", &lc.min_keyframe_gap,
        "loop candidates are at least this many keyframes older");
  t.Add("loop.max_candidates", &lc.max_candidates, "database results examined per keyframe");
  t.Add("loop.min_score", &lc.min_score, "smallest combined BoW score of a candidate");
  t.Add("loop.min_normalized_score", &lc.min_normalized_score,
        "candidate score / best covisible neighbour score, at least");
  t.Add("loop.consistency", &lc.consistency,
        "consecutive keyframes whose candidate groups must agree");
  t.Add("loop.relocalize_candidates", &lc.relocalize_candidates,
        "database results tried for relocalisation");
  t.Add("loop.loop_edge_weight", &lc.loop_edge_weight,
        "information of a loop edge relative to a pose-graph edge");
  t.Add("loop.max_drift_ratio", &lc.max_drift_ratio,
        "a loop may move its keyframe by at most max_drift_floor + this x the path since "
        "the candidate (odometry consistency)");
  t.Add("loop.max_drift_floor", &lc.max_drift_floor,
        "loop correction always allowed by the odometry consistency check, m");
  t.Add("loop.global_ba", &lc.global_ba,
        "after a loop correction, bundle-adjust the whole map in the background");
  t.Add("loop.global_ba_iterations", &lc.global_ba_iterations,
        "Levenberg-Marquardt iterations of that global bundle adjustment");
  t.Add("loop.global_ba_followup", &lc.global_ba_followup,
        "keyframes after a correction, one more global bundle adjustment (0 = none)");
  t.Add("loop.database.line_weight", &lc.database.line_weight,
        "weight of a line relative to a point in the combined score");
  t.Add("loop.verification.min_inliers", &lc.verification.min_inliers,
        "point + line inliers a loop needs");
  t.Add("loop.verification.min_inlier_ratio", &lc.verification.min_inlier_ratio,
        "RANSAC inliers / descriptor matches, at least");
  t.Add("loop.verification.max_translation_sigma", &lc.verification.max_translation_sigma,
        "largest 1-sigma translation uncertainty of a loop, m");
  t.Add("loop.verification.max_rotation_sigma_deg", &lc.verification.max_rotation_sigma_deg,
        "largest 1-sigma rotation uncertainty of a loop, deg");
  t.Add("loop.pose_graph.max_iterations", &lc.pose_graph.max_iterations,
        "pose-graph Levenberg-Marquardt iterations");
  t.Add("loop.pose_graph.rotation_weight", &lc.pose_graph.rotation_weight,
        "pose-graph rotation residual weight relative to translation");
  return t;
}

}  // namespace pl_slam
