// Stereo and frame-to-frame point matching against the synthetic world's exact depth and poses.
#include <algorithm>
#include <cmath>
#include <iostream>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "pl_slam/features/point_features.h"
#include "pl_slam/matching/patch_alignment.h"
#include "pl_slam/matching/point_matching.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "test_util/cameras.h"

namespace pl_slam {
namespace {

struct Detected {
  PointFeatures points;
  cv::Mat desc;
  int stereo = 0;
};

Detected DetectAndMatch(const sim::SyntheticSequence& seq, int index,
                        const PointMatchingOptions& mo) {
  const StereoFrame f = seq.Render(index);
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  det.Detect(f.left, &kl, &dl);
  det.Detect(f.right, &kr, &dr);
  Detected out;
  out.stereo = MatchStereoPoints(seq.camera(), f.left, f.right, kl, dl, kr, dr, mo, &out.points);
  out.desc = dl;
  return out;
}

sim::SyntheticSequence Room() {
  sim::SequenceOptions o;
  o.scene = sim::SceneKind::kRoom;
  o.num_frames = 0;  // the scene's own length: realistic motion between frames
  return sim::SyntheticSequence(o);
}

TEST(PointMatching, StereoDepthAgreesWithTheRenderedDepth) {
  const auto seq = Room();
  for (bool subpixel : {false, true}) {
    PointMatchingOptions mo;
    mo.subpixel = subpixel;
    const Detected d = DetectAndMatch(seq, 10, mo);
    const cv::Mat depth = seq.RenderDepth(10);
    ASSERT_GT(d.stereo, 200) << "too few stereo matches";
    int good = 0, total = 0;
    std::vector<double> disp_err;
    for (const auto& p : d.points) {
      if (!p.has_depth) continue;
      const float z = depth.at<float>(static_cast<int>(std::lround(p.uv.y())),
                                      static_cast<int>(std::lround(p.uv.x())));
      if (z <= 0.f) continue;
      ++total;
      const double true_disp = seq.camera().DisparityFromDepth(z);
      disp_err.push_back(std::abs(true_disp - p.disparity));
      good += disp_err.back() < 1.0;
    }
    std::sort(disp_err.begin(), disp_err.end());
    const double median = disp_err[disp_err.size() / 2];
    // Precision of the matches: nearly all within a pixel of the true disparity.
    // Coarse ORB positions are quantised by the pyramid level; the refined ones must be tight.
    EXPECT_GT(static_cast<double>(good) / total, subpixel ? 0.97 : 0.85) << "subpixel=" << subpixel;
    if (subpixel)
      EXPECT_LT(median, 0.3) << "sub-pixel refinement should give < 0.3 px median error";
    std::cout << "subpixel=" << subpixel << ": " << d.stereo
              << " stereo matches, median |disparity error| " << median << " px, within 1 px "
              << 100.0 * good / total << "%\n";
  }
}

// Sub-pixel disparities must not lean towards whole pixels. Over 10 frames of the room, the
// signed error against the rendered depth is averaged per fractional part of the true
// disparity. A parabola through SAD costs alone gave -0.07 px at 0.25 and +0.075 px at 0.65
// (median |error| 0.13 px), a depth error of ~0.35% that depends on the depth; the Lucas-Kanade
// step that follows it brings both down.
TEST(PointMatching, SubpixelDisparitiesDoNotLeanTowardsWholePixels) {
  const auto seq = Room();
  PointMatchingOptions mo;
  std::vector<double> bin_sum(10, 0.0), bin_n(10, 0.0), abs_err;
  for (int index = 0; index < 400; index += 40) {
    const Detected d = DetectAndMatch(seq, index, mo);
    const cv::Mat depth = seq.RenderDepth(index);
    for (const auto& p : d.points) {
      if (!p.has_depth) continue;
      const int x = static_cast<int>(std::floor(p.uv.x())),
                y = static_cast<int>(std::floor(p.uv.y()));
      if (x < 1 || y < 1 || x + 2 >= depth.cols || y + 2 >= depth.rows) continue;
      const float z[4] = {depth.at<float>(y, x), depth.at<float>(y, x + 1),
                          depth.at<float>(y + 1, x), depth.at<float>(y + 1, x + 1)};
      const float z_min = *std::min_element(z, z + 4), z_max = *std::max_element(z, z + 4);
      if (!(z_min > 0.f) || z_max - z_min > 0.02f * z_min) continue;  // depth edges
      // Inverse depth is linear across a plane's image: interpolate it at the keypoint.
      const double ax = p.uv.x() - x, ay = p.uv.y() - y;
      const double inv_z =
          (1 - ay) * ((1 - ax) / z[0] + ax / z[1]) + ay * ((1 - ax) / z[2] + ax / z[3]);
      const double true_disp = seq.camera().DisparityFromDepth(1.0 / inv_z);
      const double e = p.disparity - true_disp;
      if (std::abs(e) > 1.0) continue;  // a wrong match, not a sub-pixel error
      const int bin = std::min(9, static_cast<int>((true_disp - std::floor(true_disp)) * 10.0));
      bin_sum[bin] += e;
      bin_n[bin] += 1.0;
      abs_err.push_back(std::abs(e));
    }
  }
  ASSERT_GT(abs_err.size(), 2000u);
  std::sort(abs_err.begin(), abs_err.end());
  const double median = abs_err[abs_err.size() / 2];
  double worst_bias = 0.0;
  for (int b = 0; b < 10; ++b) {
    ASSERT_GT(bin_n[b], 100.0) << "bin " << b;
    worst_bias = std::max(worst_bias, std::abs(bin_sum[b] / bin_n[b]));
  }
  std::cout << abs_err.size() << " stereo points: median |disparity error| " << median
            << " px, largest mean error of a fractional-part bin " << worst_bias << " px\n";
  EXPECT_LT(median, 0.06);
  EXPECT_LT(worst_bias, 0.04);
}

// Where the right image's detector misses a corner (no right keypoint at all here), the row
// search finds it by correlation: most left keypoints get a depth, as precise as the
// descriptor matches' (the test above). Off, none do.
TEST(PointMatching, RowSearchFindsCornersTheRightDetectorMissed) {
  const auto seq = Room();
  const StereoFrame f = seq.Render(10);
  const cv::Mat depth = seq.RenderDepth(10);
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kl;
  cv::Mat dl;
  det.Detect(f.left, &kl, &dl);
  ASSERT_GT(kl.size(), 500u);
  PointMatchingOptions mo;
  PointFeatures points;
  const int stereo =
      MatchStereoPoints(seq.camera(), f.left, f.right, kl, dl, {}, cv::Mat(), mo, &points);
  EXPECT_GT(stereo, static_cast<int>(kl.size() / 2));
  std::vector<double> err;
  for (const auto& p : points) {
    if (!p.has_depth) continue;
    const float z = depth.at<float>(static_cast<int>(std::lround(p.uv.y())),
                                    static_cast<int>(std::lround(p.uv.x())));
    if (z > 0.f) err.push_back(std::abs(seq.camera().DisparityFromDepth(z) - p.disparity));
  }
  ASSERT_GT(err.size(), kl.size() / 2);
  std::sort(err.begin(), err.end());
  const double within =
      static_cast<double>(std::upper_bound(err.begin(), err.end(), 1.0) - err.begin()) / err.size();
  std::cout << stereo << " of " << kl.size() << " keypoints found along the row, median |disparity "
            << "error| " << err[err.size() / 2] << " px, within 1 px " << 100.0 * within << "%\n";
  EXPECT_GT(within, 0.97);
  EXPECT_LT(err[err.size() / 2], 0.1);

  mo.row_search_min_zncc = 0.0;
  EXPECT_EQ(MatchStereoPoints(seq.camera(), f.left, f.right, kl, dl, {}, cv::Mat(), mo, &points),
            0);
}

// A patch that repeats along the row (stripes) or has no texture matches several columns, or
// none, equally well: the row search gives no depth rather than a guess.
TEST(PointMatching, RowSearchRefusesRepeatedAndFlatPatches) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  cv::Mat stripes(480, 752, CV_8UC1), flat(480, 752, CV_8UC1, cv::Scalar(128));
  for (int c = 0; c < stripes.cols; ++c)
    stripes.col(c).setTo(cv::Scalar(128 + 60 * std::sin(2.0 * M_PI * c / 12.0)));
  // The right image is the left one shifted by 20 px: the true match is among the repeats.
  cv::Mat stripes_right = cv::Mat::zeros(stripes.size(), CV_8UC1);
  stripes(cv::Rect(20, 0, stripes.cols - 20, stripes.rows))
      .copyTo(stripes_right(cv::Rect(0, 0, stripes.cols - 20, stripes.rows)));
  std::vector<cv::KeyPoint> kl;
  for (int v = 40; v < 440; v += 40)
    for (int u = 250; u < 700; u += 37) kl.emplace_back(static_cast<float>(u), v, 31.f);
  const cv::Mat desc(static_cast<int>(kl.size()), 32, CV_8UC1, cv::Scalar(0));
  PointFeatures points;
  EXPECT_EQ(MatchStereoPoints(cam, stripes, stripes_right, kl, desc, {}, cv::Mat(),
                              PointMatchingOptions(), &points),
            0);
  EXPECT_EQ(
      MatchStereoPoints(cam, flat, flat, kl, desc, {}, cv::Mat(), PointMatchingOptions(), &points),
      0);
}

// A plain wall with a few light-switch plates: each sharp corner looks alike at every pyramid
// level, so the detector finds it two to four times. Those copies are the same place, not
// rivals: counted as rivals they make the ratio tests refuse many corners (stereo and frame to
// frame); with same_corner_radius those match too, at the right disparity and shift.
// `plate`: the plates' grey level, `blur`: the optics' (sigma, px).
cv::Mat PlatesOnAWall(int shift_u, int shift_v, int plate = 200, double blur = 0.6) {
  cv::Mat img(480, 752, CV_8UC1, cv::Scalar(150));
  for (int k = 0; k < 4; ++k) {  // no two on the same rows, no two of the same size
    const int u = 200 + 120 * k + shift_u, v = 40 + 105 * k + shift_v;
    cv::rectangle(img, cv::Rect(u, v, 44 + 8 * k, 70 + 6 * k), cv::Scalar(plate), cv::FILLED);
    cv::rectangle(img, cv::Rect(u + 16 + 2 * k, v + 24, 12 + 2 * k, 22), cv::Scalar(90),
                  cv::FILLED);
  }
  cv::Mat noise(img.size(), CV_16SC1);
  cv::RNG(7 + shift_u).fill(noise, cv::RNG::NORMAL, 0, 2);
  cv::Mat out;
  img.convertTo(out, CV_16SC1);
  out += noise;
  out.convertTo(out, CV_8UC1);
  cv::GaussianBlur(out, out, cv::Size(0, 0), blur);
  return out;
}

TEST(PointMatching, CopiesOfOneCornerAreNotItsRivals) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  constexpr int kDisparity = 30, kDu = 6, kDv = 4;
  const cv::Mat left = PlatesOnAWall(0, 0), right = PlatesOnAWall(-kDisparity, 0);
  const cv::Mat next = PlatesOnAWall(kDu, kDv), next_right = PlatesOnAWall(kDu - kDisparity, kDv);
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kl, kr, kn, knr;
  cv::Mat dl, dr, dn, dnr;
  det.Detect(left, &kl, &dl);
  det.Detect(right, &kr, &dr);
  det.Detect(next, &kn, &dn);
  det.Detect(next_right, &knr, &dnr);
  // Correct and wrong matches without (0) and with (1) same_corner_radius.
  int stereo[2] = {0, 0}, stereo_wrong[2] = {0, 0}, f2f[2] = {0, 0}, f2f_wrong[2] = {0, 0};
  for (int on = 0; on < 2; ++on) {
    PointMatchingOptions mo;
    mo.row_search_min_zncc = 0.0;  // descriptor matches only
    mo.same_corner_radius = on ? 4.0 : 0.0;
    PointFeatures a, b;
    MatchStereoPoints(cam, left, right, kl, dl, kr, dr, mo, &a);
    MatchStereoPoints(cam, next, next_right, kn, dn, knr, dnr, mo, &b);
    for (const PointFeature& p : a) {
      if (!p.has_depth) continue;
      const bool right_disparity = std::abs(cam.TrueDisparity(p.disparity) - kDisparity) < 1.0;
      ++(right_disparity ? stereo : stereo_wrong)[on];
    }
    const SE3 still;  // the prediction: no motion, the shift is within the search radius
    for (const auto& [i, j] : MatchPointsFrameToFrame(cam, a, dl, b, dn, mo, &still)) {
      const bool right_shift = (b[j].uv - a[i].uv - Eigen::Vector2d(kDu, kDv)).norm() < 1.5;
      ++(right_shift ? f2f : f2f_wrong)[on];
    }
  }
  std::cout << "correct (wrong) stereo matches " << stereo[0] << " (" << stereo_wrong[0] << ") -> "
            << stereo[1] << " (" << stereo_wrong[1] << "), frame to frame " << f2f[0] << " ("
            << f2f_wrong[0] << ") -> " << f2f[1] << " (" << f2f_wrong[1] << ") of " << kl.size()
            << " keypoints" << std::endl;
  // More correct matches, and no larger share of wrong ones (corners of one plate a few pixels
  // apart are real rivals: those stay).
  EXPECT_GE(stereo[1], stereo[0] + 8);
  EXPECT_LE(stereo_wrong[1] * (stereo[0] + stereo_wrong[0]),
            stereo_wrong[0] * (stereo[1] + stereo_wrong[1]));
  EXPECT_GE(f2f[1], f2f[0] + 6);
  EXPECT_LE(f2f_wrong[1] * (f2f[0] + f2f_wrong[0]), f2f_wrong[0] * (f2f[1] + f2f_wrong[1]));
}

