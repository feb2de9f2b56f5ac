// The odometry chain: its propagated covariance matches the spread of sampled noisy walks and
// of gaps repeating one motion error, grows along a walk and over every lost frame, and the odom
// poses of a whole run with loop closure stay continuous while the map's poses jump.
#include "pl_slam/system/odometry.h"

#include <random>

#include <gtest/gtest.h>

#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/system/slam_system.h"
#include "test_util/system_options.h"

namespace pl_slam {
namespace {

// Position and rotation error of `est` against `truth` as OdometryChain defines them.
Vector6d PoseError(const SE3& truth, const SE3& est) {
  Vector6d e;
  e.head<3>() = truth.translation() - est.translation();
  e.tail<3>() = (truth * SE3(est.so3(), Eigen::Vector3d::Zero()).inverse())
                    .Log()
                    .tail<3>();  // R_true R_est^T
  // Log of a pure rotation: the rotation part is its axis-angle.
  return e;
}

// The spread of `samples` walks of `steps` steps about the chain's pose `T_odom_c`: each step is
// `step` perturbed on the left by noise of standard deviations `sigma`, drawn anew every step,
// or (one_error) once per walk and repeated on every step.
Matrix6d SampledCovariance(const SE3& step, const Vector6d& sigma, int steps, bool one_error,
                           const SE3& T_odom_c, unsigned seed, int samples = 4000) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  auto draw = [&]() {
    Vector6d d;
    for (int i = 0; i < 6; ++i) d(i) = sigma(i) * n(rng);
    return SE3::Exp(d) * step;
  };
  Matrix6d empirical = Matrix6d::Zero();
  for (int s = 0; s < samples; ++s) {
    SE3 T;
    const SE3 wrong = one_error ? draw() : step;
    for (int k = 0; k < steps; ++k) T = T * (one_error ? wrong : draw());
    const Vector6d e = PoseError(T, T_odom_c);
    empirical += e * e.transpose();
  }
  return empirical / samples;
}

TEST(OdometryChainTest, CovarianceMatchesTheSpreadOfNoisyWalks) {
  // A curving walk of 40 steps; each measured step has left-perturbation noise Sigma_inc.
  Vector6d step_xi;
  step_xi << 0.05, 0.01, 0.3, 0.0, 0.04, 0.01;
  const SE3 step = SE3::Exp(step_xi);
  Vector6d sigma;
  sigma << 0.004, 0.004, 0.008, 0.003, 0.003, 0.002;
  const Matrix6d inc_cov = sigma.cwiseAbs2().asDiagonal();
  OdometryChain chain;
  double previous_trace = 0.0;
  for (int k = 0; k < 40; ++k) {
    chain.Advance(step, inc_cov);
    const double trace = chain.covariance().topLeftCorner<3, 3>().trace();
    EXPECT_GT(trace, previous_trace);  // grows with every step
    previous_trace = trace;
  }
  // Monte Carlo: truth = the noise-free chain; samples perturb every step.
  const Matrix6d empirical = SampledCovariance(step, sigma, 40, false, chain.T_odom_c(), 3);
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(std::sqrt(empirical(i, i)), std::sqrt(chain.covariance()(i, i)),
                0.12 * std::sqrt(chain.covariance()(i, i)))
        << "component " << i;
  }
}

