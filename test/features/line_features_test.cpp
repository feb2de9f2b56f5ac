#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include <opencv2/imgproc.hpp>
#include <opencv2/line_descriptor.hpp>

#include "pl_slam/features/line_features.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Polygons rendered with exact area coverage: drawn at 8x resolution, then box-averaged, so
// edges sit at their true sub-pixel positions (pixel centres at integer coordinates).
class Canvas {
 public:
  Canvas(int width, int height, double background)
      : hi_(height * kSuper, width * kSuper, CV_8UC1, cv::Scalar(background)) {}
  void FillPolygon(const std::vector<cv::Point2d>& corners, double value) {
    std::vector<cv::Point> pts;
    for (const cv::Point2d& c : corners) {
      // Low-res (u, v) -> high-res pixel coordinates, 4 fractional bits for fillConvexPoly.
      pts.emplace_back(cvRound(((c.x + 0.5) * kSuper - 0.5) * 16),
                       cvRound(((c.y + 0.5) * kSuper - 0.5) * 16));
    }
    cv::fillConvexPoly(hi_, pts, cv::Scalar(value), cv::LINE_8, 4);
  }
  cv::Mat Image() const {
    cv::Mat low;
    cv::resize(hi_, low, cv::Size(hi_.cols / kSuper, hi_.rows / kSuper), 0, 0, cv::INTER_AREA);
    return low;
  }

 private:
  static constexpr int kSuper = 8;
  cv::Mat hi_;
};

// Distance of point p to the infinite line through a and b.
double DistToLine(const Eigen::Vector2d& p, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  const Eigen::Vector2d d = (b - a).normalized();
  const Eigen::Vector2d r = p - a;
  return std::abs(d.x() * r.y() - d.y() * r.x());
}

// The detected line matching the drawn edge a -> b (same direction within 5 deg, both
// endpoints near its line), or nullptr.
const LineFeature* FindEdge(const LineFeatures& lines, const Eigen::Vector2d& a,
                            const Eigen::Vector2d& b) {
  const double angle = std::atan2(b.y() - a.y(), b.x() - a.x());
  for (const LineFeature& f : lines) {
    double d = std::abs(f.angle - angle);
    d = std::min(d, 2 * kPi - d);
    if (d > 5.0 * kPi / 180.0) continue;
    if (DistToLine(f.s, a, b) < 1.0 && DistToLine(f.e, a, b) < 1.0) return &f;
  }
  return nullptr;
}

