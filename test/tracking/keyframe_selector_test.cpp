// Keyframe selector: the entropy formula, first-order covariance propagation against Monte
// Carlo, the entropy-ratio trigger, safety triggers and invalid input.
#include "pl_slam/tracking/keyframe_selector.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

Matrix6d Diag(double sigma_t, double sigma_r) {
  Vector6d v;
  v << sigma_t * sigma_t, sigma_t * sigma_t, sigma_t * sigma_t, sigma_r * sigma_r,
      sigma_r * sigma_r, sigma_r * sigma_r;
  return v.asDiagonal();
}

// A selector that never fires on its own (to observe the chain).
KeyframeSelectorOptions Passive() {
  KeyframeSelectorOptions o;
  o.min_inliers = 0;
  o.max_translation = 1e5;
  o.max_rotation_deg = 180.0;
  o.min_frames = o.max_frames = 100000;
  o.min_translation = o.min_rotation_deg = 0.0;
  return o;
}

/// Default options with the at-rest rule off: the entropy tests below chain zero motions.
KeyframeSelectorOptions EvenAtRest() {
  KeyframeSelectorOptions o;
  o.min_translation = o.min_rotation_deg = 0.0;
  return o;
}

TEST(Entropy, MatchesTheFormulaOnADiagonalCovariance) {
  Vector6d var;
  var << 1e-4, 4e-4, 9e-6, 2e-6, 1e-6, 5e-5;
  double expected = 3.0 * (1.0 + std::log(2.0 * kPi));
  for (int i = 0; i < 6; ++i) expected += 0.5 * std::log(var(i));
  EXPECT_NEAR(Entropy(var.asDiagonal()), expected, 1e-12);
  // Rotating the covariance does not change its determinant.
  Eigen::Matrix<double, 6, 6> Q = Eigen::HouseholderQR<Matrix6d>(Matrix6d::Random()).householderQ();
  EXPECT_NEAR(Entropy(Q * Matrix6d(var.asDiagonal()) * Q.transpose()), expected, 1e-9);
  // The unit-variance Gaussian: h = 3 (1 + log 2 pi) ~ 8.51; realistic estimates are negative.
  EXPECT_NEAR(Entropy(Matrix6d::Identity()), 8.513631199, 1e-8);
  EXPECT_LT(Entropy(Diag(0.01, 0.01)), 0.0);
}

TEST(Entropy, SingularAndNonFiniteCovariances) {
  EXPECT_EQ(Entropy(Matrix6d::Zero()), -std::numeric_limits<double>::infinity());
  Matrix6d neg = Diag(0.1, 0.1);
  neg(2, 2) = -1e-3;
  EXPECT_EQ(Entropy(neg), -std::numeric_limits<double>::infinity());
  Matrix6d nan = Diag(0.1, 0.1);
  nan(1, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isnan(Entropy(nan)));
}

