// Motion estimator: analytic Jacobians against central differences, recovery of known motions
// on synthetic scenes (clean, noisy, with gross outliers, points only, lines only, far from the
// prior), covariance consistency (chi2), degenerate input and timing.
#include "pl_slam/tracking/motion_estimator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

using Matrix26d = Eigen::Matrix<double, 2, 6>;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

StereoCamera TestCamera() {
  StereoCamera cam;
  cam.fx = 450.0;
  cam.fy = 455.0;
  cam.cx = 375.5;
  cam.cy = 239.5;
  cam.baseline = 0.11;
  cam.width = 752;
  cam.height = 480;
  return cam;
}

// A motion of `meters` along a fixed oblique direction and `degrees` about a fixed axis.
SE3 Motion(double meters, double degrees) {
  const Eigen::Vector3d t = meters * Eigen::Vector3d(0.3, -0.2, 0.93).normalized();
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 1.0, -0.3).normalized();
  return SE3(ExpSO3(degrees * kDeg * axis), t);
}

// Random pose with rotation up to `max_angle` rad and translation up to `max_t` metres.
SE3 RandomPose(std::mt19937* rng, double max_angle, double max_t) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Eigen::Vector3d axis = Eigen::Vector3d(u(*rng), u(*rng), u(*rng)).normalized();
  const Eigen::Vector3d t(u(*rng), u(*rng), u(*rng));
  return SE3(ExpSO3(axis * max_angle * std::abs(u(*rng))), max_t * t);
}

// Synthetic scene: 3D features in the previous camera frame, visible in both frames under
// T_cur_prev, with current-frame observations.
struct Scene {
  PointMatches3D2D points;
  LineMatches3D2D lines;
  std::vector<uint8_t> point_outlier;  // 1 when the observation was replaced by garbage
  std::vector<uint8_t> line_outlier;
};

struct SceneSpec {
  int num_points = 300;
  int num_lines = 60;
  double noise_px = 0.0;          // Gaussian pixel noise of each observed point / line endpoint
  double outlier_fraction = 0.0;  // fraction of observations replaced by random ones
  // Observed segment endpoints are where the projected 3D endpoints would be, moved along the
  // line by up to this fraction of its length (the detector never finds the same endpoints).
  double endpoint_slide = 0.0;
  bool parallel_lines = false;  // every segment along the same 3D direction (degenerate)
};

// Direction of every segment of a SceneSpec::parallel_lines scene, previous camera frame.
const Eigen::Vector3d kParallelDirection = Eigen::Vector3d(0.1, 1.0, 0.05).normalized();

bool Visible(const StereoCamera& cam, const Eigen::Vector3d& X) {
  return X.z() > 0.5 && cam.InImage(cam.Project(X), 5.0);
}

Eigen::Vector3d LineThrough(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector3d l =
      Eigen::Vector3d(a.x(), a.y(), 1.0).cross(Eigen::Vector3d(b.x(), b.y(), 1.0));
  return l / l.head<2>().norm();
}