// Descriptors can pair a corner with a keypoint that is not it (a faint corner beside another, a
// corner the other camera sees against another background). Two plates' corners are given their
// true partners, two a keypoint on the plain wall beside the plate, with the same descriptors:
// the patch check refuses those two, and only those.
TEST(PointMatching, StereoMatchesWhosePatchesDisagreeAreRefused) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  constexpr int kDisparity = 30;
  const cv::Mat left = PlatesOnAWall(0, 0), right = PlatesOnAWall(-kDisparity, 0);
  std::vector<cv::KeyPoint> kl, kr;
  for (int k = 0; k < 4; ++k) {
    const float u = 200.f + 120.f * k, v = 40.f + 105.f * k;  // each plate's top-left corner
    kl.emplace_back(u, v, 31.f);
    kr.emplace_back(u - kDisparity - (k < 2 ? 0.f : 40.f), v, 31.f);
  }
  cv::Mat desc(4, 32, CV_8UC1);
  cv::RNG(3).fill(desc, cv::RNG::UNIFORM, 0, 256);
  for (const double min_zncc : {0.0, 0.9}) {
    PointMatchingOptions mo;
    mo.row_search_min_zncc = 0.0;  // descriptor matches only
    mo.stereo_min_zncc = min_zncc;
    PointFeatures points;
    const int matched = MatchStereoPoints(cam, left, right, kl, desc, kr, desc, mo, &points);
    EXPECT_EQ(matched, min_zncc > 0.0 ? 2 : 4) << "stereo_min_zncc " << min_zncc;
    for (int k = 0; k < 2; ++k) {
      ASSERT_TRUE(points[k].has_depth);
      EXPECT_NEAR(cam.TrueDisparity(points[k].disparity), kDisparity, 0.3);
    }
    for (int k = 2; k < 4; ++k) EXPECT_EQ(points[k].has_depth, min_zncc == 0.0) << k;
  }
  PointMatchingOptions bad;
  bad.stereo_min_zncc = 1.5;
  EXPECT_NE(bad.Validate().find("stereo_min_zncc"), std::string::npos);
}

