#include "pl_slam/tracking/motion_estimator.h"
#include "pl_slam/util/validation.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

using Matrix26d = Eigen::Matrix<double, 2, 6>;

// Median of chi2 with 2 dof (2 ln 2): turns the median squared residual norm into a variance.
constexpr double kChi2Median2Dof = 1.3862943611198906;
// Damping bounds of the Levenberg-Marquardt safeguard. Accepted steps shrink lambda towards pure
// Gauss-Newton; a lambda this large means no step along the gradient lowers the cost any more.
constexpr double kInitialLambda = 1e-6;
constexpr double kMinLambda = 1e-12;
constexpr double kMaxLambda = 1e8;
// Fewer scalar residuals than unknowns leaves the motion undetermined.
constexpr int kMinResiduals = 6;

// Projects X (depth already checked) and, when J is not null, writes d pi(Exp(d) X) / d d.
inline void ProjectWithJacobian(const StereoCamera& cam, const Eigen::Vector3d& X,
                                Eigen::Vector2d* uv, Matrix26d* J) {
  const double iz = 1.0 / X.z();
  const double x = X.x() * iz;
  const double y = X.y() * iz;
  (*uv) << cam.fx * x + cam.cx, cam.fy * y + cam.cy;
  if (J == nullptr) return;
  // d pi / dX * [I, -Hat(X)], expanded: the translation block is d pi / dX, the rotation block
  // the classic image Jacobian of a rotation (independent of depth).
  (*J) << cam.fx * iz, 0.0, -cam.fx * x * iz, -cam.fx * x * y, cam.fx * (1.0 + x * x),
      -cam.fx * y,  //
      0.0, cam.fy * iz, -cam.fy * y * iz, -cam.fy * (1.0 + y * y), cam.fy * x * y, cam.fy * x;
}

// Outlier threshold of one feature type and what it does to the residual variance.
struct Threshold {
  double thr2 = 0.0;  // squared threshold on s
  // E[s | s <= thr2] / E[s] for s ~ sigma_robust^2 chi2(2): the share of the residual variance
  // the inliers keep. Dividing the inlier variance by it undoes the truncation (at the default
  // 99 % it is 0.95: left alone the covariance would be ~5 % optimistic once the threshold
  // exceeds outlier_min_px).
  double keep = 1.0;
  double sigma2 = 0.0;  // sigma_robust^2, per scalar residual
};

// The correspondences of one EstimateMotion call and which of them take part. Everything here
// is allocated once per call, outside the iterations.
struct Problem {
  const StereoCamera& cam;
  const PointMatches3D2D& points;
  const LineMatches3D2D& lines;
  const MotionEstimatorOptions& opt;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> l;  // normalised
  std::vector<uint8_t> point_active;
  std::vector<uint8_t> line_active;
  Threshold point_threshold;  // set by SelectInliers
  Threshold line_threshold;
  SE3 prior;                               // the motion prior (prior_covariance)
  Matrix6d prior_info = Matrix6d::Zero();  // its information (metric)
  bool with_prior = false;
  // Squared pixels per unit of the prior's squared Mahalanobis distance: the correspondences'
  // noise variance, floored at prior_min_sigma_px^2 (the first step: the floor; the second:
  // their robust variance from SelectInliers, floored).
  double prior_scale = 1.0;
};

// Normal equations of the IRLS Gauss-Newton step at one pose.
struct Normal {
  Matrix6d H = Matrix6d::Zero();  // sum rho'(s) w J^T J
  Vector6d g = Vector6d::Zero();  // sum rho'(s) w J^T r
  double cost = 0.0;              // sum rho(s), the robust cost being minimised
  double sq = 0.0;                // sum s
  double psi_sq = 0.0;            // sum rho'(s)^2 s: spread of the influence, |rho' r|^2
  double sum_weight = 0.0;        // sum rho'(s): the IRLS weight inside H
  double sum_curvature = 0.0;     // sum (rho'(s) + rho'(s)^3) / 2: curvature of the loss
  int residuals = 0;              // scalar residuals that took part
};