Scene MakeScene(const StereoCamera& cam, const SE3& T_cur_prev, const SceneSpec& spec,
                std::mt19937* rng) {
  std::uniform_real_distribution<double> uu(0.0, cam.width - 1.0), uv(0.0, cam.height - 1.0);
  std::uniform_real_distribution<double> depth(1.5, 12.0), unit(-1.0, 1.0), u01(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  auto random_point = [&]() {
    for (;;) {
      const Eigen::Vector3d P =
          cam.BackProject(uu(*rng), uv(*rng), cam.DisparityFromDepth(depth(*rng)));
      if (Visible(cam, T_cur_prev * P)) return P;
    }
  };
  Scene s;
  for (int i = 0; i < spec.num_points; ++i) {
    PointMatch3D2D m;
    m.P_prev = random_point();
    const bool outlier = u01(*rng) < spec.outlier_fraction;
    if (outlier) {
      m.uv_cur = Eigen::Vector2d(uu(*rng), uv(*rng));
    } else {
      m.uv_cur = cam.Project(T_cur_prev * m.P_prev) +
                 spec.noise_px * Eigen::Vector2d(noise(*rng), noise(*rng));
    }
    s.points.push_back(m);
    s.point_outlier.push_back(outlier);
  }
  while (static_cast<int>(s.lines.size()) < spec.num_lines) {
    LineMatch3D2D m;
    m.P_prev = random_point();
    const Eigen::Vector3d dir =
        spec.parallel_lines ? kParallelDirection
                            : Eigen::Vector3d(unit(*rng), unit(*rng), unit(*rng)).normalized();
    m.Q_prev = m.P_prev + (0.5 + 1.5 * u01(*rng)) * dir;
    const Eigen::Vector3d XP = T_cur_prev * m.P_prev, XQ = T_cur_prev * m.Q_prev;
    if (!Visible(cam, XP) || !Visible(cam, XQ) || !Visible(cam, m.Q_prev)) continue;
    const Eigen::Vector2d p = cam.Project(XP), q = cam.Project(XQ);
    if ((p - q).norm() < 20.0) continue;  // a detector would not report it
    const bool outlier = u01(*rng) < spec.outlier_fraction;
    if (outlier) {
      m.l_cur =
          LineThrough(Eigen::Vector2d(uu(*rng), uv(*rng)), Eigen::Vector2d(uu(*rng), uv(*rng)));
    } else {
      const double a = spec.endpoint_slide * unit(*rng), b = 1.0 + spec.endpoint_slide * unit(*rng);
      const Eigen::Vector2d s_obs =
          p + a * (q - p) + spec.noise_px * Eigen::Vector2d(noise(*rng), noise(*rng));
      const Eigen::Vector2d e_obs =
          p + b * (q - p) + spec.noise_px * Eigen::Vector2d(noise(*rng), noise(*rng));
      m.l_cur = LineThrough(s_obs, e_obs);
    }
    s.lines.push_back(m);
    s.line_outlier.push_back(outlier);
  }
  return s;
}

// Translation (m) and rotation (deg) of T_est * T_true^-1.
struct PoseError {
  double t = 0.0;
  double deg = 0.0;
};
PoseError Error(const SE3& T_est, const SE3& T_true) {
  const SE3 d = T_est * T_true.inverse();
  return {d.translation().norm(), d.RotationAngle() / kDeg};
}

bool AllFinite(const MotionEstimate& e) {
  return e.T_cur_prev.IsFinite() && e.covariance.allFinite() && e.covariance_prev_cur.allFinite() &&
         std::isfinite(e.rmse_px) && std::isfinite(e.sigma_px);
}

// --- Jacobian checking --------------------------------------------------------------------

// Residual of one correspondence at T (false when not evaluable).
using ResidualFn = std::function<bool(const SE3&, Eigen::Vector2d*, Matrix26d*)>;

// Central differences of r(Exp(d) T) at d = 0.
Matrix26d NumericJacobian(const ResidualFn& f, const SE3& T) {
  constexpr double kH = 1e-6;
  Matrix26d J;
  for (int k = 0; k < 6; ++k) {
    Vector6d d = Vector6d::Zero();
    d(k) = kH;
    Eigen::Vector2d rp, rm;
    EXPECT_TRUE(f(SE3::Exp(d) * T, &rp, nullptr));
    EXPECT_TRUE(f(SE3::Exp(-d) * T, &rm, nullptr));
    J.col(k) = (rp - rm) / (2.0 * kH);
  }
  return J;
}

// Passes when every entry agrees within kRelTol of the largest entry. Central differences with
// h = 1e-6 on pixel residuals are good to ~1e-10 relative here; a wrong term is O(1) relative.
constexpr double kRelTol = 1e-7;
::testing::AssertionResult JacobianMatches(const Matrix26d& analytic, const Matrix26d& numeric) {
  const double scale = std::max(1.0, numeric.cwiseAbs().maxCoeff());
  const double err = (analytic - numeric).cwiseAbs().maxCoeff();
  if (err <= kRelTol * scale) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure()
         << "max |J_analytic - J_numeric| = " << err << " > " << kRelTol * scale << "\nanalytic:\n"
         << analytic << "\nnumeric:\n"
         << numeric;
}

TEST(MotionEstimatorJacobian, PointMatchesCentralDifferences) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = RandomPose(&rng, 0.5, 0.5);
    const Eigen::Vector3d P =
        T.inverse() * Eigen::Vector3d(3 * u(rng), 2 * u(rng), 4.0 + 3.0 * u(rng));
    const Eigen::Vector2d uv(300 + 50 * u(rng), 200 + 50 * u(rng));
    ResidualFn f = [&](const SE3& Tx, Eigen::Vector2d* r, Matrix26d* J) {
      return PointResidualAndJacobian(cam, Tx, P, uv, 0.05, r, J);
    };
    Eigen::Vector2d r;
    Matrix26d J;
    ASSERT_TRUE(f(T, &r, &J));
    EXPECT_TRUE(JacobianMatches(J, NumericJacobian(f, T))) << "trial " << trial;
  }
}