// The plates' corners with the right detector's keypoints missing (as it misses faint corners
// that the left one found at its lower threshold): a blurred corner's correlation falls off
// slowly along the plate's edges, 0.05-0.1 a pixel, yet it has one peak. Those slopes are no
// rivals, so the corners take their depth from the row search, at the right disparity.
TEST(PointMatching, RowSearchPlacesBlurredCornersOnTheirSlopes) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  constexpr int kDisparity = 30;
  const cv::Mat left = PlatesOnAWall(0, 0, 175, 1.0),
                right = PlatesOnAWall(-kDisparity, 0, 175, 1.0);
  std::vector<cv::KeyPoint> kl;
  for (int k = 0; k < 4; ++k) {  // the outer and inner corners of every plate
    const int u = 200 + 120 * k, v = 40 + 105 * k, w = 44 + 8 * k, h = 70 + 6 * k;
    const int iu = u + 16 + 2 * k, iv = v + 24, iw = 12 + 2 * k, ih = 22;
    for (const auto& [cu, cv_] : {std::pair{u, v},
                                  {u + w - 1, v},
                                  {u, v + h - 1},
                                  {u + w - 1, v + h - 1},
                                  {iu, iv},
                                  {iu + iw - 1, iv},
                                  {iu, iv + ih - 1},
                                  {iu + iw - 1, iv + ih - 1}})
      kl.emplace_back(static_cast<float>(cu), static_cast<float>(cv_), 31.f);
  }
  const cv::Mat desc(static_cast<int>(kl.size()), 32, CV_8UC1, cv::Scalar(0));
  PointFeatures points;
  MatchStereoPoints(cam, left, right, kl, desc, {}, cv::Mat(), PointMatchingOptions(), &points);
  int right_place = 0, wrong = 0;
  for (const PointFeature& p : points) {
    if (!p.has_depth) continue;
    ++(std::abs(cam.TrueDisparity(p.disparity) - kDisparity) < 0.3 ? right_place : wrong);
  }
  std::cout << right_place << " of " << kl.size() << " corners at the right disparity, " << wrong
            << " elsewhere\n";
  EXPECT_GE(right_place, static_cast<int>(kl.size()) * 3 / 4);
  EXPECT_EQ(wrong, 0);
}