// How far the projection of P_prev under T moves per pixel of disparity error, times the
// relative depth noise k: d pi(T P(d)) / d d with P(d) = P * Z(d) / Z and Z = fx b / (d + doffs),
// so dP / dd = -P Z / (fx b).
inline Eigen::Vector2d DepthShift(const StereoCamera& cam, const SE3& T,
                                  const Eigen::Vector3d& P_prev, double k) {
  if (!(P_prev.z() > 0.0) || !(cam.baseline > 0.0)) return Eigen::Vector2d::Zero();
  const Eigen::Vector3d X = T * P_prev;
  const double iz = 1.0 / X.z();
  const Eigen::Vector3d dX = T.so3() * P_prev * (-k * P_prev.z() / (cam.fx * cam.baseline));
  return {cam.fx * iz * (dX.x() - X.x() * iz * dX.z()),
          cam.fy * iz * (dX.y() - X.y() * iz * dX.z())};
}

// Whitens a point residual (and its Jacobian) whose covariance, relative to its own noise
// without depth error, is I + g g^T (depth_noise is relative to the feature's own precision, so
// the match's weight does not enter): W = I - c g g^T / |g|^2, c = 1 - 1 / sqrt(1 + |g|^2).
inline void WhitenAlong(const Eigen::Vector2d& g, Eigen::Vector2d* r, Matrix26d* J) {
  const double g2 = g.squaredNorm();
  if (!(g2 > 1e-12)) return;
  const double c = (1.0 - 1.0 / std::sqrt(1.0 + g2)) / g2;
  *r -= c * g * g.dot(*r);
  if (J != nullptr) J->noalias() -= c * g * (g.transpose() * *J);
}

// Point and line residual of correspondence i at T; false when it cannot be evaluated.
inline bool PointResidual(const Problem& p, const SE3& T, std::size_t i, Eigen::Vector2d* r,
                          Matrix26d* J) {
  const PointMatch3D2D& m = p.points[i];
  if (!PointResidualAndJacobian(p.cam, T, m.P_prev, m.uv_cur, p.opt.min_depth, r, J)) {
    return false;
  }
  if (m.depth_noise > 0.0) WhitenAlong(DepthShift(p.cam, T, m.P_prev, m.depth_noise), r, J);
  return true;
}
// Right-image column residual of point i at T (stereo_residual) and its Jacobian row; false
// when the point has no right-image observation or the option is off.
inline bool RightResidual(const Problem& p, const SE3& T, std::size_t i, double* r, Vector6d* J) {
  const PointMatch3D2D& m = p.points[i];
  if (!p.opt.stereo_residual || !std::isfinite(m.u_right_cur)) return false;
  const Eigen::Vector3d X = T * m.P_prev;
  if (!(X.z() > p.opt.min_depth)) return false;
  const double iz = 1.0 / X.z();
  const double xr = X.x() - p.cam.baseline;
  *r = p.cam.fx * xr * iz + p.cam.cx + p.cam.doffs - m.u_right_cur;
  if (J != nullptr) {
    // d u_r / dX = a; a left perturbation moves X by rho + phi x X, and a . (phi x X) = phi .
    // (X x a).
    const Eigen::Vector3d a(p.cam.fx * iz, 0.0, -p.cam.fx * xr * iz * iz);
    J->head<3>() = a;
    J->tail<3>() = X.cross(a);
  }
  return true;
}