TEST(MotionEstimatorJacobian, LineMatchesCentralDifferences) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(12);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 T = RandomPose(&rng, 0.5, 0.5);
    const SE3 Ti = T.inverse();
    const Eigen::Vector3d P = Ti * Eigen::Vector3d(3 * u(rng), 2 * u(rng), 4.0 + 3.0 * u(rng));
    const Eigen::Vector3d Q = Ti * Eigen::Vector3d(3 * u(rng), 2 * u(rng), 4.0 + 3.0 * u(rng));
    const Eigen::Vector3d l = LineThrough(Eigen::Vector2d(300 + 80 * u(rng), 200 + 80 * u(rng)),
                                          Eigen::Vector2d(400 + 80 * u(rng), 300 + 80 * u(rng)));
    ResidualFn f = [&](const SE3& Tx, Eigen::Vector2d* r, Matrix26d* J) {
      return LineResidualAndJacobian(cam, Tx, P, Q, l, 0.05, r, J);
    };
    Eigen::Vector2d r;
    Matrix26d J;
    ASSERT_TRUE(f(T, &r, &J));
    EXPECT_TRUE(JacobianMatches(J, NumericJacobian(f, T))) << "trial " << trial;
  }
}

// The comparison must be able to fail: a slightly wrong entry and a classic convention bug
// (right instead of left perturbation, i.e. the rotation block of R * [I, -Hat(P)]) are caught.
TEST(MotionEstimatorJacobian, CheckerRejectsWrongJacobians) {
  const StereoCamera cam = TestCamera();
  const SE3 T = Motion(0.2, 8.0);
  const Eigen::Vector3d P = T.inverse() * Eigen::Vector3d(0.7, -0.4, 5.0);
  const Eigen::Vector2d uv(320.0, 250.0);
  ResidualFn f = [&](const SE3& Tx, Eigen::Vector2d* r, Matrix26d* J) {
    return PointResidualAndJacobian(cam, Tx, P, uv, 0.05, r, J);
  };
  Eigen::Vector2d r;
  Matrix26d J;
  ASSERT_TRUE(f(T, &r, &J));
  const Matrix26d numeric = NumericJacobian(f, T);
  ASSERT_TRUE(JacobianMatches(J, numeric));

  Matrix26d slightly_off = J;
  slightly_off(1, 4) += 1e-5 * J.cwiseAbs().maxCoeff();
  EXPECT_FALSE(JacobianMatches(slightly_off, numeric));

  // Right-perturbation Jacobian: d pi / dX * R * [I, -Hat(P)].
  const Eigen::Vector3d X = T * P;
  Eigen::Matrix<double, 2, 3> dpi;
  dpi << cam.fx / X.z(), 0.0, -cam.fx * X.x() / (X.z() * X.z()), 0.0, cam.fy / X.z(),
      -cam.fy * X.y() / (X.z() * X.z());
  Eigen::Matrix<double, 3, 6> dX;
  dX << T.rotation(), -T.rotation() * Hat(P);
  EXPECT_FALSE(JacobianMatches(dpi * dX, numeric));

  // Sign error on the rotation block.
  Matrix26d flipped = J;
  flipped.rightCols<3>() *= -1.0;
  EXPECT_FALSE(JacobianMatches(flipped, numeric));
}

TEST(MotionEstimatorJacobian, BehindCameraIsSkippedWithoutNaN) {
  const StereoCamera cam = TestCamera();
  Eigen::Vector2d r(7.0, 7.0);
  Matrix26d J = Matrix26d::Constant(3.0);
  EXPECT_FALSE(
      PointResidualAndJacobian(cam, SE3(), Eigen::Vector3d(0, 0, -2), {1, 1}, 0.05, &r, &J));
  EXPECT_FALSE(
      PointResidualAndJacobian(cam, SE3(), Eigen::Vector3d(0, 0, 0.0), {1, 1}, 0.05, &r, &J));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(
      PointResidualAndJacobian(cam, SE3(), Eigen::Vector3d(0, 0, nan), {1, 1}, 0.05, &r, &J));
  EXPECT_FALSE(LineResidualAndJacobian(cam, SE3(), Eigen::Vector3d(0, 0, 3),
                                       Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(1, 0, -300), 0.05,
                                       &r, &J));
  EXPECT_EQ(r, Eigen::Vector2d(7.0, 7.0));  // untouched
  EXPECT_TRUE(J.isApprox(Matrix26d::Constant(3.0)));
}

TEST(MotionEstimatorLoss, PseudoHuberWeightIsTheLossDerivative) {
  for (double delta : {0.5, 1.0, 3.0}) {
    EXPECT_EQ(PseudoHuberWeight(0.0, delta), 1.0);
    for (double s : {0.01, 1.0, 10.0, 1000.0}) {
      const double h = 1e-5 * s;
      const double numeric =
          (PseudoHuberLoss(s + h, delta) - PseudoHuberLoss(s - h, delta)) / (2.0 * h);
      EXPECT_NEAR(PseudoHuberWeight(s, delta), numeric, 1e-8) << "s=" << s << " delta=" << delta;
    }
    // Quadratic (rho(s) ~ s) for small residuals, linear in |r| (~ 2 delta |r|) for large ones.
    EXPECT_NEAR(PseudoHuberLoss(1e-6, delta) / 1e-6, 1.0, 1e-5);
    EXPECT_NEAR(PseudoHuberLoss(1e8, delta) / (2.0 * delta * 1e4), 1.0, 1e-3);
  }
}

