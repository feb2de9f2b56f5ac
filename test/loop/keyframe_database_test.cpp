// Keyframe database: inverted-index queries, exclusions, removal, combined point + line score,
// and retrieval of the first pass of the synthetic room loop with the default vocabulary.
#include "pl_slam/loop/keyframe_database.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <thread>

#include "pl_slam/loop/loop_features.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

// A random sparse BoW vector over `words` words with `n` entries.
BowVector RandomBow(int words, int n, std::mt19937_64* rng) {
  std::uniform_int_distribution<int> word(0, words - 1);
  std::uniform_real_distribution<float> value(0.1f, 1.0f);
  std::map<uint32_t, float> m;
  while (static_cast<int>(m.size()) < n) m[word(*rng)] = value(*rng);
  BowVector v(m.begin(), m.end());
  float sum = 0.0f;
  for (const auto& p : v) sum += p.second;
  for (auto& p : v) p.second /= sum;
  return v;
}

// Keeps a random 70 % of the entries of v and renormalises.
BowVector Subsample(const BowVector& v, std::mt19937_64* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  BowVector out;
  float sum = 0.0f;
  for (const auto& p : v) {
    if (u(*rng) < 0.7) {
      out.push_back(p);
      sum += p.second;
    }
  }
  for (auto& p : out) p.second /= sum;
  return out;
}

KeyframeBow RandomKeyframe(std::mt19937_64* rng) {
  KeyframeBow kf;
  kf.points = RandomBow(10000, 300, rng);
  kf.lines = RandomBow(10000, 60, rng);
  kf.num_points = 600;
  kf.num_lines = 80;
  kf.point_spread = 0.8;
  kf.line_spread = 0.6;
  return kf;
}

TEST(KeyframeDatabaseTest, QueryFindsTheRightKeyframeAmongManyAndHonoursExclusions) {
  std::mt19937_64 rng(1);
  KeyframeDatabase db;
  std::vector<KeyframeBow> kfs;
  for (int id = 0; id < 2000; ++id) {
    kfs.push_back(RandomKeyframe(&rng));
    db.Add(id * 3, kfs.back());  // ids need not be dense
  }
  EXPECT_EQ(db.size(), 2000u);
  for (int target : {0, 777, 1999}) {
    KeyframeBow q = kfs[target];
    q.points = Subsample(q.points, &rng);
    q.lines = Subsample(q.lines, &rng);
    const auto res = db.Query(q, 5);
    ASSERT_EQ(res.size(), 5u);
    EXPECT_EQ(res[0].id, target * 3);
    EXPECT_GT(res[0].score, 3.0 * res[1].score);
    for (std::size_t i = 1; i < res.size(); ++i) EXPECT_GE(res[i - 1].score, res[i].score);
    // The index computes the same score as the pairwise formula.
    EXPECT_NEAR(res[0].score, CombinedScore(q, kfs[target], 1.0), 1e-4);
    EXPECT_NEAR(res[0].point_score, BowL1Score(q.points, kfs[target].points), 1e-4);
    EXPECT_NEAR(res[0].line_score, BowL1Score(q.lines, kfs[target].lines), 1e-4);

    const std::unordered_set<int> exclude{target * 3, res[1].id};
    const auto res_ex = db.Query(q, 5, &exclude);
    ASSERT_EQ(res_ex.size(), 5u);
    for (const auto& c : res_ex) EXPECT_EQ(exclude.count(c.id), 0u);
    EXPECT_EQ(res_ex[0].id, res[2].id);
  }
}

TEST(KeyframeDatabaseTest, OnlyKeyframesSharingWordsAreTouchedAndRemovalWorks) {
  KeyframeDatabase db;
  KeyframeBow a, b, c;
  a.points = {{1, 0.5f}, {2, 0.5f}};
  b.points = {{2, 0.25f}, {3, 0.75f}};
  c.points = {{7, 1.0f}};
  a.num_points = b.num_points = c.num_points = 10;
  a.point_spread = b.point_spread = c.point_spread = 0.5;
  db.Add(10, a);
  db.Add(20, b);
  db.Add(30, c);
  KeyframeBow q;
  q.points = {{2, 1.0f}};
  q.num_points = 10;
  q.point_spread = 0.5;
  auto res = db.Query(q, 10);
  ASSERT_EQ(res.size(), 2u);  // c shares no word: never touched, not returned
  EXPECT_EQ(res[0].id, 10);
  EXPECT_NEAR(res[0].score, 0.5, 1e-6);  // no lines anywhere: the point score alone
  EXPECT_EQ(res[1].id, 20);
  EXPECT_NEAR(res[1].score, 0.25, 1e-6);
  EXPECT_EQ(res[0].shared_words, 1);

  EXPECT_TRUE(db.Remove(10));
  EXPECT_FALSE(db.Remove(10));
  EXPECT_FALSE(db.Contains(10));
  res = db.Query(q, 10);
  ASSERT_EQ(res.size(), 1u);
  EXPECT_EQ(res[0].id, 20);
  // Re-adding an id replaces its entry (slot reuse must not leave stale postings).
  db.Add(20, c);
  EXPECT_EQ(db.size(), 2u);
  EXPECT_TRUE(db.Query(q, 10).empty());
  db.Add(40, a);
  res = db.Query(q, 10);
  ASSERT_EQ(res.size(), 1u);
  EXPECT_EQ(res[0].id, 40);
  db.Clear();
  EXPECT_EQ(db.size(), 0u);
  EXPECT_TRUE(db.Query(q, 10).empty());
}

