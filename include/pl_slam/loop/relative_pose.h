// Geometric verification of a loop (or relocalisation) candidate: the relative pose of the
// query frame with respect to the candidate keyframe from their points and line segments.
//
// Pipeline:
//  1. Descriptor matching, no pose prior: candidate points WITH depth against all query points,
//     mutual best + ratio test (optionally only within shared vocabulary nodes, see
//     FeatureNodeIndex); candidate lines with depth against query lines (MatchLines without a
//     prediction: mutual best, ratio, direction and length agreement).
//  2. RANSAC over the 3D(candidate) - 2D(query) point matches with the minimal P3P solver
//     (cv::solveP3P, up to 4 solutions per sample), each hypothesis scored by its point
//     inliers plus the line matches whose projected 3D endpoints lie close to the query line.
//     P3P rather than 3D-3D (Umeyama on stereo points of both frames): the query needs no
//     stereo depth, and the error is measured in the image where it is well modelled (stereo
//     depth noise grows with the square of the distance, reprojection noise does not), the
//     same cost as the refinement, so RANSAC and refinement agree on who is an inlier.
//  3. EstimateMotion (robust Gauss-Newton, points + lines) on the RANSAC inliers.
//  4. Optionally, guided re-matching with that pose (points projected within a radius, lines
//     with the prediction gate of MatchLines) and a second EstimateMotion on all of them.
//  5. Gates: inlier count, RANSAC inlier ratio, covariance (1-sigma translation / rotation),
//     bounded translation and rotation.
// Convention: T_query_candidate maps candidate-camera points into the query camera,
// X_query = T_query_candidate * X_candidate (EstimateMotion's T_cur_prev with prev =
// candidate); its covariance is EstimateMotion's (left perturbation, [rho; phi]).
#pragma once

#include <cstdint>
#include <string>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/loop/vocabulary.h"
#include "pl_slam/matching/line_matching.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {

/// Options of EstimateRelativePose.
struct RelativePoseOptions {
  int max_point_distance = 64;          ///< descriptor stage: largest point Hamming distance
  double point_ratio = 0.8;             ///< descriptor stage: best < ratio * second best (points)
  int min_point_matches = 12;           ///< fewer descriptor point matches: fail before RANSAC
  int ransac_max_iterations = 500;      ///< RANSAC samples at most (fewer when confident)
  double ransac_confidence = 0.999;     ///< probability of drawing one all-inlier sample
  double ransac_threshold_px = 3.0;     ///< point inlier: reprojection error below (pixels)
  double line_threshold_px = 3.0;       ///< line inlier: both endpoint distances below (pixels)
  uint64_t seed = 1;                    ///< RANSAC sampling seed (results are deterministic)
  bool guided_rematch = true;           ///< step 4: re-match with the refined pose
  double guided_radius_px = 10.0;       ///< step 4: point search radius around the projection
  int min_inliers = 30;                 ///< final point + line inliers at least this
  double min_inlier_ratio = 0.25;       ///< RANSAC point inliers / descriptor point matches
  double max_translation_sigma = 0.05;  ///< largest 1-sigma translation uncertainty (metres)
  double max_rotation_sigma_deg = 1.0;  ///< largest 1-sigma rotation uncertainty (degrees)
  double max_translation = 5.0;         ///< larger relative translations are rejected (m)
  double max_rotation_deg = 90.0;       ///< larger relative rotations are rejected (degrees)
  /// ORB pyramid scale step (tracker points.scale_factor): a keypoint of octave o gets weight
  /// scale^(-2 o) in the refinement and a RANSAC threshold scale^o times wider.
  double octave_scale_factor = 1.2;
  /// Line matching of step 1 (f2f_* without a prediction) and step 4 (with one). Looser
  /// direction / length gates than frame-to-frame tracking: the views may differ more.
  LineMatchingOptions line_matching = [] {
    LineMatchingOptions o;
    o.f2f_max_angle_deg = 30.0;
    o.f2f_min_length_ratio = 0.3;
    return o;
  }();
  PointMatchingOptions point_matching;  ///< step 4 point matching (f2f_ratio, max_distance)
  MotionEstimatorOptions motion;        ///< steps 3 and 4

  /// Empty when valid, else "key=value must be in [a, b]" naming the first bad key.
  std::string Validate() const;
};

/// Result of EstimateRelativePose. On failure T_query_candidate is the best estimate reached
/// (identity when none) and `failure` says which stage refused.
struct RelativePose {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  bool success = false;                    ///< every gate passed
  SE3 T_query_candidate;                   ///< X_query = T_query_candidate * X_candidate
  Matrix6d covariance = Matrix6d::Zero();  ///< left perturbation of T_query_candidate
  int point_matches = 0;                   ///< descriptor-stage point matches
  int line_matches = 0;                    ///< descriptor-stage line matches (with depth)
  int ransac_point_inliers = 0;            ///< best RANSAC hypothesis: point inliers
  int ransac_line_inliers = 0;             ///< best RANSAC hypothesis: line inliers
  int ransac_iterations = 0;               ///< samples drawn
  double inlier_ratio = 0.0;               ///< ransac_point_inliers / point_matches
  int point_inliers = 0;                   ///< final refinement: point inliers
  int line_inliers = 0;                    ///< final refinement: line inliers
  double rmse_px = 0.0;                    ///< final refinement: inlier RMS residual
  std::string failure;                     ///< empty on success
};

/// Estimates T_query_candidate from the features of two rectified frames of the same stereo
/// camera (pipeline above). `query_point_nodes` / `candidate_point_nodes` (both or neither;
/// from Vocabulary::Transform or ComputeKeyframeBow at the same level) restrict the
/// descriptor stage to points sharing a vocabulary node: faster, a few matches fewer. Never
/// throws on bad data (reported through `failure`); throws ConfigError on invalid options or
/// camera, InputError on descriptors that do not fit the features.
RelativePose EstimateRelativePose(const StereoCamera& camera, const StereoFeatures& query,
                                  const StereoFeatures& candidate,
                                  const RelativePoseOptions& options,
                                  const FeatureNodeIndex* query_point_nodes = nullptr,
                                  const FeatureNodeIndex* candidate_point_nodes = nullptr);

/// Descriptor-stage point matches (candidate index, query index): candidate points with depth
/// against all query points, mutual best within max_distance and passing the ratio test;
/// restricted to shared nodes when both node indices are given.
std::vector<std::pair<int, int>> MatchPointsByDescriptor(
    const StereoFeatures& candidate, const StereoFeatures& query, int max_distance, double ratio,
    const FeatureNodeIndex* candidate_nodes = nullptr,
    const FeatureNodeIndex* query_nodes = nullptr);

}  // namespace pl_slam