inline bool LineResidual(const Problem& p, const SE3& T, std::size_t i, Eigen::Vector2d* r,
                         Matrix26d* J) {
  const LineMatch3D2D& m = p.lines[i];
  if (!LineResidualAndJacobian(p.cam, T, m.P_prev, m.Q_prev, p.l[i], p.opt.min_depth, r, J)) {
    return false;
  }
  if (m.depth_noise > 0.0) {
    // Each endpoint's distance to the line moves by n . g per pixel of disparity error.
    const Eigen::Vector2d n = p.l[i].head<2>();
    const double gp = n.dot(DepthShift(p.cam, T, m.P_prev, m.depth_noise));
    const double gq = n.dot(DepthShift(p.cam, T, m.Q_prev, m.depth_noise));
    const double fp = 1.0 / std::sqrt(1.0 + gp * gp);
    const double fq = 1.0 / std::sqrt(1.0 + gq * gq);
    (*r)(0) *= fp;
    (*r)(1) *= fq;
    if (J != nullptr) {
      J->row(0) *= fp;
      J->row(1) *= fq;
    }
  }
  return true;
}

// Linearises every active correspondence at T (H and g only when `jacobians`).
void Accumulate(const Problem& p, const SE3& T, bool jacobians, Normal* n) {
  *n = Normal();
  const double delta = p.opt.huber_delta_px;
  Eigen::Vector2d r;
  Matrix26d J;
  double rr = 0.0;  // right-image residual (stereo_residual), with its Jacobian row Jr
  Vector6d Jr;
  // One observation under one robust loss: r, and rr too when `right` (3 scalar residuals).
  auto add = [&](double w, bool right) {
    const int dims = right ? 3 : 2;
    const double s = w * (right ? r.squaredNorm() + rr * rr : r.squaredNorm());
    const double rho_prime = PseudoHuberWeight(s, delta);
    n->cost += PseudoHuberLoss(s, delta);
    n->sq += s;
    n->psi_sq += rho_prime * rho_prime * s;
    // Per pair of scalar residuals (Normal's unit).
    n->sum_weight += 0.5 * dims * rho_prime;
    // Curvature of rho(|r|^2) per unit residual: rho' across the residual, rho'^3 along it.
    n->sum_curvature += 0.5 * ((dims - 1) * rho_prime + rho_prime * rho_prime * rho_prime);
    n->residuals += dims;
    if (jacobians) {
      const double f = rho_prime * w;
      n->H.noalias() += f * J.transpose() * J;
      n->g.noalias() += f * J.transpose() * r;
      if (right) {
        n->H.noalias() += f * Jr * Jr.transpose();
        n->g.noalias() += f * Jr * rr;
      }
    }
  };
  Matrix26d* Jp = jacobians ? &J : nullptr;
  int skipped = 0;
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    if (!p.point_active[i]) continue;
    if (PointResidual(p, T, i, &r, Jp)) {
      add(p.points[i].weight, RightResidual(p, T, i, &rr, jacobians ? &Jr : nullptr));
    } else {
      ++skipped;
    }
  }
  for (std::size_t i = 0; i < p.lines.size(); ++i) {
    if (!p.line_active[i]) continue;
    if (LineResidual(p, T, i, &r, Jp)) {
      add(p.lines[i].weight, false);
    } else {
      ++skipped;
    }
  }
  // A correspondence pushed behind the camera costs as much as an outlier at the largest
  // threshold: otherwise a step could lower the cost just by making residuals disappear.
  const double max2 = p.opt.outlier_max_px * p.opt.outlier_max_px;
  n->cost += skipped * PseudoHuberLoss(max2, delta);
  // The motion prior, quadratic (not robust): its residual is the left perturbation from the
  // prior, whose Jacobian under T <- Exp(d) * T is the identity to first order.
  if (p.with_prior) {
    const Vector6d d = (T * p.prior.inverse()).Log();
    const Vector6d info_d = p.prior_scale * (p.prior_info * d);
    n->cost += d.dot(info_d);
    if (jacobians) {
      n->H += p.prior_scale * p.prior_info;
      n->g += info_d;
    }
  }
}

