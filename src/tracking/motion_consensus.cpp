#include "pl_slam/tracking/motion_consensus.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Dense>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {
namespace {

// Lines closer to parallel than this (|cos| above) give no translation along their direction.
constexpr double kMaxLineCos = 0.985;  // ~10 degrees
// Sampled points closer together than this (metres) fix no rotation.
constexpr double kMinPointSpacing = 0.02;
// A segment pair whose angle changed by more than this between the frames (radians) is no
// rigid motion of the same two lines.
constexpr double kMaxLineAngleChange = 0.1;
constexpr uint64_t kSeed = 0x9e3779b97f4a7c15ULL;

// Rotation R minimising sum |R a_i - b_i|^2 over (already centred) vector pairs.
Eigen::Matrix3d KabschRotation(const Eigen::Matrix3d& H) {
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  return svd.matrixV() * D * svd.matrixU().transpose();
}

bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

// Squared reprojection errors of every correspondence at T (infinity when behind the camera).
struct Scorer {
  const StereoCamera& cam;
  const PointMatches3D2D& points;
  const LineMatches3D2D& lines;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> l;  // normalised
  std::vector<uint8_t> line_ok;

  bool Project(const Eigen::Vector3d& X, Eigen::Vector2d* uv) const {
    if (!(X.z() > 1e-3)) return false;
    *uv << cam.fx * X.x() / X.z() + cam.cx, cam.fy * X.y() / X.z() + cam.cy;
    return true;
  }
  double PointError2(const SE3& T, std::size_t i) const {
    Eigen::Vector2d uv;
    if (!Project(T * points[i].P_prev, &uv)) return std::numeric_limits<double>::infinity();
    return (uv - points[i].uv_cur).squaredNorm();
  }
  double LineError2(const SE3& T, std::size_t i) const {
    if (!line_ok[i]) return std::numeric_limits<double>::infinity();
    Eigen::Vector2d p, q;
    if (!Project(T * lines[i].P_prev, &p) || !Project(T * lines[i].Q_prev, &q))
      return std::numeric_limits<double>::infinity();
    const double dp = l[i].x() * p.x() + l[i].y() * p.y() + l[i].z();
    const double dq = l[i].x() * q.x() + l[i].y() * q.y() + l[i].z();
    return 0.5 * (dp * dp + dq * dq);
  }
  // MSAC cost and supporters of T; stops early (returning a cost above `bound`) once the cost
  // exceeds bound, since such a hypothesis cannot be the best.
  double Cost(const SE3& T, double thr2, double bound, int* support) const {
    double cost = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      const double e = PointError2(T, i);
      n += e <= thr2;
      cost += std::min(e, thr2);
      if (cost > bound) return cost;
    }
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const double e = LineError2(T, i);
      n += e <= thr2;
      cost += std::min(e, thr2);
      if (cost > bound) return cost;
    }
    *support = n;
    return cost;
  }
  // Polishes a 3D-3D minimal-set solution on the same set's image residuals: the current
  // frame's 2D observations are far more precise than its triangulated depths. A few damped
  // Gauss-Newton steps; with two segments (four residuals for six unknowns) the damping keeps
  // the directions the image does not fix where the 3D-3D solution put them.
  SE3 Polish(const SE3& T0, const int* point_idx, int num_points, const int* line_idx,
             int num_lines) const {
    using Matrix26d = Eigen::Matrix<double, 2, 6>;
    SE3 T = T0;
    for (int it = 0; it < 4; ++it) {
      Matrix6d H = Matrix6d::Zero();
      Vector6d g = Vector6d::Zero();
      Eigen::Vector2d r;
      Matrix26d J;
      for (int k = 0; k < num_points; ++k) {
        const PointMatch3D2D& m = points[point_idx[k]];
        if (!PointResidualAndJacobian(cam, T, m.P_prev, m.uv_cur, 1e-3, &r, &J)) return T0;
        H.noalias() += J.transpose() * J;
        g.noalias() += J.transpose() * r;
      }
      for (int k = 0; k < num_lines; ++k) {
        const LineMatch3D2D& m = lines[line_idx[k]];
        if (!LineResidualAndJacobian(cam, T, m.P_prev, m.Q_prev, l[line_idx[k]], 1e-3, &r, &J))
          return T0;
        H.noalias() += J.transpose() * J;
        g.noalias() += J.transpose() * r;
      }
      const double damping = 1e-6 * std::max(H.diagonal().maxCoeff(), 1e-12);
      H.diagonal().array() += damping;
      const Vector6d step = H.ldlt().solve(-g);
      if (!step.allFinite()) return T0;
      T = SE3::Exp(step) * T;
      if (step.norm() < 1e-8) break;
    }
    return T.IsFinite() ? T : T0;
  }

  // Local optimisation of a new best hypothesis (LO-RANSAC): a short robust fit over the
  // correspondences within the gate, since a minimal set triangulated with depth noise only
  // roughly agrees with its supporters (the fit's own outlier step drops the rest).
  bool Refine(const SE3& T, double thr2, SE3* refined) const {
    PointMatches3D2D p;
    LineMatches3D2D q;
    for (std::size_t i = 0; i < points.size(); ++i)
      if (PointError2(T, i) <= thr2) p.push_back(points[i]);
    for (std::size_t i = 0; i < lines.size(); ++i)
      if (LineError2(T, i) <= thr2) q.push_back(lines[i]);
    if (p.size() + q.size() < 6) return false;
    MotionEstimatorOptions opt;
    opt.max_iterations = 5;
    const MotionEstimate est = EstimateMotion(cam, p, q, T, opt);
    if (!est.success) return false;
    *refined = est.T_cur_prev;
    return true;
  }
};

}  // namespace