// A point on an edge has no place along its row: along an edge that runs with the row every
// column matches as well, and along an edge slanted to the rows (15 deg) the correlation falls
// slowly, several columns nearly as well as the best. The row search gives neither a depth.
TEST(PointMatching, RowSearchRefusesPointsOnEdges) {
  const StereoCamera cam = testing_util::EurocSizedCamera();
  constexpr int kDisparity = 30, kPlate = 175;
  constexpr double kBlur = 1.2;
  const auto refused = [&](const cv::Mat& left, const cv::Mat& right,
                           const std::vector<cv::KeyPoint>& kps) {
    const cv::Mat desc(static_cast<int>(kps.size()), 32, CV_8UC1, cv::Scalar(0));
    PointFeatures points;
    return MatchStereoPoints(cam, left, right, kps, desc, {}, cv::Mat(), PointMatchingOptions(),
                             &points) == 0;
  };
  std::vector<cv::KeyPoint> along;  // halfway along the plates' top and bottom edges
  for (int k = 0; k < 4; ++k) {
    const float u = 200 + 120 * k, v = 40 + 105 * k, w = 44 + 8 * k, h = 70 + 6 * k;
    along.emplace_back(u + w / 2, v, 31.f);
    along.emplace_back(u + w / 2, v + h - 1, 31.f);
  }
  EXPECT_TRUE(refused(PlatesOnAWall(0, 0, kPlate, kBlur),
                      PlatesOnAWall(-kDisparity, 0, kPlate, kBlur), along));

  const double slope = std::tan(15.0 * M_PI / 180.0);
  const auto slanted = [&](int shift_u) {
    cv::Mat img(480, 752, CV_8UC1, cv::Scalar(150));
    for (int v = 0; v < img.rows; ++v)
      for (int u = 0; u < img.cols; ++u)
        if (v > 240 + slope * (u - shift_u - 376)) img.at<uint8_t>(v, u) = kPlate;
    cv::Mat out;
    cv::GaussianBlur(img, out, cv::Size(0, 0), kBlur);
    return out;
  };
  std::vector<cv::KeyPoint> on_edge;
  for (int u = 250; u <= 500; u += 50)
    on_edge.emplace_back(static_cast<float>(u), static_cast<float>(240 + slope * (u - 376)), 31.f);
  EXPECT_TRUE(refused(slanted(0), slanted(-kDisparity), on_edge));
}