// --- Estimation ---------------------------------------------------------------------------

TEST(MotionEstimator, NoiseFreeRecoveryPointsAndLines) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(1);
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T_true = RandomPose(&rng, 5.0 * kDeg, 0.15);
    SceneSpec spec;
    spec.endpoint_slide = 0.2;
    const Scene s = MakeScene(cam, T_true, spec, &rng);
    const SE3 prior = SE3::Exp(0.02 * Vector6d::Ones()) * T_true;
    const MotionEstimate e =
        EstimateMotion(cam, s.points, s.lines, prior, MotionEstimatorOptions());
    ASSERT_TRUE(e.success) << e.failure;
    EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);
    EXPECT_EQ(e.point_inliers, spec.num_points);
    EXPECT_EQ(e.line_inliers, spec.num_lines);
    EXPECT_LT(e.rmse_px, 1e-6);
    // Clean data: the covariance is scaled by the sigma floor, never zero.
    EXPECT_DOUBLE_EQ(e.sigma_px, MotionEstimatorOptions().min_sigma_px);
    EXPECT_GT(e.covariance.determinant(), 0.0);
  }
}

// Over many noisy trials the error, whitened by the reported covariance, must be chi2 with 6
// dof: mean 6 (the mean of 200 draws has a standard deviation of 0.24). This checks the
// covariance's shape AND scale, for both T_cur_prev and its inverse T_prev_cur, with noise well
// below and comparable to the Pseudo-Huber scale (where the loss is no longer quadratic).
struct Chi2Result {
  double mean_cur_prev = 0.0;
  double mean_prev_cur = 0.0;
  double mean_rmse_px = 0.0;
  double mean_wrong_side = 0.0;  // T_prev_cur with Ad(T_cur_prev) instead of Ad(T_prev_cur)
  double max_t = 0.0;
  double max_deg = 0.0;
};
Chi2Result RunChi2Trials(double noise_px, int trials, unsigned seed, const SE3& T_true) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(seed);
  Chi2Result out;
  for (int trial = 0; trial < trials; ++trial) {
    SceneSpec spec;
    spec.num_points = 150;
    spec.num_lines = 40;
    spec.noise_px = noise_px;
    const Scene s = MakeScene(cam, T_true, spec, &rng);
    const MotionEstimate e =
        EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
    EXPECT_TRUE(e.success) << e.failure;
    if (!e.success) continue;
    // Left perturbations: T_true = Exp(d) T_est, so d = Log(T_true T_est^-1).
    const Vector6d d = (T_true * e.T_cur_prev.inverse()).Log();
    out.mean_cur_prev += d.dot(e.covariance.ldlt().solve(d)) / trials;
    const Vector6d d_inv = (T_true.inverse() * e.T_cur_prev).Log();
    out.mean_prev_cur += d_inv.dot(e.covariance_prev_cur.ldlt().solve(d_inv)) / trials;
    const Matrix6d Ad_wrong = e.T_cur_prev.Adjoint();
    const Matrix6d wrong = Ad_wrong * e.covariance * Ad_wrong.transpose();
    out.mean_wrong_side += d_inv.dot(wrong.ldlt().solve(d_inv)) / trials;
    out.mean_rmse_px += e.rmse_px / trials;
    const PoseError err = Error(e.T_cur_prev, T_true);
    out.max_t = std::max(out.max_t, err.t);
    out.max_deg = std::max(out.max_deg, err.deg);
  }
  std::printf(
      "noise %.2f px, %d trials: chi2 mean T_cur_prev %.3f, T_prev_cur %.3f (expect 6); "
      "mean rmse %.3f px; worst error %.2f mm %.3f deg\n",
      noise_px, trials, out.mean_cur_prev, out.mean_prev_cur, out.mean_rmse_px, 1e3 * out.max_t,
      out.max_deg);
  return out;
}

TEST(MotionEstimator, CovarianceIsConsistentWithTheError) {
  const Chi2Result r = RunChi2Trials(0.5, 200, 2, Motion(0.1, 3.0));
  RecordProperty("chi2_mean_cur_prev", std::to_string(r.mean_cur_prev));
  EXPECT_NEAR(r.mean_cur_prev, 6.0, 1.0);
  EXPECT_NEAR(r.mean_prev_cur, 6.0, 1.0);
  EXPECT_NEAR(r.mean_rmse_px, 0.5, 0.03);
  EXPECT_LT(r.max_t, 0.01);
  EXPECT_LT(r.max_deg, 0.1);
}

TEST(MotionEstimator, CovarianceStaysConsistentWhenNoiseIsNearTheLossScale) {
  const Chi2Result r = RunChi2Trials(1.5, 200, 3, Motion(0.1, 3.0));
  EXPECT_NEAR(r.mean_cur_prev, 6.0, 1.0);
  EXPECT_NEAR(r.mean_prev_cur, 6.0, 1.0);
}

