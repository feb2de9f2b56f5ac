// Matching a frame's features against the landmarks of a local map projected with a pose
// estimate: used by tracking (bounded drift while the camera stays in mapped space, which the
// original PL-SLAM lacked) and by keyframe insertion (more observations of existing landmarks).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "pl_slam/camera/stereo_camera.h"
#include "pl_slam/features/stereo_features.h"
#include "pl_slam/geometry/se3.h"
#include "pl_slam/map/map.h"
#include "pl_slam/mapping/local_mapper.h"

namespace pl_slam {

/// Matches (local-map index, feature index).
struct LocalMapMatches {
  std::vector<std::pair<int, int>> points;
  std::vector<std::pair<int, int>> lines;
};

/// Which elements take part; an empty vector means all, else 1 = skip.
struct LocalMapMasks {
  std::vector<char> skip_local_points, skip_local_lines;
  std::vector<char> skip_feature_points, skip_feature_lines;
};

/// Projects the local map's landmarks in front of the camera and inside the image with T_c_w
/// and matches them to the features (mutual best descriptor matches within `search_radius`
/// pixels for points, the line matcher's prediction gates for segments).
LocalMapMatches MatchLocalMap(const StereoCamera& camera, const LocalMap& local, const SE3& T_c_w,
                              const StereoFeatures& features, const LocalMapMasks& masks,
                              const MappingFrontEnd& front_end, double search_radius);

/// Result of tracking a frame against the local map.
struct LocalMapTracking {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  bool success = false;
  SE3 T_w_c;  ///< refined pose (the prior when not successful)
  int point_matches = 0, line_matches = 0;
  int point_inliers = 0, line_inliers = 0;
  /// Covariance of the camera-frame perturbation of T_c_w (MotionEstimate::covariance).
  Matrix6d covariance = Matrix6d::Zero();
  /// Inlier (feature index, landmark) pairs.
  std::vector<std::pair<int, LandmarkId>> point_associations, line_associations;
  std::string failure;  ///< why not successful
};

/// What TrackLocalMap accepts: fewest inliers and largest correction of the prior.
struct LocalMapGate {
  int min_inliers = 0;
  double max_correction = 0.0;  ///< metres
  double max_correction_deg = 0.0;
  /// The tracking gate of the options: track_min_inliers, track_max_correction(_deg).
  static LocalMapGate Of(const MappingOptions& options) {
    return {options.track_min_inliers, options.track_max_correction,
            options.track_max_correction_deg};
  }
};

/// Refines T_w_c_prior by matching the frame's features to the local map and running the
/// robust motion estimator on the 3D (world) - 2D correspondences. Refuses (success = false)
/// with fewer inliers or a larger correction than the gate allows (by default
/// options.track_min_inliers and options.track_max_correction(_deg)).
LocalMapTracking TrackLocalMap(const StereoCamera& camera, const StereoFeatures& features,
                               const LocalMap& local, const SE3& T_w_c_prior,
                               const MappingOptions& options, const MappingFrontEnd& front_end,
                               const LocalMapGate* gate = nullptr);

}  // namespace pl_slam
