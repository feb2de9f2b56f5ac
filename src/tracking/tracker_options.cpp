// Feature modes and TrackerOptions validation (the tracker itself: stereo_tracker.cpp).
#include <sstream>
#include <string>

#include "pl_slam/tracking/stereo_tracker.h"
#include "pl_slam/util/error.h"

namespace pl_slam {

FeatureMode ParseFeatureMode(const std::string& name) {
  if (name == "points") return FeatureMode::kPoints;
  if (name == "lines") return FeatureMode::kLines;
  if (name == "points_lines") return FeatureMode::kPointsAndLines;
  throw ConfigError("mode='" + name + "' must be one of points, lines, points_lines");
}

const char* FeatureModeName(FeatureMode mode) {
  switch (mode) {
    case FeatureMode::kPoints:
      return "points";
    case FeatureMode::kLines:
      return "lines";
    case FeatureMode::kPointsAndLines:
      return "points_lines";
  }
  return "?";
}

std::string TrackerOptions::Validate() const {
  std::ostringstream os;
  if (min_inliers < 6 || min_inliers > 1000)
    os << "min_inliers=" << min_inliers << " must be in [6, 1000]";
  else if (!(max_translation > 0.0 && max_translation <= 100.0))
    os << "max_translation=" << max_translation << " must be in (0, 100]";
  else if (!(max_rotation_deg > 0.0 && max_rotation_deg <= 180.0))
    os << "max_rotation_deg=" << max_rotation_deg << " must be in (0, 180]";
  else if (!(line_weight > 0.0 && line_weight <= 100.0))
    os << "line_weight=" << line_weight << " must be in (0, 100]";
  else if (!(depth_noise >= 0.0 && depth_noise <= 10.0))
    os << "depth_noise=" << depth_noise << " must be in [0, 10]";
  else if (!(keyframe_min_inlier_ratio >= 0.0 && keyframe_min_inlier_ratio <= 100.0))
    os << "keyframe_min_inlier_ratio=" << keyframe_min_inlier_ratio << " must be in [0, 100]";
  else if (!(keyframe_max_correction > 0.0 && keyframe_max_correction <= 100.0))
    os << "keyframe_max_correction=" << keyframe_max_correction << " must be in (0, 100]";
  else if (!(keyframe_max_correction_deg > 0.0 && keyframe_max_correction_deg <= 180.0))
    os << "keyframe_max_correction_deg=" << keyframe_max_correction_deg << " must be in (0, 180]";
  else if (!(keyframe_max_chi2 >= 0.0 && keyframe_max_chi2 <= 1e6))
    os << "keyframe_max_chi2=" << keyframe_max_chi2 << " must be in [0, 1e6]";
  else if (relaxed_min_inliers < 0 || relaxed_min_inliers > 1000)
    os << "relaxed_min_inliers=" << relaxed_min_inliers << " must be in [0, 1000]";
  else if (!(relaxed_max_deviation > 0.0 && relaxed_max_deviation <= 10.0))
    os << "relaxed_max_deviation=" << relaxed_max_deviation << " must be in (0, 10]";
  else if (!(relaxed_max_deviation_deg > 0.0 && relaxed_max_deviation_deg <= 90.0))
    os << "relaxed_max_deviation_deg=" << relaxed_max_deviation_deg << " must be in (0, 90]";
  else if (max_predicted_frames < 0 || max_predicted_frames > 1000)
    os << "max_predicted_frames=" << max_predicted_frames << " must be in [0, 1000]";
  else if (lost_rotation_min_inliers < 0 || lost_rotation_min_inliers > 1000)
    os << "lost_rotation_min_inliers=" << lost_rotation_min_inliers << " must be in [0, 1000]";
  else if (fused_min_inliers != 0 && (fused_min_inliers < 3 || fused_min_inliers > 1000))
    os << "fused_min_inliers=" << fused_min_inliers << " must be 0 or in [3, 1000]";
  else if (!(fused_sigma > 0.0 && fused_sigma <= 10.0))
    os << "fused_sigma=" << fused_sigma << " must be in (0, 10]";
  else if (!(fused_sigma_deg > 0.0 && fused_sigma_deg <= 90.0))
    os << "fused_sigma_deg=" << fused_sigma_deg << " must be in (0, 90]";
  if (!os.str().empty()) return os.str();
  const std::pair<const char*, std::string> nested[] = {
      {"points.", points.Validate()},       {"point_matching.", point_matching.Validate()},
      {"lines.", lines.Validate()},         {"line_matching.", line_matching.Validate()},
      {"motion.", motion.Validate()},       {"consensus.", consensus.Validate()},
      {"keyframes.", keyframes.Validate()}, {"direct.", direct.Validate()}};
  for (const auto& [prefix, err] : nested)
    if (!err.empty()) return prefix + err;
  return "";
}

}  // namespace pl_slam