// The inverse's covariance only differs visibly from a wrongly transported one under a large
// motion (the adjoint's rotation and its t x R coupling): 0.5 m and 15 degrees.
TEST(MotionEstimator, InverseCovarianceIsConsistentUnderLargeMotion) {
  const Chi2Result r = RunChi2Trials(0.5, 200, 4, Motion(0.5, 15.0));
  std::printf(
      "same trials, T_prev_cur covariance transported with Ad(T_cur_prev): chi2 mean "
      "%.3f\n",
      r.mean_wrong_side);
  EXPECT_NEAR(r.mean_cur_prev, 6.0, 1.0);
  EXPECT_NEAR(r.mean_prev_cur, 6.0, 1.0);
  EXPECT_GT(r.mean_wrong_side, 8.0);  // the check can tell the two apart
}

TEST(MotionEstimator, ThirtyPercentGrossOutliersAreRejected) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    const SE3 T_true = RandomPose(&rng, 4.0 * kDeg, 0.12);
    SceneSpec spec;
    spec.num_points = 300;
    spec.num_lines = 80;
    spec.noise_px = 0.5;
    spec.outlier_fraction = 0.3;
    spec.endpoint_slide = 0.2;
    const Scene s = MakeScene(cam, T_true, spec, &rng);
    const MotionEstimate e =
        EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
    ASSERT_TRUE(e.success) << e.failure;
    const PoseError err = Error(e.T_cur_prev, T_true);
    EXPECT_LT(err.t, 0.01) << "trial " << trial;
    EXPECT_LT(err.deg, 0.1) << "trial " << trial;
    int outliers = 0, outliers_kept = 0, inliers = 0, inliers_dropped = 0;
    for (std::size_t i = 0; i < s.points.size(); ++i) {
      if (s.point_outlier[i]) {
        ++outliers;
        outliers_kept += e.point_inlier[i];
      } else {
        ++inliers;
        inliers_dropped += !e.point_inlier[i];
      }
    }
    for (std::size_t i = 0; i < s.lines.size(); ++i) {
      if (s.line_outlier[i]) {
        ++outliers;
        outliers_kept += e.line_inlier[i];
      } else {
        ++inliers;
        inliers_dropped += !e.line_inlier[i];
      }
    }
    // A random observation can land within the threshold of the truth by chance (a random
    // line through the projected segment most easily): allow 2 % of them.
    EXPECT_LE(outliers_kept, std::max(1, outliers / 50)) << "trial " << trial;
    EXPECT_LE(inliers_dropped, inliers / 50) << "trial " << trial;
  }
}

TEST(MotionEstimator, LinesOnly) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(4);
  const SE3 T_true = Motion(0.12, 4.0);
  SceneSpec spec;
  spec.num_points = 0;
  spec.num_lines = 40;
  spec.endpoint_slide = 0.25;
  Scene s = MakeScene(cam, T_true, spec, &rng);
  MotionEstimate e = EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);
  EXPECT_EQ(e.line_inliers, spec.num_lines);

  spec.noise_px = 0.5;
  s = MakeScene(cam, T_true, spec, &rng);
  e = EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  const PoseError err = Error(e.T_cur_prev, T_true);
  EXPECT_LT(err.t, 0.02);
  EXPECT_LT(err.deg, 0.2);
}

TEST(MotionEstimator, PointsOnlyIgnoresLinesWhenAsked) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(5);
  const SE3 T_true = Motion(0.12, 4.0);
  SceneSpec spec;
  spec.noise_px = 0.5;
  Scene s = MakeScene(cam, T_true, spec, &rng);
  // Garbage lines must not matter when lines are off.
  for (LineMatch3D2D& m : s.lines) m.l_cur = Eigen::Vector3d(1.0, 0.0, -10.0);
  MotionEstimatorOptions opt;
  opt.use_lines = false;
  const MotionEstimate e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_EQ(e.line_inliers, 0);
  EXPECT_EQ(std::count(e.line_inlier.begin(), e.line_inlier.end(), 1), 0);
  EXPECT_GE(e.point_inliers, 290);
  const PoseError err = Error(e.T_cur_prev, T_true);
  EXPECT_LT(err.t, 0.01);
  EXPECT_LT(err.deg, 0.1);
}

TEST(MotionEstimator, ConvergesFromAFarPrior) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(6);
  const SE3 T_true = Motion(0.3, 10.0);
  SceneSpec spec;
  spec.endpoint_slide = 0.2;
  Scene s = MakeScene(cam, T_true, spec, &rng);
  MotionEstimate e = EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);

  spec.noise_px = 0.5;
  spec.outlier_fraction = 0.2;
  s = MakeScene(cam, T_true, spec, &rng);
  e = EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  const PoseError err = Error(e.T_cur_prev, T_true);
  EXPECT_LT(err.t, 0.01);
  EXPECT_LT(err.deg, 0.1);
}

