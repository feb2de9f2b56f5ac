// Analytic Jacobians of the bundle-adjustment costs against central differences taken through
// the SE(3) manifold (tangent space) and the landmark coordinates. The tolerance is relative to
// the Jacobian's size, far below the error a wrong sign, a missing term or a swapped column
// gives (checked: each test also fails on a deliberately wrong Jacobian below).
#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "pl_slam/optimization/line_cost.h"
#include "pl_slam/optimization/point_cost.h"
#include "pl_slam/optimization/se3_manifold.h"

namespace pl_slam {
namespace {

StereoCamera Camera() {
  StereoCamera c;
  c.fx = 450;
  c.fy = 455;
  c.cx = 370;
  c.cy = 245;
  c.baseline = 0.11;
  c.width = 752;
  c.height = 480;
  return c;
}

SE3 RandomPose(std::mt19937* rng) {
  std::normal_distribution<double> n(0.0, 0.3);
  Vector6d xi;
  for (int i = 0; i < 6; ++i) xi(i) = n(*rng);
  return SE3::Exp(xi);
}

/// Numeric Jacobian of `cost` (tangent for block 0 = pose, coordinates for the others)
/// compared with the analytic one; returns the largest difference relative to max(1, |J|).
double JacobianError(const ceres::CostFunction& cost, std::vector<std::vector<double>> params) {
  const int m = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  std::vector<double*> ptrs;
  for (auto& p : params) ptrs.push_back(p.data());
  std::vector<std::vector<double>> J(sizes.size());
  std::vector<double*> jptrs;
  for (size_t b = 0; b < sizes.size(); ++b) {
    J[b].assign(m * sizes[b], 0.0);
    jptrs.push_back(J[b].data());
  }
  std::vector<double> r(m);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), jptrs.data()));
  SE3Manifold manifold;
  double worst = 0.0;
  const double h = 1e-6;
  for (size_t b = 0; b < sizes.size(); ++b) {
    const int dim = b == 0 ? 6 : sizes[b];
    for (int k = 0; k < dim; ++k) {
      std::vector<double> rp(m), rm(m);
      const std::vector<double> saved = params[b];
      for (int sign : {1, -1}) {
        if (b == 0) {
          double delta[6] = {0, 0, 0, 0, 0, 0};
          delta[k] = sign * h;
          manifold.Plus(saved.data(), delta, params[b].data());
        } else {
          params[b][k] += sign * h;
        }
        EXPECT_TRUE(cost.Evaluate(ptrs.data(), sign > 0 ? rp.data() : rm.data(), nullptr));
        params[b] = saved;
      }
      for (int i = 0; i < m; ++i) {
        const double numeric = (rp[i] - rm[i]) / (2 * h);
        const double analytic = J[b][i * sizes[b] + k];  // lifted: tangent in the first 6 cols
        worst = std::max(worst, std::abs(numeric - analytic) / std::max(1.0, std::abs(numeric)));
      }
    }
  }
  return worst;
}

std::vector<double> PoseParams(const SE3& T) {
  std::vector<double> p(7);
  SE3ToParams(T, p.data());
  return p;
}
std::vector<double> Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

TEST(SE3ManifoldTest, PlusMinusRoundTrip) {
  std::mt19937 rng(3);
  SE3Manifold m;
  for (int trial = 0; trial < 20; ++trial) {
    const SE3 x = RandomPose(&rng), y = RandomPose(&rng);
    double px[7], py[7], d[6], back[7];
    SE3ToParams(x, px);
    SE3ToParams(y, py);
    m.Minus(py, px, d);
    m.Plus(px, d, back);
    const SE3 yb = SE3FromParams(back);
    EXPECT_LT((yb.matrix() - y.matrix()).norm(), 1e-9);
  }
}

TEST(PointCostTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(7);
  const StereoCamera cam = Camera();
  for (int trial = 0; trial < 30; ++trial) {
    const SE3 T_c_w = RandomPose(&rng);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Eigen::Vector3d p_c(u(rng), u(rng), 2.0 + u(rng));
    const Eigen::Vector3d p_w = T_c_w.inverse() * p_c;
    const Eigen::Vector2d obs = cam.Project(p_c) + Eigen::Vector2d(1.5, -2.0);
    MonoPointCost mono(cam, obs, 0.0, 0.8);
    StereoPointCost stereo(cam, obs, obs.x() - 20.0, 0.8);
    DisparityCost disparity(cam, 20.0, 2.5);
    EXPECT_LT(JacobianError(mono, {PoseParams(T_c_w), Vec(p_w)}), 1e-5);
    EXPECT_LT(JacobianError(stereo, {PoseParams(T_c_w), Vec(p_w)}), 1e-5);
    EXPECT_LT(JacobianError(disparity, {PoseParams(T_c_w), Vec(p_w)}), 1e-5);
  }
}

