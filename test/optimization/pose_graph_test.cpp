// Pose-graph optimisation (loop correction) on a ring of keyframes with known truth: chained
// odometry with a small bias drifts, one loop edge with the true relative pose must pull the
// ring back, fixed nodes must stay put; bad edges are skipped and bad options refused.
#include <gtest/gtest.h>

#include <cmath>

#include "pl_slam/optimization/pose_graph.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

using Poses = std::vector<SE3, Eigen::aligned_allocator<SE3>>;
using Edges = std::vector<PoseGraphEdge, Eigen::aligned_allocator<PoseGraphEdge>>;

/// 40 camera poses on a circle of radius 2 m, each turned 9 degrees from the previous one.
Poses Ring() {
  Poses truth;
  for (int k = 0; k < 40; ++k) {
    const double a = 2.0 * M_PI * k / 40.0;
    const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.0, a, 0.0));
    truth.emplace_back(
        R, Eigen::Vector3d(2.0 * std::sin(a), 0.1 * std::sin(3.0 * a), 2.0 * std::cos(a)));
  }
  return truth;
}

double MaxPositionError(const Poses& a, const Poses& b) {
  double e = 0.0;
  for (size_t k = 0; k < a.size(); ++k)
    e = std::max(e, (a[k].translation() - b[k].translation()).norm());
  return e;
}

/// Odometry edges k -> k+1 with a bias (0.3 deg of yaw and 1 cm forward per step), the poses
/// chained from them (the drifted estimate) and one loop edge 39 -> 0 with the true value.
void DriftedGraph(const Poses& truth, Poses* estimate, Edges* edges) {
  Vector6d bias;
  bias << 0.0, 0.0, 0.01, 0.0, 0.3 * M_PI / 180.0, 0.0;
  const SE3 B = SE3::Exp(bias);
  estimate->assign(1, truth[0]);
  edges->clear();
  for (size_t k = 0; k + 1 < truth.size(); ++k) {
    PoseGraphEdge e;
    e.i = static_cast<int>(k);
    e.j = static_cast<int>(k + 1);
    e.T_i_j = truth[k].inverse() * truth[k + 1] * B;
    edges->push_back(e);
    estimate->push_back(estimate->back() * e.T_i_j);
  }
  PoseGraphEdge loop;
  loop.i = static_cast<int>(truth.size()) - 1;
  loop.j = 0;
  loop.T_i_j = truth.back().inverse() * truth[0];
  loop.is_loop = true;
  edges->push_back(loop);
}

TEST(PoseGraphTest, LoopEdgePullsTheDriftedRingBack) {
  const Poses truth = Ring();
  Poses poses;
  Edges edges;
  DriftedGraph(truth, &poses, &edges);
  const double before = MaxPositionError(poses, truth);
  std::vector<char> fixed(poses.size(), 0);
  fixed[0] = 1;
  const PoseGraphSummary s = OptimizePoseGraph(edges, fixed, PoseGraphOptions(), &poses);
  ASSERT_TRUE(s.success) << s.message;
  const double after = MaxPositionError(poses, truth);
  std::cout << "ring: largest position error " << before * 100 << " cm drifted, " << after * 100
            << " cm after the optimisation (cost " << s.initial_cost << " -> " << s.final_cost
            << ")\n";
  EXPECT_GT(before, 0.3);  // the bias has a visible effect
  // Every odometry edge carries the same bias, so no pose graph recovers the truth: the
  // optimum is a ring of longer edges (larger radius) with the 12 deg of excess turn spread
  // evenly over the 41 edges, the loop edge included. The largest position error falls to
  // ~0.29 of the drift, and the loop edge holds to about its share of the turn.
  EXPECT_LT(after, 0.35 * before);
  const SE3 loop_error = edges.back().T_i_j.inverse() * poses[39].inverse() * poses[0];
  std::cout << "loop edge error after: " << loop_error.translation().norm() * 100 << " cm, "
            << loop_error.RotationAngle() * 180.0 / M_PI << " deg\n";
  EXPECT_LT(loop_error.translation().norm(), 0.02);
  EXPECT_LT(loop_error.RotationAngle() * 180.0 / M_PI, 0.6);
  EXPECT_LT(s.final_cost, 0.05 * s.initial_cost);
  // The fixed node has not moved.
  EXPECT_LT((poses[0].translation() - truth[0].translation()).norm(), 1e-12);
  EXPECT_LT(
      (poses[0].rotation() * truth[0].rotation().transpose() - Eigen::Matrix3d::Identity()).norm(),
      1e-12);
}

TEST(PoseGraphTest, ConsistentGraphStaysWhereItIs) {
  const Poses truth = Ring();
  Edges edges;
  for (size_t k = 0; k + 1 < truth.size(); ++k) {
    PoseGraphEdge e;
    e.i = static_cast<int>(k);
    e.j = static_cast<int>(k + 1);
    e.T_i_j = truth[k].inverse() * truth[k + 1];
    edges.push_back(e);
  }
  Poses poses = truth;
  const PoseGraphSummary s = OptimizePoseGraph(edges, {}, PoseGraphOptions(), &poses);
  ASSERT_TRUE(s.success) << s.message;
  EXPECT_LT(MaxPositionError(poses, truth), 1e-9);
}

TEST(PoseGraphTest, BadEdgesAreSkippedAndBadOptionsThrowNamingTheKey) {
  const Poses truth = Ring();
  Poses poses;
  Edges edges;
  DriftedGraph(truth, &poses, &edges);
  Edges bad = edges;
  PoseGraphEdge e = edges[3];
  e.j = static_cast<int>(poses.size());  // no such node
  bad.push_back(e);
  e = edges[4];
  e.weight = std::nan("");
  bad.push_back(e);
  Poses a = poses, b = poses;
  const PoseGraphSummary sa = OptimizePoseGraph(edges, {}, PoseGraphOptions(), &a);
  const PoseGraphSummary sb = OptimizePoseGraph(bad, {}, PoseGraphOptions(), &b);
  ASSERT_TRUE(sa.success && sb.success) << sa.message << " / " << sb.message;
  EXPECT_LT(MaxPositionError(a, b), 1e-9);  // the same solution as without the bad edges
  Poses none;
  EXPECT_FALSE(OptimizePoseGraph(edges, {}, PoseGraphOptions(), &none).success);
  PoseGraphOptions options;
  options.max_iterations = 0;
  try {
    OptimizePoseGraph(edges, {}, options, &poses);
    ADD_FAILURE() << "max_iterations=0 accepted";
  } catch (const ConfigError& err) {
    std::cout << err.what() << "\n";
    EXPECT_NE(std::string(err.what()).find("pose_graph.max_iterations"), std::string::npos);
  }
}

}  // namespace
}  // namespace pl_slam