std::string ConsensusOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("max_hypotheses", max_hypotheses, 1, 100000));
  check(CheckRange("confidence", confidence, 0.0, 1.0, true));
  if (first.empty() && !(confidence < 1.0)) first = "confidence=1 must be below 1";
  check(CheckRange("inlier_px", inlier_px, 0.0, 100.0, true));
  check(CheckRange("gate_px", gate_px, inlier_px, 1000.0));
  check(CheckRange("disparity_sigma_px", disparity_sigma_px, 0.0, 100.0, true));
  return first;
}

bool RigidFromPoints(const Points3D& prev, const Points3D& cur, SE3* T_cur_prev) {
  const std::size_t n = prev.size();
  if (n < 3 || cur.size() != n) return false;
  Eigen::Vector3d cp = Eigen::Vector3d::Zero(), cc = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    cp += prev[i];
    cc += cur[i];
  }
  cp /= static_cast<double>(n);
  cc /= static_cast<double>(n);
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) H += (prev[i] - cp) * (cur[i] - cc).transpose();
  // Collinear points leave a rotation about their line free: two singular values vanish.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(1) > 1e-6 * std::max(sv(0), 1e-12)) || !(sv(0) > 0.0)) return false;
  const Eigen::Matrix3d R = KabschRotation(H);
  const Eigen::Vector3d t = cc - R * cp;
  if (!R.allFinite() || !t.allFinite()) return false;
  *T_cur_prev = SE3(R, t);
  return true;
}

bool RigidFromLines(const Eigen::Vector3d& a1, const Eigen::Vector3d& d1, const Eigen::Vector3d& a2,
                    const Eigen::Vector3d& d2, const Eigen::Vector3d& b1, const Eigen::Vector3d& e1,
                    const Eigen::Vector3d& b2, const Eigen::Vector3d& e2, double max_angle_change,
                    SE3* T_cur_prev) {
  const Eigen::Vector3d u1 = d1.normalized(), u2 = d2.normalized();
  const Eigen::Vector3d v1 = e1.normalized(), v2 = e2.normalized();
  if (!u1.allFinite() || !u2.allFinite() || !v1.allFinite() || !v2.allFinite()) return false;
  const double cu = u1.dot(u2), cv = v1.dot(v2);
  if (std::abs(cu) > kMaxLineCos || std::abs(cv) > kMaxLineCos) return false;
  if (std::abs(std::acos(std::clamp(cu, -1.0, 1.0)) - std::acos(std::clamp(cv, -1.0, 1.0))) >
      max_angle_change)
    return false;
  // Rotation: the two directions and their normal, matched in both frames.
  const Eigen::Vector3d nu = u1.cross(u2).normalized(), nv = v1.cross(v2).normalized();
  const Eigen::Matrix3d H = u1 * v1.transpose() + u2 * v2.transpose() + nu * nv.transpose();
  const Eigen::Matrix3d R = KabschRotation(H);
  // Translation: R a_i + t lies on line i of the current frame, (I - v v^T)(R a_i + t - b_i) = 0.
  const Eigen::Matrix3d M1 = Eigen::Matrix3d::Identity() - v1 * v1.transpose();
  const Eigen::Matrix3d M2 = Eigen::Matrix3d::Identity() - v2 * v2.transpose();
  const Eigen::Vector3d rhs = M1 * (b1 - R * a1) + M2 * (b2 - R * a2);
  const Eigen::Vector3d t = (M1 + M2).ldlt().solve(rhs);
  if (!R.allFinite() || !t.allFinite()) return false;
  *T_cur_prev = SE3(R, t);
  return true;
}

