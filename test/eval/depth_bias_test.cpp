// Scoring of pl_slam_bench_depth (src/apps/depth_bias.h): depth binning, bias statistics and
// the ground-truth endpoint disparities of a segment, on samples with known errors.
#include <gtest/gtest.h>

#include "../../src/apps/depth_bias.h"

namespace pl_slam::bench {
namespace {

TEST(DepthBias, BinsByDepth) {
  const DepthBins bins;
  EXPECT_EQ(bins.Index(-1.0), -1);
  EXPECT_EQ(bins.Index(NAN), -1);
  EXPECT_EQ(bins.Index(0.0), 0);
  EXPECT_EQ(bins.Index(4.99), 0);
  EXPECT_EQ(bins.Index(5.0), 1);
  EXPECT_EQ(bins.Index(39.0), 3);
  EXPECT_EQ(bins.Index(80.0), 5);
  EXPECT_EQ(bins.Index(1e6), 5);
  EXPECT_EQ(bins.Label(0), "0-5");
  EXPECT_EQ(bins.Label(5), "80+");
}

TEST(DepthBias, BiasPerBinWithGrossErrors) {
  // fx * baseline = 388.2 (street camera). Near bin (8 m): +0.2 px bias, one gross mismatch
  // of +10 px among 11. Far bin (50 m): -0.1 px bias. Errors alternate +-0.05 around the bias.
  const double fb = 718.856 * 0.54;
  BiasTable table;
  for (int i = 0; i < 10; ++i) {
    const double d = fb / 8.0;
    EXPECT_TRUE(table.Add({d + 0.2 + (i % 2 ? 0.05 : -0.05), d, 8.0}));
  }
  table.Add({fb / 8.0 + 10.0, fb / 8.0, 8.0});
  for (int i = 0; i < 10; ++i) {
    const double d = fb / 50.0;
    table.Add({d - 0.1 + (i % 2 ? 0.05 : -0.05), d, 50.0});
  }
  EXPECT_FALSE(table.Add({1.0, 1.0, -3.0}));  // no bin
  ASSERT_EQ(table.bin(1).size(), 11u);
  ASSERT_EQ(table.bin(4).size(), 10u);
  EXPECT_EQ(table.all().size(), 21u);

  const BiasStats near = Summarize(table.bin(1));
  EXPECT_EQ(near.count, 11);
  EXPECT_NEAR(near.mean, (10 * 0.2 + 10.0) / 11, 1e-9);  // the mean carries the mismatch
  EXPECT_NEAR(near.core_mean, 0.2, 1e-9);                // the core does not
  EXPECT_NEAR(near.median, 0.25, 1e-9);                  // 6 of 11 at +0.25 or more (one is +10)
  EXPECT_NEAR(near.gross_pct, 100.0 / 11, 1e-9);
  // Depth too small by the bias: Z_meas / Z_gt - 1 = d / (d + e) - 1 at the median error.
  const double d8 = fb / 8.0;
  EXPECT_NEAR(near.depth_pct, 100.0 * (d8 / (d8 + 0.25) - 1.0), 1e-9);
  EXPECT_LT(near.depth_pct, 0.0);

  const BiasStats far = Summarize(table.bin(4));
  EXPECT_NEAR(far.mean, -0.1, 1e-9);
  EXPECT_NEAR(far.median, -0.1, 1e-9);  // even count: the middle two, -0.15 and -0.05
  EXPECT_NEAR(far.sigma, 1.4826 * 0.05, 1e-9);
  EXPECT_GT(far.depth_pct, 0.0);  // disparity too small: depth too large

  const std::string md = table.Markdown();
  EXPECT_NE(md.find("| 5-10 | 11 | +1.091 | +0.200 | +0.250"), std::string::npos) << md;
  EXPECT_NE(md.find("| 0-5 | 0 |"), std::string::npos) << md;
}

TEST(DepthBias, PixelLockingShowsInTheFractionTable) {
  // Measurements pulled 30% of the way towards the nearest whole disparity.
  std::vector<DisparitySample> s;
  for (int i = 0; i < 400; ++i) {
    const double d = 10.0 + i / 400.0;
    const double pulled = d + 0.3 * (std::round(d) - d);
    s.push_back({pulled, d, 20.0});
  }
  const std::vector<BiasStats> q = ByFraction(s);
  ASSERT_EQ(q.size(), 4u);
  for (const auto& b : q) EXPECT_EQ(b.count, 100);
  EXPECT_LT(q[0].median, -0.02);
  EXPECT_LT(q[1].median, -0.02);
  EXPECT_GT(q[2].median, 0.02);
  EXPECT_GT(q[3].median, 0.02);
}

TEST(DepthBias, EndpointDisparitiesFromSamplesAlongASegment) {
  // Disparity 30 -> 20 along the segment; samples at t = 0.05 .. 0.95, three on an occluder.
  std::vector<std::pair<double, double>> td;
  for (int k = 0; k < 19; ++k) {
    const double t = 0.05 + 0.05 * k;
    td.emplace_back(t, 30.0 - 10.0 * t + (k >= 8 && k <= 10 ? 15.0 : 0.0));
  }
  double d0 = 0, d1 = 0;
  ASSERT_TRUE(FitEndpointDisparities(td, 0.05, 5, &d0, &d1));
  EXPECT_NEAR(d0, 30.0, 1e-9);
  EXPECT_NEAR(d1, 20.0, 1e-9);
  // Mostly another surface: no consistent line, no ground truth.
  for (int k = 0; k < 12; ++k) td[k].second += 5.0 * (k % 3);
  EXPECT_FALSE(FitEndpointDisparities(td, 0.05, 5, &d0, &d1));
  // Too few samples.
  EXPECT_FALSE(FitEndpointDisparities({{0.1, 1.0}, {0.5, 2.0}, {0.9, 3.0}}, 0.05, 5, &d0, &d1));
}

TEST(DepthBias, OffsetAndScaleOfTheErrors) {
  // A principal-point error of -0.4 px and a 1.5% longer baseline, over 3..60 px, plus one
  // gross mismatch the fit must ignore.
  std::vector<DisparitySample> s;
  for (int i = 0; i < 40; ++i) {
    const double d = 3.0 + 1.5 * i;
    s.push_back({1.015 * d - 0.4, d, 388.2 / d});
  }
  s.push_back({50.0, 10.0, 38.8});
  double a = 0, b = 0;
  ASSERT_TRUE(FitOffsetScale(s, &a, &b));
  EXPECT_NEAR(a, -0.4, 1e-9);
  EXPECT_NEAR(b, 0.015, 1e-9);
  EXPECT_FALSE(FitOffsetScale({s.begin(), s.begin() + 5}, &a, &b));  // too few
}

TEST(DepthBias, SteepMeansNearVertical) {
  EXPECT_TRUE(IsSteep(M_PI / 2));
  EXPECT_TRUE(IsSteep(-M_PI / 3));
  EXPECT_TRUE(IsSteep(2.0));  // 115 deg
  EXPECT_FALSE(IsSteep(M_PI / 6));
  EXPECT_FALSE(IsSteep(M_PI - 0.3));
}

}  // namespace
}  // namespace pl_slam::bench