// LM-damped IRLS Gauss-Newton from *T over the active correspondences. False (with a reason)
// when too few residuals can be evaluated.
bool Optimize(const Problem& p, SE3* T, int* iterations, std::string* failure) {
  const MotionEstimatorOptions& opt = p.opt;
  Normal n;
  Accumulate(p, *T, true, &n);
  if (n.residuals < kMinResiduals) {
    *failure = "only " + std::to_string(n.residuals / 2) +
               " correspondences in front of the camera (need 3)";
    return false;
  }
  double lambda = kInitialLambda;
  Normal trial;
  for (int it = 0; it < opt.max_iterations; ++it) {
    ++*iterations;
    // Marquardt scaling (lambda * diag H) is unit-free between metres and radians; the small
    // floor keeps the system solvable along directions no residual constrains.
    Matrix6d A = n.H;
    const double floor = 1e-12 * std::max(n.H.diagonal().maxCoeff(), 1e-300);
    for (int k = 0; k < 6; ++k) A(k, k) += lambda * (n.H(k, k) + floor);
    Vector6d step;
    if (opt.rotation_only) {
      // A left rotation keeps the camera centre (-R^T t) where it is.
      step.head<3>().setZero();
      step.tail<3>() = A.bottomRightCorner<3, 3>().ldlt().solve(-n.g.tail<3>());
    } else {
      step = A.ldlt().solve(-n.g);
    }
    if (!step.allFinite()) {
      lambda *= 10.0;
      if (lambda > kMaxLambda) break;
      continue;
    }
    const double step_norm = step.norm();
    const SE3 T_new = SE3::Exp(step) * (*T);
    Accumulate(p, T_new, false, &trial);
    if (trial.residuals >= kMinResiduals && trial.cost <= n.cost) {
      const double drop = n.cost - trial.cost;
      const double old_cost = n.cost;
      *T = T_new;
      Accumulate(p, *T, true, &n);
      lambda = std::max(lambda * 0.1, kMinLambda);
      if (step_norm < opt.min_update || drop <= opt.min_relative_cost_change * old_cost) break;
    } else {
      // A step this small that does not lower the cost is round-off: we are at the minimum.
      if (step_norm < opt.min_update) break;
      lambda *= 10.0;
      if (lambda > kMaxLambda) break;
    }
  }
  return true;
}

Threshold OutlierThreshold(std::vector<double>* s, const MotionEstimatorOptions& opt) {
  const double lo = opt.outlier_min_px * opt.outlier_min_px;
  const double hi = opt.outlier_max_px * opt.outlier_max_px;
  Threshold t;
  t.thr2 = lo;
  if (s->empty()) return t;
  auto mid = s->begin() + s->size() / 2;
  std::nth_element(s->begin(), mid, s->end());
  const double sigma2 = *mid / kChi2Median2Dof;
  t.sigma2 = sigma2;
  t.thr2 = std::clamp(opt.outlier_chi2 * sigma2, lo, hi);
  if (sigma2 > 0.0) {
    // chi2(2) / 2 is exponential with unit mean: truncated at a, its mean is
    // (1 - (1 + a) e^-a) / (1 - e^-a).
    const double a = 0.5 * t.thr2 / sigma2;
    const double ea = std::exp(-a);
    if (ea < 1.0) t.keep = std::clamp((1.0 - (1.0 + a) * ea) / (1.0 - ea), 0.05, 1.0);
  }
  return t;
}

