// Geometry of the synthetic renderer: known 3D points land where the stereo camera model
// predicts (both images, disparity fx * b / Z), nearer surfaces hide farther ones, depth maps
// agree with an independent ray cast, and rendering is bit-reproducible.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "pl_slam/sim/scenes.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::shared_ptr<const Texture> UniformTexture(float grey, int size = 64) {
  return std::make_shared<const Texture>(cv::Mat(size, size, CV_32F, cv::Scalar(grey)));
}

// A texture of `size` x `size` texels on a dark background with Gaussian blobs of std
// sigma_texels centred at the given continuous texel coordinates (texel i covers [i, i+1)).
std::shared_ptr<const Texture> BlobTexture(int size, const std::vector<cv::Point2d>& centres,
                                           double sigma_texels, float background, float peak) {
  cv::Mat img(size, size, CV_32F, cv::Scalar(background));
  for (int r = 0; r < size; ++r) {
    for (int c = 0; c < size; ++c) {
      for (const cv::Point2d& p : centres) {
        const double dx = c + 0.5 - p.x, dy = r + 0.5 - p.y;
        img.at<float>(r, c) += static_cast<float>(
            peak * std::exp(-(dx * dx + dy * dy) / (2 * sigma_texels * sigma_texels)));
      }
    }
  }
  return std::make_shared<const Texture>(img);
}

// Intensity-weighted centroid of (image - background) in a window around `guess`.
Eigen::Vector2d Centroid(const cv::Mat& image, const Eigen::Vector2d& guess, int radius,
                         double background) {
  double sw = 0, su = 0, sv = 0;
  const int u0 = static_cast<int>(std::round(guess.x()));
  const int v0 = static_cast<int>(std::round(guess.y()));
  for (int v = v0 - radius; v <= v0 + radius; ++v) {
    for (int u = u0 - radius; u <= u0 + radius; ++u) {
      if (u < 0 || v < 0 || u >= image.cols || v >= image.rows) continue;
      const double value = image.depth() == CV_8U ? image.at<uint8_t>(v, u) : image.at<float>(v, u);
      const double w = std::max(0.0, value - background);
      sw += w;
      su += w * u;
      sv += w * v;
    }
  }
  EXPECT_GT(sw, 0.0) << "no blob near " << guess.transpose();
  return {su / sw, sv / sw};
}

SequenceOptions QuietOptions() {
  SequenceOptions o;
  o.noise_sigma = 0.0;
  return o;
}

Trajectory SinglePose(const SE3& T_w_c) {
  Trajectory traj(1);
  traj[0].t = 0.0;
  traj[0].T_w_c = T_w_c;
  return traj;
}

struct BlobCase {
  const char* name;
  SE3 T_w_c;  // camera pose
  SE3 T_w_q;  // quad frame: quad spans x, y in [-0.3, 0.3] at z = 0 of this frame
};

class BlobProjectionTest : public ::testing::TestWithParam<int> {};