TEST(PointMatching, FrameToFrameMatchesAreConsistentWithTheTruePose) {
  const auto seq = Room();
  PointMatchingOptions mo;
  const Detected a = DetectAndMatch(seq, 20, mo), b = DetectAndMatch(seq, 21, mo);
  const SE3 T_cur_prev = seq.ground_truth()[21].T_w_c.inverse() * seq.ground_truth()[20].T_w_c;
  for (bool guided : {false, true}) {
    const SE3 prediction = SE3();  // a poor prediction (identity) must still work within the radius
    const auto matches = MatchPointsFrameToFrame(seq.camera(), a.points, a.desc, b.points, b.desc,
                                                 mo, guided ? &prediction : nullptr);
    ASSERT_GT(matches.size(), 150u) << "guided=" << guided;
    int correct = 0;
    for (const auto& [i, j] : matches) {
      const Eigen::Vector2d uv = seq.camera().Project(T_cur_prev * a.points[i].p_c);
      correct += (uv - b.points[j].uv).norm() < 3.0;
    }
    EXPECT_GT(static_cast<double>(correct) / matches.size(), 0.97) << "guided=" << guided;
  }
}

TEST(PointMatching, UnrelatedImagesGiveFewMatches) {
  const auto seq = Room();
  PointMatchingOptions mo;
  const Detected a = DetectAndMatch(seq, 0, mo);
  cv::Mat noise(480, 752, CV_8UC1);
  cv::RNG(3).fill(noise, cv::RNG::UNIFORM, 0, 256);
  PointDetector det{PointDetectorOptions()};
  std::vector<cv::KeyPoint> kn;
  cv::Mat dn;
  det.Detect(noise, &kn, &dn);
  PointFeatures pn;
  MatchStereoPoints(seq.camera(), noise, noise, kn, dn, kn, dn, mo, &pn);
  const auto matches = MatchPointsFrameToFrame(seq.camera(), a.points, a.desc, pn, dn, mo);
  EXPECT_LT(matches.size(), 15u);
}