TEST(LineDetector, FindsDrawnEdgesWithSubPixelAccuracy) {
  Canvas canvas(752, 480, 60);
  // A bright axis-aligned rectangle at fractional coordinates and a rotated dark square.
  const std::vector<cv::Point2d> rect = {
      {100.3, 80.6}, {300.7, 80.6}, {300.7, 260.2}, {100.3, 260.2}};
  canvas.FillPolygon(rect, 200);
  const std::vector<cv::Point2d> square = [] {
    std::vector<cv::Point2d> corners;
    for (int k = 0; k < 4; ++k) {
      const double a = 25.0 * kPi / 180.0 + k * kPi / 2;
      corners.emplace_back(520.0 + 110.0 * std::cos(a), 300.0 + 110.0 * std::sin(a));
    }
    return corners;
  }();
  canvas.FillPolygon(square, 10);
  const cv::Mat img = canvas.Image();

  LineDetector det{LineDetectorOptions()};
  LineFeatures lines;
  cv::Mat desc;
  det.Detect(img, &lines, &desc);
  ASSERT_GE(lines.size(), 8u);
  EXPECT_EQ(desc.rows, static_cast<int>(lines.size()));
  EXPECT_EQ(desc.cols, 32);
  EXPECT_EQ(desc.type(), CV_8UC1);

  for (const auto* poly : {&rect, &square}) {
    for (int k = 0; k < 4; ++k) {
      const cv::Point2d& p = (*poly)[k];
      const cv::Point2d& q = (*poly)[(k + 1) % 4];
      const Eigen::Vector2d a(p.x, p.y), b(q.x, q.y);
      // The bright side must be on the right of s -> e: the rectangle is bright inside and
      // listed clockwise on screen, so its edges keep their order; the dark square is
      // inside-dark, so its edges are reversed.
      const bool reversed = poly == &square;
      const LineFeature* f = reversed ? FindEdge(lines, b, a) : FindEdge(lines, a, b);
      ASSERT_NE(f, nullptr) << "edge " << k << " of " << (reversed ? "square" : "rectangle")
                            << " not found";
      // Sub-pixel: on the drawn line within 0.2 px; endpoints within 2 px of the corners.
      EXPECT_LT(DistToLine(f->s, a, b), 0.2) << "edge " << k;
      EXPECT_LT(DistToLine(f->e, a, b), 0.2) << "edge " << k;
      const Eigen::Vector2d s_true = reversed ? b : a, e_true = reversed ? a : b;
      EXPECT_LT((f->s - s_true).norm(), 2.0) << "edge " << k;
      EXPECT_LT((f->e - e_true).norm(), 2.0) << "edge " << k;
    }
  }
  for (const LineFeature& f : lines) {
    EXPECT_NEAR(f.l.x() * f.l.x() + f.l.y() * f.l.y(), 1.0, 1e-9);
    EXPECT_NEAR(f.l.dot(Eigen::Vector3d(f.s.x(), f.s.y(), 1.0)), 0.0, 1e-6);
    EXPECT_NEAR(f.l.dot(Eigen::Vector3d(f.e.x(), f.e.y(), 1.0)), 0.0, 1e-6);
    EXPECT_NEAR(f.length, (f.e - f.s).norm(), 1e-9);
    EXPECT_NEAR(f.angle, std::atan2(f.e.y() - f.s.y(), f.e.x() - f.s.x()), 1e-9);
    EXPECT_EQ(f.octave, 0);
    EXPECT_FALSE(f.has_depth);
  }
}

TEST(LineDetector, KeepsTheLongestAndDropsShortOnes) {
  Canvas canvas(640, 480, 40);
  // Vertical bars of lengths 20..300 px (min(width, height) = 480).
  for (int k = 0; k < 15; ++k) {
    const double x = 20.0 + 40.0 * k, len = 20.0 + 20.0 * k;
    canvas.FillPolygon({{x, 60}, {x + 15, 60}, {x + 15, 60 + len}, {x, 60 + len}}, 220);
  }
  const cv::Mat img = canvas.Image();
  LineDetectorOptions opt;
  opt.min_length_ratio = 0.1;  // 48 px
  LineDetector det(opt);
  LineFeatures lines;
  cv::Mat desc;
  det.Detect(img, &lines, &desc);
  ASSERT_FALSE(lines.empty());
  for (size_t i = 0; i < lines.size(); ++i) {
    EXPECT_GE(lines[i].length, 48.0 - 1e-6);
    if (i > 0) EXPECT_LE(lines[i].length, lines[i - 1].length + 1e-9) << "not sorted longest first";
  }
  opt.max_lines = 6;
  LineDetector capped(opt);
  LineFeatures top;
  capped.Detect(img, &top, &desc);
  ASSERT_EQ(top.size(), 6u);
  EXPECT_EQ(desc.rows, 6);
  for (size_t i = 0; i < top.size(); ++i) EXPECT_NEAR(top[i].length, lines[i].length, 1e-9);
  // The 6 longest are the two long sides of the three longest bars (260..300 px).
  EXPECT_GT(top.back().length, 250.0);
}