// A plane carrying Gaussian blobs at known texel positions: each blob's intensity centroid
// must be where StereoCamera::Project / ProjectRight put the corresponding 3D point, for a
// fronto-parallel plane, a slanted one and a general camera pose.
TEST_P(BlobProjectionTest, BlobsLandOnPredictedPixels) {
  const Eigen::Matrix3d R_tilt =
      Eigen::AngleAxisd(35 * kPi / 180, Eigen::Vector3d::UnitY()).toRotationMatrix() *
      Eigen::AngleAxisd(-20 * kPi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const SE3 T_general = CameraPoseFromYawPitchRoll({0.3, -0.2, 1.1}, 0.4, 0.15, -0.1);
  // Points 2.6 m in front of the general camera, plane slanted.
  const SE3 T_general_q =
      T_general *
      SE3(Eigen::Matrix3d(Eigen::AngleAxisd(0.5, Eigen::Vector3d(1, 2, 0.5).normalized())),
          Eigen::Vector3d(0.1, -0.05, 2.6));
  const BlobCase cases[] = {
      {"fronto_parallel", SE3(),
       SE3(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.05, 0.02, 2.5))},
      {"slanted", SE3(), SE3(R_tilt, Eigen::Vector3d(-0.1, 0.05, 2.2))},
      {"general_pose", T_general, T_general_q},
  };
  const BlobCase& bc = cases[GetParam()];
  SCOPED_TRACE(bc.name);

  const int size = 300;        // texels
  const double texel = 0.002;  // metres: the quad is 0.6 m wide
  std::vector<cv::Point2d> centres;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) centres.emplace_back(60.3 + 90.0 * i, 55.7 + 93.0 * j);
  }
  const float background = 30.0f;
  auto world = std::make_shared<World>();
  const Eigen::Matrix3d R = bc.T_w_q.rotation();
  const Eigen::Vector3d corner = bc.T_w_q * Eigen::Vector3d(-0.3, -0.3, 0.0);
  world->AddQuad(MakeQuad(corner, R.col(0) * size * texel, R.col(1) * size * texel,
                          BlobTexture(size, centres, 5.0, background, 200.0f)));

  SyntheticSequence seq(QuietOptions(), world, SinglePose(bc.T_w_c));
  const StereoCamera& cam = seq.camera();
  const StereoFrame frame = seq.Render(0);
  ASSERT_EQ(frame.left.type(), CV_8UC1);
  ASSERT_EQ(frame.right.type(), CV_8UC1);
  const TexturedQuad& quad = seq.world().quads()[0];
  const SE3 T_c_w = bc.T_w_c.inverse();
  for (const cv::Point2d& c : centres) {
    const Eigen::Vector3d p_c = T_c_w * quad.PointAtTexel(c.x, c.y);
    ASSERT_GT(p_c.z(), 1.0);
    const Eigen::Vector2d left_px = cam.Project(p_c);
    const Eigen::Vector2d right_px = cam.ProjectRight(p_c);
    ASSERT_TRUE(cam.InImage(left_px, 10) && cam.InImage(right_px, 10));
    const Eigen::Vector2d left_c = Centroid(frame.left, left_px, 9, background + 3);
    const Eigen::Vector2d right_c = Centroid(frame.right, right_px, 9, background + 3);
    EXPECT_LT((left_c - left_px).norm(), 0.15)
        << "left blob " << left_c.transpose() << " predicted " << left_px.transpose();
    EXPECT_LT((right_c - right_px).norm(), 0.15)
        << "right blob " << right_c.transpose() << " predicted " << right_px.transpose();
    // Rectified pair: same row, disparity fx * b / Z.
    EXPECT_NEAR(left_c.y(), right_c.y(), 0.2);
    EXPECT_NEAR(left_c.x() - right_c.x(), cam.DisparityFromDepth(p_c.z()), 0.15);
  }
}

INSTANTIATE_TEST_SUITE_P(Cases, BlobProjectionTest, ::testing::Values(0, 1, 2));

