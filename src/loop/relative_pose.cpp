#include "pl_slam/loop/relative_pose.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>
#include <unordered_map>

#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

// Relative information of a keypoint at pyramid level `octave` (as the tracker weighs it).
double OctaveWeight(int octave, double scale_factor) {
  return std::pow(scale_factor, -2.0 * octave);
}

void CheckDescriptors(const StereoFeatures& f, const char* which) {
  const bool points_ok = f.points.empty() ||
                         (f.point_descriptors.type() == CV_8UC1 && f.point_descriptors.cols == 32 &&
                          f.point_descriptors.rows == static_cast<int>(f.points.size()));
  const bool lines_ok =
      f.lines.empty() || (f.line_descriptors.type() == CV_8UC1 && f.line_descriptors.cols == 32 &&
                          f.line_descriptors.rows == static_cast<int>(f.lines.size()));
  if (!points_ok || !lines_ok) {
    throw InputError(std::string("EstimateRelativePose: ") + which +
                     " descriptors do not fit its features (CV_8UC1, 32 columns, one row each)");
  }
}

// Number of points (of P, uv, weights) within the threshold under T.
struct Correspondences {
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> P;   // candidate 3D
  std::vector<Eigen::Vector2d, Eigen::aligned_allocator<Eigen::Vector2d>> uv;  // query pixels
  std::vector<double> thr2;  // per-match squared pixel threshold
};
struct LineCorrespondences {
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> P, Q;  // candidate 3D
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> l;     // query lines
};

int CountPointInliers(const StereoCamera& cam, const SE3& T, const Correspondences& c,
                      double min_depth, std::vector<uint8_t>* inlier) {
  int n = 0;
  if (inlier) inlier->assign(c.P.size(), 0);
  for (std::size_t i = 0; i < c.P.size(); ++i) {
    const Eigen::Vector3d X = T * c.P[i];
    if (!(X.z() > min_depth)) continue;
    if ((cam.Project(X) - c.uv[i]).squaredNorm() < c.thr2[i]) {
      ++n;
      if (inlier) (*inlier)[i] = 1;
    }
  }
  return n;
}

int CountLineInliers(const StereoCamera& cam, const SE3& T, const LineCorrespondences& c,
                     double thr, double min_depth, std::vector<uint8_t>* inlier) {
  int n = 0;
  if (inlier) inlier->assign(c.P.size(), 0);
  for (std::size_t i = 0; i < c.P.size(); ++i) {
    const Eigen::Vector3d XP = T * c.P[i], XQ = T * c.Q[i];
    if (!(XP.z() > min_depth && XQ.z() > min_depth)) continue;
    const Eigen::Vector2d p = cam.Project(XP), q = cam.Project(XQ);
    const double dp = c.l[i].dot(Eigen::Vector3d(p.x(), p.y(), 1.0));
    const double dq = c.l[i].dot(Eigen::Vector3d(q.x(), q.y(), 1.0));
    if (std::abs(dp) < thr && std::abs(dq) < thr) {
      ++n;
      if (inlier) (*inlier)[i] = 1;
    }
  }
  return n;
}

Eigen::Vector3d NormalisedLine(const LineFeature& f) {
  Eigen::Vector3d l = f.l;
  const double n = l.head<2>().norm();
  if (n > 0.0) l /= n;
  return l;
}