// A dashed marking running into the view at 20 deg from the rows: the detector finds each
// dash's long edge as a piece and joins the pieces. The joined line must be the line through
// all of them: its direction averaged from the short pieces' own directions misses the far
// end by a fraction of a pixel, which stereo turns into a pixel of disparity there.
TEST(LineDetector, JoinedPiecesOfADashedEdgeLieOnTheirCommonLine) {
  Canvas canvas(752, 480, 50);
  const double angle = 20.0 * kPi / 180.0;
  const Eigen::Vector2d dir(std::cos(angle), std::sin(angle)), normal(-dir.y(), dir.x());
  const Eigen::Vector2d start(60.3, 90.7);
  constexpr double kDash = 30.0, kGap = 3.0, kWidth = 5.0;
  for (int k = 0; k < 16; ++k) {
    const Eigen::Vector2d a = start + (k * (kDash + kGap)) * dir, b = a + kDash * dir;
    const Eigen::Vector2d c = b + kWidth * normal, d = a + kWidth * normal;
    canvas.FillPolygon({{a.x(), a.y()}, {b.x(), b.y()}, {c.x(), c.y()}, {d.x(), d.y()}}, 210);
  }
  LineDetector det{LineDetectorOptions()};
  LineFeatures lines;
  cv::Mat desc;
  det.Detect(canvas.Image(), &lines, &desc);
  // The dashes' edge on the line start + t dir: one segment joining the 16 pieces (a dash's
  // edge is 30 px, the run 525 px).
  const Eigen::Vector2d line_a = start, line_b = start + dir;
  const LineFeature* edge = nullptr;
  for (const LineFeature& f : lines)
    if (DistToLine(f.s, line_a, line_b) < 2.0 && DistToLine(f.e, line_a, line_b) < 2.0 &&
        (!edge || f.length > edge->length))
      edge = &f;
  ASSERT_NE(edge, nullptr);
  EXPECT_GT(edge->length, 450.0);
  EXPECT_LT(DistToLine(edge->s, line_a, line_b), 0.25);
  EXPECT_LT(DistToLine(edge->e, line_a, line_b), 0.25);
}

TEST(LineDetector, EmptyUniformAndTinyImagesGiveNothing) {
  LineDetector det{LineDetectorOptions()};
  LineFeatures lines(3);
  cv::Mat desc;
  det.Detect(cv::Mat(), &lines, &desc);
  EXPECT_TRUE(lines.empty());
  EXPECT_EQ(desc.rows, 0);
  det.Detect(cv::Mat(480, 752, CV_8UC1, cv::Scalar(128)), &lines, &desc);
  EXPECT_TRUE(lines.empty());
  EXPECT_EQ(desc.rows, 0);
  det.Detect(cv::Mat(2, 2, CV_8UC1, cv::Scalar(9)), &lines, &desc);
  EXPECT_TRUE(lines.empty());
  LineDetectorOptions lsd;
  lsd.detector = LineDetectorKind::kLsd;
  LineDetector(lsd).Detect(cv::Mat(480, 752, CV_8UC1, cv::Scalar(128)), &lines, &desc);
  EXPECT_TRUE(lines.empty());
}

TEST(LineDetector, RejectsColourImages) {
  LineDetector det{LineDetectorOptions()};
  LineFeatures lines;
  cv::Mat desc;
  EXPECT_THROW(det.Detect(cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(0)), &lines, &desc), InputError);
}

cv::Mat SyntheticFrame() {
  sim::SequenceOptions so;
  so.scene = sim::SceneKind::kRoom;
  return sim::SyntheticSequence(so).Render(3).left;
}