TEST(LineCostTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(11);
  const StereoCamera cam = Camera();
  for (int trial = 0; trial < 30; ++trial) {
    const SE3 T_c_w = RandomPose(&rng);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    const Eigen::Vector3d P_c(u(rng), u(rng), 2.5 + u(rng)), Q_c(u(rng), u(rng), 2.5 + u(rng));
    const Eigen::Vector3d l =
        LineThrough(cam.Project(P_c) + Eigen::Vector2d(1, 2), cam.Project(Q_c));
    const Eigen::Vector3d lr =
        LineThrough(cam.ProjectRight(P_c), cam.ProjectRight(Q_c) + Eigen::Vector2d(0, 3));
    MonoLineCost mono(cam, l, l, 1.3);
    StereoLineCost stereo(cam, l, lr, 1.3);
    std::vector<double> PQ = Vec(T_c_w.inverse() * P_c);
    for (double v : Vec(T_c_w.inverse() * Q_c)) PQ.push_back(v);
    EXPECT_LT(JacobianError(mono, {PoseParams(T_c_w), PQ}), 1e-5);
    EXPECT_LT(JacobianError(stereo, {PoseParams(T_c_w), PQ}), 1e-5);
  }
}

TEST(EndpointLineCostTest, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(13);
  const StereoCamera cam = Camera();
  for (int trial = 0; trial < 30; ++trial) {
    const SE3 T_c_w = RandomPose(&rng);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Eigen::Vector3d P_c(u(rng), u(rng), 2.5 + u(rng)), Q_c(u(rng), u(rng), 2.5 + u(rng));
    const Eigen::Vector2d s = cam.Project(P_c) + Eigen::Vector2d(1, 2), e = cam.Project(Q_c);
    const Eigen::Vector2d sr = cam.ProjectRight(P_c),
                          er = cam.ProjectRight(Q_c) + Eigen::Vector2d(0, 3);
    // A third of the trials: the landmark's start point lies behind the camera (its line is
    // still in view), which the form is meant to handle.
    const Eigen::Vector3d d = P_c - Q_c;
    if (trial % 3 == 0 && std::abs(d.z()) > 0.2) P_c = Q_c - 2.0 * Q_c.z() * d / d.z();
    MonoEndpointLineCost mono(cam, s, e, s, e, 1.3);
    StereoEndpointLineCost stereo(cam, s, e, sr, er, 1.3);
    std::vector<double> PQ = Vec(T_c_w.inverse() * P_c);
    for (double v : Vec(T_c_w.inverse() * Q_c)) PQ.push_back(v);
    EXPECT_LT(JacobianError(mono, {PoseParams(T_c_w), PQ}), 1e-5) << "trial " << trial;
    EXPECT_LT(JacobianError(stereo, {PoseParams(T_c_w), PQ}), 1e-5) << "trial " << trial;
  }
}

// The observed-endpoint form measures pixel distances of the observed endpoints to the
// projected 3D line, whatever part of the line the landmark's endpoints span; the paper's form
// (LineCost) changes with that span and drops the observation once an endpoint is behind.
TEST(EndpointLineCostTest, ResidualsIgnoreWhereTheLandmarkEndsAlongItsLine) {
  const StereoCamera cam = Camera();
  const Eigen::Vector3d P_c(-0.6, 0.4, 2.0), Q_c(-0.6, 0.4, 9.0);  // a wall edge receding
  const Eigen::Vector2d s = cam.Project(Eigen::Vector3d(-0.6, 0.4, 3.0));
  const Eigen::Vector2d e = cam.Project(Eigen::Vector3d(-0.6, 0.4, 6.0));
  const Eigen::Vector2d sr = cam.ProjectRight(Eigen::Vector3d(-0.6, 0.4, 3.0));
  const Eigen::Vector2d er = cam.ProjectRight(Eigen::Vector3d(-0.6, 0.4, 6.0));
  const Eigen::Vector2d normal = Eigen::Vector2d(e - s).unitOrthogonal();
  // The observed start is 1.5 px off the line, the rest exact.
  StereoEndpointLineCost cost(cam, s + 1.5 * normal, e, sr, er, 2.0);
  const std::vector<double> pose = PoseParams(SE3());
  auto eval = [&](const ceres::CostFunction& c, const Eigen::Vector3d& P,
                  const Eigen::Vector3d& Q) {
    std::vector<double> PQ = Vec(P);
    for (double v : Vec(Q)) PQ.push_back(v);
    const double* params[] = {pose.data(), PQ.data()};
    Eigen::Vector4d r;
    EXPECT_TRUE(c.Evaluate(params, r.data(), nullptr));
    return r;
  };
  const Eigen::Vector4d r0 = eval(cost, P_c, Q_c);
  EXPECT_NEAR(std::abs(r0(0)), 3.0, 1e-6);  // 1.5 px times sqrt_info 2
  EXPECT_NEAR(r0.tail<3>().norm(), 0.0, 1e-9);
  const Eigen::Vector3d d = (Q_c - P_c).normalized();
  for (double slide : {-4.0, 0.7, 25.0}) {  // -4: the start point is 2 m behind the camera
    const Eigen::Vector4d r = eval(cost, P_c + slide * d, Q_c + 1.5 * slide * d);
    EXPECT_NEAR((r - r0).norm(), 0.0, 1e-6) << "slide " << slide;
  }
  // The paper's form: the same observation gives other residuals for another span, and none
  // once the start point is behind the camera.
  StereoLineCost paper(cam, LineThrough(s + 1.5 * normal, e), LineThrough(sr, er), 2.0);
  EXPECT_GT((eval(paper, P_c + 0.7 * d, Q_c) - eval(paper, P_c, Q_c)).norm(), 0.1);
  EXPECT_EQ(eval(paper, P_c - 4.0 * d, Q_c).norm(), 0.0);
  // Both endpoints behind the camera: no residual.
  EXPECT_EQ(eval(cost, P_c - 4.0 * d, P_c - 3.0 * d).norm(), 0.0);
}