// rotation_only: from a prior with the true camera centre and a rotation 8 degrees off, a few
// correspondences (some wrong) give the rotation; the centre stays the prior's and the
// covariance has no translation part. With the centre 3 cm off the rotation is still within
// a degree, while a full estimate from so few would not be trusted.
TEST(MotionEstimator, RotationOnlyFitsTheRotationAboutThePriorsCentre) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(11);
  const SE3 T_true = Motion(0.05, 12.0);
  SceneSpec spec;
  spec.num_points = 5;
  spec.num_lines = 2;
  spec.noise_px = 0.5;
  spec.endpoint_slide = 0.2;
  const Scene s = MakeScene(cam, T_true, spec, &rng);
  MotionEstimatorOptions opt;
  opt.rotation_only = true;
  opt.min_inliers = 4;
  auto centre = [](const SE3& T_cur_prev) {
    return (-(T_cur_prev.rotation().transpose() * T_cur_prev.translation())).eval();
  };
  // The prior: the true centre, the rotation 8 degrees off about another axis.
  const Eigen::Vector3d c_true = centre(T_true);
  const Eigen::Matrix3d R_prior =
      ExpSO3(8.0 * kDeg * Eigen::Vector3d(1.0, 0.3, 0.2).normalized()) * T_true.rotation();
  const SE3 prior(R_prior, -R_prior * c_true);
  MotionEstimate e = EstimateMotion(cam, s.points, s.lines, prior, opt);
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((centre(e.T_cur_prev) - c_true).norm(), 1e-9) << "the centre must not move";
  EXPECT_LT(Error(e.T_cur_prev, T_true).deg, 0.3);
  EXPECT_EQ(e.covariance.topRows<3>().norm(), 0.0);
  EXPECT_GT((e.covariance.bottomRightCorner<3, 3>().trace()), 0.0);

  // The centre 3 cm off: the rotation absorbs part of it.
  const Eigen::Vector3d c_off = c_true + Eigen::Vector3d(0.03, 0.0, 0.0);
  e = EstimateMotion(cam, s.points, s.lines, SE3(R_prior, -R_prior * c_off), opt);
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((centre(e.T_cur_prev) - c_off).norm(), 1e-9);
  EXPECT_LT(Error(e.T_cur_prev, T_true).deg, 1.0);
}

// A plate on a wall 1 m ahead, its ten corners the only features, the camera walking 5 cm
// towards it: the left image alone fixes the approach only through the plate's growth; the
// current frame's right image (stereo_residual) fixes it through the disparity. Exact without
// noise, and with 0.3 px noise the covariance stays consistent with the error (chi2, 6 dof).
TEST(MotionEstimator, StereoResidualFixesTheApproachToAPlateOnAWall) {
  const StereoCamera cam = TestCamera();
  const SE3 T_true(ExpSO3(0.5 * kDeg * Eigen::Vector3d::UnitY()), Eigen::Vector3d(0, 0, -0.05));
  std::vector<Eigen::Vector3d> corners;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 2; ++j) corners.emplace_back(-0.08 + 0.04 * i, -0.05 + 0.1 * j, 1.0);
  auto observe = [&](double noise_px, std::mt19937* rng) {
    std::normal_distribution<double> n(0.0, noise_px);
    PointMatches3D2D pm;
    for (const Eigen::Vector3d& P : corners) {
      PointMatch3D2D m;
      m.P_prev = P;
      const Eigen::Vector3d X = T_true * P;
      m.uv_cur = cam.Project(X) + Eigen::Vector2d(n(*rng), n(*rng));
      m.u_right_cur = cam.ProjectRight(X).x() + n(*rng);
      pm.push_back(m);
    }
    return pm;
  };
  MotionEstimatorOptions left_only, stereo;
  stereo.stereo_residual = true;
  std::mt19937 rng(5);
  const MotionEstimate exact = EstimateMotion(cam, observe(0.0, &rng), {}, SE3(), stereo);
  ASSERT_TRUE(exact.success) << exact.failure;
  EXPECT_LT(Error(exact.T_cur_prev, T_true).t, 1e-6);

  const int trials = 300;
  double z2_left = 0.0, z2_stereo = 0.0, var_left = 0.0, var_stereo = 0.0, chi2 = 0.0;
  for (int k = 0; k < trials; ++k) {
    const PointMatches3D2D pm = observe(0.3, &rng);
    const MotionEstimate a = EstimateMotion(cam, pm, {}, SE3(), left_only);
    const MotionEstimate b = EstimateMotion(cam, pm, {}, SE3(), stereo);
    ASSERT_TRUE(a.success && b.success) << a.failure << b.failure;
    z2_left += std::pow((a.T_cur_prev * T_true.inverse()).translation().z(), 2) / trials;
    z2_stereo += std::pow((b.T_cur_prev * T_true.inverse()).translation().z(), 2) / trials;
    var_left += a.covariance(2, 2) / trials;
    var_stereo += b.covariance(2, 2) / trials;
    const Vector6d d = (T_true * b.T_cur_prev.inverse()).Log();
    chi2 += d.dot(b.covariance.ldlt().solve(d)) / trials;
  }
  std::printf(
      "approach error (rms): %.2f mm from the left image, %.2f mm with the right one; "
      "sigma %.2f / %.2f mm; chi2 mean %.2f (expect 6)\n",
      1e3 * std::sqrt(z2_left), 1e3 * std::sqrt(z2_stereo), 1e3 * std::sqrt(var_left),
      1e3 * std::sqrt(var_stereo), chi2);
  EXPECT_LT(std::sqrt(z2_stereo), 0.7 * std::sqrt(z2_left));
  EXPECT_LT(std::sqrt(var_stereo), 0.7 * std::sqrt(var_left));
  EXPECT_NEAR(chi2, 6.0, 1.5);
}

