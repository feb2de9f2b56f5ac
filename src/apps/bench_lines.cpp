// pl_slam_bench_lines: timing and quality of the line front end (detection + LBD, stereo
// matching, frame-to-frame matching) on real and synthetic images. Not a test: it prints
// numbers for tuning and for the record.
//
//   timing:   --data DIR (EuRoC or KITTI folder, rectified by the dataset reader)
//   accuracy: --gt DIR (stereo_disparity_gt: KITTI 2015 000046_10, Middlebury Motorcycle Q)
//   f2f:      --sim room|corridor (synthetic sequence with exact depth and poses)
//   recall:   --recall lowtex_corner [--bare] [--seeds 1,2,3] (edges the world knows: recall,
//             precision, stereo depth and endpoint offsets of each detector)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <thread>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "pl_slam/features/line_features.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/matching/line_matching.h"
#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/error.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

constexpr char kUsage[] =
    "usage: pl_slam_bench_lines [--data DIR] [--gt DIR] [--sim room|corridor] [--recall SCENE]\n"
    "                           [options]\n"
    "  --recall SCENE      recall / precision against a lowtex scene's structural edges\n"
    "                      (every 5th frame; --bare, --seeds 1,2,3, --frames N = whole walk,\n"
    "                      --exposure normal|dim|bright)\n"
    "  --frames N          frames for timing / simulation (default 100 / 40)\n"
    "  --detector edge|lsd segment detector (default edge)\n"
    "  --max-lines N       lines kept per image (default: detector default)\n"
    "  --min-length R      min_length_ratio (default: detector default)\n"
    "  --low-contrast-cell N  low_contrast_cell (default: detector default)\n"
    "  --stereo-ratio R    stereo ratio test (default: matcher default)\n"
    "  --f2f-ratio R       frame-to-frame ratio test (default: matcher default)\n"
    "  --max-distance D    largest Hamming distance (default: matcher default)\n"
    "  --min-stereo-angle A  min_stereo_angle_deg (default: matcher default)\n"
    "  --no-merge          do not merge collinear pieces\n"
    "  --verbose           print every scored stereo match (--gt)\n"
    "  --opencv-threads N  cv::setNumThreads (default 1: the tracker runs images in parallel)\n";