// Two planes: the nearer one must win wherever it covers the pixel, whatever the order of
// insertion, in the radiance, the depth map and the right image (shifted by its own
// disparity, larger than the far plane's).
TEST(RendererTest, NearerPlaneOccludesFartherOne) {
  for (bool near_first : {false, true}) {
    SCOPED_TRACE(near_first ? "near quad added first" : "far quad added first");
    auto world = std::make_shared<World>();
    auto add_far = [&] {
      world->AddQuad(MakeQuad({-4, -3, 5.0}, {8, 0, 0}, {0, 6, 0}, UniformTexture(50)));
    };
    auto add_near = [&] {
      world->AddQuad(MakeQuad({-0.2, -0.2, 2.0}, {0.4, 0, 0}, {0, 0.4, 0}, UniformTexture(200)));
    };
    if (near_first) {
      add_near();
      add_far();
    } else {
      add_far();
      add_near();
    }
    SyntheticSequence seq(QuietOptions(), world, SinglePose(SE3()));
    const StereoCamera& cam = seq.camera();
    const RenderedView left = seq.RenderGroundTruth(0);
    const RenderedView right = seq.RenderGroundTruth(0, true);
    const int cu = static_cast<int>(cam.cx), cv_ = static_cast<int>(cam.cy);
    EXPECT_NEAR(left.radiance.at<float>(cv_, cu), 200.0f, 0.5f);
    EXPECT_NEAR(left.depth.at<float>(cv_, cu), 2.0f, 1e-4f);
    EXPECT_NEAR(left.radiance.at<float>(cv_, cu + 150), 50.0f, 0.5f);
    EXPECT_NEAR(left.depth.at<float>(cv_, cu + 150), 5.0f, 1e-4f);

    // Left edge of the near square (x = -0.2 m at Z = 2) in each image.
    const double edge_left = cam.Project({-0.2, 0.0, 2.0}).x();
    const double edge_right = cam.ProjectRight({-0.2, 0.0, 2.0}).x();
    EXPECT_NEAR(edge_left - edge_right, cam.fx * cam.baseline / 2.0, 1e-9);
    for (const auto& [view, edge] :
         {std::make_pair(&left, edge_left), std::make_pair(&right, edge_right)}) {
      const int inside = static_cast<int>(std::ceil(edge)) + 2;
      const int outside = static_cast<int>(std::floor(edge)) - 2;
      EXPECT_NEAR(view->radiance.at<float>(cv_, inside), 200.0f, 0.5f) << "u=" << inside;
      EXPECT_NEAR(view->radiance.at<float>(cv_, outside), 50.0f, 0.5f) << "u=" << outside;
      EXPECT_EQ(view->quad_id.at<int>(cv_, inside), near_first ? 0 : 1);
    }
    // The anti-aliased edge pixel lies between the two grey levels in proportion to coverage.
    const int edge_px = static_cast<int>(std::round(edge_left));
    const double coverage = std::clamp(edge_px + 0.5 - edge_left, 0.0, 1.0);
    EXPECT_NEAR(left.radiance.at<float>(cv_, edge_px), 50 + 150 * coverage, 150 * 0.15);
  }
}