// Marks as active the correspondences whose squared residual at T is within the threshold of
// their type (a type with too few residuals for a stable median shares the pooled one).
void SelectInliers(Problem* p, const SE3& T, std::vector<double>* scratch) {
  constexpr std::size_t kMinForOwnScale = 10;
  const std::size_t np = p->points.size();
  const std::size_t nl = p->lines.size();
  // s per correspondence, -1 when it cannot be evaluated.
  scratch->assign(np + nl, -1.0);
  std::vector<double>& s = *scratch;
  Eigen::Vector2d r;
  double rr = 0.0;
  for (std::size_t i = 0; i < np; ++i) {
    if (p->point_active[i] && PointResidual(*p, T, i, &r, nullptr)) {
      s[i] = p->points[i].weight * r.squaredNorm();
      // Three dof scaled to the mean of two.
      if (RightResidual(*p, T, i, &rr, nullptr))
        s[i] = (s[i] + p->points[i].weight * rr * rr) * (2.0 / 3.0);
    }
  }
  for (std::size_t i = 0; i < nl; ++i) {
    if (p->line_active[i] && LineResidual(*p, T, i, &r, nullptr)) {
      s[np + i] = p->lines[i].weight * r.squaredNorm();
    }
  }
  std::vector<double> point_s, line_s, all_s;
  point_s.reserve(np);
  line_s.reserve(nl);
  all_s.reserve(np + nl);
  for (std::size_t i = 0; i < np; ++i) {
    if (s[i] >= 0.0) point_s.push_back(s[i]);
  }
  for (std::size_t i = 0; i < nl; ++i) {
    if (s[np + i] >= 0.0) line_s.push_back(s[np + i]);
  }
  all_s = point_s;
  all_s.insert(all_s.end(), line_s.begin(), line_s.end());
  const Threshold pooled = OutlierThreshold(&all_s, p->opt);
  p->point_threshold =
      point_s.size() >= kMinForOwnScale ? OutlierThreshold(&point_s, p->opt) : pooled;
  p->line_threshold = line_s.size() >= kMinForOwnScale ? OutlierThreshold(&line_s, p->opt) : pooled;
  if (p->with_prior) {
    const double floor = std::max(p->opt.min_sigma_px, p->opt.prior_min_sigma_px);
    p->prior_scale = std::max(pooled.sigma2, floor * floor);
  }
  for (std::size_t i = 0; i < np; ++i) {
    p->point_active[i] = s[i] >= 0.0 && s[i] <= p->point_threshold.thr2;
  }
  for (std::size_t i = 0; i < nl; ++i) {
    p->line_active[i] = s[np + i] >= 0.0 && s[np + i] <= p->line_threshold.thr2;
  }
}

}  // namespace

std::string MotionEstimatorOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("max_iterations", max_iterations, 1, 1000));
  check(CheckRange("huber_delta_px", huber_delta_px, 0.0, 1000.0, true));
  check(CheckRange("outlier_chi2", outlier_chi2, 0.0, 1000.0, true));
  check(CheckRange("outlier_min_px", outlier_min_px, 0.0, 1000.0));
  check(CheckRange("outlier_max_px", outlier_max_px, outlier_min_px, 1e6));
  check(CheckRange("min_update", min_update, 0.0, 1.0));
  check(CheckRange("min_relative_cost_change", min_relative_cost_change, 0.0, 1.0));
  check(CheckRange("min_depth", min_depth, 0.0, 100.0, true));
  check(CheckRange("min_inliers", min_inliers, 3, 1000000));
  check(CheckRange("rank_tolerance", rank_tolerance, 0.0, 1.0, true));
  check(CheckRange("min_sigma_px", min_sigma_px, 0.0, 100.0, true));
  check(CheckRange("prior_min_sigma_px", prior_min_sigma_px, 0.0, 100.0));
  if (first.empty() && !use_points && !use_lines) {
    first = "use_points=false and use_lines=false: at least one must be true";
  }
  return first;
}

double PseudoHuberLoss(double s, double delta) {
  const double d2 = delta * delta;
  return 2.0 * d2 * (std::sqrt(1.0 + s / d2) - 1.0);
}

double PseudoHuberWeight(double s, double delta) {
  return 1.0 / std::sqrt(1.0 + s / (delta * delta));
}

bool PointResidualAndJacobian(const StereoCamera& cam, const SE3& T_cur_prev,
                              const Eigen::Vector3d& P_prev, const Eigen::Vector2d& uv_cur,
                              double min_depth, Eigen::Vector2d* r, Matrix26d* J) {
  const Eigen::Vector3d X = T_cur_prev * P_prev;
  // Written so that a NaN depth fails too.
  if (!(X.z() > min_depth)) return false;
  Eigen::Vector2d uv;
  ProjectWithJacobian(cam, X, &uv, J);
  *r = uv - uv_cur;
  return true;
}