ConsensusResult FindMotionConsensus(const StereoCamera& cam, const PointMatches3D2D& points,
                                    const Points3D& points_cur, const LineMatches3D2D& lines,
                                    const Points3D& lines_cur_P, const Points3D& lines_cur_Q,
                                    const std::vector<SE3>& candidates, int min_inliers,
                                    const ConsensusOptions& options) {
  const std::string bad = options.Validate();
  if (!bad.empty()) throw ConfigError("consensus: " + bad);
  if (points_cur.size() != points.size() || lines_cur_P.size() != lines.size() ||
      lines_cur_Q.size() != lines.size()) {
    throw ConfigError("consensus: current-frame 3D positions must be given per correspondence");
  }
  ConsensusResult out;
  out.point_inlier.assign(points.size(), 0);
  out.line_inlier.assign(lines.size(), 0);
  out.point_gate.assign(points.size(), 0);
  out.line_gate.assign(lines.size(), 0);
  if (!candidates.empty()) out.T_cur_prev = candidates.front();

  Scorer scorer{cam, points, lines, {}, {}};
  scorer.l.resize(lines.size(), Eigen::Vector3d::Zero());
  scorer.line_ok.assign(lines.size(), 0);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const double norm = lines[i].l_cur.head<2>().norm();
    if (norm > 1e-12 && lines[i].l_cur.allFinite() && Finite(lines[i].P_prev) &&
        Finite(lines[i].Q_prev)) {
      scorer.l[i] = lines[i].l_cur / norm;
      scorer.line_ok[i] = 1;
    }
  }

  // What minimal sets can be drawn from: correspondences with 3D in both frames.
  std::vector<int> sample_points, sample_lines;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (Finite(points[i].P_prev) && Finite(points_cur[i]) && points[i].P_prev.z() > 0.0 &&
        points_cur[i].z() > 0.0)
      sample_points.push_back(static_cast<int>(i));
  for (std::size_t i = 0; i < lines.size(); ++i)
    if (scorer.line_ok[i] && Finite(lines_cur_P[i]) && Finite(lines_cur_Q[i]) &&
        (lines[i].Q_prev - lines[i].P_prev).norm() > 1e-3 &&
        (lines_cur_Q[i] - lines_cur_P[i]).norm() > 1e-3)
      sample_lines.push_back(static_cast<int>(i));

  const double thr2 = options.inlier_px * options.inlier_px;
  const double gate2 = options.gate_px * options.gate_px;
  double best_cost = std::numeric_limits<double>::infinity();
  int best_support = -1;
  SE3 best = out.T_cur_prev;
  auto consider = [&](const SE3& T, bool candidate) {
    if (!T.IsFinite()) return false;
    int support = 0;
    const double cost = scorer.Cost(T, thr2, best_cost, &support);
    if (!(cost < best_cost)) return false;
    best_cost = cost;
    best_support = support;
    best = T;
    out.from_candidate = candidate;
    return true;
  };
  auto consider_refined = [&](const SE3& T, bool candidate) {
    if (!consider(T, candidate)) return;
    // Refit while the refit gains: each fit sees the supporters of the last.
    SE3 refined = T;
    for (int k = 0; k < 3; ++k)
      if (!scorer.Refine(best, gate2, &refined) || !consider(refined, candidate)) break;
  };
  for (const SE3& c : candidates) consider_refined(c, true);

  // Depth noise of a stereo point: dZ = Z^2 / (f b) * sigma_d.
  const double fb = cam.fx * cam.baseline;
  auto depth_sigma = [&](const Eigen::Vector3d& X) {
    return fb > 0.0 ? X.z() * X.z() / fb * options.disparity_sigma_px : 0.0;
  };
  const bool can_points = sample_points.size() >= 3;
  const bool can_lines = sample_lines.size() >= 2;
  const std::size_t total = points.size() + lines.size();
  std::mt19937_64 rng(kSeed);
  auto pick = [&rng](std::size_t n) {
    return static_cast<int>(std::uniform_int_distribution<std::size_t>(0, n - 1)(rng));
  };
  // Share of line sets among the draws: the lines' share of what can be sampled, bounded so
  // neither kind is starved.
  const double line_share = can_points && can_lines
                                ? std::clamp(static_cast<double>(sample_lines.size()) /
                                                 (sample_lines.size() + sample_points.size()),
                                             0.25, 0.75)
                                : (can_lines ? 1.0 : 0.0);
  // Draws needed to hit an all-inlier minimal set of `set_size` with the given confidence
  // when `support` of the correspondences agree with the best hypothesis so far.
  auto draws_needed = [&](int support, double set_size) {
    if (total == 0) return options.max_hypotheses;
    const double p_good = std::pow(static_cast<double>(support) / total, set_size);
    if (p_good >= 1.0) return 1;
    if (!(p_good > 0.0)) return options.max_hypotheses;
    const double k = std::log(1.0 - options.confidence) / std::log(1.0 - p_good);
    // Clamped as a double: k is huge when good sets are rare.
    return static_cast<int>(
        std::clamp(std::ceil(k), 1.0, static_cast<double>(options.max_hypotheses)));
  };
  // A prior most correspondences already agree with needs few draws to be confirmed.
  int needed = draws_needed(std::max(best_support, 0), 3.0);
  Points3D prev3(3), cur3(3);
  for (int draw = 0; draw < 4 * options.max_hypotheses && out.hypotheses < needed; ++draw) {
    if (!can_points && !can_lines) break;
    SE3 T;
    bool solved = false;
    const bool use_lines = std::uniform_real_distribution<double>(0.0, 1.0)(rng) < line_share;
    int idx[3] = {0, 0, 0};
    int line_pair[2] = {0, 0};
    if (use_lines) {
      const int i = sample_lines[pick(sample_lines.size())];
      const int j = sample_lines[pick(sample_lines.size())];
      if (i == j) continue;
      line_pair[0] = i;
      line_pair[1] = j;
      const LineMatch3D2D& mi = lines[i];
      const LineMatch3D2D& mj = lines[j];
      solved = RigidFromLines(
          0.5 * (mi.P_prev + mi.Q_prev), mi.Q_prev - mi.P_prev, 0.5 * (mj.P_prev + mj.Q_prev),
          mj.Q_prev - mj.P_prev, 0.5 * (lines_cur_P[i] + lines_cur_Q[i]),
          lines_cur_Q[i] - lines_cur_P[i], 0.5 * (lines_cur_P[j] + lines_cur_Q[j]),
          lines_cur_Q[j] - lines_cur_P[j], kMaxLineAngleChange, &T);
    } else {
      idx[0] = sample_points[pick(sample_points.size())];
      idx[1] = sample_points[pick(sample_points.size())];
      idx[2] = sample_points[pick(sample_points.size())];
      if (idx[0] == idx[1] || idx[0] == idx[2] || idx[1] == idx[2]) continue;
      bool rigid = true;
      for (int a = 0; a < 3 && rigid; ++a) {
        prev3[a] = points[idx[a]].P_prev;
        cur3[a] = points_cur[idx[a]];
      }
      // A rigid motion keeps distances: refuse sets whose distances changed beyond the depth
      // noise (a mismatch among them), and sets too tight to fix a rotation.
      for (int a = 0; a < 3 && rigid; ++a) {
        const int b = (a + 1) % 3;
        const double dp = (prev3[a] - prev3[b]).norm();
        const double dc = (cur3[a] - cur3[b]).norm();
        const double tol = 3.0 * (depth_sigma(prev3[a]) + depth_sigma(prev3[b]) +
                                  depth_sigma(cur3[a]) + depth_sigma(cur3[b])) +
                           0.01;
        rigid = std::abs(dp - dc) <= tol && dp > kMinPointSpacing;
      }
      if (!rigid) continue;
      solved = RigidFromPoints(prev3, cur3, &T);
    }
    if (!solved) continue;
    T = use_lines ? scorer.Polish(T, nullptr, 0, line_pair, 2)
                  : scorer.Polish(T, idx, 3, nullptr, 0);
    ++out.hypotheses;
    const int before = best_support;
    consider_refined(T, false);
    if (best_support > before)
      needed = std::min(needed, draws_needed(best_support, use_lines ? 2.0 : 3.0));
  }

  out.T_cur_prev = best;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const double e = scorer.PointError2(best, i);
    out.point_inlier[i] = e <= thr2;
    out.point_gate[i] = e <= gate2;
    out.point_inliers += out.point_inlier[i];
  }
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const double e = scorer.LineError2(best, i);
    out.line_inlier[i] = e <= thr2;
    out.line_gate[i] = e <= gate2;
    out.line_inliers += out.line_inlier[i];
  }
  const int support = out.point_inliers + out.line_inliers;
  if (best_support < 0) {
    out.failure = "no motion hypothesis (too few correspondences with stereo depth)";
  } else if (support < min_inliers) {
    out.failure = "no consensus: the best of " + std::to_string(out.hypotheses) +
                  " hypotheses has " + std::to_string(support) +
                  " supporters (min_inliers=" + std::to_string(min_inliers) + ")";
  } else {
    out.success = true;
  }
  return out;
}

}  // namespace pl_slam