// Samples every increment as Exp(e_k) * T_k with e_k ~ N(0, S_k), chains them, and compares
// the empirical covariance of Log(T_true * T_est^-1) (the left perturbation of T_kf_cur) with
// the selector's propagated one. Whitened, all eigenvalues must lie within 10 % of 1; the same
// comparison rejects the propagation without the adjoint (so the test can fail).
TEST(KeyframeSelectorPropagation, MatchesMonteCarlo) {
  std::mt19937 rng(21);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  constexpr int kSteps = 10;
  std::vector<SE3, Eigen::aligned_allocator<SE3>> T;
  std::vector<Matrix6d, Eigen::aligned_allocator<Matrix6d>> S, L;
  for (int k = 0; k < kSteps; ++k) {
    const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    T.push_back(SE3(ExpSO3(6.0 * kDeg * axis), Eigen::Vector3d(0.2, 0.05 * u(rng), 0.3)));
    // A random correlated covariance, standard deviations ~ 3-8 mm and mrad.
    Matrix6d A = Matrix6d::Random();
    Matrix6d C = 4e-6 * A * A.transpose() + Diag(0.004, 0.004);
    S.push_back(C);
    L.push_back(C.llt().matrixL());
  }

  KeyframeSelector selector(Passive());
  ASSERT_EQ(selector.AddFrame(SE3(), Matrix6d::Zero(), 100), KeyframeReason::kFirst);
  Matrix6d wrong = Matrix6d::Zero();  // sum of the S_k, no adjoint
  for (int k = 0; k < kSteps; ++k) {
    ASSERT_EQ(selector.AddFrame(T[k], S[k], 100), KeyframeReason::kNone);
    wrong += S[k];
  }
  const SE3 T_est = selector.T_kf_cur();
  const Matrix6d propagated = selector.covariance_kf_cur();

  constexpr int kSamples = 20000;
  Matrix6d empirical = Matrix6d::Zero();
  for (int i = 0; i < kSamples; ++i) {
    SE3 T_true;
    for (int k = 0; k < kSteps; ++k) {
      Vector6d z;
      for (int j = 0; j < 6; ++j) z(j) = n01(rng);
      T_true = T_true * (SE3::Exp(L[k] * z) * T[k]);
    }
    const Vector6d e = (T_true * T_est.inverse()).Log();
    empirical += e * e.transpose();
  }
  empirical /= kSamples;

  // Eigenvalues of C^-1/2 empirical C^-1/2.
  auto whitened = [&empirical](const Matrix6d& C) {
    const Matrix6d Li = C.llt().matrixL().solve(Matrix6d::Identity());
    return Eigen::SelfAdjointEigenSolver<Matrix6d>(Li * empirical * Li.transpose()).eigenvalues();
  };
  const Vector6d good = whitened(propagated);
  const Vector6d bad = whitened(wrong);
  std::printf(
      "whitened empirical covariance eigenvalues, first-order propagation: [%.3f, %.3f]; "
      "without the adjoint: [%.3f, %.3f]\n",
      good.minCoeff(), good.maxCoeff(), bad.minCoeff(), bad.maxCoeff());
  EXPECT_GT(good.minCoeff(), 0.9);
  EXPECT_LT(good.maxCoeff(), 1.1);
  EXPECT_TRUE(bad.minCoeff() < 0.9 || bad.maxCoeff() > 1.1);
}

// Constant per-frame covariance and no motion: Sigma(kf, kf + u) = u Sigma_1 exactly, so
// h(u) = h(1) + 3 log u and the paper's test alpha = h(u) / h(1) < 0.9 first holds at the
// smallest u with 3 log u > 0.1 |h(1)|: u = 5 for 0.1 mm / 0.1 mrad per frame.
TEST(KeyframeSelectorEntropy, FiresAsUncertaintyAccumulates) {
  KeyframeSelectorOptions opt = EvenAtRest();
  opt.min_inliers = 10;
  KeyframeSelector selector(opt);
  const Matrix6d cov = Diag(1e-4, 1e-4);
  const double h1 = Entropy(cov);
  ASSERT_LT(h1, 0.0);
  int expected = 1;
  while (!(3.0 * std::log(expected) > 0.1 * std::abs(h1))) ++expected;
  ASSERT_EQ(expected, 5);

  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kFirst);
  for (int cycle = 0; cycle < 3; ++cycle) {
    double previous_ratio = 1.0;
    for (int u = 1; u <= expected; ++u) {
      const KeyframeReason r = selector.AddFrame(SE3(), cov, 100);
      EXPECT_EQ(selector.frames_since_keyframe(), u);
      EXPECT_NEAR(selector.last_entropy(), h1 + 3.0 * std::log(u), 1e-9);
      EXPECT_LE(selector.last_entropy_ratio(), previous_ratio);
      previous_ratio = selector.last_entropy_ratio();
      if (u < expected) {
        EXPECT_EQ(r, KeyframeReason::kNone) << "u=" << u;
        EXPECT_GE(selector.last_entropy_ratio(), 0.9);
      } else {
        EXPECT_EQ(r, KeyframeReason::kEntropy) << "u=" << u;
        EXPECT_LT(selector.last_entropy_ratio(), 0.9);
      }
    }
    // After the keyframe the chain restarts from it.
  }
}

