// Geometric verification: relative pose from points and lines against known ground truth
// (synthetic correspondences, rendered synthetic frames), refusal of unrelated frames.
#include "pl_slam/loop/relative_pose.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "pl_slam/loop/loop_features.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

constexpr double kDeg = 180.0 / M_PI;

StereoCamera TestCamera() { return testing_util::EurocSizedCamera(); }

void RandomRow(cv::Mat* m, int row, std::mt19937_64* rng) {
  for (int b = 0; b < 32; ++b) m->at<uint8_t>(row, b) = static_cast<uint8_t>((*rng)() & 0xff);
}

// Copies row `src_row` of src into row `row` of dst with `bits` random bits flipped.
void NoisyCopy(const cv::Mat& src, int src_row, cv::Mat* dst, int row, int bits,
               std::mt19937_64* rng) {
  src.row(src_row).copyTo(dst->row(row));
  std::uniform_int_distribution<int> bit(0, 255);
  for (int i = 0; i < bits; ++i) {
    const int k = bit(*rng);
    dst->at<uint8_t>(row, k / 8) ^= static_cast<uint8_t>(1u << (k % 8));
  }
}

LineFeature MakeLine(const StereoCamera& cam, const Eigen::Vector3d& P, const Eigen::Vector3d& Q) {
  LineFeature f;
  f.s = cam.Project(P);
  f.e = cam.Project(Q);
  f.l = Eigen::Vector3d(f.s.x(), f.s.y(), 1.0).cross(Eigen::Vector3d(f.e.x(), f.e.y(), 1.0));
  f.l /= f.l.head<2>().norm();
  f.angle = std::atan2(f.e.y() - f.s.y(), f.e.x() - f.s.x());
  f.length = (f.e - f.s).norm();
  return f;
}

// Candidate frame with 3D points and lines; the query sees them through T_q_c with pixel
// noise, plus gross outliers (similar descriptors at random places) and unmatched clutter.
struct SyntheticPair {
  StereoFeatures query, candidate;
  SE3 T_q_c;
};

SyntheticPair MakePair(const StereoCamera& cam, uint64_t seed, int points, int outliers,
                       int lines) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(-3.0, 3.0), uy(-2.0, 2.0), uz(2.5, 8.0), u01(0, 1);
  std::normal_distribution<double> noise(0.0, 0.5);
  SyntheticPair p;
  p.T_q_c = SE3(ExpSO3(Eigen::Vector3d(0.05, -0.15, 0.03)), Eigen::Vector3d(0.3, -0.1, 0.25));
  cv::Mat cdesc(points + outliers, 32, CV_8UC1), qdesc(points + outliers + 50, 32, CV_8UC1);
  for (int i = 0; i < points + outliers; ++i) {
    PointFeature f;
    Eigen::Vector3d P;
    do {
      P = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
    } while (!cam.InImage(cam.Project(P), 5) || !cam.InImage(cam.Project(p.T_q_c * P), 5));
    f.p_c = P;
    f.uv = cam.Project(P);
    f.has_depth = true;
    f.disparity = cam.DisparityFromDepth(P.z());
    p.candidate.points.push_back(f);
    RandomRow(&cdesc, i, &rng);
    PointFeature g;
    if (i < points) {
      g.uv = cam.Project(p.T_q_c * P) + Eigen::Vector2d(noise(rng), noise(rng));
    } else {
      g.uv = Eigen::Vector2d(u01(rng) * (cam.width - 1), u01(rng) * (cam.height - 1));
    }
    p.query.points.push_back(g);
    NoisyCopy(cdesc, i, &qdesc, i, 8, &rng);
  }
  for (int i = points + outliers; i < qdesc.rows; ++i) {  // clutter seen only by the query
    PointFeature g;
    g.uv = Eigen::Vector2d(u01(rng) * (cam.width - 1), u01(rng) * (cam.height - 1));
    p.query.points.push_back(g);
    RandomRow(&qdesc, i, &rng);
  }
  p.candidate.point_descriptors = cdesc;
  p.query.point_descriptors = qdesc;

  cv::Mat cl(lines, 32, CV_8UC1), ql(lines, 32, CV_8UC1);
  for (int i = 0; i < lines; ++i) {
    Eigen::Vector3d P, Q;
    do {
      P = Eigen::Vector3d(ux(rng), uy(rng), uz(rng));
      Q = P + Eigen::Vector3d(0.3 * ux(rng), 0.6 * uy(rng), 0.2 * ux(rng));
    } while (!cam.InImage(cam.Project(P), 5) || !cam.InImage(cam.Project(Q), 5) ||
             !cam.InImage(cam.Project(p.T_q_c * P), 5) ||
             !cam.InImage(cam.Project(p.T_q_c * Q), 5) ||
             (cam.Project(P) - cam.Project(Q)).norm() < 40.0);
    LineFeature c = MakeLine(cam, P, Q);
    c.has_depth = true;
    c.P_c = P;
    c.Q_c = Q;
    p.candidate.lines.push_back(c);
    p.query.lines.push_back(MakeLine(cam, p.T_q_c * P, p.T_q_c * Q));
    RandomRow(&cl, i, &rng);
    NoisyCopy(cl, i, &ql, i, 6, &rng);
  }
  p.candidate.line_descriptors = cl;
  p.query.line_descriptors = ql;
  return p;
}