double Ms(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// "median / p95 (n)" of a sample.
std::string Stats(std::vector<double> v) {
  if (v.empty()) return "n/a";
  std::sort(v.begin(), v.end());
  const double med = v[v.size() / 2];
  const double p95 = v[std::min(v.size() - 1, static_cast<size_t>(std::ceil(0.95 * v.size())) - 1)];
  std::ostringstream os;
  os.precision(3);
  os << std::fixed << med << " / " << p95;
  return os.str();
}

double Median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

cv::Mat ReadGray(const std::string& path) {
  cv::Mat img = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (img.empty()) throw pl_slam::InputError(path + ": cannot read image");
  return img;
}

// Middlebury PFM (little-endian when the scale is negative; rows stored bottom-up). OpenCV's
// reader scales the values by 1/|scale|, which is wrong for Middlebury disparities.
cv::Mat ReadPfm(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  in >> magic >> w >> h >> scale;
  in.get();
  if (!in || magic != "Pf" || w <= 0 || h <= 0 || scale >= 0) {
    throw pl_slam::InputError(path + ": not a little-endian single-channel PFM");
  }
  cv::Mat d(h, w, CV_32FC1);
  for (int y = h - 1; y >= 0; --y) in.read(reinterpret_cast<char*>(d.ptr<float>(y)), 4 * w);
  if (!in) throw pl_slam::InputError(path + ": truncated PFM");
  return d;
}

struct Setup {
  pl_slam::LineDetectorOptions det;
  pl_slam::LineMatchingOptions match;
  bool verbose = false;  // print every scored stereo match
};

// ---------------------------------------------------------------------------------------
// CPU time of the calling thread: on a shared machine it is far less noisy than wall time,
// which also counts the time other processes hold the core.
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

// Wall and thread-CPU time of one call.
template <typename F>
void Time(F&& f, std::vector<double>* wall, std::vector<double>* cpu) {
  const double c0 = ThreadCpuMs();
  const auto t0 = Clock::now();
  f();
  wall->push_back(Ms(t0));
  cpu->push_back(ThreadCpuMs() - c0);
}

void RunTiming(const Setup& setup, const std::string& folder, int frames) {
  // Rectified frames through the dataset reader; all loaded first so that I/O is not timed.
  auto source = pl_slam::OpenDatasetFolder(folder);
  const pl_slam::StereoCamera cam = source->camera();
  std::vector<pl_slam::StereoFrame> data;
  pl_slam::StereoFrame fr;
  while (static_cast<int>(data.size()) < frames && source->Next(&fr)) data.push_back(fr);
  if (data.empty()) throw pl_slam::InputError(folder + ": no frames");

  // Ground-truth pose of each frame (nearest stamp), to check frame-to-frame matches.
  const pl_slam::Trajectory& gt = source->ground_truth();
  auto gt_pose = [&](const pl_slam::StereoFrame& f, pl_slam::SE3* T_w_c) {
    if (gt.empty()) return false;
    auto it = std::lower_bound(gt.begin(), gt.end(), f.stamp_s(),
                               [](const pl_slam::StampedPose& p, double t) { return p.t < t; });
    if (it == gt.end() ||
        (it != gt.begin() && std::abs((it - 1)->t - f.stamp_s()) < std::abs(it->t - f.stamp_s())))
      --it;
    if (std::abs(it->t - f.stamp_s()) > 0.01) return false;
    *T_w_c = it->T_w_c;
    return true;
  };
  // A match of a previous line with depth is consistent when its 3D endpoints, moved by the
  // true motion, project within 3 px of the current line.
  int f2f_checked[2] = {0, 0}, f2f_consistent[2] = {0, 0};
  std::vector<double> n_guided;
  auto check = [&](const pl_slam::LineFeatures& p, const pl_slam::LineFeatures& c,
                   const std::vector<std::pair<int, int>>& m, const pl_slam::SE3& T_cur_prev,
                   int kind) {
    for (const auto& [i, j] : m) {
      if (!p[i].has_depth) continue;
      const Eigen::Vector3d P = T_cur_prev * p[i].P_c, Q = T_cur_prev * p[i].Q_c;
      if (P.z() <= 0 || Q.z() <= 0) continue;
      const Eigen::Vector2d a = cam.Project(P), b = cam.Project(Q);
      const double da = std::abs(c[j].l.dot(Eigen::Vector3d(a.x(), a.y(), 1.0)));
      const double db = std::abs(c[j].l.dot(Eigen::Vector3d(b.x(), b.y(), 1.0)));
      ++f2f_checked[kind];
      f2f_consistent[kind] += std::max(da, db) < 3.0;
    }
  };

  const pl_slam::LineDetector detector(setup.det);
  std::vector<double> w_left, c_left, w_right, c_right, w_pair, w_stereo, c_stereo, w_f2f, c_f2f;
  std::vector<double> n_lines, n_stereo, n_f2f;
  pl_slam::LineFeatures prev;
  cv::Mat prev_desc;
  pl_slam::SE3 T_w_prev;
  bool prev_has_gt = false;
  for (const pl_slam::StereoFrame& f : data) {
    pl_slam::SE3 T_w_cur;
    const bool has_gt = gt_pose(f, &T_w_cur);
    pl_slam::LineFeatures left, right;
    cv::Mat ld, rd;
    Time([&] { detector.Detect(f.left, &left, &ld); }, &w_left, &c_left);
    Time([&] { detector.Detect(f.right, &right, &rd); }, &w_right, &c_right);
    // The tracker's layout: both images at once, one thread each.
    {
      pl_slam::LineFeatures l2, r2;
      cv::Mat ld2, rd2;
      const auto t0 = Clock::now();
      std::thread th([&] { detector.Detect(f.right, &r2, &rd2); });
      detector.Detect(f.left, &l2, &ld2);
      th.join();
      w_pair.push_back(Ms(t0));
    }
    int ns = 0;
    Time([&] { ns = pl_slam::MatchStereoLines(cam, &left, ld, right, rd, setup.match); }, &w_stereo,
         &c_stereo);
    n_lines.push_back(static_cast<double>(left.size()));
    n_stereo.push_back(ns);
    if (!prev.empty()) {
      std::vector<std::pair<int, int>> m;
      Time([&] { m = pl_slam::MatchLines(prev, prev_desc, left, ld, setup.match); }, &w_f2f,
           &c_f2f);
      n_f2f.push_back(static_cast<double>(m.size()));
      if (has_gt && prev_has_gt) {
        pl_slam::LinePrediction pred;
        pred.T_cur_prev = T_w_cur.inverse() * T_w_prev;
        pred.camera = cam;
        check(prev, left, m, pred.T_cur_prev, 0);
        const auto mg = pl_slam::MatchLines(prev, prev_desc, left, ld, setup.match, &pred);
        n_guided.push_back(static_cast<double>(mg.size()));
        check(prev, left, mg, pred.T_cur_prev, 1);
      }
    }
    prev = std::move(left);
    prev_desc = ld;
    T_w_prev = T_w_cur;
    prev_has_gt = has_gt;
  }
  std::cout << "timing on " << source->Describe() << " (" << data.size()
            << " rectified stereo frames, " << cam.width << "x" << cam.height
            << "), median / p95 in ms, wall | thread CPU:\n"
            << "  detect+LBD left          " << Stats(w_left) << " | " << Stats(c_left) << "\n"
            << "  detect+LBD right         " << Stats(w_right) << " | " << Stats(c_right) << "\n"
            << "  detect+LBD both (2 thr.) " << Stats(w_pair) << "\n"
            << "  stereo matching          " << Stats(w_stereo) << " | " << Stats(c_stereo) << "\n"
            << "  f2f matching             " << Stats(w_f2f) << " | " << Stats(c_f2f) << "\n"
            << "  lines per image " << Median(n_lines) << ", stereo matches " << Median(n_stereo)
            << ", f2f matches " << Median(n_f2f) << " (medians)\n";
  if (f2f_checked[0] > 0) {
    std::printf(
        "  f2f matches consistent with the true motion (3D endpoints reproject < 3 px): unguided "
        "%.1f%% "
        "of %d; guided by the true motion: %.1f%% of %d (%.0f matches/frame)\n",
        100.0 * f2f_consistent[0] / f2f_checked[0], f2f_checked[0],
        100.0 * f2f_consistent[1] / std::max(1, f2f_checked[1]), f2f_checked[1], Median(n_guided));
  }
}

// ---------------------------------------------------------------------------------------
// Endpoint-disparity errors of stereo line matches against a dense or semi-dense ground
// truth (<= 0 or non-finite = unknown). On every image row the segment covers, our
// disparity (linear between the endpoint disparities: exact for a 3D segment) is compared
// with the GT within +-2 px along the row: with the foreground's (largest valid disparity:
// an occluding edge belongs to the nearer surface) and with whichever agrees best (an upper
// bound). Per segment the median over rows counts; KITTI's LiDAR GT only has some rows.
struct GtScore {
  int lines = 0, matched = 0, scored = 0;
  int fg_1px = 0, fg_2px = 0, any_1px = 0, any_2px = 0;
  std::vector<double> fg_err;
};

GtScore ScoreAgainstGt(const pl_slam::LineFeatures& left, const std::vector<int>& right_of_left,
                       const pl_slam::LineFeatures& right, const cv::Mat& gt, bool verbose) {
  GtScore s;
  s.lines = static_cast<int>(left.size());
  for (size_t i = 0; i < left.size(); ++i) {
    if (right_of_left[i] < 0) continue;
    ++s.matched;
    const auto& l = left[i];
    const auto& r = right[right_of_left[i]];
    const double d_s = l.s.x() - (-(r.l(1) * l.s.y() + r.l(2)) / r.l(0));
    const double d_e = l.e.x() - (-(r.l(1) * l.e.y() + r.l(2)) / r.l(0));
    std::vector<double> fg, any;
    const int v0 = static_cast<int>(std::ceil(std::min(l.s.y(), l.e.y())));
    const int v1 = static_cast<int>(std::floor(std::max(l.s.y(), l.e.y())));
    for (int v = std::max(v0, 0); v <= std::min(v1, gt.rows - 1); ++v) {
      const double t = (v - l.s.y()) / (l.e.y() - l.s.y());
      const double u = l.s.x() + t * (l.e.x() - l.s.x());
      const double d = d_s + t * (d_e - d_s);
      double best_fg = -1.0, best_any = 1e9;
      for (int k = -2; k <= 2; ++k) {
        const int x = cvRound(u) + k;
        if (x < 0 || x >= gt.cols) continue;
        const float g = gt.at<float>(v, x);
        if (!std::isfinite(g) || g <= 0) continue;
        best_fg = std::max(best_fg, static_cast<double>(g));
        best_any = std::min(best_any, std::abs(g - d));
      }
      if (best_fg > 0) {
        fg.push_back(std::abs(best_fg - d));
        any.push_back(best_any);
      }
    }
    if (fg.size() < 3) continue;
    ++s.scored;
    const double e_fg = Median(fg), e_any = Median(any);
    if (verbose) {
      std::printf(
          "    s=(%.1f,%.1f) e=(%.1f,%.1f) len %.0f ang %.0f d=(%.2f,%.2f) rows %zu err fg %.2f "
          "any %.2f\n",
          l.s.x(), l.s.y(), l.e.x(), l.e.y(), l.length, l.angle * 180 / M_PI, d_s, d_e, fg.size(),
          e_fg, e_any);
    }
    s.fg_err.push_back(e_fg);
    s.fg_1px += e_fg <= 1.0;
    s.fg_2px += e_fg <= 2.0;
    s.any_1px += e_any <= 1.0;
    s.any_2px += e_any <= 2.0;
  }
  return s;
}

void RunGtPair(const Setup& setup, const std::string& name, const cv::Mat& l_img,
               const cv::Mat& r_img, const cv::Mat& gt, double max_disparity) {
  pl_slam::StereoCamera cam;  // disparities are scored, so any consistent model will do
  cam.fx = cam.fy = 700.0;
  cam.cx = l_img.cols / 2.0;
  cam.cy = l_img.rows / 2.0;
  cam.baseline = 0.5;
  cam.width = l_img.cols;
  cam.height = l_img.rows;
  pl_slam::LineMatchingOptions mo = setup.match;
  mo.max_disparity = max_disparity;
  const pl_slam::LineDetector detector(setup.det);
  pl_slam::LineFeatures left, right;
  cv::Mat ld, rd;
  detector.Detect(l_img, &left, &ld);
  detector.Detect(r_img, &right, &rd);
  std::vector<int> r_of_l;
  pl_slam::MatchStereoLines(cam, &left, ld, right, rd, mo, &r_of_l);
  const GtScore s = ScoreAgainstGt(left, r_of_l, right, gt, setup.verbose);
  auto pct = [&](int k) { return s.scored ? 100.0 * k / s.scored : 0.0; };
  std::printf(
      "  %-22s lines %3d  matched %3d  scored %3d  foreground-GT: <=1px %5.1f%%  <=2px %5.1f%%  "
      "median err %.2f px | best-side GT: <=1px %5.1f%%  <=2px %5.1f%%\n",
      name.c_str(), s.lines, s.matched, s.scored, pct(s.fg_1px), pct(s.fg_2px), Median(s.fg_err),
      pct(s.any_1px), pct(s.any_2px));
}

void RunGt(const Setup& setup, const fs::path& root) {
  std::cout
      << "stereo line matches vs ground-truth disparity (median over the rows of each segment):\n";
  const fs::path kitti = root / "KITTI_2015" / "training";
  if (fs::exists(kitti / "image_2" / "000046_10.png")) {
    const cv::Mat l = ReadGray((kitti / "image_2" / "000046_10.png").string());
    const cv::Mat r = ReadGray((kitti / "image_3" / "000046_10.png").string());
    cv::Mat raw =
        cv::imread((kitti / "disp_occ_0" / "000046_10.png").string(), cv::IMREAD_UNCHANGED);
    cv::Mat gt;
    raw.convertTo(gt, CV_32F, 1.0 / 256.0);
    RunGtPair(setup, "KITTI 2015 000046_10", l, r, gt, 250.0);
  }
  const fs::path mb = root / "MIDDLEBURY_2014" / "trainingQ" / "Motorcycle";
  if (fs::exists(mb / "im0.png")) {
    const cv::Mat l = ReadGray((mb / "im0.png").string());
    const cv::Mat r = ReadGray((mb / "im1.png").string());
    RunGtPair(setup, "Middlebury Motorcycle Q", l, r, ReadPfm((mb / "disp0GT.pfm").string()),
              100.0);
  }
}

// ---------------------------------------------------------------------------------------
// Ground-truth 3D points along a left-image segment: depth of the nearest surface among the
// pixel and its neighbours across the line (the edge belongs to the occluder).
bool GtSegment3D(const pl_slam::StereoCamera& cam, const cv::Mat& depth,
                 const pl_slam::LineFeature& f,
                 std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>* pts) {
  pts->clear();
  const Eigen::Vector2d n(f.l(0), f.l(1));
  for (int k = 1; k <= 9; ++k) {
    const Eigen::Vector2d p = f.s + (k / 10.0) * (f.e - f.s);
    float z = 0;
    for (double off : {0.0, -1.5, 1.5}) {
      const int x = cvRound(p.x() + off * n.x()), y = cvRound(p.y() + off * n.y());
      if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) continue;
      const float d = depth.at<float>(y, x);
      if (d > 0 && (z == 0 || d < z)) z = d;
    }
    if (z > 0) pts->push_back({(p.x() - cam.cx) * z / cam.fx, (p.y() - cam.cy) * z / cam.fy, z});
  }
  return pts->size() >= 3;
}