TEST(LineDetector, LbdIsBitCompatibleWithOpenCv) {
  const cv::Mat img = SyntheticFrame();
  LineDetector det{LineDetectorOptions()};
  LineFeatures lines;
  cv::Mat desc;
  det.Detect(img, &lines, &desc);
  ASSERT_GT(lines.size(), 50u);
  // The same lines as OpenCV KeyLines (octave 0, every field consistent).
  std::vector<cv::line_descriptor::KeyLine> keylines;
  for (size_t i = 0; i < lines.size(); ++i) {
    const LineFeature& f = lines[i];
    cv::line_descriptor::KeyLine kl;
    kl.startPointX = kl.sPointInOctaveX = static_cast<float>(f.s.x());
    kl.startPointY = kl.sPointInOctaveY = static_cast<float>(f.s.y());
    kl.endPointX = kl.ePointInOctaveX = static_cast<float>(f.e.x());
    kl.endPointY = kl.ePointInOctaveY = static_cast<float>(f.e.y());
    kl.lineLength = static_cast<float>(f.length);
    kl.angle = static_cast<float>(f.angle);
    kl.octave = 0;
    kl.class_id = static_cast<int>(i);
    kl.response = static_cast<float>(f.length / std::max(img.cols, img.rows));
    kl.size = (kl.endPointX - kl.startPointX) * (kl.endPointY - kl.startPointY);
    kl.pt = cv::Point2f((kl.startPointX + kl.endPointX) / 2, (kl.startPointY + kl.endPointY) / 2);
    cv::LineIterator it(img, cv::Point2f(kl.startPointX, kl.startPointY),
                        cv::Point2f(kl.endPointX, kl.endPointY));
    kl.numOfPixels = it.count;
    keylines.push_back(kl);
  }
  cv::Mat reference;
  cv::line_descriptor::BinaryDescriptor::createBinaryDescriptor()->compute(img, keylines,
                                                                           reference);
  ASSERT_EQ(reference.rows, desc.rows);
  int identical = 0, differing_bits = 0;
  for (int i = 0; i < desc.rows; ++i) {
    const int d = static_cast<int>(cv::norm(desc.row(i), reference.row(i), cv::NORM_HAMMING));
    identical += d == 0;
    differing_bits += d;
  }
  // Rounding x + 0.5 in float instead of round() could in principle move a sample across a
  // pixel border; allow for that, nothing more.
  EXPECT_GE(identical, desc.rows - 1);
  EXPECT_LE(differing_bits, 4);
  // ComputeLbdDescriptors on the same lines gives the detector's descriptors.
  cv::Mat again;
  ComputeLbdDescriptors(img, lines, &again);
  EXPECT_EQ(cv::norm(again, desc, cv::NORM_HAMMING), 0.0);
}

TEST(LineDetector, ConcurrentCallsMatchSequentialOnes) {
  const cv::Mat a = SyntheticFrame();
  cv::Mat b;
  cv::flip(a, b, 1);
  LineDetector det{LineDetectorOptions()};
  LineFeatures la, lb, ca, cb;
  cv::Mat da, db, dca, dcb;
  det.Detect(a, &la, &da);
  det.Detect(b, &lb, &db);
  for (int round = 0; round < 5; ++round) {
    std::thread t([&] { det.Detect(b, &cb, &dcb); });
    det.Detect(a, &ca, &dca);
    t.join();
    ASSERT_EQ(ca.size(), la.size());
    ASSERT_EQ(cb.size(), lb.size());
    EXPECT_EQ(cv::norm(dca, da, cv::NORM_HAMMING), 0.0);
    EXPECT_EQ(cv::norm(dcb, db, cv::NORM_HAMMING), 0.0);
    for (size_t i = 0; i < la.size(); ++i) EXPECT_EQ(ca[i].s, la[i].s);
  }
}

TEST(LineDetector, LsdAlternativeFindsTheRectangle) {
  Canvas canvas(640, 480, 60);
  canvas.FillPolygon({{150.5, 100.5}, {450.5, 100.5}, {450.5, 350.5}, {150.5, 350.5}}, 200);
  LineDetectorOptions opt;
  opt.detector = LineDetectorKind::kLsd;
  LineFeatures lines;
  cv::Mat desc;
  LineDetector(opt).Detect(canvas.Image(), &lines, &desc);
  EXPECT_NE(FindEdge(lines, {150.5, 100.5}, {450.5, 100.5}), nullptr);
  EXPECT_NE(FindEdge(lines, {450.5, 350.5}, {150.5, 350.5}), nullptr);
  EXPECT_EQ(desc.rows, static_cast<int>(lines.size()));
}

TEST(LineDetector, OptionsValidationNamesTheKey) {
  EXPECT_EQ(LineDetectorOptions().Validate(), "");
  auto expect_key = [](LineDetectorOptions opt, const std::string& key) {
    const std::string err = opt.Validate();
    EXPECT_EQ(err.rfind(key + "=", 0), 0u) << err;
    try {
      LineDetector det(opt);
      ADD_FAILURE() << "no ConfigError for " << key;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("lines." + key), std::string::npos) << e.what();
    }
  };
  LineDetectorOptions o;
  o.min_length_ratio = 0.0;
  expect_key(o, "min_length_ratio");
  o = {};
  o.max_lines = -1;
  expect_key(o, "max_lines");
  o = {};
  o.canny_low = 0;
  expect_key(o, "canny_low");
  o = {};
  o.canny_high = o.canny_low - 1;
  expect_key(o, "canny_high");
  o = {};
  o.max_fit_distance = 9;
  expect_key(o, "max_fit_distance");
  o = {};
  o.merge_max_gap = -1;
  expect_key(o, "merge_max_gap");
  o = {};
  o.merge_max_distance = 11;
  expect_key(o, "merge_max_distance");
  o = {};
  o.merge_max_angle_deg = 45;
  expect_key(o, "merge_max_angle_deg");
  o = {};
  o.lsd_scale = 2;
  expect_key(o, "lsd_scale");
  o = {};
  o.low_contrast_cell = 8;
  expect_key(o, "low_contrast_cell");
}