// With the right principal point offset (doffs), the right-image residuals of the exact
// observations are zero: the costs project into the right image as the camera model does.
TEST(StereoCostsTest, RightImageResidualsFollowThePrincipalPointOffset) {
  StereoCamera cam = Camera();
  cam.doffs = 2.5;
  const Eigen::Vector3d P_c(0.3, -0.2, 2.5), Q_c(-0.4, 0.5, 3.5);
  const std::vector<double> pose = PoseParams(SE3());
  StereoPointCost point(cam, cam.Project(P_c), cam.ProjectRight(P_c).x(), 1.0);
  std::vector<double> P = Vec(P_c);
  const double* point_params[] = {pose.data(), P.data()};
  double r[4];
  ASSERT_TRUE(point.Evaluate(point_params, r, nullptr));
  EXPECT_NEAR(std::abs(r[0]) + std::abs(r[1]) + std::abs(r[2]), 0.0, 1e-9);
  StereoLineCost line(cam, LineThrough(cam.Project(P_c), cam.Project(Q_c)),
                      LineThrough(cam.ProjectRight(P_c), cam.ProjectRight(Q_c)), 1.0);
  std::vector<double> PQ = Vec(P_c);
  for (double v : Vec(Q_c)) PQ.push_back(v);
  const double* line_params[] = {pose.data(), PQ.data()};
  ASSERT_TRUE(line.Evaluate(line_params, r, nullptr));
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(r[k], 0.0, 1e-9) << "row " << k;
  StereoEndpointLineCost endpoints(cam, cam.Project(P_c), cam.Project(Q_c), cam.ProjectRight(P_c),
                                   cam.ProjectRight(Q_c), 1.0);
  ASSERT_TRUE(endpoints.Evaluate(line_params, r, nullptr));
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(r[k], 0.0, 1e-9) << "endpoint form, row " << k;
  // The same observations under a camera without the offset are 2.5 px off on the right.
  StereoPointCost plain(Camera(), cam.Project(P_c), cam.ProjectRight(P_c).x(), 1.0);
  ASSERT_TRUE(plain.Evaluate(point_params, r, nullptr));
  EXPECT_NEAR(std::abs(r[2]), 2.5, 1e-9);
  // The disparity residual measures left column minus right column, offset included, and is
  // whitened by its own information.
  const double measured = cam.Project(P_c).x() - cam.ProjectRight(P_c).x();
  DisparityCost disparity(cam, measured, 4.0);
  ASSERT_TRUE(disparity.Evaluate(point_params, r, nullptr));
  EXPECT_NEAR(r[0], 0.0, 1e-9);
  DisparityCost off(cam, measured - 0.5, 4.0);
  ASSERT_TRUE(off.Evaluate(point_params, r, nullptr));
  EXPECT_NEAR(r[0], 2.0, 1e-9);
}