// A gap of unseen increments: the motion model's step is wrong by one error, drawn once per
// gap and repeated on every frame (the camera keeps the motion the model got wrong). The
// chain's covariance must match that spread, which grows with the gap's length: treating the
// frames' errors as independent understates it by sqrt(length). A measured increment ends the
// run, so the next gap starts adding up afresh.
TEST(OdometryChainTest, UnseenRunGrowsWithItsLength) {
  Vector6d step_xi;
  step_xi << 0.0, 0.0, 0.05, 0.0, 0.01, 0.0;  // walking forward, turning slowly
  const SE3 step = SE3::Exp(step_xi);
  Vector6d sigma;
  sigma << 0.01, 0.01, 0.02, 0.004, 0.004, 0.004;
  const Matrix6d inc_cov = sigma.cwiseAbs2().asDiagonal();
  const int gap = 30;
  OdometryChain chain, independent;
  for (int k = 0; k < gap; ++k) {
    chain.Advance(step, inc_cov, /*unseen=*/true);
    independent.Advance(step, inc_cov, /*unseen=*/false);
  }
  // The same error on every frame of the gap.
  const Matrix6d empirical = SampledCovariance(step, sigma, gap, true, chain.T_odom_c(), 5);
  for (int i = 0; i < 6; ++i) {
    const double chain_sd = std::sqrt(chain.covariance()(i, i));
    EXPECT_NEAR(std::sqrt(empirical(i, i)), chain_sd, 0.15 * chain_sd) << "component " << i;
  }
  // Independent errors would claim about sqrt(30) = 5.5 times less in the walking direction.
  EXPECT_GT(chain.covariance()(2, 2), 20.0 * independent.covariance()(2, 2));

  // A measured increment ends the run: a second gap adds as much as the first one did.
  OdometryChain twice;
  for (int k = 0; k < gap; ++k) twice.Advance(SE3(), inc_cov, true);
  const double first_gap = twice.covariance()(2, 2);
  twice.Advance(SE3(), Matrix6d::Zero(), false);
  for (int k = 0; k < gap; ++k) twice.Advance(SE3(), inc_cov, true);
  EXPECT_NEAR(twice.covariance()(2, 2), 2.0 * first_gap, 1e-9 + 1e-6 * first_gap);
}

// A long gap while turning: the summed rotation deviation stops at half a turn per axis, the
// position's goes on growing.
TEST(OdometryChainTest, UnseenRotationStopsAtHalfATurn) {
  Vector6d step_xi;
  step_xi << 0.0, 0.0, 0.05, 0.0, 0.08, 0.0;
  const Matrix6d inc_cov = (step_xi.cwiseAbs2() + Vector6d::Constant(1e-4)).asDiagonal();
  OdometryChain chain;
  double position_before = 0.0;
  for (int k = 0; k < 200; ++k) {
    chain.Advance(SE3::Exp(step_xi), inc_cov, /*unseen=*/true);
    const double position = chain.covariance().topLeftCorner<3, 3>().trace();
    EXPECT_GT(position, position_before) << "frame " << k;
    position_before = position;
  }
  // 200 frames of 4.6 deg would sum to over 900 deg.
  const double rotation = chain.covariance().bottomRightCorner<3, 3>().trace();
  EXPECT_LE(rotation, 3.0 * M_PI * M_PI * 1.0001);
  EXPECT_GE(rotation, 0.99 * M_PI * M_PI);
}

TEST(OdometryChainTest, ResetAndSetCovariance) {
  OdometryChain chain;
  chain.Advance(SE3::Exp(Vector6d::Constant(0.1)), Matrix6d::Identity() * 1e-4);
  EXPECT_GT(chain.covariance()(0, 0), 1e-5);
  Matrix6d bad = Matrix6d::Identity();
  bad(0, 0) = std::nan("");
  chain.SetCovariance(bad);  // ignored
  EXPECT_GT(chain.covariance()(0, 0), 1e-5);
  chain.SetCovariance(Matrix6d::Identity() * 1e-8);
  EXPECT_NEAR(chain.covariance()(0, 0), 1e-8, 1e-12);
  chain.Reset();
  EXPECT_LT(chain.T_odom_c().translation().norm(), 1e-15);
  EXPECT_LT(chain.covariance()(0, 0), 1e-9);
}