bool LineResidualAndJacobian(const StereoCamera& cam, const SE3& T_cur_prev,
                             const Eigen::Vector3d& P_prev, const Eigen::Vector3d& Q_prev,
                             const Eigen::Vector3d& l_cur, double min_depth, Eigen::Vector2d* r,
                             Matrix26d* J) {
  const Eigen::Vector3d XP = T_cur_prev * P_prev;
  const Eigen::Vector3d XQ = T_cur_prev * Q_prev;
  if (!(XP.z() > min_depth) || !(XQ.z() > min_depth)) return false;
  Eigen::Vector2d uv_p, uv_q;
  if (J == nullptr) {
    ProjectWithJacobian(cam, XP, &uv_p, nullptr);
    ProjectWithJacobian(cam, XQ, &uv_q, nullptr);
  } else {
    Matrix26d Jp, Jq;
    ProjectWithJacobian(cam, XP, &uv_p, &Jp);
    ProjectWithJacobian(cam, XQ, &uv_q, &Jq);
    // d (l . (u, v, 1)) = l(0) du + l(1) dv.
    J->row(0) = l_cur(0) * Jp.row(0) + l_cur(1) * Jp.row(1);
    J->row(1) = l_cur(0) * Jq.row(0) + l_cur(1) * Jq.row(1);
  }
  (*r) << l_cur(0) * uv_p.x() + l_cur(1) * uv_p.y() + l_cur(2),
      l_cur(0) * uv_q.x() + l_cur(1) * uv_q.y() + l_cur(2);
  return true;
}