void RunSim(const Setup& setup, const std::string& scene, int frames) {
  pl_slam::sim::SequenceOptions so;
  so.scene = pl_slam::sim::ParseSceneKind(scene);
  // The scene's own length: a shorter sequence would stretch the same path over fewer
  // frames, i.e. faster motion. Only the first `frames` are processed.
  const pl_slam::sim::SyntheticSequence seq(so);
  const int n = std::min(frames, static_cast<int>(seq.size()));
  const pl_slam::StereoCamera& cam = seq.camera();
  const pl_slam::LineDetector detector(setup.det);

  struct FrameData {
    pl_slam::LineFeatures lines;
    cv::Mat desc;
    cv::Mat depth;
  };
  auto process = [&](int k) {
    FrameData fd;
    const pl_slam::StereoFrame fr = seq.Render(k);
    pl_slam::LineFeatures right;
    cv::Mat rd;
    detector.Detect(fr.left, &fd.lines, &fd.desc);
    detector.Detect(fr.right, &right, &rd);
    pl_slam::MatchStereoLines(cam, &fd.lines, fd.desc, right, rd, setup.match);
    fd.depth = seq.RenderDepth(k);
    return fd;
  };

  int stereo = 0, stereo_ok = 0, lines_total = 0;
  int f2f[2] = {0, 0}, f2f_ok[2] = {0, 0}, repeat_den = 0, repeat_num = 0;
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> pts;
  FrameData prev = process(0);
  for (int k = 1; k < n; ++k) {
    FrameData cur = process(k);
    const pl_slam::SE3 T_cur_prev =
        seq.ground_truth()[k].T_w_c.inverse() * seq.ground_truth()[k - 1].T_w_c;
    // Stereo disparity of the previous frame's lines vs. the rendered depth, compared at the
    // first and last GT sample (t = 0.1, 0.9; disparity is linear along the segment).
    for (const auto& f : prev.lines) {
      ++lines_total;
      if (!f.has_depth || !GtSegment3D(cam, prev.depth, f, &pts)) continue;
      ++stereo;
      const double ds = cam.DisparityFromDepth(f.P_c.z()), de = cam.DisparityFromDepth(f.Q_c.z());
      const double d0 = 0.9 * ds + 0.1 * de, d1 = 0.1 * ds + 0.9 * de;
      stereo_ok += std::abs(d0 - cam.DisparityFromDepth(pts.front().z())) < 0.5 &&
                   std::abs(d1 - cam.DisparityFromDepth(pts.back().z())) < 0.5;
    }
    // A previous line maps to a current line when its GT 3D points, moved by the true
    // motion, project within 2 px (median) of that line.
    auto correct = [&](int i, int j) {
      if (!GtSegment3D(cam, prev.depth, prev.lines[i], &pts)) return -1;
      std::vector<double> dist;
      for (const auto& p : pts) {
        const Eigen::Vector3d q = T_cur_prev * p;
        if (q.z() <= 0) continue;
        const Eigen::Vector2d uv = cam.Project(q);
        dist.push_back(std::abs(cur.lines[j].l.dot(Eigen::Vector3d(uv.x(), uv.y(), 1.0))));
      }
      return dist.size() >= 3 && Median(dist) < 2.0 ? 1 : 0;
    };
    pl_slam::LinePrediction pred;
    pred.T_cur_prev = T_cur_prev;
    pred.camera = cam;
    for (int guided = 0; guided < 2; ++guided) {
      const auto m = pl_slam::MatchLines(prev.lines, prev.desc, cur.lines, cur.desc, setup.match,
                                         guided ? &pred : nullptr);
      for (const auto& [i, j] : m) {
        const int c = correct(i, j);
        if (c < 0) continue;
        ++f2f[guided];
        f2f_ok[guided] += c;
      }
    }
    // Detector repeatability (descriptor-free): previous lines with a current segment at the
    // predicted place, same direction within 5 degrees, overlapping.
    for (int i = 0; i < static_cast<int>(prev.lines.size()); ++i) {
      if (!GtSegment3D(cam, prev.depth, prev.lines[i], &pts)) continue;
      const Eigen::Vector3d a = T_cur_prev * pts.front(), b = T_cur_prev * pts.back();
      if (a.z() <= 0 || b.z() <= 0) continue;
      const Eigen::Vector2d pa = cam.Project(a), pb = cam.Project(b);
      if (!cam.InImage(pa) || !cam.InImage(pb)) continue;
      ++repeat_den;
      const double ang = std::atan2(pb.y() - pa.y(), pb.x() - pa.x());
      for (const auto& c : cur.lines) {
        double da = std::fmod(std::abs(ang - c.angle), 2 * M_PI);
        if (da > M_PI) da = 2 * M_PI - da;
        if (da > 5.0 * M_PI / 180.0) continue;
        const double ea = c.l.dot(Eigen::Vector3d(pa.x(), pa.y(), 1)),
                     eb = c.l.dot(Eigen::Vector3d(pb.x(), pb.y(), 1));
        if (std::abs(ea) > 2.0 || std::abs(eb) > 2.0) continue;
        const Eigen::Vector2d u = (c.e - c.s) / c.length;
        const double t1 = u.dot(pa - c.s), t2 = u.dot(pb - c.s);
        if (std::max(t1, t2) < 0 || std::min(t1, t2) > c.length) continue;
        ++repeat_num;
        break;
      }
    }
    prev = std::move(cur);
  }
  auto pct = [](int a, int b) { return b ? 100.0 * a / b : 0.0; };
  std::printf(
      "synthetic %s, first %d frames: lines/frame %.1f, stereo depth %.1f%% of lines, disparity "
      "within 0.5 px: %.1f%%\n",
      scene.c_str(), n, static_cast<double>(lines_total) / (n - 1), pct(stereo, lines_total),
      pct(stereo_ok, stereo));
  std::printf("  detector repeatability %.1f%% (%d lines)\n", pct(repeat_num, repeat_den),
              repeat_den);
  std::printf(
      "  f2f unguided: %.1f matches/frame, %.1f%% correct; guided (true motion): %.1f "
      "matches/frame, "
      "%.1f%% correct\n",
      static_cast<double>(f2f[0]) / (n - 1), pct(f2f_ok[0], f2f[0]),
      static_cast<double>(f2f[1]) / (n - 1), pct(f2f_ok[1], f2f[1]));
}

