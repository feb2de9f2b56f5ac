// Bundle adjustment on a synthetic scene with known truth: perturbed poses and landmarks must
// return close to the truth, gross outliers must be flagged, fixed poses must not move.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>

#include "pl_slam/optimization/bundle_adjustment.h"
#include "pl_slam/optimization/line_cost.h"
#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

StereoCamera Camera() { return testing_util::EurocSizedCamera(); }

struct Scene {
  std::vector<SE3, Eigen::aligned_allocator<SE3>> poses;  // T_w_c, truth
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points, P, Q;
};

Scene MakeScene(std::mt19937* rng) {
  Scene s;
  for (int i = 0; i < 6; ++i) {
    Vector6d xi;
    xi << 0.15 * i, 0.02 * i, 0.05 * i, 0.01 * i, 0.04 * i, 0.0;
    s.poses.push_back(SE3::Exp(xi));
  }
  std::uniform_real_distribution<double> x(-2.0, 2.5), y(-1.2, 1.2), z(3.0, 7.0);
  for (int i = 0; i < 150; ++i) s.points.emplace_back(x(*rng), y(*rng), z(*rng));
  for (int i = 0; i < 25; ++i) {
    const Eigen::Vector3d a(x(*rng), y(*rng), z(*rng));
    Eigen::Vector3d d(0.3 * y(*rng), 1.0, 0.2 * y(*rng));  // mostly vertical: stereo-friendly
    s.P.push_back(a);
    s.Q.push_back(a + 0.8 * d.normalized());
  }
  return s;
}

// Observations as the front end makes them: a corner's left-image position with noise_px, and
// its right column the left one minus a disparity refined on its own (matching/point_matching.h),
// 3x more precise than the corner (street family: 0.07 px against ~0.3 px).
BaProblem Observe(const Scene& s, const StereoCamera& cam, std::mt19937* rng, double noise_px) {
  std::normal_distribution<double> n(0.0, noise_px), nd(0.0, noise_px / 3.0);
  BaProblem p;
  for (const SE3& T : s.poses) {
    BaPose bp;
    bp.T_w_c = T;
    p.poses.push_back(bp);
  }
  p.points = s.points;
  p.line_P = s.P;
  p.line_Q = s.Q;
  for (size_t k = 0; k < s.poses.size(); ++k) {
    const SE3 T_c_w = s.poses[k].inverse();
    for (size_t i = 0; i < s.points.size(); ++i) {
      const Eigen::Vector3d X = T_c_w * s.points[i];
      const Eigen::Vector2d uv = cam.Project(X);
      if (X.z() < 0.5 || !cam.InImage(uv)) continue;
      BaPointObservation o;
      o.pose = static_cast<int>(k);
      o.point = static_cast<int>(i);
      o.uv = uv + Eigen::Vector2d(n(*rng), n(*rng));
      o.stereo = true;
      o.u_right = o.uv.x() - (uv.x() - cam.ProjectRight(X).x() + nd(*rng));
      p.point_obs.push_back(o);
    }
    for (size_t i = 0; i < s.P.size(); ++i) {
      const Eigen::Vector3d A = T_c_w * s.P[i], B = T_c_w * s.Q[i];
      if (A.z() < 0.5 || B.z() < 0.5) continue;
      BaLineObservation o;
      o.pose = static_cast<int>(k);
      o.line = static_cast<int>(i);
      const Eigen::Vector2d e(n(*rng), n(*rng));
      o.s = cam.Project(A) + e;
      o.e = cam.Project(B) - e;
      o.stereo = true;
      o.s_right = cam.ProjectRight(A);
      o.e_right = cam.ProjectRight(B) + e;
      p.line_obs.push_back(o);
    }
  }
  return p;
}

double MaxPoseError(const BaProblem& p, const Scene& s) {
  double worst = 0.0;
  for (size_t k = 0; k < s.poses.size(); ++k)
    worst = std::max(worst, (p.poses[k].T_w_c.translation() - s.poses[k].translation()).norm());
  return worst;
}

