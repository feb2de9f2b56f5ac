// Motion estimation with a motion prior (EstimateMotion's prior covariance): a few clustered
// features that alone leave the motion unobservable, held by the prior; covariance
// consistency; a prior covariance that is not positive definite is refused.
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "pl_slam/tracking/motion_estimator.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

bool Finite(const MotionEstimate& e) {
  return e.T_cur_prev.IsFinite() && e.covariance.allFinite() && e.covariance_prev_cur.allFinite();
}

// A light switch 1 m ahead (8 corners within 8 x 12 cm): the corners alone trade a turn
// against a sideways step, so their estimate is mostly too uncertain to keep. With a motion
// prior (a prior covariance) the estimate is as certain as prior and corners together allow:
// at 1 px of noise its covariance is consistent with its error (chi2 mean ~6) and the distance
// to the wall, which the corners' disparities measure (stereo_residual), is better than the
// prior's; at 0.3 px the corners are still weighed at prior_min_sigma_px (1 px), so the
// covariance is conservative, never optimistic.
TEST(MotionEstimator, APriorHoldsWhatAFewClusteredFeaturesLeaveOpen) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  const SE3 T_true(ExpSO3(0.4 * kDeg * Eigen::Vector3d(0.3, 1.0, 0.1).normalized()),
                   Eigen::Vector3d(0.004, -0.003, -0.05));
  std::vector<Eigen::Vector3d> corners;
  for (double x : {-0.04, 0.04})
    for (double y : {-0.06, 0.06}) corners.emplace_back(0.3 + x, 0.1 + y, 1.0);
  for (double x : {-0.01, 0.01})
    for (double y : {-0.02, 0.02}) corners.emplace_back(0.3 + x, 0.1 + y, 0.99);
  const double sigma_m = 0.01, sigma_rad = 0.5 * kDeg;
  MotionEstimatorOptions options;
  options.stereo_residual = true;
  Matrix6d prior_cov = Matrix6d::Zero();
  prior_cov.diagonal() << sigma_m * sigma_m, sigma_m * sigma_m, sigma_m * sigma_m,
      sigma_rad * sigma_rad, sigma_rad * sigma_rad, sigma_rad * sigma_rad;
  std::mt19937 rng(21);
  std::normal_distribution<double> n01(0.0, 1.0);
  auto observe = [&](double noise_px) {
    PointMatches3D2D pm;
    for (const Eigen::Vector3d& P : corners) {
      PointMatch3D2D m;
      m.P_prev = P;
      m.uv_cur = cam.Project(T_true * P) + noise_px * Eigen::Vector2d(n01(rng), n01(rng));
      m.u_right_cur = cam.ProjectRight(T_true * P).x() + noise_px * n01(rng);
      pm.push_back(m);
    }
    return pm;
  };
  struct Stats {
    int plain_too_uncertain = 0;
    double chi2 = 0.0, z_fused = 0.0, z_prior = 0.0;  // chi2 mean, rms approach errors (m)
  };
  const int trials = 300;
  auto run = [&](double noise_px) {
    Stats st;
    for (int k = 0; k < trials; ++k) {
      Vector6d e;
      for (int j = 0; j < 6; ++j) e(j) = n01(rng) * (j < 3 ? sigma_m : sigma_rad);
      const SE3 prior = SE3::Exp(e) * T_true;  // the truth is Exp(-e) * prior: prior ~ N(T, S)
      const PointMatches3D2D pm = observe(noise_px);
      const MotionEstimate a = EstimateMotion(cam, pm, {}, prior, options);
      st.plain_too_uncertain += !a.success || !SigmaWithin(a.covariance, 0.05, 3.0 * kDeg);
      const MotionEstimate b = EstimateMotion(cam, pm, {}, prior, options, &prior_cov);
      EXPECT_TRUE(b.success) << b.failure;
      if (!b.success) continue;
      EXPECT_TRUE(Finite(b));
      EXPECT_TRUE(SigmaWithin(b.covariance, sigma_m, sigma_rad));
      const Vector6d d = (T_true * b.T_cur_prev.inverse()).Log();
      st.chi2 += d.dot(b.covariance.ldlt().solve(d)) / trials;
      st.z_fused += std::pow((b.T_cur_prev * T_true.inverse()).translation().z(), 2) / trials;
      st.z_prior += std::pow((prior * T_true.inverse()).translation().z(), 2) / trials;
    }
    st.z_fused = std::sqrt(st.z_fused);
    st.z_prior = std::sqrt(st.z_prior);
    std::printf(
        "switch 1 m ahead, %.1f px: %d of %d plain estimates too uncertain; with the prior: "
        "chi2 mean %.2f, approach error %.2f mm against the prior's %.2f mm\n",
        noise_px, st.plain_too_uncertain, trials, st.chi2, 1e3 * st.z_fused, 1e3 * st.z_prior);
    return st;
  };
  const Stats one = run(1.0);
  EXPECT_GT(one.plain_too_uncertain, trials / 2);
  EXPECT_NEAR(one.chi2, 6.0, 1.5);
  EXPECT_LT(one.z_fused, 0.7 * one.z_prior);
  const Stats low = run(0.3);
  EXPECT_LT(low.chi2, 6.0);
  EXPECT_LT(low.z_fused, one.z_fused);

  // A prior covariance that is not positive definite is refused, not trusted.
  Matrix6d bad = prior_cov;
  bad(2, 2) = -1e-4;
  const MotionEstimate c = EstimateMotion(cam, observe(0.0), {}, T_true, options, &bad);
  EXPECT_FALSE(c.success);
  EXPECT_NE(c.failure.find("positive definite"), std::string::npos) << c.failure;
  EXPECT_TRUE(Finite(c));
}

}  // namespace
}  // namespace pl_slam