// Blank frames in the middle of a walk, more than the motion model covers: the odometry's
// uncertainty grows on every lost frame, also once the pose only stays where it was (the
// camera goes on moving unseen), so the pose tracking resumes from is not over-trusted.
TEST(OdometryChainTest, CovarianceGrowsOnEveryLostFrame) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  const sim::SyntheticSequence seq(so);
  SystemOptions options = testing_util::SequentialWithVocabulary();
  const int gap_begin = 12, gap_end = gap_begin + 2 * options.tracker.max_predicted_frames + 5;
  SlamSystem sys(seq.camera(), options);
  double before_gap = 0.0, previous = 0.0;
  int unpredicted = 0;
  for (int i = 0; i < gap_end; ++i) {
    StereoFrame frame = seq.Render(i);
    if (i >= gap_begin) frame.left = frame.right = cv::Mat(frame.left.size(), CV_8UC1, 128);
    const FrameResult r = sys.Process(frame);
    const double trace = r.odom_covariance.topLeftCorner<3, 3>().trace();
    if (i < gap_begin) {
      ASSERT_TRUE(r.pose_valid) << "frame " << i;
      before_gap = trace;
    } else {
      ASSERT_EQ(r.state, TrackingState::kLost) << "frame " << i;
      EXPECT_GT(trace, previous) << "frame " << i << (r.predicted ? " (predicted)" : "");
      unpredicted += !r.predicted;
    }
    previous = trace;
  }
  // Each lost frame adds at least (1 cm)^2 per axis.
  std::cout << "position variance " << before_gap << " m^2 before the gap, " << previous
            << " after " << gap_end - gap_begin << " lost frames (" << unpredicted
            << " past the motion model)\n";
  EXPECT_GE(unpredicted, options.tracker.max_predicted_frames);
  EXPECT_GT(previous - before_gap, 3e-4 * (gap_end - gap_begin) * 0.99);
}

// The room walked once round and a little more: loop closure corrects the map. The map pose
// jumps then; the odom pose never does (REP-105), and its covariance shrinks at the loop.
TEST(OdometryChainTest, OdomStaysContinuousThroughALoopClosure) {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  const sim::SyntheticSequence seq(so);
  SlamSystem sys(seq.camera(), testing_util::SequentialWithVocabulary());
  std::vector<double> odom_steps, map_steps;
  SE3 last_odom, last_map;
  int loops = 0;
  double cov_before_loop = 0.0, cov_after_loop = 0.0;
  for (int i = 0; i < static_cast<int>(seq.size()); ++i) {
    const FrameResult r = sys.Process(seq.Render(i));
    ASSERT_TRUE(r.pose_valid) << "frame " << i;
    if (i > 0) {
      odom_steps.push_back((r.T_odom_c.translation() - last_odom.translation()).norm());
      map_steps.push_back((r.T_w_c.translation() - last_map.translation()).norm());
    }
    const double cov = r.odom_covariance.topLeftCorner<3, 3>().trace();
    if (r.loops > loops) {
      cov_after_loop = cov;
      loops = r.loops;
    } else if (loops == 0) {
      cov_before_loop = cov;
    }
    last_odom = r.T_odom_c;
    last_map = r.T_w_c;
  }
  ASSERT_GE(loops, 1);
  std::vector<double> sorted = odom_steps;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  const double odom_max = *std::max_element(odom_steps.begin(), odom_steps.end());
  const double map_max = *std::max_element(map_steps.begin(), map_steps.end());
  std::cout << "median step " << median * 1000 << " mm, largest odom step " << odom_max * 1000
            << " mm, largest map step " << map_max * 1000 << " mm; position variance "
            << cov_before_loop << " m^2 before the loop, " << cov_after_loop << " after\n";
  // The map's corrections (bundle adjustment, the loop) went into map -> odom.
  const double map_odom = (last_map * last_odom.inverse()).translation().norm();
  std::cout << "map -> odom at the end: " << map_odom * 1000 << " mm\n";
  EXPECT_GT(map_odom, 1e-4);
  EXPECT_LT(odom_max, 5.0 * median);
  EXPECT_LT(cov_after_loop, cov_before_loop);
  EXPECT_GT(cov_before_loop, 0.0);
}

}  // namespace
}  // namespace pl_slam