// Recall and precision of the detector against the structural edges a low-texture scene
// knows (door frames, skirting, rails, room corners), every 5th frame: a visible edge at least
// as long as the detector's minimum counts as found when detections within 2 px and 3 deg of
// it cover half its length; a detection is correct when half of it lies on such an edge.
// Texture (posters, tiles) has no recorded edges, so precision is meaningful on --bare.
struct RecallStats {
  int edges = 0, found = 0, detections = 0, correct = 0, frames = 0;
  // Correct detections steep enough for stereo, those given a depth, and those whose depth is
  // within 0.5 px of disparity of the rendered one at both ends.
  int steep = 0, with_depth = 0, depth_ok = 0;
  // Correct detections' endpoint distances from their edge's line, px, signed positive
  // towards the edge's brighter side (where the two sides differ).
  std::vector<double> offsets;
  std::vector<double> ms;
};

// The unit normal of edge (a, b) pointing to its brighter side in `img` (sampled 3 px either
// side of the edge's middle); false where the two sides do not differ by 4 grey levels.
bool NormalTowardsBright(const cv::Mat& img, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                         Eigen::Vector2d* normal) {
  const Eigen::Vector2d u = (b - a).normalized();
  const Eigen::Vector2d n(-u.y(), u.x()), m = 0.5 * (a + b);
  auto grey = [&img](const Eigen::Vector2d& q) {
    const long x = std::lround(q.x()), y = std::lround(q.y());
    return (x < 0 || y < 0 || x >= img.cols || y >= img.rows)
               ? -1
               : static_cast<int>(img.at<uint8_t>(static_cast<int>(y), static_cast<int>(x)));
  };
  const int plus = grey(m + 3.0 * n), minus = grey(m - 3.0 * n);
  if (plus < 0 || minus < 0 || std::abs(plus - minus) < 4) return false;
  *normal = plus > minus ? n : Eigen::Vector2d(-n);
  return true;
}