void ExpectPoseNear(const SE3& est, const SE3& truth, double max_m, double max_deg) {
  const SE3 err = est * truth.inverse();
  EXPECT_LT(err.translation().norm(), max_m);
  EXPECT_LT(err.RotationAngle() * kDeg, max_deg);
}

TEST(RelativePoseTest, RecoversKnownPoseFromPointsAndLinesWithOutliers) {
  const StereoCamera cam = TestCamera();
  const SyntheticPair p = MakePair(cam, 1, 150, 60, 40);
  const RelativePose rp = EstimateRelativePose(cam, p.query, p.candidate, RelativePoseOptions());
  ASSERT_TRUE(rp.success) << rp.failure;
  EXPECT_TRUE(rp.failure.empty());
  ExpectPoseNear(rp.T_query_candidate, p.T_q_c, 0.01, 0.1);
  EXPECT_GE(rp.point_inliers, 140);
  EXPECT_LE(rp.point_inliers, 160);  // the 60 gross outliers are not inliers
  EXPECT_GE(rp.line_inliers, 30);
  EXPECT_GE(rp.ransac_line_inliers, 30);
  EXPECT_GT(rp.inlier_ratio, 0.6);
  EXPECT_GT(rp.covariance.trace(), 0.0);
  EXPECT_LT((rp.covariance.topLeftCorner<3, 3>().trace()), 1e-4);
}

TEST(RelativePoseTest, NodeRestrictedMatchingGivesTheSamePose) {
  const StereoCamera cam = TestCamera();
  const SyntheticPair p = MakePair(cam, 2, 150, 30, 20);
  VocabularyOptions vo;
  vo.branching = 4;
  vo.depth = 3;
  const Vocabulary voc = Vocabulary::Train({p.candidate.point_descriptors}, vo);
  FeatureNodeIndex qn, cn;
  voc.Transform(p.query.point_descriptors, &qn, 1);
  voc.Transform(p.candidate.point_descriptors, &cn, 1);
  const auto all = MatchPointsByDescriptor(p.candidate, p.query, 64, 0.8);
  const auto restricted = MatchPointsByDescriptor(p.candidate, p.query, 64, 0.8, &cn, &qn);
  EXPECT_GE(restricted.size(), all.size() * 8 / 10);
  for (const auto& [i, j] : restricted) EXPECT_EQ(i, j);  // only true correspondences
  const RelativePose rp =
      EstimateRelativePose(cam, p.query, p.candidate, RelativePoseOptions(), &qn, &cn);
  ASSERT_TRUE(rp.success) << rp.failure;
  ExpectPoseNear(rp.T_query_candidate, p.T_q_c, 0.01, 0.1);
}

TEST(RelativePoseTest, UnrelatedFramesAreRefusedWithAReason) {
  const StereoCamera cam = TestCamera();
  const SyntheticPair a = MakePair(cam, 3, 150, 0, 30);
  const SyntheticPair b = MakePair(cam, 4, 150, 0, 30);
  const RelativePose rp = EstimateRelativePose(cam, a.query, b.candidate, RelativePoseOptions());
  EXPECT_FALSE(rp.success);
  EXPECT_FALSE(rp.failure.empty());
  std::cout << "[ info ] unrelated synthetic frames: " << rp.failure << "\n";
  // Empty features: a failure, not an exception.
  const RelativePose none =
      EstimateRelativePose(cam, StereoFeatures(), b.candidate, RelativePoseOptions());
  EXPECT_FALSE(none.success);
  EXPECT_NE(none.failure.find("point matches"), std::string::npos);
}