// A prior 2 m off along the optical axis puts the nearest features behind the camera: they
// are skipped (not NaN) until the estimate brings them back in front, and the result is exact.
TEST(MotionEstimator, ConvergesWhenThePriorPutsFeaturesBehindTheCamera) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(10);
  const SE3 T_true = Motion(0.1, 3.0);
  SceneSpec spec;
  spec.endpoint_slide = 0.2;
  const Scene s = MakeScene(cam, T_true, spec, &rng);
  const SE3 prior = SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, -2.0)) * T_true;
  int behind = 0;
  for (const PointMatch3D2D& m : s.points) behind += (prior * m.P_prev).z() <= 0.05;
  ASSERT_GT(behind, 5);
  const MotionEstimate e = EstimateMotion(cam, s.points, s.lines, prior, MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);
  EXPECT_EQ(e.point_inliers, spec.num_points);
}

TEST(MotionEstimator, DegenerateInputFailsWithoutNaN) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(7);
  const SE3 T_true = Motion(0.1, 3.0);
  const MotionEstimatorOptions opt;

  MotionEstimate e = EstimateMotion(cam, {}, {}, SE3(), opt);
  EXPECT_FALSE(e.success);
  EXPECT_FALSE(e.failure.empty());
  EXPECT_TRUE(AllFinite(e));

  SceneSpec two;
  two.num_points = 2;
  two.num_lines = 0;
  Scene s = MakeScene(cam, T_true, two, &rng);
  e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
  EXPECT_FALSE(e.success);
  EXPECT_NE(e.failure.find("usable correspondences"), std::string::npos) << e.failure;
  EXPECT_TRUE(AllFinite(e));

  // Mutually parallel segments, noise-free: translating along their direction changes no
  // residual at all.
  SceneSpec parallel;
  parallel.num_points = 0;
  parallel.num_lines = 30;
  parallel.parallel_lines = true;
  parallel.endpoint_slide = 0.2;
  s = MakeScene(cam, T_true, parallel, &rng);
  e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
  EXPECT_FALSE(e.success);
  EXPECT_NE(e.failure.find("rank-deficient"), std::string::npos) << e.failure;
  EXPECT_TRUE(AllFinite(e));
  EXPECT_EQ(e.line_inliers, 0);
  EXPECT_TRUE(e.covariance.isZero());

  // With noise the same set is only nearly degenerate: the estimate may succeed, but its
  // covariance must then show the weak direction (translation along the segments).
  parallel.noise_px = 0.5;
  SceneSpec general = parallel;
  general.parallel_lines = false;
  const Scene s_general = MakeScene(cam, T_true, general, &rng);
  const MotionEstimate e_general =
      EstimateMotion(cam, s_general.points, s_general.lines, SE3(), opt);
  ASSERT_TRUE(e_general.success) << e_general.failure;
  const Eigen::Vector3d dir_cur = T_true.rotation() * kParallelDirection;
  auto std_along = [&dir_cur](const MotionEstimate& est) {
    return std::sqrt(dir_cur.dot(est.covariance.topLeftCorner<3, 3>() * dir_cur));
  };
  for (int k = 0; k < 5; ++k) {
    s = MakeScene(cam, T_true, parallel, &rng);
    e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
    EXPECT_TRUE(AllFinite(e));
    if (e.success) {
      EXPECT_GT(std_along(e), 5.0 * std_along(e_general))
          << std_along(e) << " m vs " << std_along(e_general) << " m";
    }
  }

  // Everything behind the camera after the prior.
  SceneSpec many;
  s = MakeScene(cam, T_true, many, &rng);
  for (PointMatch3D2D& m : s.points) m.P_prev.z() = -m.P_prev.z();
  s.lines.clear();
  e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
  EXPECT_FALSE(e.success);
  EXPECT_TRUE(AllFinite(e));

  // Non-finite prior.
  s = MakeScene(cam, T_true, many, &rng);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  e = EstimateMotion(cam, s.points, s.lines, SE3(Eigen::Quaterniond::Identity(), {nan, 0, 0}), opt);
  EXPECT_FALSE(e.success);
  EXPECT_TRUE(AllFinite(e));

  // Non-finite or zero-weight matches are ignored, the rest still gives the motion.
  s.points[0].uv_cur.x() = nan;
  s.points[1].P_prev.y() = std::numeric_limits<double>::infinity();
  s.points[2].weight = 0.0;
  s.lines[0].l_cur = Eigen::Vector3d(0.0, 0.0, 1.0);
  s.lines[1].weight = nan;
  e = EstimateMotion(cam, s.points, s.lines, SE3(), opt);
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_TRUE(AllFinite(e));
  EXPECT_EQ(e.point_inlier[0] + e.point_inlier[1] + e.point_inlier[2], 0);
  EXPECT_EQ(e.line_inlier[0] + e.line_inlier[1], 0);
  EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);
}