// "median / p90 |offset|, mean offset" of the endpoint offsets, px.
std::string OffsetStats(const std::vector<double>& offsets) {
  if (offsets.empty()) return "n/a";
  std::vector<double> a;
  double sum = 0.0;
  for (double o : offsets) {
    a.push_back(std::abs(o));
    sum += o;
  }
  std::sort(a.begin(), a.end());
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.2f / %.2f, %+.2f", a[a.size() / 2], a[a.size() * 9 / 10],
                sum / offsets.size());
  return buf;
}

// Length of detection (s, e) lying within 2 px and 3 deg of edge (a, b), along the edge.
double Overlap(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& s,
               const Eigen::Vector2d& e) {
  const Eigen::Vector2d u = (b - a).normalized();
  const Eigen::Vector2d n(-u.y(), u.x());
  if (std::abs(n.dot(s - a)) > 2.0 || std::abs(n.dot(e - a)) > 2.0) return 0.0;
  const Eigen::Vector2d v = (e - s).normalized();
  if (std::abs(u.dot(v)) < std::cos(3.0 * M_PI / 180.0)) return 0.0;
  const double t0 = u.dot(s - a), t1 = u.dot(e - a);
  const double lo = std::max(0.0, std::min(t0, t1)),
               hi = std::min((b - a).norm(), std::max(t0, t1));
  return std::max(0.0, hi - lo);
}