MotionEstimate EstimateMotion(const StereoCamera& cam, const PointMatches3D2D& points,
                              const LineMatches3D2D& lines, const SE3& prior_T_cur_prev,
                              const MotionEstimatorOptions& options,
                              const Matrix6d* prior_covariance) {
  const std::string bad = options.Validate();
  if (!bad.empty()) throw ConfigError("motion estimator: " + bad);

  MotionEstimate out;
  out.point_inlier.assign(points.size(), 0);
  out.line_inlier.assign(lines.size(), 0);
  const bool prior_ok = prior_T_cur_prev.IsFinite();
  out.T_cur_prev = prior_ok ? prior_T_cur_prev : SE3();
  auto fail = [&out, &prior_T_cur_prev, prior_ok](const std::string& why) {
    out.T_cur_prev = prior_ok ? prior_T_cur_prev : SE3();
    out.covariance.setZero();
    out.covariance_prev_cur.setZero();
    std::fill(out.point_inlier.begin(), out.point_inlier.end(), 0);
    std::fill(out.line_inlier.begin(), out.line_inlier.end(), 0);
    out.point_inliers = out.line_inliers = 0;
    out.rmse_px = out.sigma_px = 0.0;
    out.success = false;
    out.failure = why;
    return out;
  };
  if (!prior_ok) return fail("the motion prior is not finite");
  if (!(cam.fx > 0.0) || !(cam.fy > 0.0) || !std::isfinite(cam.cx) || !std::isfinite(cam.cy)) {
    return fail("camera intrinsics are not valid");
  }

  Problem p{cam,
            points,
            lines,
            options,
            {},
            {},
            {},
            {},
            {},
            prior_T_cur_prev,
            Matrix6d::Zero(),
            false,
            std::max(options.min_sigma_px * options.min_sigma_px,
                     options.prior_min_sigma_px * options.prior_min_sigma_px)};
  const bool with_prior = prior_covariance != nullptr;
  if (with_prior) {
    if (options.rotation_only) return fail("a prior covariance with rotation_only");
    const Matrix6d c = 0.5 * (*prior_covariance + prior_covariance->transpose());
    const Eigen::LLT<Matrix6d> llt(c);
    if (!c.allFinite() || llt.info() != Eigen::Success)
      return fail("the prior covariance is not finite and positive definite");
    p.prior_info = llt.solve(Matrix6d::Identity());
    p.prior_info = 0.5 * (p.prior_info + p.prior_info.transpose()).eval();
    p.with_prior = true;
  }
  p.point_active.assign(points.size(), 0);
  p.line_active.assign(lines.size(), 0);
  p.l.resize(lines.size(), Eigen::Vector3d::Zero());
  int usable = 0;
  auto weight_ok = [](double w) { return std::isfinite(w) && w > 0.0; };
  auto noise_ok = [](double k) { return std::isfinite(k) && k >= 0.0; };
  if (options.use_points) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      const PointMatch3D2D& m = points[i];
      p.point_active[i] = m.P_prev.allFinite() && m.uv_cur.allFinite() && weight_ok(m.weight) &&
                          noise_ok(m.depth_noise);
      usable += p.point_active[i];
    }
  }
  if (options.use_lines) {
    for (std::size_t i = 0; i < lines.size(); ++i) {
      const LineMatch3D2D& m = lines[i];
      const double norm = m.l_cur.head<2>().norm();
      const bool ok = m.P_prev.allFinite() && m.Q_prev.allFinite() && m.l_cur.allFinite() &&
                      norm > 1e-12 && weight_ok(m.weight) && noise_ok(m.depth_noise);
      if (ok) p.l[i] = m.l_cur / norm;
      p.line_active[i] = ok;
      usable += ok;
    }
  }
  if (2 * usable < kMinResiduals) {
    return fail("only " + std::to_string(usable) + " usable correspondences (need 3)");
  }

  // Step 1: robust fit from the prior over every usable correspondence.
  SE3 T = prior_T_cur_prev;
  std::string why;
  if (!Optimize(p, &T, &out.iterations, &why)) return fail("first step: " + why);

  // Outlier removal, then step 2 over the inliers only.
  std::vector<double> scratch;
  SelectInliers(&p, T, &scratch);
  if (!Optimize(p, &T, &out.iterations, &why)) return fail("second step: " + why);

  // Inliers are the step-2 set, minus any that left the field of depth at the solution.
  Eigen::Vector2d r;
  for (std::size_t i = 0; i < points.size(); ++i) {
    out.point_inlier[i] = p.point_active[i] && PointResidual(p, T, i, &r, nullptr);
    out.point_inliers += out.point_inlier[i];
  }
  for (std::size_t i = 0; i < lines.size(); ++i) {
    out.line_inlier[i] = p.line_active[i] && LineResidual(p, T, i, &r, nullptr);
    out.line_inliers += out.line_inlier[i];
  }
  const int inliers = out.point_inliers + out.line_inliers;
  if (inliers < options.min_inliers) {
    return fail("only " + std::to_string(inliers) +
                " inliers (min_inliers=" + std::to_string(options.min_inliers) + ")");
  }

  Normal n;
  Accumulate(p, T, true, &n);
  if (options.rotation_only) {
    // Only the rotation block is estimated: the translation rows and columns carry nothing.
    n.H.topRows<3>().setZero();
    n.H.leftCols<3>().setZero();
    n.H.topLeftCorner<3, 3>().setIdentity();
  }
  const int unknowns = options.rotation_only ? 3 : 6;
  // Observability on the Jacobi-normalised Hessian: unit diagonal, so the eigenvalues compare
  // metres and radians on an equal footing.
  const Vector6d diag = n.H.diagonal();
  if (!(diag.minCoeff() > 0.0) || !n.H.allFinite()) {
    return fail("rank-deficient Hessian (a motion direction has no constraint)");
  }
  const Vector6d inv_sqrt = diag.cwiseSqrt().cwiseInverse();
  const Matrix6d N = inv_sqrt.asDiagonal() * n.H * inv_sqrt.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Matrix6d> eig(N);
  const double min_eig = eig.eigenvalues()(0);
  if (eig.info() != Eigen::Success || !(min_eig > options.rank_tolerance)) {
    std::ostringstream os;
    os << "rank-deficient Hessian: smallest normalised eigenvalue " << min_eig
       << " (rank_tolerance=" << options.rank_tolerance << ")";
    return fail(os.str());
  }

  // Residual variance with Huber's correction for an M-estimator (Robust Statistics, 1981,
  // Sec. 7.6): the estimate's covariance is the sandwich A^-1 B A^-1 with A ~ c2 H0 (true
  // curvature of the robust cost), B ~ E[rho'^2 s] H0 (spread of the influence) and
  // H = c1 H0 (the IRLS Hessian). Hence cov = sigma^2 H^-1 with sigma^2 = E[rho'^2 s] c1 / c2^2.
  // On clean data rho' -> 1 and this is the least-squares sum s / (m - 6) (m - 3 for the
  // rotation alone); unlike sum rho' s / (m - 6) it stays consistent when the noise is
  // comparable to huber_delta_px.
  const int m = n.residuals;
  const double count = 0.5 * m;
  const double c1 = n.sum_weight / count;
  const double c2 = n.sum_curvature / count;
  // Undo the truncation of the noise distribution by the outlier threshold (see Threshold).
  const double keep =
      (out.point_inliers * p.point_threshold.keep + out.line_inliers * p.line_threshold.keep) /
      std::max(1, out.point_inliers + out.line_inliers);
  // With a motion prior its six equations determine the six unknowns: all m residuals are
  // free to measure the noise.
  const int dof = with_prior ? m : m - unknowns;
  const double var = dof > 0 ? n.psi_sq / dof * c1 / (c2 * c2) / keep : 0.0;
  out.sigma_px = std::max(std::sqrt(var), options.min_sigma_px);
  out.rmse_px = m > 0 ? std::sqrt(n.sq / m) : 0.0;
  // H^-1 = D^-1/2 N^-1 D^-1/2, through the eigenvectors of the well-scaled N.
  const Matrix6d N_inv = eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
                         eig.eigenvectors().transpose();
  Matrix6d cov =
      out.sigma_px * out.sigma_px * (inv_sqrt.asDiagonal() * N_inv * inv_sqrt.asDiagonal());
  if (with_prior) {
    // The correspondences' information at their noise as weighed (floored at
    // prior_min_sigma_px), plus the prior's (metric).
    const double s2 = std::max(out.sigma_px * out.sigma_px,
                               options.prior_min_sigma_px * options.prior_min_sigma_px);
    Matrix6d info = (n.H - p.prior_scale * p.prior_info) / s2;
    info += p.prior_info;
    cov = info.ldlt().solve(Matrix6d::Identity());
  }
  cov = 0.5 * (cov + cov.transpose()).eval();
  if (options.rotation_only) {
    cov.topRows<3>().setZero();
    cov.leftCols<3>().setZero();
  }
  const Matrix6d Ad = T.inverse().Adjoint();
  Matrix6d cov_inv = Ad * cov * Ad.transpose();
  cov_inv = 0.5 * (cov_inv + cov_inv.transpose()).eval();
  if (!T.IsFinite() || !cov.allFinite() || !cov_inv.allFinite()) {
    return fail("non-finite result");
  }
  out.T_cur_prev = T;
  out.covariance = cov;
  out.covariance_prev_cur = cov_inv;
  out.success = true;
  return out;
}

bool SigmaWithin(const Matrix6d& covariance, double max_m, double max_rad) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> t(covariance.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> r(covariance.bottomRightCorner<3, 3>());
  return std::sqrt(std::max(0.0, t.eigenvalues()(2))) <= max_m &&
         std::sqrt(std::max(0.0, r.eigenvalues()(2))) <= max_rad;
}

}  // namespace pl_slam