// The extent gauge of a line landmark: holds the endpoints along the line only.
TEST(LineExtentCostTest, HoldsTheEndpointsAlongTheLineOnly) {
  const Eigen::Vector3d P0(0.2, -0.5, 3.0), Q0(0.4, 0.7, 3.5);
  const LineExtentCost cost(P0, Q0, 50.0);
  const Eigen::Vector3d d = (Q0 - P0).normalized();
  const Eigen::Vector3d across = d.cross(Eigen::Vector3d::UnitX()).normalized();
  auto eval = [&](const Eigen::Vector3d& P, const Eigen::Vector3d& Q, double* J = nullptr) {
    double x[6] = {P.x(), P.y(), P.z(), Q.x(), Q.y(), Q.z()};
    const double* params[1] = {x};
    double* jac[1] = {J};
    Eigen::Vector2d r;
    EXPECT_TRUE(cost.Evaluate(params, r.data(), J ? jac : nullptr));
    return r;
  };
  EXPECT_LT(eval(P0, Q0).norm(), 1e-12);
  EXPECT_LT(eval(P0 + 0.1 * across, Q0 - 0.2 * across).norm(), 1e-12);  // across: free
  EXPECT_NEAR(eval(P0 + 0.02 * d, Q0).x(), 1.0, 1e-9);                  // 2 cm along: 1
  EXPECT_NEAR(eval(P0, Q0 - 0.04 * d).y(), -2.0, 1e-9);
  // Analytic Jacobian against central differences at a random point.
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.3);
  const Eigen::Vector3d P = P0 + Eigen::Vector3d(n(rng), n(rng), n(rng));
  const Eigen::Vector3d Q = Q0 + Eigen::Vector3d(n(rng), n(rng), n(rng));
  double J[12];
  eval(P, Q, J);
  const double h = 1e-6;
  double worst = 0.0;
  for (int k = 0; k < 6; ++k) {
    Eigen::Matrix<double, 6, 1> x;
    x << P, Q;
    Eigen::Matrix<double, 6, 1> xp = x, xm = x;
    xp(k) += h;
    xm(k) -= h;
    const Eigen::Vector2d num =
        (eval(xp.head<3>(), xp.tail<3>()) - eval(xm.head<3>(), xm.tail<3>())) / (2 * h);
    for (int i = 0; i < 2; ++i) worst = std::max(worst, std::abs(num(i) - J[i * 6 + k]));
  }
  EXPECT_LT(worst, 1e-6);
  // Degenerate reference: no residual, no Jacobian, nothing non-finite.
  const LineExtentCost degenerate(P0, P0, 50.0);
  double x[6] = {1, 2, 3, 4, 5, 6};
  const double* params[1] = {x};
  double* jac[1] = {J};
  double r[2];
  EXPECT_TRUE(degenerate.Evaluate(params, r, jac));
  EXPECT_EQ(r[0], 0.0);
  EXPECT_EQ(r[1], 0.0);
  for (double v : J) EXPECT_EQ(v, 0.0);
}

// The check itself must be able to fail: a cost whose pose Jacobian has a flipped rotation
// block is rejected by the same comparison.
class WrongPointCost final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  explicit WrongPointCost(const StereoCamera& cam, const Eigen::Vector2d& uv)
      : inner_(cam, uv, 0.0, 1.0) {}
  bool Evaluate(double const* const* p, double* r, double** J) const override {
    if (!inner_.Evaluate(p, r, J)) return false;
    if (J && J[0])
      for (int i = 0; i < 2; ++i)
        for (int k = 3; k < 6; ++k) J[0][i * 7 + k] = -J[0][i * 7 + k];
    return true;
  }

 private:
  MonoPointCost inner_;
};

TEST(PointCostTest, ComparisonDetectsAWrongJacobian) {
  const StereoCamera cam = Camera();
  std::mt19937 rng(5);
  const SE3 T_c_w = RandomPose(&rng);
  const Eigen::Vector3d p_c(0.3, -0.2, 2.0);
  WrongPointCost wrong(cam, cam.Project(p_c));
  EXPECT_GT(JacobianError(wrong, {PoseParams(T_c_w), Vec(T_c_w.inverse() * p_c)}), 1e-2);
}

TEST(PointCostTest, BehindTheCameraGivesZeroResidual) {
  const StereoCamera cam = Camera();
  MonoPointCost cost(cam, Eigen::Vector2d(100, 100), 0.0, 1.0);
  const std::vector<double> pose = PoseParams(SE3());
  const std::vector<double> p = {0.0, 0.0, -1.0};
  const double* params[2] = {pose.data(), p.data()};
  double r[2] = {1, 1}, j0[14], j1[6];
  double* J[2] = {j0, j1};
  ASSERT_TRUE(cost.Evaluate(params, r, J));
  EXPECT_EQ(r[0], 0.0);
  EXPECT_EQ(r[1], 0.0);
  for (double v : j0) EXPECT_EQ(v, 0.0);
}

}  // namespace
}  // namespace pl_slam