// A moving camera: rotation uncertainty leaks into translation through the adjoint, so the
// entropy grows faster than with a still camera and the keyframe comes no later.
TEST(KeyframeSelectorEntropy, FiresEarlierWhenMoving) {
  KeyframeSelectorOptions opt = EvenAtRest();
  opt.min_frames = 2;
  opt.min_inliers = 10;
  const Matrix6d cov = Diag(1e-3, 1e-3);
  auto frames_to_keyframe = [&](const SE3& step) {
    KeyframeSelector selector(opt);
    selector.AddFrame(SE3(), cov, 100);
    for (int u = 1; u < 100; ++u) {
      if (selector.AddFrame(step, cov, 100) == KeyframeReason::kEntropy) return u;
    }
    return -1;
  };
  const int still = frames_to_keyframe(SE3());
  const int moving = frames_to_keyframe(
      SE3(ExpSO3(Eigen::Vector3d(0, 2.0 * kDeg, 0)), Eigen::Vector3d(0.05, 0.0, 0.1)));
  EXPECT_EQ(still, 3);
  EXPECT_GE(moving, opt.min_frames);
  EXPECT_LE(moving, still);
}

// When h(kf, kf + 1) >= 0 (an extremely uncertain first increment) the paper's ratio grows with
// the uncertainty; the selector still fires, on the same entropy margin.
TEST(KeyframeSelectorEntropy, PositiveEntropyStillFires) {
  KeyframeSelectorOptions opt = EvenAtRest();
  opt.min_inliers = 0;
  KeyframeSelector selector(opt);
  const Matrix6d cov = Diag(1.0, 1.0);
  ASSERT_GT(Entropy(cov), 0.0);
  selector.AddFrame(SE3(), cov, 100);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kEntropy);  // min_frames = 3
  EXPECT_GT(selector.last_entropy_ratio(), 1.0);
}

// A camera at rest (or a frozen stream) chains growing uncertainty but sees nothing new: the
// entropy and frame-count triggers wait for min_translation or min_rotation_deg of motion; the
// inlier trigger does not.
TEST(KeyframeSelectorSafety, AtRestTheEntropyAndFrameCountTriggersWait) {
  KeyframeSelectorOptions opt;
  opt.min_inliers = 10;
  opt.max_frames = 10;
  KeyframeSelector selector(opt);
  const Matrix6d cov = Diag(1e-4, 1e-4);
  selector.AddFrame(SE3(), cov, 100);
  for (int u = 1; u <= 50; ++u)
    ASSERT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone) << "u=" << u;
  EXPECT_LT(selector.last_entropy_ratio(), 0.9);  // the entropy test alone would have fired
  // 4 mm per frame: the 3rd step passes 1 cm and the pending keyframe (frame count, checked
  // before the entropy) comes at once.
  const SE3 step(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.004, 0.0, 0.0));
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kMaxFrames);
  // Turning in place counts as motion too.
  for (int u = 1; u <= 20; ++u)
    ASSERT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone);
  const SE3 turn(ExpSO3(Eigen::Vector3d(0.0, 0.3 * kDeg, 0.0)), Eigen::Vector3d::Zero());
  EXPECT_EQ(selector.AddFrame(turn, cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(turn, cov, 100), KeyframeReason::kMaxFrames);  // 0.6 deg
  // Few inliers still force a keyframe at rest.
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 5), KeyframeReason::kFewInliers);
}