// Points along a wall 2 m ahead, six with a descriptor of their own and six in pairs of
// copies 300 px apart (a pattern repeated along the wall), seen again after the camera moved
// 8 cm to the right. Searched everywhere, each copy has an identical rival and the ratio test
// refuses it; around its predicted position it has none. A search guided by a right prediction
// that finds fewer matches than asked for is kept when the search everywhere finds fewer still;
// after a wrong prediction the search everywhere is kept.
TEST(PointMatching, APredictionThatTellsCopiesApartIsNotReplacedBySearchingEverywhere) {
  const StereoCamera camera = testing_util::EurocSizedCamera();
  constexpr double kDepth = 2.0;
  const SE3 T_cur_prev(Eigen::Matrix3d::Identity(), Eigen::Vector3d(-0.08, 0.0, 0.0));
  cv::RNG rng(11);
  cv::Mat desc(12, 32, CV_8UC1);
  rng.fill(desc, cv::RNG::UNIFORM, 0, 256);
  for (int k = 6; k < 12; k += 2) desc.row(k).copyTo(desc.row(k + 1));
  PointFeatures prev, cur;
  for (int k = 0; k < 12; ++k) {
    const bool copy = k >= 6;
    const double u = copy ? 120.0 + 60.0 * ((k - 6) / 2) + 300.0 * (k % 2) : 100.0 + 90.0 * k;
    const double v = copy ? 330.0 : 150.0 + 20.0 * (k % 3);
    PointFeature p;
    p.uv = {u, v};
    p.has_depth = true;
    p.p_c = kDepth * Eigen::Vector3d((u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1);
    p.disparity = camera.DisparityFromDepth(kDepth);
    prev.push_back(p);
    PointFeature c = p;
    c.uv = camera.Project(T_cur_prev * p.p_c);
    c.p_c = T_cur_prev * p.p_c;
    cur.push_back(c);
  }
  const PointMatchingOptions mo;
  const auto correct = [&](const std::vector<std::pair<int, int>>& matches) {
    int n = 0;
    for (const auto& [i, j] : matches) n += i == j;
    return n;
  };
  const auto everywhere = MatchPointsFrameToFrame(camera, prev, desc, cur, desc, mo);
  const auto guided = MatchPointsFrameToFrame(camera, prev, desc, cur, desc, mo, &T_cur_prev);
  ASSERT_EQ(everywhere.size(), 6u) << "the copies should fail the ratio test";
  ASSERT_EQ(guided.size(), 12u);
  const auto kept = MatchPointsPredicted(camera, prev, desc, cur, desc, mo, T_cur_prev, 30);
  EXPECT_EQ(kept.size(), 12u);
  EXPECT_EQ(correct(kept), 12);
  // A prediction 20 cm off (about 45 px at 2 m): nothing within the search radius.
  const SE3 wrong(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.12, 0.0, 0.0));
  const auto recovered = MatchPointsPredicted(camera, prev, desc, cur, desc, mo, wrong, 30);
  EXPECT_EQ(recovered.size(), 6u);
  EXPECT_EQ(correct(recovered), 6);
}