TEST(RelativePoseTest, OptionsAreValidatedWithTheKeyNamed) {
  RelativePoseOptions o;
  o.min_inlier_ratio = 1.5;
  EXPECT_NE(o.Validate().find("min_inlier_ratio=1.5"), std::string::npos);
  o = RelativePoseOptions();
  o.motion.max_iterations = 0;
  EXPECT_NE(o.Validate().find("motion.max_iterations=0"), std::string::npos);
  EXPECT_THROW(EstimateRelativePose(TestCamera(), StereoFeatures(), StereoFeatures(), o),
               ConfigError);
  StereoFeatures bad;
  bad.points.resize(3);
  EXPECT_THROW(EstimateRelativePose(TestCamera(), bad, StereoFeatures(), RelativePoseOptions()),
               InputError);
}

// --- Rendered synthetic frames ----------------------------------------------------------------

TEST(RelativePoseSyntheticTest, RoomFramesGiveTheGroundTruthPoseAndTheCorridorIsRefused) {
  sim::SequenceOptions so;  // room, 480 frames
  const sim::SyntheticSequence room(so);
  so.scene = sim::SceneKind::kCorridor;
  const sim::SyntheticSequence corridor(so);
  const StereoCamera& cam = room.camera();
  LoopFeatureExtractor extractor(cam);
  const Trajectory& gt = room.ground_truth();

  // The loop revisit: frame 472 against the nearest first-pass frame (by ground truth), and a
  // pair 12 frames apart on the first pass.
  int nearest = 0;
  double best = 1e9;
  for (int c = 0; c <= 60; ++c) {
    const SE3 d = gt[472].T_w_c.inverse() * gt[c].T_w_c;
    const double cost = d.translation().norm() + d.RotationAngle();
    if (cost < best) {
      best = cost;
      nearest = c;
    }
  }
  const StereoFeatures f472 = extractor.Extract(room.Render(472));
  for (const auto& [q, c] : {std::pair<int, int>{472, nearest}, {112, 100}}) {
    const StereoFeatures fq = q == 472 ? f472 : extractor.Extract(room.Render(q));
    const StereoFeatures fc = extractor.Extract(room.Render(c));
    const RelativePose rp = EstimateRelativePose(cam, fq, fc, RelativePoseOptions());
    const SE3 truth = gt[q].T_w_c.inverse() * gt[c].T_w_c;
    const SE3 err = rp.T_query_candidate * truth.inverse();
    std::cout << "[ info ] room " << q << " vs " << c << ": " << (rp.success ? "ok" : rp.failure)
              << ", " << rp.point_matches << " point / " << rp.line_matches
              << " line matches, inliers " << rp.point_inliers << " + " << rp.line_inliers
              << ", truth " << truth.translation().norm() << " m / " << truth.RotationAngle() * kDeg
              << " deg, error " << err.translation().norm() * 100 << " cm / "
              << err.RotationAngle() * kDeg << " deg\n";
    ASSERT_TRUE(rp.success) << rp.failure;
    EXPECT_LT(err.translation().norm(), 0.03);
    EXPECT_LT(err.RotationAngle() * kDeg, 0.5);
  }
  const StereoFeatures fcorridor = extractor.Extract(corridor.Render(150));
  const StereoFeatures f240 = extractor.Extract(room.Render(240));
  const RelativePose unrelated = EstimateRelativePose(cam, f472, fcorridor, RelativePoseOptions());
  std::cout << "[ info ] room 472 vs corridor 150: " << unrelated.failure << "\n";
  EXPECT_FALSE(unrelated.success);
  // The same room from the opposite side of the loop.
  const RelativePose opposite = EstimateRelativePose(cam, f472, f240, RelativePoseOptions());
  std::cout << "[ info ] room 472 vs room 240: " << opposite.failure << "\n";
  EXPECT_FALSE(opposite.success);
  RelativePoseOptions loose;
  loose.min_point_matches = 3;
  for (const StereoFeatures* other : {&f240, &fcorridor}) {
    const RelativePose rl = EstimateRelativePose(cam, f472, *other, loose);
    std::cout << "[ info ]   with min_point_matches=3: " << rl.failure << "\n";
    EXPECT_FALSE(rl.success);
  }
}

}  // namespace
}  // namespace pl_slam