TEST(KeyframeSelectorSafety, FewInliers) {
  KeyframeSelectorOptions opt;
  opt.min_inliers = 50;
  KeyframeSelector selector(opt);
  const Matrix6d cov = Diag(1e-4, 1e-4);
  selector.AddFrame(SE3(), cov, 100);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 50), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 49), KeyframeReason::kFewInliers);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.frames_since_keyframe(), 1);
}

TEST(KeyframeSelectorSafety, LargeTranslationAndRotation) {
  KeyframeSelectorOptions opt = Passive();
  opt.max_translation = 1.0;
  opt.max_rotation_deg = 10.0;
  const Matrix6d cov = Diag(1e-4, 1e-4);
  {
    KeyframeSelector selector(opt);
    selector.AddFrame(SE3(), cov, 100);
    const SE3 step(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 0.3));
    for (int u = 1; u <= 3; ++u)
      EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
    EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kLargeMotion);  // 1.2 m
    EXPECT_NEAR(selector.T_kf_cur().translation().z(), 1.2, 1e-12);  // old keyframe -> new one
    EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
    EXPECT_NEAR(selector.T_kf_cur().translation().z(), 0.3, 1e-12);  // restarted
  }
  {
    KeyframeSelector selector(opt);
    selector.AddFrame(SE3(), cov, 100);
    const SE3 step(ExpSO3(Eigen::Vector3d(0.0, 0.0, 3.0 * kDeg)), Eigen::Vector3d::Zero());
    for (int u = 1; u <= 3; ++u)
      EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
    EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kLargeMotion);  // 12 deg
  }
}

TEST(KeyframeSelectorSafety, MaxFrames) {
  KeyframeSelectorOptions opt = Passive();
  opt.min_frames = 1;
  opt.max_frames = 7;
  opt.entropy_ratio = 1e-3;  // the entropy test would fire at u = 5 with 0.9
  KeyframeSelector selector(opt);
  const Matrix6d cov = Diag(1e-4, 1e-4);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kFirst);
  for (int cycle = 0; cycle < 2; ++cycle) {
    for (int u = 1; u < 7; ++u)
      ASSERT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kNone);
    EXPECT_EQ(selector.AddFrame(SE3(), cov, 100), KeyframeReason::kMaxFrames);
  }
}

// Local mapping idle (ORB-SLAM's rule): a keyframe idle_min_frames after the last one, but only
// once the camera has moved, never while mapping is busy, and never with the rule off.
TEST(KeyframeSelectorSafety, MappingIdle) {
  KeyframeSelectorOptions opt = Passive();
  opt.idle_min_frames = 2;
  opt.min_translation = 0.01;
  const Matrix6d cov = Diag(1e-4, 1e-4);
  const SE3 step(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.02, 0.0, 0.0));
  KeyframeSelector selector(opt);
  EXPECT_EQ(selector.AddFrame(SE3(), cov, 100, true), KeyframeReason::kFirst);
  EXPECT_EQ(selector.AddFrame(step, cov, 100, true), KeyframeReason::kNone);  // 1 frame
  EXPECT_EQ(selector.AddFrame(step, cov, 100, true), KeyframeReason::kMappingIdle);
  EXPECT_EQ(selector.AddFrame(step, cov, 100, false), KeyframeReason::kNone);
  EXPECT_EQ(selector.AddFrame(step, cov, 100, false), KeyframeReason::kNone);  // busy
  EXPECT_EQ(selector.AddFrame(step, cov, 100, true), KeyframeReason::kMappingIdle);
  for (int u = 1; u <= 10; ++u)  // at rest: nothing new to map
    ASSERT_EQ(selector.AddFrame(SE3(), cov, 100, true), KeyframeReason::kNone) << "u=" << u;
  EXPECT_EQ(selector.AddFrame(step, cov, 100, true), KeyframeReason::kMappingIdle);
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kMappingIdle), "mapping_idle");

  opt.idle_min_frames = 0;  // off
  KeyframeSelector off(opt);
  off.AddFrame(SE3(), cov, 100, true);
  for (int u = 1; u <= 20; ++u)
    ASSERT_EQ(off.AddFrame(step, cov, 100, true), KeyframeReason::kNone) << "u=" << u;
}