TEST(MotionEstimator, UnnormalisedLinesAreNormalised) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(8);
  const SE3 T_true = Motion(0.1, 3.0);
  SceneSpec spec;
  spec.num_points = 0;
  spec.num_lines = 30;
  Scene s = MakeScene(cam, T_true, spec, &rng);
  for (LineMatch3D2D& m : s.lines) m.l_cur *= -37.0;
  const MotionEstimate e = EstimateMotion(cam, s.points, s.lines, SE3(), MotionEstimatorOptions());
  ASSERT_TRUE(e.success) << e.failure;
  EXPECT_LT((e.T_cur_prev * T_true.inverse()).Log().norm(), 1e-8);
}

TEST(MotionEstimator, OptionsAreValidated) {
  EXPECT_EQ(MotionEstimatorOptions().Validate(), "");
  MotionEstimatorOptions opt;
  opt.huber_delta_px = 0.0;
  EXPECT_EQ(opt.Validate(), "huber_delta_px=0 must be in (0, 1000]");
  EXPECT_THROW(EstimateMotion(TestCamera(), {}, {}, SE3(), opt), ConfigError);
  opt = MotionEstimatorOptions();
  opt.max_iterations = 0;
  EXPECT_EQ(opt.Validate(), "max_iterations=0 must be in [1, 1000]");
  opt = MotionEstimatorOptions();
  opt.outlier_max_px = 1.0;  // below outlier_min_px
  EXPECT_NE(opt.Validate().find("outlier_max_px=1 must be in [2,"), std::string::npos)
      << opt.Validate();
  opt = MotionEstimatorOptions();
  opt.use_points = opt.use_lines = false;
  EXPECT_FALSE(opt.Validate().empty());
}

// ~300 points + 100 lines with 10% outliers, both steps, repeated: the same accurate result every
// time. The time is printed for information only (speed is measured by the benchmarks, not
// asserted in tests: sanitizer builds and busy machines are many times slower).
TEST(MotionEstimator, ThreeHundredPointsAndHundredLinesWithOutliers) {
  const StereoCamera cam = TestCamera();
  std::mt19937 rng(9);
  const SE3 T_true = Motion(0.1, 3.0);
  SceneSpec spec;
  spec.num_points = 300;
  spec.num_lines = 100;
  spec.noise_px = 0.5;
  spec.outlier_fraction = 0.1;
  spec.endpoint_slide = 0.2;
  const Scene s = MakeScene(cam, T_true, spec, &rng);
  const SE3 prior = SE3::Exp(0.01 * Vector6d::Ones()) * T_true;  // a constant-velocity guess
  std::vector<double> ms;
  int iterations = 0;
  for (int rep = 0; rep < 50; ++rep) {
    const auto t0 = std::chrono::steady_clock::now();
    const MotionEstimate e =
        EstimateMotion(cam, s.points, s.lines, prior, MotionEstimatorOptions());
    const auto t1 = std::chrono::steady_clock::now();
    ASSERT_TRUE(e.success);
    const SE3 err = e.T_cur_prev * T_true.inverse();
    ASSERT_LT(err.translation().norm(), 0.01);
    ASSERT_LT(err.RotationAngle() * 180.0 / M_PI, 0.2);
    iterations = e.iterations;
    ms.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
  }
  std::sort(ms.begin(), ms.end());
  std::printf(
      "EstimateMotion, 300 points + 100 lines, 10%% outliers: min %.3f ms, median %.3f "
      "ms, %d iterations\n",
      ms.front(), ms[ms.size() / 2], iterations);
  RecordProperty("min_ms", std::to_string(ms.front()));
}

}  // namespace
}  // namespace pl_slam