void RunRecall(const std::string& scene, bool bare, const std::string& exposure,
               const std::vector<int>& seeds, int frames, const pl_slam::LineMatchingOptions& match,
               const std::vector<std::pair<std::string, pl_slam::LineDetectorOptions>>& configs) {
  const double min_sin = std::sin(match.min_stereo_angle_deg * M_PI / 180.0);
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> pts;
  std::vector<RecallStats> stats(configs.size());
  for (int seed : seeds) {
    pl_slam::sim::SequenceOptions so;
    so.scene = pl_slam::sim::ParseSceneKind(scene);
    so.bare = bare;
    so.world_seed = static_cast<uint64_t>(seed);
    so.num_frames = frames;
    pl_slam::sim::ApplyExposurePreset(exposure, &so);
    const pl_slam::sim::SyntheticSequence seq(so);
    for (int i = 0; i < static_cast<int>(seq.size()); i += 5) {
      const pl_slam::StereoFrame frame = seq.Render(i);
      const auto visible = seq.VisibleStructuralEdges(i);
      const cv::Mat depth = seq.RenderDepth(i);
      const pl_slam::StereoCamera& cam = seq.camera();
      for (size_t c = 0; c < configs.size(); ++c) {
        const pl_slam::LineDetector detector(configs[c].second);
        pl_slam::LineFeatures lines;
        cv::Mat desc;
        const auto t0 = Clock::now();
        detector.Detect(frame.left, &lines, &desc);
        stats[c].ms.push_back(Ms(t0));
        const double min_len =
            configs[c].second.min_length_ratio * std::min(frame.left.cols, frame.left.rows);
        RecallStats& st = stats[c];
        ++st.frames;
        for (const auto& g : visible) {
          if (g.length() < min_len) continue;
          double covered = 0.0;
          for (const auto& l : lines) covered += Overlap(g.a, g.b, l.s, l.e);
          ++st.edges;
          st.found += covered >= 0.5 * g.length();
        }
        pl_slam::LineFeatures right;
        cv::Mat right_desc;
        detector.Detect(frame.right, &right, &right_desc);
        pl_slam::MatchStereoLines(cam, &lines, desc, right, right_desc, match);
        for (const auto& l : lines) {
          ++st.detections;
          const pl_slam::sim::VisibleEdge* edge = nullptr;
          for (const auto& g : visible)
            if (Overlap(g.a, g.b, l.s, l.e) >= 0.5 * l.length) edge = &g;
          const bool on_edge = edge != nullptr;
          st.correct += on_edge;
          Eigen::Vector2d bright;
          if (on_edge && NormalTowardsBright(frame.left, edge->a, edge->b, &bright)) {
            st.offsets.push_back(bright.dot(l.s - edge->a));
            st.offsets.push_back(bright.dot(l.e - edge->a));
          }
          if (!on_edge || std::abs(std::sin(l.angle)) < min_sin) continue;
          ++st.steep;
          if (!l.has_depth) continue;
          ++st.with_depth;
          if (!GtSegment3D(cam, depth, l, &pts)) continue;
          const double ds = cam.DisparityFromDepth(l.P_c.z()),
                       de = cam.DisparityFromDepth(l.Q_c.z());
          st.depth_ok +=
              std::abs(0.9 * ds + 0.1 * de - cam.DisparityFromDepth(pts.front().z())) < 0.5 &&
              std::abs(0.1 * ds + 0.9 * de - cam.DisparityFromDepth(pts.back().z())) < 0.5;
        }
      }
    }
  }
  std::cout << "| detector | frames | edges | recall | detections / frame | precision | ms / image "
               "(median / p95) | steep edges with stereo depth | depth within 0.5 px | endpoint "
               "offset from the edge, px (median / p90 of its size, mean towards the bright "
               "side) |\n"
               "|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t c = 0; c < configs.size(); ++c) {
    const RecallStats& st = stats[c];
    std::printf("| %s | %d | %d | %.1f%% | %.1f | %.1f%% | %s | %.1f%% of %d | %.1f%% | %s |\n",
                configs[c].first.c_str(), st.frames, st.edges,
                100.0 * st.found / std::max(1, st.edges),
                static_cast<double>(st.detections) / std::max(1, st.frames),
                100.0 * st.correct / std::max(1, st.detections), Stats(st.ms).c_str(),
                100.0 * st.with_depth / std::max(1, st.steep), st.steep,
                100.0 * st.depth_ok / std::max(1, st.with_depth), OffsetStats(st.offsets).c_str());
  }
}

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv,
      {"data", "gt", "sim", "frames", "detector", "max-lines", "min-length", "low-contrast-cell",
       "stereo-ratio", "f2f-ratio", "max-distance", "min-stereo-angle", "opencv-threads", "recall",
       "seeds", "exposure"},
      {"no-merge", "help", "bare"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  if (!cl.Has("data") && !cl.Has("gt") && !cl.Has("sim") && !cl.Has("recall")) {
    std::cerr << kUsage;
    return 2;
  }
  cv::setNumThreads(cl.GetInt("opencv-threads", 1));
  Setup setup;
  const std::string det = cl.Get("detector", "edge");
  if (det == "lsd") {
    setup.det.detector = pl_slam::LineDetectorKind::kLsd;
  } else if (det != "edge") {
    throw pl_slam::ConfigError("--detector=" + det + " must be edge or lsd");
  }
  setup.det.max_lines = cl.GetInt("max-lines", setup.det.max_lines);
  setup.det.min_length_ratio = cl.GetDouble("min-length", setup.det.min_length_ratio);
  setup.det.low_contrast_cell = cl.GetInt("low-contrast-cell", setup.det.low_contrast_cell);
  setup.det.merge_collinear = !cl.Has("no-merge");
  setup.verbose = cl.Has("verbose");
  setup.match.stereo_ratio = cl.GetDouble("stereo-ratio", setup.match.stereo_ratio);
  setup.match.f2f_ratio = cl.GetDouble("f2f-ratio", setup.match.f2f_ratio);
  setup.match.max_distance = cl.GetInt("max-distance", setup.match.max_distance);
  setup.match.min_stereo_angle_deg =
      cl.GetDouble("min-stereo-angle", setup.match.min_stereo_angle_deg);
  for (const std::string& err : {setup.det.Validate(), setup.match.Validate()}) {
    if (!err.empty()) throw pl_slam::ConfigError(err);
  }
  std::cout << "detector " << det << ", max_lines " << setup.det.max_lines << ", min_length_ratio "
            << setup.det.min_length_ratio << ", merge " << setup.det.merge_collinear
            << ", stereo_ratio " << setup.match.stereo_ratio << ", f2f_ratio "
            << setup.match.f2f_ratio << ", max_distance " << setup.match.max_distance << "\n";
  if (cl.Has("data")) RunTiming(setup, cl.Get("data", ""), cl.GetInt("frames", 100));
  if (cl.Has("gt")) RunGt(setup, cl.Get("gt", ""));
  if (cl.Has("sim")) RunSim(setup, cl.Get("sim", ""), cl.GetInt("frames", 40));
  if (cl.Has("recall")) {
    std::vector<int> seeds;
    std::stringstream ss(cl.Get("seeds", "1"));
    for (std::string t; std::getline(ss, t, ',');) seeds.push_back(std::stoi(t));
    pl_slam::LineDetectorOptions single = setup.det;
    single.min_lines = 0;
    single.low_contrast_cell = 0;
    pl_slam::LineDetectorOptions lsd = setup.det;
    lsd.detector = pl_slam::LineDetectorKind::kLsd;
    RunRecall(cl.Get("recall", ""), cl.Has("bare"), cl.Get("exposure", "normal"), seeds,
              cl.GetInt("frames", 0), setup.match,
              {{"edge chain (default: low-contrast search below min_lines and in empty cells)",
                setup.det},
               {"edge chain, normal thresholds only", single},
               {"LSD", lsd}});
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return Run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "pl_slam_bench_lines: " << e.what() << "\n";
    return 1;
  }
}