TEST(KeyframeSelector, InvalidInputForcesAKeyframeWithoutNaN) {
  KeyframeSelector selector(KeyframeSelectorOptions{});
  const Matrix6d cov = Diag(1e-3, 1e-3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  selector.AddFrame(SE3(), cov, 100);
  const SE3 step(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 0.1));
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);

  Matrix6d bad = cov;
  bad(0, 1) = nan;
  Matrix6d negative = cov;
  negative(4, 4) = -1e-6;
  const SE3 nan_pose(Eigen::Quaterniond::Identity(), Eigen::Vector3d(nan, 0.0, 0.0));
  for (const auto& [T, C] : std::vector<std::pair<SE3, Matrix6d>>{
           {step, bad}, {step, Matrix6d::Zero()}, {step, negative}, {nan_pose, cov}}) {
    EXPECT_EQ(selector.AddFrame(T, C, 100), KeyframeReason::kInvalidInput);
    EXPECT_TRUE(selector.T_kf_cur().IsFinite());
    EXPECT_TRUE(selector.covariance_kf_cur().allFinite());
    EXPECT_TRUE(std::isfinite(selector.last_entropy_ratio()));
    EXPECT_TRUE(std::isfinite(selector.last_entropy()));
  }
  // Valid input afterwards chains from the forced keyframe.
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
  EXPECT_EQ(selector.frames_since_keyframe(), 1);
  EXPECT_NEAR(selector.T_kf_cur().translation().z(), 0.1, 1e-12);
}

TEST(KeyframeSelector, FirstFrameAndReset) {
  KeyframeSelector selector(KeyframeSelectorOptions{});
  const Matrix6d cov = Diag(1e-3, 1e-3);
  const SE3 step(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.0, 0.0, 0.1));
  EXPECT_EQ(selector.AddFrame(step, Matrix6d::Zero(), 0), KeyframeReason::kFirst);
  EXPECT_EQ(selector.frames_since_keyframe(), 0);
  EXPECT_TRUE(selector.T_kf_cur().matrix().isIdentity());
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kNone);
  EXPECT_DOUBLE_EQ(selector.last_entropy_ratio(), 1.0);
  EXPECT_TRUE(selector.covariance_kf_cur().isApprox(cov));
  selector.Reset();
  EXPECT_EQ(selector.AddFrame(step, cov, 100), KeyframeReason::kFirst);
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kEntropy), "entropy");
  EXPECT_STREQ(KeyframeReasonName(KeyframeReason::kInvalidInput), "invalid_input");
}

TEST(KeyframeSelector, OptionsAreValidated) {
  EXPECT_EQ(KeyframeSelectorOptions().Validate(), "");
  KeyframeSelectorOptions opt;
  opt.entropy_ratio = 1.5;
  EXPECT_EQ(opt.Validate(), "entropy_ratio=1.5 must be in (0, 1]");
  EXPECT_THROW(KeyframeSelector{opt}, ConfigError);
  opt = KeyframeSelectorOptions();
  opt.max_frames = 2;  // below min_frames = 3
  EXPECT_EQ(opt.Validate(), "max_frames=2 must be in [3, 100000]");
  opt = KeyframeSelectorOptions();
  opt.max_rotation_deg = 0.0;
  EXPECT_EQ(opt.Validate(), "max_rotation_deg=0 must be in (0, 180]");
  opt = KeyframeSelectorOptions();
  opt.idle_min_frames = -1;
  EXPECT_EQ(opt.Validate(), "idle_min_frames=-1 must be in [0, 100000]");
}

}  // namespace
}  // namespace pl_slam