TEST(LineDetector, AFaintEdgeBesideStrongOnesIsFoundInTheCellsTheyLeaveEmpty) {
  // Strong rectangles (more segments than min_lines) on the left two thirds of the image, and
  // a door frame 12 grey levels off the paint on the plain right third: below the normal
  // thresholds, above the low-contrast ones, and the image is not poor in segments.
  Canvas canvas(752, 480, 120);
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) {
      const double x = 20.3 + 110.0 * c, y = 30.6 + 110.0 * r;
      canvas.FillPolygon({{x, y}, {x + 70.0, y}, {x + 70.0, y + 60.0}, {x, y + 60.0}}, 220);
    }
  }
  const Eigen::Vector2d a(620.4, 60.0), b(620.4, 420.0);
  canvas.FillPolygon({{a.x(), a.y()}, {752.0, a.y()}, {752.0, b.y()}, {a.x(), b.y()}}, 132);
  const cv::Mat img = canvas.Image();

  LineDetectorOptions opt;
  ASSERT_EQ(opt.low_contrast_cell, 64) << "the default this test describes";
  LineFeatures with_cells, without;
  cv::Mat desc;
  LineDetector(opt).Detect(img, &with_cells, &desc);
  EXPECT_EQ(desc.rows, static_cast<int>(with_cells.size()));
  opt.low_contrast_cell = 0;
  LineDetector(opt).Detect(img, &without, &desc);
  ASSERT_GE(static_cast<int>(without.size()), opt.min_lines) << "the image must not be poor";
  // Either orientation (the detector orients segments by their brighter side).
  auto find = [&](const LineFeatures& lines) {
    const LineFeature* f = FindEdge(lines, a, b);
    return f ? f : FindEdge(lines, b, a);
  };
  EXPECT_EQ(find(without), nullptr) << "the normal thresholds already see the edge";
  const LineFeature* found = find(with_cells);
  ASSERT_NE(found, nullptr) << "the faint edge was not found in the empty cells";
  EXPECT_GT(found->length, 0.9 * (b - a).norm());
  // A first search that fills the cap leaves no room: no search in the empty cells.
  LineDetectorOptions capped;
  capped.max_lines = opt.min_lines;
  LineFeatures at_cap;
  LineDetector(capped).Detect(img, &at_cap, &desc);
  EXPECT_EQ(find(at_cap), nullptr) << "faint segments displaced strong ones under the cap";
  // The strong edges are kept as the first search found them.
  for (const LineFeature& f : without) {
    bool kept = false;
    for (const LineFeature& g : with_cells)
      kept |= (f.s - g.s).norm() < 0.5 && (f.e - g.e).norm() < 0.5;
    EXPECT_TRUE(kept) << "segment " << f.s.transpose() << " -> " << f.e.transpose() << " lost";
  }
}

TEST(MakeLineFeature, NormalisesTheLine) {
  const LineFeature f = MakeLineFeature({10, 20}, {13, 24});
  EXPECT_NEAR(f.length, 5.0, 1e-12);
  EXPECT_NEAR(f.l.head<2>().norm(), 1.0, 1e-12);
  EXPECT_NEAR(f.l.dot(Eigen::Vector3d(16, 28, 1)), 0.0, 1e-12);           // on the line
  EXPECT_NEAR(std::abs(f.l.dot(Eigen::Vector3d(6, 23, 1))), 5.0, 1e-12);  // 5 px to the side
  EXPECT_NEAR(f.angle, std::atan2(4.0, 3.0), 1e-12);
}

}  // namespace
}  // namespace pl_slam