// Where a matched corner is in the next frame: the reference patch aligned there lies closer
// to the true image of the same surface point (ground-truth depth and poses) than the corner
// the detector finds again, whose position moves with its pixel grid and its own response.
TEST(PointMatching, AnAlignedPatchFollowsTheSurfaceCloserThanTheDetectedCorner) {
  const auto seq = Room();
  const PointMatchingOptions mo;
  std::vector<double> detected_err, aligned_err;
  for (int a = 10; a < 200; a += 38) {
    const int b = a + 1;
    const Detected pa = DetectAndMatch(seq, a, mo), pb = DetectAndMatch(seq, b, mo);
    const cv::Mat depth = seq.RenderDepth(a);
    const cv::Mat ia = seq.Render(a).left, ib = seq.Render(b).left;
    const SE3 T_b_a = seq.ground_truth()[b].T_w_c.inverse() * seq.ground_truth()[a].T_w_c;
    for (const auto& [i, j] : MatchPointsFrameToFrame(seq.camera(), pa.points, pa.desc, pb.points,
                                                      pb.desc, mo, &T_b_a)) {
      const Eigen::Vector2d& uv = pa.points[i].uv;
      const float z = depth.at<float>(static_cast<int>(std::lround(uv.y())),
                                      static_cast<int>(std::lround(uv.x())));
      if (!(z > 0.f)) continue;
      const Eigen::Vector3d X((uv.x() - seq.camera().cx) / seq.camera().fx * z,
                              (uv.y() - seq.camera().cy) / seq.camera().fy * z, z);
      const Eigen::Vector2d truth = seq.camera().Project(T_b_a * X);
      Eigen::Vector2d offset;
      if (!AlignPatch(TakePatch(ia, uv), ib, pb.points[j].uv, 1.5, &offset)) continue;
      const Eigen::Vector2d aligned = pb.points[j].uv + offset;
      if ((pb.points[j].uv - truth).norm() > 2.0) continue;  // a wrong match or a depth edge
      detected_err.push_back((pb.points[j].uv - truth).norm());
      aligned_err.push_back((aligned - truth).norm());
    }
  }
  ASSERT_GT(detected_err.size(), 500u);
  std::sort(detected_err.begin(), detected_err.end());
  std::sort(aligned_err.begin(), aligned_err.end());
  const double d = detected_err[detected_err.size() / 2], al = aligned_err[aligned_err.size() / 2];
  std::cout << detected_err.size() << " matches: median distance to the true image " << d
            << " px detected, " << al << " px aligned\n";
  EXPECT_LT(al, 0.5 * d);
}

TEST(PointMatching, HammingDistance) {
  uint8_t a[32] = {0}, b[32] = {0};
  EXPECT_EQ(HammingDistance32(a, b), 0);
  b[0] = 0xFF;
  b[31] = 0x01;
  EXPECT_EQ(HammingDistance32(a, b), 9);
}

}  // namespace
}  // namespace pl_slam