TEST(BundleAdjustmentTest, RecoversPerturbedPosesAndLandmarks) {
  std::mt19937 rng(1);
  const StereoCamera cam = Camera();
  const Scene scene = MakeScene(&rng);
  BaProblem p = Observe(scene, cam, &rng, 0.5);
  ASSERT_GT(p.point_obs.size(), 500u);
  ASSERT_GT(p.line_obs.size(), 80u);
  p.poses[0].fixed = true;
  std::normal_distribution<double> n(0.0, 1.0);
  for (size_t k = 1; k < p.poses.size(); ++k) {
    Vector6d xi;
    for (int i = 0; i < 6; ++i) xi(i) = (i < 3 ? 0.05 : 0.01) * n(rng);
    p.poses[k].T_w_c = SE3::Exp(xi) * p.poses[k].T_w_c;
  }
  for (auto& x : p.points) x += 0.05 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  for (size_t i = 0; i < p.line_P.size(); ++i) {
    p.line_P[i] += 0.05 * Eigen::Vector3d(n(rng), n(rng), n(rng));
    p.line_Q[i] += 0.05 * Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  const double before = MaxPoseError(p, scene);
  // Landmark errors (lines: endpoint distance to the true infinite 3D line, since endpoints may
  // slide along it) before and after: stereo depth noise at 3-7 m bounds what BA can reach
  // (~0.1 m per view at 5 m), so the test asks for a clear reduction, not a fixed figure.
  auto landmark_errors = [&](double* point_err, double* line_err) {
    *point_err = *line_err = 0.0;
    for (size_t i = 0; i < p.points.size(); ++i)
      *point_err += (p.points[i] - scene.points[i]).norm();
    *point_err /= p.points.size();
    for (size_t i = 0; i < p.line_P.size(); ++i) {
      const Eigen::Vector3d d = (scene.Q[i] - scene.P[i]).normalized();
      for (const Eigen::Vector3d& X : {p.line_P[i], p.line_Q[i]}) {
        const Eigen::Vector3d v = X - scene.P[i];
        *line_err += (v - v.dot(d) * d).norm();
      }
    }
    *line_err /= 2.0 * p.line_P.size();
  };
  double point_before, line_before, point_after, line_after;
  landmark_errors(&point_before, &line_before);
  BundleAdjustmentOptions options;
  options.max_iterations = 20;
  const BaSummary summary = SolveBundleAdjustment(cam, options, &p);
  ASSERT_TRUE(summary.success) << summary.message;
  EXPECT_GT(before, 0.04);
  EXPECT_LT(MaxPoseError(p, scene), 0.01);
  EXPECT_LT(summary.final_cost, summary.initial_cost);
  // The first pose was fixed.
  EXPECT_LT((p.poses[0].T_w_c.matrix() - scene.poses[0].matrix()).norm(), 1e-12);
  landmark_errors(&point_after, &line_after);
  EXPECT_LT(point_after, 0.5 * point_before);
  EXPECT_LT(line_after, 0.5 * line_before);
  // Clean data: (almost) no outliers at 95 %.
  EXPECT_LT(summary.point_outliers, static_cast<int>(0.1 * p.point_obs.size()));
}

// Endpoint-to-line residuals do not say where a segment ends. In the paper's form ("projected":
// projected endpoints to the observed line) all of a line's residuals pull each endpoint toward
// the same best point of the line, so repeated local BAs shrank segments to points (70-80% of
// the room's line landmarks within a few keyframes, which then matched nothing). Local
// mapping's remedy, as here: LineExtentCost in every BA, then the extent re-anchored to the
// creating keyframe's observed endpoints. 30 rounds of 5 iterations keep every segment's length
// in both residual forms; the same rounds without the gauge collapse the paper's form.
TEST(BundleAdjustmentTest, RepeatedRunsWithTheExtentGaugeKeepSegments) {
  auto worst_length_change = [](bool gauge, const std::string& residual) {
    std::mt19937 rng(3);
    const StereoCamera cam = Camera();
    const Scene scene = MakeScene(&rng);
    BaProblem p = Observe(scene, cam, &rng, 0.5);
    p.poses[0].fixed = true;
    BundleAdjustmentOptions options;
    options.line_residual = residual;
    if (!gauge) options.line_extent_weight = 0.0;
    for (int round = 0; round < 30; ++round) {
      EXPECT_TRUE(SolveBundleAdjustment(cam, options, &p).success);
      if (!gauge) continue;
      const SE3 T_c_w = scene.poses[0].inverse();
      for (size_t i = 0; i < scene.P.size(); ++i)
        AnchorSegmentToObservation(cam, p.poses[0].T_w_c, cam.Project(T_c_w * scene.P[i]),
                                   cam.Project(T_c_w * scene.Q[i]), &p.line_P[i], &p.line_Q[i]);
    }
    double worst = 0.0;
    for (size_t i = 0; i < scene.P.size(); ++i) {
      const double true_length = (scene.Q[i] - scene.P[i]).norm();
      const double length = (p.line_Q[i] - p.line_P[i]).norm();
      worst = std::max(worst, std::abs(length - true_length) / true_length);
    }
    return worst;
  };
  const double observed = worst_length_change(true, "observed");
  const double projected = worst_length_change(true, "projected");
  const double without = worst_length_change(false, "projected");
  std::cout << "worst relative length change after 30 rounds: " << observed << " (observed), "
            << projected << " (projected) with the gauge, " << without << " without (projected)\n";
  EXPECT_LT(observed, 0.05);
  EXPECT_LT(projected, 0.05);
  EXPECT_GT(without, 0.5);  // the failure this guards against is real in this scene
}

TEST(LineExtentTest, AnchorRestoresTheObservedExtent) {
  const StereoCamera cam = Camera();
  const SE3 T_w_c(ExpSO3(Eigen::Vector3d(0.05, -0.1, 0.02)), Eigen::Vector3d(0.3, -0.2, 0.1));
  const Eigen::Vector3d P(-0.4, -0.6, 4.0), Q(0.1, 0.7, 4.6);  // world
  const Eigen::Vector2d s = cam.Project(T_w_c.inverse() * P), e = cam.Project(T_w_c.inverse() * Q);
  // A collapsed-ish estimate on the right line: 5 cm long, off-centre.
  const Eigen::Vector3d d = (Q - P).normalized();
  Eigen::Vector3d P_est = P + 0.6 * d, Q_est = P + 0.65 * d;
  ASSERT_TRUE(AnchorSegmentToObservation(cam, T_w_c, s, e, &P_est, &Q_est));
  EXPECT_LT((P_est - P).norm(), 1e-9);
  EXPECT_LT((Q_est - Q).norm(), 1e-9);
  // A degenerate line or a ray along the line: refused, nothing changed.
  Eigen::Vector3d A = P, B = P;
  EXPECT_FALSE(AnchorSegmentToObservation(cam, T_w_c, s, e, &A, &B));
  EXPECT_EQ(A, P);
  const Eigen::Vector3d C = T_w_c.translation();
  A = C + 2.0 * (P - C).normalized();
  B = C + 3.0 * (P - C).normalized();  // the line is the viewing ray of s
  const Eigen::Vector3d A0 = A, B0 = B;
  EXPECT_FALSE(AnchorSegmentToObservation(cam, T_w_c, s, e, &A, &B));
  EXPECT_EQ(A, A0);
  EXPECT_EQ(B, B0);
}

TEST(BundleAdjustmentTest, FlagsGrossOutliers) {
  // One pass: the outliers are flagged after the solve (the mapper removes them from the map).
  // Two passes (the default): the second solve without them recovers the poses.
  for (const bool second_pass : {false, true}) {
    std::mt19937 rng(2);
    const StereoCamera cam = Camera();
    const Scene scene = MakeScene(&rng);
    BaProblem p = Observe(scene, cam, &rng, 0.3);
    p.poses[0].fixed = true;
    std::vector<size_t> bad;
    for (size_t k = 0; k < p.point_obs.size(); k += 25) {
      p.point_obs[k].uv += Eigen::Vector2d(30.0, -25.0);
      bad.push_back(k);
    }
    BundleAdjustmentOptions options;
    options.second_pass = second_pass;
    const BaSummary summary = SolveBundleAdjustment(cam, options, &p);
    ASSERT_TRUE(summary.success);
    for (size_t k : bad) EXPECT_EQ(summary.point_outlier[k], 1) << "observation " << k;
    EXPECT_LE(summary.point_outliers, static_cast<int>(bad.size() + 0.05 * p.point_obs.size()));
    EXPECT_LT(MaxPoseError(p, scene), second_pass ? 0.01 : 0.05) << "second_pass " << second_pass;
  }
}

// The newest pose keeps five observations, all wrong: a common 40 px shift (a keyframe
// associated with the wrong stretch of a repeated pattern) and up to 25 px each. The first pass
// turns the pose 6 deg towards the shift, where two of the five fit: too few to fix a pose, and
// the second pass would fit the pose to those two (0.22 m, 4.7 deg off). It goes back to where
// it started instead, where none of the five fits. The other poses still solve.
TEST(BundleAdjustmentTest, APoseLeftWithoutInliersReturnsToItsStart) {
  std::mt19937 rng(4);
  const StereoCamera cam = Camera();
  const Scene scene = MakeScene(&rng);
  BaProblem p = Observe(scene, cam, &rng, 0.3);
  p.poses[0].fixed = true;
  const int last = static_cast<int>(p.poses.size()) - 1;
  const SE3 start = p.poses[last].T_w_c;
  std::uniform_real_distribution<double> wrong(-25.0, 25.0);
  std::vector<BaPointObservation, Eigen::aligned_allocator<BaPointObservation>> kept;
  int mine = 0;
  for (const BaPointObservation& o : p.point_obs) {
    if (o.pose != last) {
      kept.push_back(o);
    } else if (mine < 5) {
      ++mine;
      kept.push_back(o);
      const Eigen::Vector2d shift(40.0 + wrong(rng), wrong(rng));
      kept.back().uv += shift;
      kept.back().u_right += shift.x();
    }
  }
  p.point_obs = kept;
  p.line_obs.erase(std::remove_if(p.line_obs.begin(), p.line_obs.end(),
                                  [&](const BaLineObservation& o) { return o.pose == last; }),
                   p.line_obs.end());
  const BaSummary summary = SolveBundleAdjustment(cam, BundleAdjustmentOptions(), &p);
  ASSERT_TRUE(summary.success);
  int outliers = 0;
  for (size_t k = 0; k < p.point_obs.size(); ++k)
    if (p.point_obs[k].pose == last) outliers += summary.point_outlier[k];
  EXPECT_EQ(outliers, 5);
  const SE3 moved = start.inverse() * p.poses[last].T_w_c;
  EXPECT_LT(moved.translation().norm(), 1e-9);
  EXPECT_LT(moved.RotationAngle(), 1e-9);
  for (int k = 1; k < last; ++k)
    EXPECT_LT((p.poses[k].T_w_c.translation() - scene.poses[k].translation()).norm(), 0.01)
        << "pose " << k;
}

TEST(BundleAdjustmentTest, OutlierSigmaScalesTheOutlierGates) {
  // Keypoints at 0.2 px noise; every 8th observation is a neighbouring corner 2 px off (the
  // misassociations a local-map search makes). With outlier_sigma = 1 px (ORB-SLAM's) they sit
  // inside the chi2 gates and stay in the map; at 0.5 px most are flagged, while the clean
  // observations still pass. (What this does to accuracy is measured by the benchmark.)
  int flagged_bad[2], flagged_good[2];
  size_t n_bad = 0, n_good = 0;
  const double sigmas[2] = {1.0, 0.5};
  for (int run = 0; run < 2; ++run) {
    std::mt19937 rng(3);
    const StereoCamera cam = Camera();
    const Scene scene = MakeScene(&rng);
    BaProblem p = Observe(scene, cam, &rng, 0.2);
    p.poses[0].fixed = true;
    std::vector<char> is_bad(p.point_obs.size(), 0);
    for (size_t k = 0; k < p.point_obs.size(); k += 8) {
      p.point_obs[k].uv.x() += 2.0;
      p.point_obs[k].u_right += 2.0;
      is_bad[k] = 1;
    }
    BundleAdjustmentOptions options;
    options.outlier_sigma = sigmas[run];
    const BaSummary summary = SolveBundleAdjustment(cam, options, &p);
    ASSERT_TRUE(summary.success);
    flagged_bad[run] = flagged_good[run] = 0;
    n_bad = n_good = 0;
    for (size_t k = 0; k < p.point_obs.size(); ++k) {
      (is_bad[k] ? flagged_bad[run] : flagged_good[run]) += summary.point_outlier[k];
      ++(is_bad[k] ? n_bad : n_good);
    }
  }
  EXPECT_EQ(flagged_bad[0], 0) << "1 px gates keep 2 px errors";
  EXPECT_GT(flagged_bad[1], static_cast<int>(0.5 * n_bad)) << "0.5 px gates flag 2 px errors";
  for (int run = 0; run < 2; ++run)
    EXPECT_LT(flagged_good[run], static_cast<int>(0.05 * n_good))
        << "outlier_sigma " << sigmas[run];
  BundleAdjustmentOptions bad;
  bad.outlier_sigma = 0.0;
  EXPECT_NE(bad.Validate().find("outlier_sigma"), std::string::npos);
}

TEST(BundleAdjustmentTest, AWrongDisparityLeavesItsLeftObservationInTheMap) {
  // Every 10th stereo observation has a disparity 3 px too large (an occluding edge inside the
  // stereo patch, a repeated pattern); its left-image position is right. Fitted as a residual
  // of its own (disparity_sigma > 0), the disparity is an outlier on its own: the observation
  // is not flagged and the second pass, without those disparities, recovers the poses. Fitted
  // as the right image's column (disparity_sigma = 0), the whole observation is flagged.
  for (const double disparity_sigma : {1.0, 0.0}) {
    std::mt19937 rng(5);
    const StereoCamera cam = Camera();
    const Scene scene = MakeScene(&rng);
    BaProblem p = Observe(scene, cam, &rng, 0.2);
    p.poses[0].fixed = true;
    std::vector<size_t> bad;
    for (size_t k = 0; k < p.point_obs.size(); k += 10) {
      p.point_obs[k].u_right -= 3.0;
      bad.push_back(k);
    }
    BundleAdjustmentOptions options;
    options.disparity_sigma = disparity_sigma;
    const BaSummary summary = SolveBundleAdjustment(cam, options, &p);
    ASSERT_TRUE(summary.success);
    int flagged = 0;
    for (size_t k : bad) flagged += summary.point_outlier[k];
    if (disparity_sigma > 0.0) {
      EXPECT_LE(flagged, static_cast<int>(bad.size() / 20)) << "the left-image observations";
      EXPECT_LT(summary.point_outliers, static_cast<int>(0.02 * p.point_obs.size()));
    } else {
      EXPECT_EQ(flagged, static_cast<int>(bad.size()));
    }
    EXPECT_LT(MaxPoseError(p, scene), 0.01) << "disparity_sigma " << disparity_sigma;
  }
  BundleAdjustmentOptions negative;
  negative.disparity_sigma = -1.0;
  EXPECT_NE(negative.Validate().find("disparity_sigma"), std::string::npos);
}

TEST(BundleAdjustmentTest, RejectsBadOptionsAndHandlesEmptyProblems) {
  const StereoCamera cam = Camera();
  BundleAdjustmentOptions bad;
  bad.max_iterations = 0;
  BaProblem p;
  EXPECT_THROW(SolveBundleAdjustment(cam, bad, &p), ConfigError);
  BundleAdjustmentOptions bad_residual;
  bad_residual.line_residual = "endpoints";
  EXPECT_EQ(bad_residual.Validate(),
            "line_residual='endpoints' must be auto, observed or projected");
  EXPECT_FALSE(SolveBundleAdjustment(cam, BundleAdjustmentOptions(), &p).success);
  p.poses.emplace_back();
  BaPointObservation o;
  o.pose = 3;  // out of range: skipped
  p.point_obs.push_back(o);
  EXPECT_FALSE(SolveBundleAdjustment(cam, BundleAdjustmentOptions(), &p).success);
}

}  // namespace
}  // namespace pl_slam