TEST(KeyframeDatabaseTest, CombinedScoreWeighsPointsAndLinesByCountAndSpread) {
  KeyframeBow a, b;
  a.points = b.points = {{1, 1.0f}};  // identical points: s_p = 1
  a.lines = {{5, 1.0f}};              // disjoint lines: s_l = 0
  b.lines = {{6, 1.0f}};
  a.num_points = b.num_points = 100;
  a.num_lines = b.num_lines = 100;
  a.point_spread = b.point_spread = 0.5;
  a.line_spread = b.line_spread = 0.5;
  EXPECT_NEAR(CombinedScore(a, b, 1.0), 0.5, 1e-9);
  // Lines bunched in a small part of the image count for less.
  a.line_spread = b.line_spread = 0.125;
  EXPECT_NEAR(PointScoreWeight(a, b, 1.0), 0.8, 1e-9);
  EXPECT_NEAR(CombinedScore(a, b, 1.0), 0.8, 1e-9);
  // Fewer lines count for less too; a frame without features of either kind is neutral.
  a.line_spread = b.line_spread = 0.5;
  a.num_lines = b.num_lines = 25;
  EXPECT_NEAR(CombinedScore(a, b, 1.0), 0.8, 1e-9);
  EXPECT_NEAR(CombinedScore(a, b, 4.0), 0.5, 1e-9);
  KeyframeBow empty;
  EXPECT_NEAR(PointScoreWeight(empty, empty, 1.0), 0.5, 1e-12);
}

TEST(KeyframeDatabaseTest, OptionsAreValidatedWithTheKeyNamed) {
  KeyframeDatabaseOptions o;
  o.grid_cols = 0;
  EXPECT_NE(o.Validate().find("grid_cols=0"), std::string::npos);
  EXPECT_THROW(KeyframeDatabase{o}, ConfigError);
  o = KeyframeDatabaseOptions();
  o.min_score = 2.0;
  EXPECT_NE(o.Validate().find("min_score=2"), std::string::npos);
}

TEST(KeyframeDatabaseTest, ConcurrentAddRemoveAndQueryAreSafe) {
  KeyframeDatabase db;
  std::vector<std::thread> threads;
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&db, t] {
      std::mt19937_64 rng(100 + t);
      for (int i = 0; i < 200; ++i) {
        const KeyframeBow kf = RandomKeyframe(&rng);
        db.Add(t * 1000 + i, kf);
        const auto res = db.Query(kf, 3);
        EXPECT_FALSE(res.empty());
        if (i % 3 == 0) db.Remove(t * 1000 + i);
      }
    });
  }
  for (auto& th : threads) th.join();
  EXPECT_EQ(db.size(), 4u * (200 - 67));
}

// --- Synthetic room loop with the default vocabulary ------------------------------------------

TEST(KeyframeDatabaseSyntheticTest, RevisitOfTheRoomLoopRetrievesAFirstPassKeyframe) {
  const PointLineVocabulary voc =
      PointLineVocabulary::LoadFolder(std::string(PL_SLAM_SOURCE_DIR) + "/vocabulary");
  sim::SequenceOptions so;  // room, 480 frames, world seed 7 (the vocabulary used others)
  const sim::SyntheticSequence seq(so);
  const StereoCamera& cam = seq.camera();
  LoopFeatureExtractor extractor(cam);
  KeyframeDatabase db;
  // First pass: a keyframe every 15 frames over the first 85 % of the loop.
  for (int i = 0; i <= 405; i += 15) {
    db.Add(i, ComputeKeyframeBow(extractor.Extract(seq.Render(i)), voc, cam.width, cam.height,
                                 db.options()));
  }
  const Trajectory& gt = seq.ground_truth();
  for (int q : {466, 472, 478}) {
    const KeyframeBow bow = ComputeKeyframeBow(extractor.Extract(seq.Render(q)), voc, cam.width,
                                               cam.height, db.options());
    const auto res = db.Query(bow, 3);
    ASSERT_FALSE(res.empty());
    const SE3 T_q_c = gt[q].T_w_c.inverse() * gt[res[0].id].T_w_c;
    std::cout << "[ info ] room query frame " << q << ": top " << res[0].id << " (score "
              << res[0].score << ", points " << res[0].point_score << ", lines "
              << res[0].line_score << "), second " << (res.size() > 1 ? res[1].id : -1) << " ("
              << (res.size() > 1 ? res[1].score : 0.0) << "); ground-truth distance "
              << T_q_c.translation().norm() << " m, " << T_q_c.RotationAngle() * 180.0 / M_PI
              << " deg\n";
    EXPECT_LE(res[0].id, 45) << "query " << q;
    EXPECT_LT(T_q_c.translation().norm(), 1.0);
    EXPECT_LT(T_q_c.RotationAngle() * 180.0 / M_PI, 30.0);
  }
}

}  // namespace
}  // namespace pl_slam