// The renderer's depth map and visible-quad map agree with World::RayCast, an independent
// implementation of the same geometry, on a real scene frame; and the depth is Z.
TEST(RendererTest, DepthMatchesIndependentRayCast) {
  SequenceOptions o;
  o.scene = SceneKind::kRoom;
  o.num_frames = 40;
  SyntheticSequence seq(o);
  const StereoCamera& cam = seq.camera();
  for (int index : {0, 25}) {
    const RenderedView view = seq.RenderGroundTruth(index);
    const SE3& T_w_c = seq.ground_truth()[index].T_w_c;
    cv::RNG rng(index + 1);
    int checked = 0;
    for (int k = 0; k < 300; ++k) {
      const int u = rng.uniform(0, cam.width), v = rng.uniform(0, cam.height);
      const Eigen::Vector3d d_c((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1.0);
      const RayHit hit = seq.world().RayCast(T_w_c.translation(), T_w_c.rotation() * d_c);
      ASSERT_TRUE(hit.hit) << "the room is closed: every ray hits";
      const float depth = view.depth.at<float>(v, u);
      EXPECT_NEAR(depth, hit.lambda, 1e-4 * hit.lambda) << "pixel " << u << "," << v;
      EXPECT_NEAR((T_w_c.inverse() * hit.point_w).z(), hit.lambda, 1e-9);
      if (view.quad_id.at<int>(v, u) == hit.quad) ++checked;
    }
    EXPECT_GE(checked, 297);  // ties at shared edges may pick either quad
  }
}

// Stereo consistency on a textured scene: the right image sampled at (u - fx b / Z, v) looks
// like the left image at (u, v) wherever the point is visible in both, and much more so than
// two pixels off; and the right depth map agrees with the left one there.
TEST(RendererTest, RightImageIsLeftImageShiftedByDisparity) {
  SequenceOptions o;
  o.scene = SceneKind::kRoom;
  o.num_frames = 40;
  SyntheticSequence seq(o);
  const StereoCamera& cam = seq.camera();
  for (int index : {10, 30}) {
    SCOPED_TRACE(index);
    const RenderedView left = seq.RenderGroundTruth(index);
    const RenderedView right = seq.RenderGroundTruth(index, true);
    auto right_at = [&](double x, int v) {
      const int r0 = static_cast<int>(std::floor(x));
      const double a = x - r0;
      return (1 - a) * right.radiance.at<float>(v, r0) + a * right.radiance.at<float>(v, r0 + 1);
    };
    double diff = 0.0, diff_off = 0.0, mean_disparity = 0.0;
    int n = 0, visible = 0;
    for (int v = 20; v < cam.height - 20; v += 5) {
      for (int u = 60; u < cam.width - 20; u += 5) {
        const double z = left.depth.at<float>(v, u);
        const Eigen::Vector3d p = cam.BackProject(u, v, cam.DisparityFromDepth(z));
        const Eigen::Vector2d r = cam.ProjectRight(p);
        if (r.x() < 4 || r.x() >= cam.width - 5) continue;
        ++n;
        // Points occluded in the right view have another depth there; they must be rare.
        const int ru = static_cast<int>(std::round(r.x()));
        if (std::abs(right.depth.at<float>(v, ru) - z) > 0.01 * z) continue;
        ++visible;
        const double l = left.radiance.at<float>(v, u);
        diff += std::abs(right_at(r.x(), v) - l);
        diff_off += std::abs(right_at(r.x() + 2.0, v) - l);
        mean_disparity += cam.DisparityFromDepth(z);
      }
    }
    ASSERT_GT(n, 5000);
    EXPECT_GT(visible, 0.9 * n) << "right depth disagrees with the left depth";
    mean_disparity /= visible;
    diff /= visible;
    diff_off /= visible;
    EXPECT_GT(mean_disparity, 8.0);  // the test is meaningful only with real disparities
    EXPECT_LT(diff, 2.5);
    EXPECT_LT(diff, 0.3 * diff_off) << "texture too flat for the comparison to mean anything";
  }
}

TEST(RendererTest, RenderingIsDeterministic) {
  SequenceOptions o;
  o.scene = SceneKind::kRoom;
  o.num_frames = 20;
  SyntheticSequence a(o);
  SyntheticSequence b(o);
  const StereoFrame a1 = a.Render(7);
  const StereoFrame a2 = a.Render(7);
  const StereoFrame b1 = b.Render(7);
  EXPECT_EQ(cv::norm(a1.left, a2.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a1.right, a2.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a1.left, b1.left, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a1.right, b1.right, cv::NORM_INF), 0.0);
  EXPECT_EQ(a1.stamp_ns, b1.stamp_ns);

  // Next() yields the same frames as Render().
  StereoFrame n;
  for (int i = 0; i <= 7; ++i) ASSERT_TRUE(a.Next(&n));
  EXPECT_EQ(n.index, 7);
  EXPECT_EQ(cv::norm(n.left, a1.left, cv::NORM_INF), 0.0);

  // Another noise seed changes the noise only.
  SequenceOptions o2 = o;
  o2.seed = 2;
  SyntheticSequence c(o2);
  const StereoFrame c1 = c.Render(7);
  EXPECT_GT(cv::norm(a1.left, c1.left, cv::NORM_L1), 0.5 * a1.left.total());
  EXPECT_LT(cv::norm(a1.left, c1.left, cv::NORM_INF), 30.0);
  // Left and right noise are independent streams.
  const RenderedView gl = a.RenderGroundTruth(7);
  EXPECT_EQ(cv::norm(gl.radiance, c.RenderGroundTruth(7).radiance, cv::NORM_INF), 0.0);

  // Another world seed changes the world.
  SequenceOptions o3 = o;
  o3.world_seed = 8;
  SyntheticSequence d(o3);
  EXPECT_GT(cv::norm(a1.left, d.Render(7).left, cv::NORM_L1), 10.0 * a1.left.total());
}

// Noise has the configured standard deviation and is independent between the two cameras.
TEST(RendererTest, NoiseHasConfiguredSigma) {
  auto world = std::make_shared<World>();
  world->AddQuad(MakeQuad({-10, -10, 3.0}, {20, 0, 0}, {0, 20, 0}, UniformTexture(100)));
  SequenceOptions o;
  o.noise_sigma = 3.0;
  SyntheticSequence seq(o, world, SinglePose(SE3()));
  const StereoFrame f = seq.Render(0);
  cv::Mat l, r;
  f.left.convertTo(l, CV_64F);
  f.right.convertTo(r, CV_64F);
  cv::Scalar mean, sd;
  cv::meanStdDev(l, mean, sd);
  EXPECT_NEAR(mean[0], 100.0, 0.1);
  EXPECT_NEAR(sd[0], std::sqrt(9.0 + 1.0 / 12.0), 0.1);  // plus rounding to integers
  const cv::Mat diff = l - r;
  cv::meanStdDev(diff, mean, sd);
  EXPECT_NEAR(sd[0], std::sqrt(2.0) * 3.0, 0.15);  // independent streams
}

// With exposure change on, frames follow grey = gain * radiance + offset.
TEST(RendererTest, ExposureChangeAppliesGainAndOffset) {
  auto world = std::make_shared<World>();
  world->AddQuad(MakeQuad({-10, -10, 3.0}, {20, 0, 0}, {0, 20, 0}, UniformTexture(120)));
  Trajectory traj;
  for (int i = 0; i < 100; ++i) {
    StampedPose sp;
    sp.t = i * 0.05;
    traj.push_back(sp);
  }
  SequenceOptions o = QuietOptions();
  o.exposure_change = true;
  SyntheticSequence seq(o, world, traj);
  double lo = 1e9, hi = -1e9;
  for (int i = 0; i < 100; i += 9) {
    const Exposure e = seq.ExposureAt(i);
    const double expected = std::clamp(std::round(e.gain * 120 + e.offset), 0.0, 255.0);
    const StereoFrame f = seq.Render(i);
    EXPECT_NEAR(cv::mean(f.left)[0], expected, 0.01) << "frame " << i;
    EXPECT_NEAR(cv::mean(f.right)[0], expected, 0.01) << "frame " << i;
    lo = std::min(lo, expected);
    hi = std::max(hi, expected);
  }
  EXPECT_GT(hi - lo, 40.0);  // the brightness really varies
  o.exposure_change = false;
  SyntheticSequence still(o, world, traj);
  EXPECT_EQ(still.ExposureAt(50).gain, 1.0);
  EXPECT_NEAR(cv::mean(still.Render(50).left)[0], 120.0, 0.01);
}

TEST(RendererTest, RayMissingEverythingSeesBackground) {
  auto world = std::make_shared<World>();
  world->set_background(17.0f);
  world->AddQuad(MakeQuad({-1, -1, -3.0}, {2, 0, 0}, {0, 2, 0}, UniformTexture(200)));  // behind
  SyntheticSequence seq(QuietOptions(), world, SinglePose(SE3()));
  const RenderedView v = seq.RenderGroundTruth(0);
  EXPECT_EQ(cv::countNonZero(v.depth), 0);
  EXPECT_NEAR(cv::mean(v.radiance)[0], 17.0, 1e-6);
}

}  // namespace
}  // namespace pl_slam::sim