std::string Gates(const RelativePoseOptions& o, const MotionEstimate& est, const SE3& T) {
  std::ostringstream os;
  const int inliers = est.point_inliers + est.line_inliers;
  if (inliers < o.min_inliers) {
    os << "only " << est.point_inliers << " point + " << est.line_inliers
       << " line inliers after refinement (min_inliers=" << o.min_inliers << ")";
    return os.str();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> et(est.covariance.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(est.covariance.bottomRightCorner<3, 3>());
  const double sigma_t = std::sqrt(std::max(0.0, et.eigenvalues().maxCoeff()));
  const double sigma_r = std::sqrt(std::max(0.0, er.eigenvalues().maxCoeff())) * kRadToDeg;
  if (!(sigma_t <= o.max_translation_sigma)) {
    os << "translation uncertainty " << sigma_t
       << " m above max_translation_sigma=" << o.max_translation_sigma;
  } else if (!(sigma_r <= o.max_rotation_sigma_deg)) {
    os << "rotation uncertainty " << sigma_r
       << " deg above max_rotation_sigma_deg=" << o.max_rotation_sigma_deg;
  } else if (!(T.translation().norm() <= o.max_translation)) {
    os << "relative translation " << T.translation().norm()
       << " m above max_translation=" << o.max_translation;
  } else if (!(T.RotationAngle() * kRadToDeg <= o.max_rotation_deg)) {
    os << "relative rotation " << T.RotationAngle() * kRadToDeg
       << " deg above max_rotation_deg=" << o.max_rotation_deg;
  }
  return os.str();
}

}  // namespace

std::string RelativePoseOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("max_point_distance", max_point_distance, 0, 256));
  check(CheckRange("point_ratio", point_ratio, 0.0, 1.0, true));
  check(CheckRange("min_point_matches", min_point_matches, 3, 100000));
  check(CheckRange("ransac_max_iterations", ransac_max_iterations, 1, 1000000));
  check(CheckRange("ransac_confidence", ransac_confidence, 0.0, 0.999999, true));
  check(CheckRange("ransac_threshold_px", ransac_threshold_px, 0.0, 100.0, true));
  check(CheckRange("line_threshold_px", line_threshold_px, 0.0, 100.0, true));
  check(CheckRange("guided_radius_px", guided_radius_px, 0.0, 1000.0, true));
  check(CheckRange("min_inliers", min_inliers, 6, 100000));
  check(CheckRange("min_inlier_ratio", min_inlier_ratio, 0.0, 1.0));
  check(CheckRange("max_translation_sigma", max_translation_sigma, 0.0, 100.0, true));
  check(CheckRange("max_rotation_sigma_deg", max_rotation_sigma_deg, 0.0, 180.0, true));
  check(CheckRange("max_translation", max_translation, 0.0, 1e6, true));
  check(CheckRange("max_rotation_deg", max_rotation_deg, 0.0, 180.0, true));
  check(CheckRange("octave_scale_factor", octave_scale_factor, 1.0, 4.0, true));
  if (!first.empty()) return first;
  const std::pair<const char*, std::string> nested[] = {
      {"line_matching.", line_matching.Validate()},
      {"point_matching.", point_matching.Validate()},
      {"motion.", motion.Validate()}};
  for (const auto& [prefix, err] : nested)
    if (!err.empty()) return prefix + err;
  return "";
}

std::vector<std::pair<int, int>> MatchPointsByDescriptor(const StereoFeatures& candidate,
                                                         const StereoFeatures& query,
                                                         int max_distance, double ratio,
                                                         const FeatureNodeIndex* candidate_nodes,
                                                         const FeatureNodeIndex* query_nodes) {
  const int nc = static_cast<int>(candidate.points.size());
  const int nq = static_cast<int>(query.points.size());
  std::vector<Descriptor256> dc(nc), dq(nq);
  for (int i = 0; i < nc; ++i) dc[i] = DescriptorFromRow(candidate.point_descriptors, i);
  for (int j = 0; j < nq; ++j) dq[j] = DescriptorFromRow(query.point_descriptors, j);

  // Blocks of (candidate indices, query indices) compared all-pairs.
  std::vector<std::pair<std::vector<int>, std::vector<int>>> blocks;
  if (candidate_nodes && query_nodes) {
    std::unordered_map<uint32_t, const std::vector<int>*> query_of_node;
    for (const auto& [node, idx] : *query_nodes) query_of_node[node] = &idx;
    for (const auto& [node, idx] : *candidate_nodes) {
      const auto it = query_of_node.find(node);
      if (it != query_of_node.end()) blocks.push_back({idx, *it->second});
    }
  } else {
    std::vector<int> all_c(nc), all_q(nq);
    for (int i = 0; i < nc; ++i) all_c[i] = i;
    for (int j = 0; j < nq; ++j) all_q[j] = j;
    blocks.push_back({std::move(all_c), std::move(all_q)});
  }

  constexpr int kInf = 1 << 20;
  std::vector<int> best_q(nc, -1), best_d(nc, kInf), second_d(nc, kInf);
  std::vector<int> best_c(nq, -1), best_cd(nq, kInf);
  for (const auto& [cs, qs] : blocks) {
    for (int i : cs) {
      if (i < 0 || i >= nc || !candidate.points[i].has_depth) continue;
      for (int j : qs) {
        if (j < 0 || j >= nq) continue;
        const int d = Hamming256(dc[i], dq[j]);
        if (d < best_d[i]) {
          second_d[i] = best_d[i];
          best_d[i] = d;
          best_q[i] = j;
        } else if (d < second_d[i]) {
          second_d[i] = d;
        }
        if (d < best_cd[j]) {
          best_cd[j] = d;
          best_c[j] = i;
        }
      }
    }
  }
  std::vector<std::pair<int, int>> matches;
  for (int i = 0; i < nc; ++i) {
    const int j = best_q[i];
    if (j < 0 || best_c[j] != i || best_d[i] > max_distance) continue;
    if (second_d[i] < kInf && !(best_d[i] < ratio * second_d[i])) continue;
    matches.emplace_back(i, j);
  }
  return matches;
}

