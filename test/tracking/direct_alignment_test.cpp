// Direct alignment on rendered low-texture frames: the motion between two frames of a dim, bare
// corridor is recovered from a prediction centimetres and a degree off; a view without
// structure or with edges in one direction only, and bad images, are refused; clipped
// highlights do not hide the image noise.
#include <cmath>
#include <iostream>

#include <gtest/gtest.h>

#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/tracking/direct_alignment.h"
#include "pl_slam/util/error.h"

#include <opencv2/imgproc.hpp>

namespace pl_slam {
namespace {

constexpr double kMaxDisparity = 200.0;

sim::SequenceOptions DimBareCorner() {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kLowtexCorner;
  so.bare = true;
  so.exposure_gain = 0.45;
  return so;
}

// The image with Gaussian noise of 2 grey levels.
cv::Mat WithNoise(const cv::Mat& image, cv::RNG* rng) {
  cv::Mat noise(image.size(), CV_32F), out;
  rng->fill(noise, cv::RNG::NORMAL, 0.0, 2.0);
  image.convertTo(out, CV_32F);
  out += noise;
  out.convertTo(out, CV_8U);
  return out;
}

// Error of `est` against the true T_cur_ref: translation (m), rotation (deg).
std::pair<double, double> Error(const SE3& est, const SE3& truth) {
  const SE3 e = est * truth.inverse();
  return {e.translation().norm(), e.RotationAngle() * 180.0 / M_PI};
}

TEST(DirectAlignment, RecoversTheMotionOfADimBareCorridorFromAPoorPrediction) {
  const sim::SyntheticSequence seq(DimBareCorner());
  const DirectAlignmentOptions options;
  int checked = 0;
  for (int ref_index : {40, 120, 160, 200}) {
    const int cur_index = ref_index + 2;
    const StereoFrame ref = seq.Render(ref_index);
    const StereoFrame cur = seq.Render(cur_index);
    const SE3 truth = seq.ground_truth()[cur_index].T_w_c.inverse() *
                      seq.ground_truth()[ref_index].T_w_c;  // T_cur_ref
    Vector6d off;
    off << 0.02, -0.01, 0.015, 0.01, -0.015, 0.005;  // 2.6 cm, 1.1 deg
    const SE3 prior = SE3::Exp(off) * truth;
    const DirectReference r =
        BuildDirectReference(seq.camera(), ref.left, ref.right, kMaxDisparity, options);
    ASSERT_GE(static_cast<int>(r.points.size()), options.min_pixels) << "frame " << ref_index;
    const DirectAlignmentResult a = AlignDirect(seq.camera(), r, cur.left, prior, options);
    ASSERT_TRUE(a.success) << "frame " << ref_index << ": " << a.failure;
    const auto [et, er] = Error(a.T_cur_ref, truth);
    const auto [pt, pr] = Error(prior, truth);
    EXPECT_LT(et, 0.006) << "frame " << ref_index << " (prior " << pt << " m)";
    EXPECT_LT(er, 0.25) << "frame " << ref_index << " (prior " << pr << " deg)";
    ++checked;
  }
  EXPECT_EQ(checked, 4);
}

TEST(DirectAlignment, AViewWithoutStructureGivesNoEstimate) {
  const sim::SyntheticSequence seq(DimBareCorner());
  const cv::Mat flat(seq.camera().height, seq.camera().width, CV_8UC1, cv::Scalar(90));
  cv::RNG rng(3);
  const cv::Mat left = WithNoise(flat, &rng), right = left.clone();
  const DirectAlignmentOptions options;
  const DirectReference r = BuildDirectReference(seq.camera(), left, right, kMaxDisparity, options);
  const DirectAlignmentResult a = AlignDirect(seq.camera(), r, left, SE3(), options);
  EXPECT_FALSE(a.success);
  EXPECT_FALSE(a.failure.empty());
}

// Vertical bars on a wall facing the camera: the image fixes neither the vertical motion nor
// the pitch, and no estimate is given.
TEST(DirectAlignment, EdgesInOneDirectionGiveNoEstimate) {
  const sim::SyntheticSequence seq(DimBareCorner());
  const StereoCamera& cam = seq.camera();
  const double depth = 3.0;
  const int disparity = static_cast<int>(std::lround(cam.fx * cam.baseline / depth));
  cv::RNG rng(7);
  auto bars = [&](int shift) {
    cv::Mat img(cam.height, cam.width, CV_8UC1, cv::Scalar(90));
    for (int x0 = 100; x0 + 20 < cam.width; x0 += 90)
      cv::rectangle(img, cv::Rect(x0 - shift, 0, 20, cam.height), cv::Scalar(140), cv::FILLED);
    cv::GaussianBlur(img, img, cv::Size(5, 5), 1.0);
    return WithNoise(img, &rng);
  };
  const cv::Mat left = bars(0), right = bars(disparity);
  const DirectAlignmentOptions options;
  const DirectReference r = BuildDirectReference(cam, left, right, kMaxDisparity, options);
  ASSERT_GE(static_cast<int>(r.points.size()), options.min_pixels);
  const DirectAlignmentResult a = AlignDirect(cam, r, bars(0), SE3(), options);
  std::cout << "refused: " << a.failure << "\n";
  EXPECT_FALSE(a.success);
  EXPECT_FALSE(a.failure.empty());
}

// A clipped highlight is flat at 255: the noise estimate (which sets the edge threshold) comes
// from the rest of the image, not from the highlight's missing noise.
TEST(DirectAlignment, TheNoiseEstimateIgnoresAClippedHighlight) {
  const sim::SyntheticSequence seq(DimBareCorner());
  const StereoCamera& cam = seq.camera();
  cv::RNG rng(11);
  const cv::Mat grey(cam.height, cam.width, CV_8UC1, cv::Scalar(200));
  const cv::Mat plain = WithNoise(grey, &rng);
  cv::Mat clipped = WithNoise(grey, &rng);
  clipped(cv::Rect(0, 0, cam.width * 2 / 3, cam.height)).setTo(255);
  const DirectAlignmentOptions options;
  const DirectReference a = BuildDirectReference(cam, plain, plain, kMaxDisparity, options);
  const DirectReference b = BuildDirectReference(cam, clipped, clipped, kMaxDisparity, options);
  ASSERT_GT(a.gradient_noise, 0.f);
  EXPECT_NEAR(b.gradient_noise, a.gradient_noise, 0.2 * a.gradient_noise);
  EXPECT_LT(static_cast<int>(b.points.size()), options.min_pixels);
}

TEST(DirectAlignment, BadImagesAndOptionsAreRefused) {
  const sim::SyntheticSequence seq(DimBareCorner());
  const StereoFrame f = seq.Render(0);
  const DirectAlignmentOptions options;
  cv::Mat colour;
  cv::cvtColor(f.left, colour, cv::COLOR_GRAY2BGR);
  EXPECT_THROW(BuildDirectReference(seq.camera(), colour, f.right, kMaxDisparity, options),
               InputError);
  const DirectReference r =
      BuildDirectReference(seq.camera(), f.left, f.right, kMaxDisparity, options);
  cv::Mat half;
  cv::resize(f.left, half, cv::Size(), 0.5, 0.5);
  EXPECT_THROW(AlignDirect(seq.camera(), r, half, SE3(), options), InputError);
  DirectAlignmentOptions bad;
  bad.levels = 0;
  EXPECT_NE(bad.Validate().find("levels=0"), std::string::npos) << bad.Validate();
  bad = DirectAlignmentOptions();
  bad.max_residual = -1.0;
  EXPECT_NE(bad.Validate().find("max_residual"), std::string::npos);
}

}  // namespace
}  // namespace pl_slam
