#include "pl_slam/mapping/local_map_matching.h"

#include <cmath>
#include <sstream>

#include "pl_slam/tracking/motion_estimator.h"

namespace pl_slam {
namespace {

bool Skip(const std::vector<char>& mask, size_t i) { return !mask.empty() && mask[i]; }

/// Rows `index` of `src` stacked.
cv::Mat Rows(const cv::Mat& src, const std::vector<int>& index) {
  cv::Mat out(static_cast<int>(index.size()), src.cols, src.type());
  for (size_t k = 0; k < index.size(); ++k) src.row(index[k]).copyTo(out.row(static_cast<int>(k)));
  return out;
}

}  // namespace

LocalMapMatches MatchLocalMap(const StereoCamera& camera, const LocalMap& local, const SE3& T_c_w,
                              const StereoFeatures& features, const LocalMapMasks& masks,
                              const MappingFrontEnd& front_end, double search_radius) {
  constexpr double kMinDepth = 0.1;  // metres
  LocalMapMatches out;
  // Points.
  std::vector<int> lm_index, f_index;
  PointFeatures lm_points, f_points;
  for (size_t i = 0; i < local.points.size(); ++i) {
    if (Skip(masks.skip_local_points, i)) continue;
    const Eigen::Vector3d X = T_c_w * local.points[i].p_c;
    if (X.z() < kMinDepth || !camera.InImage(camera.Project(X))) continue;
    lm_index.push_back(static_cast<int>(i));
    lm_points.push_back(local.points[i]);
  }
  for (size_t j = 0; j < features.points.size(); ++j) {
    if (Skip(masks.skip_feature_points, j)) continue;
    f_index.push_back(static_cast<int>(j));
    f_points.push_back(features.points[j]);
  }
  if (!lm_index.empty() && !f_index.empty()) {
    PointMatchingOptions opt = front_end.point_matching;
    opt.search_radius = search_radius;
    for (const auto& [a, b] :
         MatchPointsFrameToFrame(camera, lm_points, Rows(local.point_descriptors, lm_index),
                                 f_points, Rows(features.point_descriptors, f_index), opt, &T_c_w))
      out.points.emplace_back(lm_index[a], f_index[b]);
  }
  // Lines: at least one endpoint in the image, both in front.
  lm_index.clear();
  f_index.clear();
  LineFeatures lm_lines, f_lines;
  for (size_t i = 0; i < local.lines.size(); ++i) {
    if (Skip(masks.skip_local_lines, i)) continue;
    const Eigen::Vector3d P = T_c_w * local.lines[i].P_c, Q = T_c_w * local.lines[i].Q_c;
    if (P.z() < kMinDepth || Q.z() < kMinDepth) continue;
    if (!camera.InImage(camera.Project(P)) && !camera.InImage(camera.Project(Q))) continue;
    lm_index.push_back(static_cast<int>(i));
    lm_lines.push_back(local.lines[i]);
  }
  for (size_t j = 0; j < features.lines.size(); ++j) {
    if (Skip(masks.skip_feature_lines, j)) continue;
    f_index.push_back(static_cast<int>(j));
    f_lines.push_back(features.lines[j]);
  }
  if (!lm_index.empty() && !f_index.empty()) {
    LinePrediction prediction;
    prediction.T_cur_prev = T_c_w;
    prediction.camera = camera;
    for (const auto& [a, b] :
         MatchLines(lm_lines, Rows(local.line_descriptors, lm_index), f_lines,
                    Rows(features.line_descriptors, f_index), front_end.line_matching, &prediction))
      out.lines.emplace_back(lm_index[a], f_index[b]);
  }
  return out;
}

LocalMapTracking TrackLocalMap(const StereoCamera& camera, const StereoFeatures& features,
                               const LocalMap& local, const SE3& T_w_c_prior,
                               const MappingOptions& options, const MappingFrontEnd& front_end,
                               const LocalMapGate* gate) {
  const LocalMapGate own = LocalMapGate::Of(options);
  if (!gate) gate = &own;
  LocalMapTracking result;
  result.T_w_c = T_w_c_prior;
  const SE3 T_c_w = T_w_c_prior.inverse();
  const LocalMapMatches matches = MatchLocalMap(camera, local, T_c_w, features, LocalMapMasks(),
                                                front_end, options.search_radius);
  result.point_matches = static_cast<int>(matches.points.size());
  result.line_matches = static_cast<int>(matches.lines.size());
  PointMatches3D2D pm;
  LineMatches3D2D lm;
  for (const auto& [i, j] : matches.points) {
    PointMatch3D2D m;
    m.P_prev = local.points[i].p_c;
    const PointFeature& f = features.points[j];
    m.uv_cur = f.uv;
    m.weight = std::pow(front_end.scale_factor, -2.0 * f.octave);
    m.u_right_cur = f.u_right();
    pm.push_back(m);
  }
  for (const auto& [i, j] : matches.lines) {
    LineMatch3D2D m;
    m.P_prev = local.lines[i].P_c;
    m.Q_prev = local.lines[i].Q_c;
    m.l_cur = features.lines[j].l;
    m.weight = options.line_weight;
    lm.push_back(m);
  }
  if (static_cast<int>(pm.size() + lm.size()) < gate->min_inliers) {
    std::ostringstream os;
    os << "only " << pm.size() << " point and " << lm.size() << " line matches with the local map";
    result.failure = os.str();
    return result;
  }
  const MotionEstimate est = EstimateMotion(camera, pm, lm, T_c_w, front_end.motion);
  result.point_inliers = est.point_inliers;
  result.line_inliers = est.line_inliers;
  if (!est.success) {
    result.failure = "local-map pose estimation failed: " + est.failure;
    return result;
  }
  result.covariance = est.covariance;
  if (est.point_inliers + est.line_inliers < gate->min_inliers) {
    std::ostringstream os;
    os << "only " << est.point_inliers + est.line_inliers << " local-map inliers";
    result.failure = os.str();
    return result;
  }
  const SE3 T_w_c = est.T_cur_prev.inverse();
  const SE3 correction = T_w_c_prior.inverse() * T_w_c;
  if (!T_w_c.IsFinite() || correction.translation().norm() > gate->max_correction ||
      correction.RotationAngle() * 180.0 / M_PI > gate->max_correction_deg) {
    result.failure = "local-map correction too large; frame-to-frame pose kept";
    return result;
  }
  result.success = true;
  result.T_w_c = T_w_c;
  for (size_t k = 0; k < matches.points.size(); ++k)
    if (est.point_inlier[k])
      result.point_associations.emplace_back(matches.points[k].second,
                                             local.point_ids[matches.points[k].first]);
  for (size_t k = 0; k < matches.lines.size(); ++k)
    if (est.line_inlier[k])
      result.line_associations.emplace_back(matches.lines[k].second,
                                            local.line_ids[matches.lines[k].first]);
  return result;
}

}  // namespace pl_slam
