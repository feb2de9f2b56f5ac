#include "pl_slam/eval/plot.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

namespace {

const cv::Scalar kWhite(255, 255, 255);
const cv::Scalar kText(35, 35, 35);
const cv::Scalar kMutedText(95, 95, 95);
const cv::Scalar kGrid(232, 232, 232);
const cv::Scalar kFrame(120, 120, 120);
const cv::Scalar kRmseColor(40, 40, 200);    // red, dashed
const cv::Scalar kFillColor(236, 220, 200);  // light tint of the estimate colour
constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kShift = 4;  // fractional bits for sub-pixel drawing
constexpr double kSub = 16.0;
constexpr double kTickScale = 0.42;
constexpr double kLabelScale = 0.5;

// Layout of a panel, pixels.
constexpr int kLeftMargin = 78;
constexpr int kRightMargin = 24;

cv::Point Sub(const cv::Point2d& p) { return cv::Point(cvRound(p.x * kSub), cvRound(p.y * kSub)); }

cv::Size TextSize(const std::string& s, double scale, int thickness = 1) {
  int baseline = 0;
  return cv::getTextSize(s, kFont, scale, thickness, &baseline);
}

// Text with its baseline starting at (x, y).
void Text(cv::Mat& img, const std::string& s, int x, int y, double scale, const cv::Scalar& color,
          int thickness = 1) {
  cv::putText(img, s, cv::Point(x, y), kFont, scale, color, thickness, cv::LINE_AA);
}

// Text drawn bottom-to-top, centred on `center`.
void VerticalText(cv::Mat& img, const std::string& s, cv::Point center, double scale,
                  const cv::Scalar& color) {
  int baseline = 0;
  const cv::Size sz = cv::getTextSize(s, kFont, scale, 1, &baseline);
  cv::Mat mask(sz.height + baseline + 4, sz.width + 4, CV_8UC1, cv::Scalar(0));
  cv::putText(mask, s, cv::Point(2, sz.height + 2), kFont, scale, cv::Scalar(255), 1, cv::LINE_AA);
  cv::Mat rotated;
  cv::rotate(mask, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const cv::Rect roi(center.x - rotated.cols / 2, center.y - rotated.rows / 2, rotated.cols,
                     rotated.rows);
  const cv::Rect clipped = roi & cv::Rect(0, 0, img.cols, img.rows);
  for (int r = clipped.y; r < clipped.y + clipped.height; ++r) {
    for (int c = clipped.x; c < clipped.x + clipped.width; ++c) {
      const double a = rotated.at<uchar>(r - roi.y, c - roi.x) / 255.0;
      if (a <= 0.0) continue;
      cv::Vec3b& px = img.at<cv::Vec3b>(r, c);
      for (int k = 0; k < 3; ++k) {
        px[k] = cv::saturate_cast<uchar>((1.0 - a) * px[k] + a * color[k]);
      }
    }
  }
}

// 1, 2 or 5 times a power of ten, close to `raw`.
double NiceStep(double raw) {
  if (!(raw > 0.0) || !std::isfinite(raw)) return 1.0;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / p;
  const double nice = f < 1.5 ? 1.0 : (f < 3.5 ? 2.0 : (f < 7.5 ? 5.0 : 10.0));
  return nice * p;
}

std::string TickLabel(double v, double step) {
  const int decimals = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  if (std::fabs(v) < step * 1e-6) v = 0.0;  // no "-0.0"
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string Format(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

// Data-to-pixel mapping of one panel.
struct Axes {
  cv::Rect area;
  double x0 = 0.0, x1 = 1.0, y0 = 0.0, y1 = 1.0;

  cv::Point2d ToPx(double x, double y) const {
    return {area.x + (x - x0) / (x1 - x0) * area.width,
            area.y + area.height - (y - y0) / (y1 - y0) * area.height};
  }
};

// Grid, tick labels, frame and axis labels.
void DrawAxes(cv::Mat& img, const Axes& ax, double xstep, double ystep, const std::string& xlabel,
              const std::string& ylabel) {
  const cv::Rect& a = ax.area;
  const int tick_h = TextSize("0", kTickScale).height;
  for (double v = std::ceil(ax.x0 / xstep - 1e-9) * xstep; v <= ax.x1 + 1e-9 * xstep; v += xstep) {
    const double px = ax.ToPx(v, ax.y0).x;
    cv::line(img, Sub({px, double(a.y)}), Sub({px, double(a.y + a.height)}), kGrid, 1, cv::LINE_AA,
             kShift);
    const std::string s = TickLabel(v, xstep);
    const cv::Size sz = TextSize(s, kTickScale);
    const int tx = std::min(cvRound(px - sz.width / 2.0), img.cols - 3 - sz.width);
    Text(img, s, tx, a.y + a.height + tick_h + 8, kTickScale, kMutedText);
  }
  int widest = 0;
  for (double v = std::ceil(ax.y0 / ystep - 1e-9) * ystep; v <= ax.y1 + 1e-9 * ystep; v += ystep) {
    const double py = ax.ToPx(ax.x0, v).y;
    cv::line(img, Sub({double(a.x), py}), Sub({double(a.x + a.width), py}), kGrid, 1, cv::LINE_AA,
             kShift);
    const std::string s = TickLabel(v, ystep);
    const cv::Size sz = TextSize(s, kTickScale);
    widest = std::max(widest, sz.width);
    Text(img, s, a.x - 7 - sz.width, cvRound(py + sz.height / 2.0), kTickScale, kMutedText);
  }
  cv::rectangle(img, a, kFrame, 1, cv::LINE_8);
  const cv::Size xl = TextSize(xlabel, kLabelScale);
  Text(img, xlabel, a.x + (a.width - xl.width) / 2, a.y + a.height + 2 * tick_h + 24, kLabelScale,
       kText);
  VerticalText(img, ylabel, cv::Point(a.x - 7 - widest - 16, a.y + a.height / 2), kLabelScale,
               kText);
}

// Drops points closer than `min_px` to the last kept one (dense ground truth would otherwise
// be thousands of sub-pixel segments).
std::vector<cv::Point2d> Decimate(const std::vector<cv::Point2d>& pts, double min_px) {
  std::vector<cv::Point2d> out;
  for (const cv::Point2d& p : pts) {
    if (out.empty() || cv::norm(p - out.back()) >= min_px) out.push_back(p);
  }
  if (!pts.empty() && out.size() > 1 && out.back() != pts.back()) out.push_back(pts.back());
  return out;
}

void DrawPolyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& color,
                  int thickness) {
  if (pts.size() < 2) return;
  std::vector<cv::Point> sub;
  sub.reserve(pts.size());
  for (const cv::Point2d& p : pts) sub.push_back(Sub(p));
  cv::polylines(img, std::vector<std::vector<cv::Point>>{sub}, false, color, thickness, cv::LINE_AA,
                kShift);
}

// Dashed polyline: the dash pattern runs continuously along the path.
void DrawDashedPolyline(cv::Mat& img, const std::vector<cv::Point2d>& pts, const cv::Scalar& color,
                        int thickness, double on, double off) {
  double phase = 0.0;
  std::vector<cv::Point2d> dash;
  for (std::size_t k = 1; k < pts.size(); ++k) {
    const cv::Point2d a = pts[k - 1];
    const cv::Point2d d = pts[k] - a;
    const double len = cv::norm(d);
    if (len <= 0.0) continue;
    double s = 0.0;
    while (s < len) {
      const bool drawing = phase < on;
      const double step = std::min(drawing ? on - phase : on + off - phase, len - s);
      if (drawing) {
        if (dash.empty()) dash.push_back(a + d * (s / len));
        dash.push_back(a + d * ((s + step) / len));
      }
      s += step;
      phase += step;
      if (drawing && phase >= on - 1e-9) {
        DrawPolyline(img, dash, color, thickness);
        dash.clear();
      }
      if (phase >= on + off - 1e-9) phase = 0.0;
    }
  }
  DrawPolyline(img, dash, color, thickness);
}

// The two axes (0 = x, 1 = y, 2 = z) with the largest extent, in index order.
std::array<int, 2> LargestAxes(const Eigen::Vector3d& extent) {
  int smallest = 0;
  for (int k = 1; k < 3; ++k) {
    if (extent[k] < extent[smallest]) smallest = k;
  }
  std::array<int, 2> out{};
  int n = 0;
  for (int k = 0; k < 3; ++k) {
    if (k != smallest) out[n++] = k;
  }
  return out;
}

void DrawLegend(cv::Mat& img, const Axes& ax, const std::vector<cv::Point2d>& gt_px,
                const std::vector<cv::Point2d>& est_px, const std::string& est_label) {
  const double scale = 0.48;
  const std::array<std::string, 3> labels = {"ground truth", est_label, "start"};
  int text_w = 0;
  for (const std::string& s : labels) text_w = std::max(text_w, TextSize(s, scale).width);
  const int row_h = 22;
  const int sample_w = 34;
  const cv::Size box(14 + sample_w + 10 + text_w + 14, 10 + row_h * 3 + 6);
  const int pad = 12;
  const cv::Rect& a = ax.area;
  // Corner with the fewest curve points under it, preferring top-left, top-right, ...
  const std::array<cv::Rect, 4> corners = {
      cv::Rect(a.x + pad, a.y + pad, box.width, box.height),
      cv::Rect(a.x + a.width - pad - box.width, a.y + pad, box.width, box.height),
      cv::Rect(a.x + pad, a.y + a.height - pad - box.height, box.width, box.height),
      cv::Rect(a.x + a.width - pad - box.width, a.y + a.height - pad - box.height, box.width,
               box.height)};
  std::size_t best = 0;
  std::size_t best_hits = static_cast<std::size_t>(-1);
  for (std::size_t c = 0; c < corners.size(); ++c) {
    const cv::Rect grown(corners[c].x - 6, corners[c].y - 6, corners[c].width + 12,
                         corners[c].height + 12);
    std::size_t hits = 0;
    for (const auto* pts : {&gt_px, &est_px}) {
      for (const cv::Point2d& p : *pts)
        hits += grown.contains(cv::Point(cvRound(p.x), cvRound(p.y)));
    }
    if (hits < best_hits) {
      best_hits = hits;
      best = c;
    }
  }
  const cv::Rect r = corners[best];
  cv::rectangle(img, r, kWhite, cv::FILLED);
  cv::rectangle(img, r, cv::Scalar(200, 200, 200), 1, cv::LINE_8);
  for (int i = 0; i < 3; ++i) {
    const double cy = r.y + 10 + row_h * i + row_h / 2.0;
    const double x0 = r.x + 14;
    const double x1 = x0 + sample_w;
    if (i == 0) {
      DrawDashedPolyline(img, {{x0, cy}, {x1, cy}}, kGroundTruthColor, 2, 9.0, 5.0);
    } else if (i == 1) {
      DrawPolyline(img, {{x0, cy}, {x1, cy}}, kEstimateColor, 2);
    } else {
      cv::circle(img, Sub({(x0 + x1) / 2.0, cy}), cvRound(6 * kSub), kWhite, cv::FILLED,
                 cv::LINE_AA, kShift);
      cv::circle(img, Sub({(x0 + x1) / 2.0, cy}), cvRound(6 * kSub), kText, 2, cv::LINE_AA, kShift);
    }
    Text(img, labels[i], cvRound(x1 + 10), cvRound(cy + TextSize(labels[i], scale).height / 2.0),
         scale, kText);
  }
}

// "SE3 aligned", "Sim3 aligned", "first-pose aligned", "not aligned".
std::string AlignmentLabel(AlignmentMode mode) {
  switch (mode) {
    case AlignmentMode::kSE3:
      return "SE3 aligned";
    case AlignmentMode::kSim3:
      return "Sim3 aligned";
    case AlignmentMode::kFirstPose:
      return "first-pose aligned";
    case AlignmentMode::kNone:
      return "not aligned";
  }
  return AlignmentModeName(mode);
}

// Widest y tick label of a panel, pixels.
int WidestYTick(const Axes& ax, double ystep) {
  int widest = 0;
  for (double v = std::ceil(ax.y0 / ystep - 1e-9) * ystep; v <= ax.y1 + 1e-9 * ystep; v += ystep) {
    widest = std::max(widest, TextSize(TickLabel(v, ystep), kTickScale).width);
  }
  return widest;
}

// Left margin that fits the y tick labels and the vertical axis label.
int RequiredLeftMargin(const Axes& ax, double ystep) {
  return WidestYTick(ax, ystep) + 7 + 16 + 12 + 6;
}

// Mapping of the top view: the plane of largest extent, equal aspect, a grid step.
struct TrajectoryLayout {
  Axes ax;
  double step = 1.0;
  std::array<int, 2> axes{{0, 1}};
};

TrajectoryLayout LayoutTrajectory(const cv::Rect& panel, int left_margin, const Trajectory& gt,
                                  const Trajectory& est) {
  TrajectoryLayout l;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  Eigen::Vector3d hi = -lo;
  for (const Trajectory* traj : {&gt, &est}) {
    for (const StampedPose& p : *traj) {
      lo = lo.cwiseMin(p.T_w_c.translation());
      hi = hi.cwiseMax(p.T_w_c.translation());
    }
  }
  // The plane comes from the ground truth when there is one, so a diverging estimate does
  // not flip the view.
  Eigen::Vector3d extent = hi - lo;
  if (gt.size() >= 2) {
    Eigen::Vector3d l = gt.front().T_w_c.translation();
    Eigen::Vector3d h = l;
    for (const StampedPose& p : gt) {
      l = l.cwiseMin(p.T_w_c.translation());
      h = h.cwiseMax(p.T_w_c.translation());
    }
    extent = h - l;
  }
  l.axes = LargestAxes(extent);

  Axes& ax = l.ax;
  ax.area = cv::Rect(panel.x + left_margin, panel.y + 52, panel.width - left_margin - kRightMargin,
                     panel.height - 52 - 62);
  const double cx = 0.5 * (lo[l.axes[0]] + hi[l.axes[0]]);
  const double cy = 0.5 * (lo[l.axes[1]] + hi[l.axes[1]]);
  double rx = hi[l.axes[0]] - lo[l.axes[0]];
  double ry = hi[l.axes[1]] - lo[l.axes[1]];
  if (std::max(rx, ry) < 1e-3) rx = ry = 1.0;  // a single point: show a metre around it
  // Equal aspect: metres per pixel from the tighter axis with 12 % padding; the other axis
  // is widened so the data is centred and the frame fills the panel.
  const double m_per_px = 1.12 * std::max(rx / ax.area.width, ry / ax.area.height);
  ax.x0 = cx - 0.5 * m_per_px * ax.area.width;
  ax.x1 = cx + 0.5 * m_per_px * ax.area.width;
  ax.y0 = cy - 0.5 * m_per_px * ax.area.height;
  ax.y1 = cy + 0.5 * m_per_px * ax.area.height;
  l.step = NiceStep(m_per_px * 95.0);  // a grid line about every 95 px
  return l;
}

// Mapping of the error-over-time panel; errors shown in millimetres when they are small.
struct ErrorLayout {
  Axes ax;
  double xstep = 1.0;
  double ystep = 1.0;
  double unit = 1.0;  // multiplier from metres to the displayed unit
  double t0 = 0.0;
  std::string unit_name = "m";
};

ErrorLayout LayoutErrors(const cv::Rect& panel, int left_margin, const AteResult& ate) {
  ErrorLayout l;
  Axes& ax = l.ax;
  ax.area = cv::Rect(panel.x + left_margin, panel.y + 30, panel.width - left_margin - kRightMargin,
                     panel.height - 30 - 62);
  const std::size_t n = std::min(ate.times.size(), ate.translation_errors.size());
  double t1 = 0.0;
  double emax = 0.0;
  if (n > 0) {
    l.t0 = *std::min_element(ate.times.begin(), ate.times.begin() + n);
    t1 = *std::max_element(ate.times.begin(), ate.times.begin() + n);
    emax = *std::max_element(ate.translation_errors.begin(), ate.translation_errors.begin() + n);
  }
  if (emax < 0.05) {
    l.unit = 1000.0;
    l.unit_name = "mm";
  }
  // In millimetres (errors below 5 cm) at least 1 mm of range, so a perfect estimate still
  // gets a readable axis; in metres the errors are at least 5 cm already.
  const double top = std::max(emax * l.unit, l.unit == 1.0 ? 0.05 : 1.0);
  l.ystep = NiceStep(top * 1.1 / 3.0);
  ax.y0 = 0.0;
  ax.y1 = std::max(l.ystep, std::ceil(top * 1.08 / l.ystep - 1e-9) * l.ystep);
  const double duration = std::max(t1 - l.t0, 1.0);
  ax.x0 = 0.0;
  ax.x1 = duration;
  l.xstep = NiceStep(duration * 95.0 / ax.area.width);
  return l;
}

void DrawMarker(cv::Mat& img, const cv::Point2d& p) {
  cv::circle(img, Sub(p), cvRound(6 * kSub), kWhite, cv::FILLED, cv::LINE_AA, kShift);
  cv::circle(img, Sub(p), cvRound(6 * kSub), kText, 2, cv::LINE_AA, kShift);
}

void DrawTrajectoryPanel(cv::Mat& img, const cv::Rect& panel, const TrajectoryLayout& layout,
                         const Trajectory& gt, const Trajectory& est, const AteResult& ate,
                         const PlotOptions& options) {
  const Axes& ax = layout.ax;
  // Title: sequence name, then the ATE.
  const std::string mode_label = AlignmentLabel(ate.alignment.mode);
  int x = ax.area.x - 40;
  const int title_y = panel.y + 32;
  if (!options.name.empty()) {
    Text(img, options.name, x, title_y, 0.68, kText, 2);
    x += TextSize(options.name, 0.68, 2).width + 18;
  }
  const std::string title = ate.translation.count == 0
                                ? std::string("ATE RMSE n/a")
                                : "ATE RMSE " + Format("%.4f m", ate.translation.rmse);
  Text(img, title, x, title_y, 0.6, kText, 1);
  x += TextSize(title, 0.6).width + 14;
  std::string detail = "(" + mode_label + ", " + std::to_string(ate.translation.count) +
                       (ate.translation.count == 1 ? " pose" : " poses");
  if (ate.alignment.mode == AlignmentMode::kSim3) {
    detail += Format(", scale %.4f", ate.alignment.scale);
  }
  detail += ")";
  Text(img, detail, x, title_y, 0.5, kMutedText, 1);

  const char* names[3] = {"x [m]", "y [m]", "z [m]"};
  cv::rectangle(img, ax.area, kWhite, cv::FILLED);
  DrawAxes(img, ax, layout.step, layout.step, names[layout.axes[0]], names[layout.axes[1]]);

  auto to_px = [&](const Trajectory& traj) {
    std::vector<cv::Point2d> pts;
    pts.reserve(traj.size());
    for (const StampedPose& p : traj) {
      const Eigen::Vector3d& t = p.T_w_c.translation();
      pts.push_back(ax.ToPx(t[layout.axes[0]], t[layout.axes[1]]));
    }
    return pts;
  };
  const std::vector<cv::Point2d> gt_px = Decimate(to_px(gt), 1.5);
  const std::vector<cv::Point2d> est_px = Decimate(to_px(est), 1.0);

  // Estimate first: the dashed ground truth on top stays visible where the two overlap.
  // A trajectory that collapses to one pixel (one pose, a stuck tracker) is drawn as a dot.
  DrawPolyline(img, est_px, kEstimateColor, 2);
  if (gt_px.size() == 1) {
    cv::circle(img, Sub(gt_px.front()), cvRound(4 * kSub), kGroundTruthColor, cv::FILLED,
               cv::LINE_AA, kShift);
  }
  DrawDashedPolyline(img, gt_px, kGroundTruthColor, 2, 9.0, 5.0);
  const std::vector<cv::Point2d>& start_src = gt_px.empty() ? est_px : gt_px;
  if (!start_src.empty()) DrawMarker(img, start_src.front());
  if (est_px.size() == 1) {  // on top of the start marker it would otherwise hide under
    cv::circle(img, Sub(est_px.front()), cvRound(4 * kSub), kEstimateColor, cv::FILLED, cv::LINE_AA,
               kShift);
  }
  cv::rectangle(img, ax.area, kFrame, 1, cv::LINE_8);
  DrawLegend(img, ax, gt_px, est_px, "estimate (" + mode_label + ")");
}

void DrawErrorPanel(cv::Mat& img, const cv::Rect& panel, const ErrorLayout& layout,
                    const AteResult& ate) {
  const Axes& ax = layout.ax;
  Text(img, "translation error over time", ax.area.x, panel.y + 20, 0.5, kText, 1);
  cv::rectangle(img, ax.area, kWhite, cv::FILLED);
  DrawAxes(img, ax, layout.xstep, layout.ystep, "time [s]", "error [" + layout.unit_name + "]");
  const std::size_t n = std::min(ate.times.size(), ate.translation_errors.size());
  if (n == 0) return;

  std::vector<cv::Point2d> pts;
  for (std::size_t i = 0; i < n; ++i) {
    pts.push_back(ax.ToPx(ate.times[i] - layout.t0, ate.translation_errors[i] * layout.unit));
  }
  const std::vector<cv::Point2d> curve = Decimate(pts, 1.0);
  // Light fill under the curve, then the curve and the RMSE level.
  std::vector<cv::Point> poly;
  poly.push_back(Sub(ax.ToPx(ate.times.front() - layout.t0, 0.0)));
  for (const cv::Point2d& p : curve) poly.push_back(Sub(p));
  poly.push_back(Sub(ax.ToPx(ate.times[n - 1] - layout.t0, 0.0)));
  if (curve.size() >= 2) {
    cv::fillPoly(img, std::vector<std::vector<cv::Point>>{poly}, kFillColor, cv::LINE_AA, kShift);
  }
  if (curve.size() == 1) {
    cv::circle(img, Sub(curve.front()), cvRound(3 * kSub), kEstimateColor, cv::FILLED, cv::LINE_AA,
               kShift);
  }
  DrawPolyline(img, curve, kEstimateColor, 1);
  const double rmse_y = ax.ToPx(0.0, ate.translation.rmse * layout.unit).y;
  DrawDashedPolyline(img,
                     {{double(ax.area.x), rmse_y}, {double(ax.area.x + ax.area.width), rmse_y}},
                     kRmseColor, 1, 7.0, 4.0);
  // Key of the dashed line in the header, right-aligned, so it never hides the curve.
  const std::string label =
      "rmse " + (layout.unit == 1.0 ? Format("%.4f m", ate.translation.rmse)
                                    : Format("%.2f mm", ate.translation.rmse * layout.unit));
  const cv::Size sz = TextSize(label, 0.45);
  const int lx = ax.area.x + ax.area.width - sz.width;
  const double ky = panel.y + 20 - sz.height / 2.0;
  DrawDashedPolyline(img, {{lx - 40.0, ky}, {lx - 8.0, ky}}, kRmseColor, 2, 7.0, 4.0);
  Text(img, label, lx, panel.y + 20, 0.45, kText);
  cv::rectangle(img, ax.area, kFrame, 1, cv::LINE_8);
}

}  // namespace

void PlotOptions::Validate() const {
  if (width < 400) throw ConfigError("plot width = " + std::to_string(width) + ": must be >= 400");
  if (height < 300) {
    throw ConfigError("plot height = " + std::to_string(height) + ": must be >= 300");
  }
  if (error_panel_height != 0 && error_panel_height < 150) {
    throw ConfigError("plot error_panel_height = " + std::to_string(error_panel_height) +
                      ": must be 0 (no panel) or >= 150");
  }
}

cv::Mat RenderTrajectoryPlot(const Trajectory& gt, const Trajectory& est_aligned,
                             const AteResult& ate, const PlotOptions& options) {
  options.Validate();
  if (gt.empty() && est_aligned.empty()) throw InputError("plot: both trajectories are empty");
  cv::Mat img(options.height + options.error_panel_height, options.width, CV_8UC3,
              cv::Scalar(250, 250, 250));
  const cv::Rect top(0, 0, options.width, options.height);
  const cv::Rect bottom(0, options.height, options.width, options.error_panel_height);
  // Both panels share the left edge of their frames; widen the margin until the widest tick
  // label of either fits (the ranges, hence the labels, depend on the margin a little).
  int margin = kLeftMargin;
  TrajectoryLayout traj;
  ErrorLayout err;
  for (int iter = 0; iter < 3; ++iter) {
    traj = LayoutTrajectory(top, margin, gt, est_aligned);
    int need = RequiredLeftMargin(traj.ax, traj.step);
    if (options.error_panel_height > 0) {
      err = LayoutErrors(bottom, margin, ate);
      need = std::max(need, RequiredLeftMargin(err.ax, err.ystep));
    }
    if (need <= margin) break;
    margin = std::min(need, options.width / 3);
  }
  DrawTrajectoryPanel(img, top, traj, gt, est_aligned, ate, options);
  if (options.error_panel_height > 0) DrawErrorPanel(img, bottom, err, ate);
  return img;
}

void WriteTrajectoryPlot(const std::string& path, const Trajectory& gt,
                         const Trajectory& est_aligned, const AteResult& ate,
                         const PlotOptions& options) {
  const cv::Mat img = RenderTrajectoryPlot(gt, est_aligned, ate, options);
  bool ok = false;
  try {
    ok = cv::imwrite(path, img);
  } catch (const cv::Exception& e) {
    throw InputError(path + ": cannot write the plot (" + e.what() + ")");
  }
  if (!ok) throw InputError(path + ": cannot write the plot (bad extension or folder?)");
}

}  // namespace eval
}  // namespace pl_slam