RelativePose EstimateRelativePose(const StereoCamera& camera, const StereoFeatures& query,
                                  const StereoFeatures& candidate,
                                  const RelativePoseOptions& options,
                                  const FeatureNodeIndex* query_point_nodes,
                                  const FeatureNodeIndex* candidate_point_nodes) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("relative_pose: " + err);
  const std::string cam_err = camera.Validate();
  if (!cam_err.empty()) throw ConfigError("camera: " + cam_err);
  CheckDescriptors(query, "query");
  CheckDescriptors(candidate, "candidate");
  RelativePose out;
  const double min_depth = options.motion.min_depth;

  // 1. Descriptor matching.
  const bool restricted = query_point_nodes && candidate_point_nodes;
  const auto point_matches = MatchPointsByDescriptor(
      candidate, query, options.max_point_distance, options.point_ratio,
      restricted ? candidate_point_nodes : nullptr, restricted ? query_point_nodes : nullptr);
  std::vector<std::pair<int, int>> line_matches;
  if (!candidate.lines.empty() && !query.lines.empty()) {
    for (const auto& m : MatchLines(candidate.lines, candidate.line_descriptors, query.lines,
                                    query.line_descriptors, options.line_matching)) {
      if (candidate.lines[m.first].has_depth) line_matches.push_back(m);
    }
  }
  out.point_matches = static_cast<int>(point_matches.size());
  out.line_matches = static_cast<int>(line_matches.size());
  if (out.point_matches < options.min_point_matches) {
    std::ostringstream os;
    os << "only " << out.point_matches
       << " descriptor point matches (min_point_matches=" << options.min_point_matches << ")";
    out.failure = os.str();
    return out;
  }

  Correspondences pc;
  std::vector<double> point_weight;
  const double thr2 = options.ransac_threshold_px * options.ransac_threshold_px;
  for (const auto& [i, j] : point_matches) {
    pc.P.push_back(candidate.points[i].p_c);
    pc.uv.push_back(query.points[j].uv);
    const double w = OctaveWeight(query.points[j].octave, options.octave_scale_factor);
    point_weight.push_back(w);
    pc.thr2.push_back(thr2 / w);  // coarser keypoints: proportionally wider threshold
  }
  LineCorrespondences lc;
  for (const auto& [i, j] : line_matches) {
    lc.P.push_back(candidate.lines[i].P_c);
    lc.Q.push_back(candidate.lines[i].Q_c);
    lc.l.push_back(NormalisedLine(query.lines[j]));
  }

  // 2. RANSAC with P3P.
  const cv::Matx33d K(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  std::mt19937_64 rng(options.seed);
  const int n = out.point_matches;
  std::uniform_int_distribution<int> pick(0, n - 1);
  SE3 best_T;
  int best_score = -1, best_points = 0, best_lines = 0;
  int needed = options.ransac_max_iterations;
  int it = 0;
  for (; it < needed; ++it) {
    int s[3];
    s[0] = pick(rng);
    do s[1] = pick(rng);
    while (s[1] == s[0]);
    do s[2] = pick(rng);
    while (s[2] == s[0] || s[2] == s[1]);
    std::vector<cv::Point3d> obj;
    std::vector<cv::Point2d> img;
    for (int k : s) {
      obj.emplace_back(pc.P[k].x(), pc.P[k].y(), pc.P[k].z());
      img.emplace_back(pc.uv[k].x(), pc.uv[k].y());
    }
    // Nearly coincident image points give an ill-conditioned sample.
    if (cv::norm(img[0] - img[1]) < 2.0 || cv::norm(img[0] - img[2]) < 2.0 ||
        cv::norm(img[1] - img[2]) < 2.0)
      continue;
    std::vector<cv::Mat> rvecs, tvecs;
    int solutions = 0;
    try {
      solutions = cv::solveP3P(obj, img, K, cv::noArray(), rvecs, tvecs, cv::SOLVEPNP_P3P);
    } catch (const cv::Exception&) {
      continue;
    }
    for (int sol = 0; sol < solutions; ++sol) {
      cv::Matx33d R;
      cv::Rodrigues(rvecs[sol], R);
      Eigen::Matrix3d Re;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) Re(r, c) = R(r, c);
      const cv::Vec3d t(tvecs[sol]);
      const SE3 T(Re, Eigen::Vector3d(t[0], t[1], t[2]));
      if (!T.IsFinite()) continue;
      const int np = CountPointInliers(camera, T, pc, min_depth, nullptr);
      if (np < 4) continue;
      const int nl = CountLineInliers(camera, T, lc, options.line_threshold_px, min_depth, nullptr);
      if (np + nl > best_score) {
        best_score = np + nl;
        best_points = np;
        best_lines = nl;
        best_T = T;
        const double w = static_cast<double>(np) / n;
        const double denom = std::log(std::max(1e-12, 1.0 - w * w * w));
        if (denom < 0.0) {
          const double k = std::log(1.0 - options.ransac_confidence) / denom;
          needed = std::min(options.ransac_max_iterations,
                            std::max(it + 1, static_cast<int>(std::ceil(k))));
        }
      }
    }
  }
  out.ransac_iterations = it;
  out.ransac_point_inliers = best_points;
  out.ransac_line_inliers = best_lines;
  out.inlier_ratio = static_cast<double>(best_points) / n;
  if (best_score < 0) {
    out.failure = "RANSAC found no pose with 4 or more point inliers";
    return out;
  }
  out.T_query_candidate = best_T;
  if (out.inlier_ratio < options.min_inlier_ratio) {
    std::ostringstream os;
    os << "RANSAC inlier ratio " << out.inlier_ratio << " (" << best_points << "/" << n
       << ") below min_inlier_ratio=" << options.min_inlier_ratio;
    out.failure = os.str();
    return out;
  }

  // 3. Robust refinement on the RANSAC inliers.
  std::vector<uint8_t> p_in, l_in;
  CountPointInliers(camera, best_T, pc, min_depth, &p_in);
  CountLineInliers(camera, best_T, lc, options.line_threshold_px, min_depth, &l_in);
  PointMatches3D2D pm;
  LineMatches3D2D lm;
  for (std::size_t i = 0; i < pc.P.size(); ++i) {
    if (!p_in[i]) continue;
    PointMatch3D2D m;
    m.P_prev = pc.P[i];
    m.uv_cur = pc.uv[i];
    m.weight = point_weight[i];
    pm.push_back(m);
  }
  for (std::size_t i = 0; i < lc.P.size(); ++i) {
    if (!l_in[i]) continue;
    LineMatch3D2D m;
    m.P_prev = lc.P[i];
    m.Q_prev = lc.Q[i];
    m.l_cur = lc.l[i];
    lm.push_back(m);
  }
  MotionEstimate est = EstimateMotion(camera, pm, lm, best_T, options.motion);
  if (!est.success) {
    out.failure = "refinement failed: " + est.failure;
    return out;
  }

  // 4. Guided re-matching with the refined pose, then a second refinement.
  if (options.guided_rematch) {
    PointMatchingOptions pmo = options.point_matching;
    pmo.search_radius = options.guided_radius_px;
    const auto gp =
        MatchPointsFrameToFrame(camera, candidate.points, candidate.point_descriptors, query.points,
                                query.point_descriptors, pmo, &est.T_cur_prev);
    LinePrediction prediction;
    prediction.T_cur_prev = est.T_cur_prev;
    prediction.camera = camera;
    std::vector<std::pair<int, int>> gl;
    if (!candidate.lines.empty() && !query.lines.empty()) {
      gl = MatchLines(candidate.lines, candidate.line_descriptors, query.lines,
                      query.line_descriptors, options.line_matching, &prediction);
    }
    PointMatches3D2D gpm;
    LineMatches3D2D glm;
    for (const auto& [i, j] : gp) {
      PointMatch3D2D m;
      m.P_prev = candidate.points[i].p_c;
      m.uv_cur = query.points[j].uv;
      m.weight = OctaveWeight(query.points[j].octave, options.octave_scale_factor);
      gpm.push_back(m);
    }
    for (const auto& [i, j] : gl) {
      if (!candidate.lines[i].has_depth) continue;
      LineMatch3D2D m;
      m.P_prev = candidate.lines[i].P_c;
      m.Q_prev = candidate.lines[i].Q_c;
      m.l_cur = NormalisedLine(query.lines[j]);
      glm.push_back(m);
    }
    if (gpm.size() + glm.size() > pm.size() + lm.size()) {
      const MotionEstimate guided =
          EstimateMotion(camera, gpm, glm, est.T_cur_prev, options.motion);
      if (guided.success &&
          guided.point_inliers + guided.line_inliers >= est.point_inliers + est.line_inliers) {
        est = guided;
      }
    }
  }

  // 5. Gates.
  out.T_query_candidate = est.T_cur_prev;
  out.covariance = est.covariance;
  out.point_inliers = est.point_inliers;
  out.line_inliers = est.line_inliers;
  out.rmse_px = est.rmse_px;
  out.failure = Gates(options, est, est.T_cur_prev);
  out.success = out.failure.empty();
  return out;
}

}  // namespace pl_slam
