// Baseline tracker behind the SlamSystem facade: points-only stereo visual odometry (ORB,
// row-constrained stereo matching, frame-to-frame PnP with RANSAC). It makes every path that
// drives the system (offline runner, nodelet, demo, tests) real end to end; the point + line
// front end of the paper replaces the internals without changing this interface.
#include "pl_slam/system/slam_system.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/features2d.hpp>

#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {

const char* TrackingStateName(TrackingState state) {
  switch (state) {
    case TrackingState::kNotInitialized: return "NOT_INITIALIZED";
    case TrackingState::kTracking: return "TRACKING";
    case TrackingState::kLost: return "LOST";
  }
  return "UNKNOWN";
}

std::string SystemOptions::Validate() const {
  std::ostringstream os;
  if (max_points < 50 || max_points > 20000) os << "max_points=" << max_points << " must be in [50, 20000]";
  else if (!(max_disparity > 1.0 && max_disparity <= 1000.0)) os << "max_disparity=" << max_disparity << " must be in (1, 1000]";
  else if (!(min_disparity >= 0.0 && min_disparity < max_disparity)) os << "min_disparity=" << min_disparity << " must be in [0, max_disparity)";
  else if (min_inliers < 6 || min_inliers > 1000) os << "min_inliers=" << min_inliers << " must be in [6, 1000]";
  return os.str();
}

namespace {

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

/// Stereo-matched features of one frame: 3D points in the left camera and their descriptors.
struct StereoPoints {
  std::vector<cv::KeyPoint> keypoints;  // all left keypoints
  cv::Mat descriptors;                  // all left descriptors (rows match keypoints)
  std::vector<int> stereo_index;        // left keypoint indices with a stereo match
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> points_c;
  cv::Mat stereo_descriptors;           // rows of descriptors for stereo_index
};

}  // namespace

struct SlamSystem::Impl {
  StereoCamera camera;
  SystemOptions options;
  cv::Ptr<cv::ORB> orb;
  TrackingState state = TrackingState::kNotInitialized;
  SE3 T_w_c;             // pose of the last good frame
  SE3 velocity;          // T_prev_cur of the last good increment (constant-velocity prior)
  StereoPoints previous;
  bool has_previous = false;
  mutable std::mutex trajectory_mutex;  // guards trajectory only (readers on other threads)
  Trajectory trajectory;

  void DetectAndMatch(const StereoFrame& frame, StereoPoints* out, FrameResult* result);
};

void SlamSystem::Impl::DetectAndMatch(const StereoFrame& frame, StereoPoints* out,
                                       FrameResult* result) {
  auto t0 = Clock::now();
  std::vector<cv::KeyPoint> kp_r;
  cv::Mat desc_r;
  orb->detectAndCompute(frame.left, cv::noArray(), out->keypoints, out->descriptors);
  orb->detectAndCompute(frame.right, cv::noArray(), kp_r, desc_r);
  result->stage_ms.emplace_back("features", MsSince(t0));
  result->points_detected = static_cast<int>(out->keypoints.size());

  t0 = Clock::now();
  if (out->keypoints.empty() || kp_r.empty()) {
    result->stage_ms.emplace_back("stereo_matching", MsSince(t0));
    return;
  }
  // Row index of right keypoints so each left keypoint only looks at its epipolar band.
  const int band = 2;
  std::vector<std::vector<int>> rows(frame.right.rows);
  for (int j = 0; j < static_cast<int>(kp_r.size()); ++j) {
    const int v = std::clamp(static_cast<int>(std::lround(kp_r[j].pt.y)), 0, frame.right.rows - 1);
    rows[v].push_back(j);
  }
  std::vector<int> best_left_for_right(kp_r.size(), -1);
  std::vector<int> best_dist_for_right(kp_r.size(), 256);
  std::vector<int> match_of_left(out->keypoints.size(), -1);
  for (int i = 0; i < static_cast<int>(out->keypoints.size()); ++i) {
    const cv::KeyPoint& kl = out->keypoints[i];
    const int v = static_cast<int>(std::lround(kl.pt.y));
    int best = 256, second = 256, best_j = -1;
    for (int r = std::max(0, v - band); r <= std::min(frame.right.rows - 1, v + band); ++r) {
      for (int j : rows[r]) {
        const double d = kl.pt.x - kp_r[j].pt.x;
        if (d < options.min_disparity || d > options.max_disparity) continue;
        if (std::abs(kl.octave - kp_r[j].octave) > 1) continue;
        const int dist = cv::norm(out->descriptors.row(i), desc_r.row(j), cv::NORM_HAMMING);
        if (dist < best) { second = best; best = dist; best_j = j; }
        else if (dist < second) { second = dist; }
      }
    }
    // Absolute gate and ratio test (best clearly below the second best).
    if (best_j < 0 || best > 60 || best > 0.8 * second) continue;
    match_of_left[i] = best_j;
    if (best < best_dist_for_right[best_j]) {
      best_dist_for_right[best_j] = best;
      best_left_for_right[best_j] = i;
    }
  }
  for (int i = 0; i < static_cast<int>(out->keypoints.size()); ++i) {
    const int j = match_of_left[i];
    if (j < 0 || best_left_for_right[j] != i) continue;  // mutual best only
    const cv::Point2f& pl = out->keypoints[i].pt;
    const double d = pl.x - kp_r[j].pt.x;
    out->stereo_index.push_back(i);
    out->points_c.push_back(camera.BackProject(pl.x, pl.y, d));
  }
  out->stereo_descriptors = cv::Mat(static_cast<int>(out->stereo_index.size()), out->descriptors.cols,
                                    out->descriptors.type());
  for (int k = 0; k < static_cast<int>(out->stereo_index.size()); ++k) {
    out->descriptors.row(out->stereo_index[k]).copyTo(out->stereo_descriptors.row(k));
  }
  result->stage_ms.emplace_back("stereo_matching", MsSince(t0));
}

SlamSystem::SlamSystem(const StereoCamera& camera, const SystemOptions& options)
    : impl_(std::make_unique<Impl>()) {
  const std::string cam_error = camera.Validate();
  if (!cam_error.empty()) throw ConfigError("camera: " + cam_error);
  const std::string opt_error = options.Validate();
  if (!opt_error.empty()) throw ConfigError(opt_error);
  impl_->camera = camera;
  impl_->options = options;
  impl_->orb = cv::ORB::create(options.max_points);
}

SlamSystem::~SlamSystem() = default;

const StereoCamera& SlamSystem::camera() const { return impl_->camera; }

void SlamSystem::Reset() {
  impl_->state = TrackingState::kNotInitialized;
  impl_->T_w_c = SE3();
  impl_->velocity = SE3();
  impl_->has_previous = false;
  std::lock_guard<std::mutex> lock(impl_->trajectory_mutex);
  impl_->trajectory.clear();
}

Trajectory SlamSystem::trajectory() const {
  std::lock_guard<std::mutex> lock(impl_->trajectory_mutex);
  return impl_->trajectory;
}

FrameResult SlamSystem::Process(const StereoFrame& frame) {
  Impl& s = *impl_;
  const auto t_start = Clock::now();
  FrameResult result;
  result.T_w_c = s.T_w_c;

  const cv::Size expected(s.camera.width, s.camera.height);
  std::string bad;
  if (frame.left.empty() || frame.right.empty()) bad = "empty image";
  else if (frame.left.type() != CV_8UC1 || frame.right.type() != CV_8UC1) bad = "images must be 8-bit single channel";
  else if (frame.left.size() != frame.right.size()) bad = "left and right image sizes differ";
  else if (frame.left.size() != expected) bad = "image size differs from the calibration";
  if (!bad.empty()) {
    PL_LOG_WARN("frame " << frame.index << ": " << bad << "; frame skipped, tracking lost");
    result.state = s.state = (s.state == TrackingState::kNotInitialized) ? TrackingState::kNotInitialized
                                                                          : TrackingState::kLost;
    result.total_ms = MsSince(t_start);
    return result;
  }

  StereoPoints current;
  s.DetectAndMatch(frame, &current, &result);

  auto t0 = Clock::now();
  bool tracked = false;
  if (s.has_previous && !s.previous.points_c.empty() && !current.descriptors.empty()) {
    // Previous 3D points against current left keypoints: mutual best with a ratio test.
    cv::BFMatcher matcher(cv::NORM_HAMMING);
    std::vector<std::vector<cv::DMatch>> knn;
    matcher.knnMatch(s.previous.stereo_descriptors, current.descriptors, knn, 2);
    std::vector<cv::DMatch> reverse;
    matcher.match(current.descriptors, s.previous.stereo_descriptors, reverse);
    std::vector<cv::Point3f> object;
    std::vector<cv::Point2f> image;
    for (const auto& m : knn) {
      if (m.empty()) continue;
      if (m.size() > 1 && m[0].distance > 0.8f * m[1].distance) continue;
      if (m[0].distance > 64) continue;
      if (reverse[m[0].trainIdx].trainIdx != m[0].queryIdx) continue;
      const auto& p = s.previous.points_c[m[0].queryIdx];
      object.emplace_back(p.x(), p.y(), p.z());
      image.push_back(current.keypoints[m[0].trainIdx].pt);
    }
    if (static_cast<int>(object.size()) >= s.options.min_inliers) {
      cv::Mat K = (cv::Mat_<double>(3, 3) << s.camera.fx, 0, s.camera.cx, 0, s.camera.fy, s.camera.cy, 0, 0, 1);
      // Initial guess from the constant-velocity prior: T_cur_prev = velocity^-1.
      const SE3 prior = s.velocity.inverse();
      cv::Mat rvec, tvec;
      cv::Mat R_cv;
      cv::eigen2cv(Eigen::Matrix3d(prior.rotation()), R_cv);
      cv::Rodrigues(R_cv, rvec);
      cv::eigen2cv(Eigen::Vector3d(prior.translation()), tvec);
      std::vector<int> inliers;
      // RANSAC on minimal EPnP sets (independent of the prior, which may be poor after a
      // sudden motion change); the prior seeds only the final refinement below.
      cv::Mat rvec_r, tvec_r;
      const bool ok = cv::solvePnPRansac(object, image, K, cv::noArray(), rvec_r, tvec_r, false, 200,
                                         2.0f, 0.999, inliers, cv::SOLVEPNP_EPNP);
      if (ok && static_cast<int>(inliers.size()) >= s.options.min_inliers) {
        std::vector<cv::Point3f> obj_in;
        std::vector<cv::Point2f> img_in;
        for (int k : inliers) { obj_in.push_back(object[k]); img_in.push_back(image[k]); }
        cv::solvePnP(obj_in, img_in, K, cv::noArray(), rvec, tvec, true, cv::SOLVEPNP_ITERATIVE);
        cv::Mat R;
        cv::Rodrigues(rvec, R);
        Eigen::Matrix3d R_e;
        Eigen::Vector3d t_e;
        cv::cv2eigen(R, R_e);
        cv::cv2eigen(tvec, t_e);
        const SE3 T_cur_prev(R_e, t_e);
        const SE3 T_prev_cur = T_cur_prev.inverse();
        // Reject implausible jumps (> 2 m or > 60 deg between consecutive frames).
        if (T_prev_cur.IsFinite() && T_prev_cur.translation().norm() < 2.0 &&
            T_prev_cur.RotationAngle() < M_PI / 3.0) {
          s.T_w_c = s.T_w_c * T_prev_cur;
          s.velocity = T_prev_cur;
          result.point_inliers = static_cast<int>(inliers.size());
          // Covariance of the increment: isotropic pixel noise propagated through the
          // Gauss-Newton normal equations would go here; the baseline reports a scaled
          // identity that shrinks with the inlier count.
          result.covariance = Matrix6d::Identity() * (1.0 / std::max(1, result.point_inliers));
          tracked = true;
        }
      }
    }
  }
  result.stage_ms.emplace_back("motion", MsSince(t0));

  if (!s.has_previous || s.state == TrackingState::kNotInitialized) {
    // First frame (or first after reset): the map starts here.
    if (static_cast<int>(current.points_c.size()) >= s.options.min_inliers) {
      s.state = TrackingState::kTracking;
      tracked = true;
      result.is_keyframe = true;
    } else {
      PL_LOG_WARN("frame " << frame.index << ": only " << current.points_c.size()
                           << " stereo points; waiting to initialise");
    }
  } else if (!tracked) {
    if (s.state == TrackingState::kTracking) {
      PL_LOG_WARN("frame " << frame.index << ": tracking lost; restarting from the last pose");
    }
    s.state = TrackingState::kLost;
    s.velocity = SE3();
  } else {
    if (s.state == TrackingState::kLost) PL_LOG_INFO("frame " << frame.index << ": tracking recovered");
    s.state = TrackingState::kTracking;
  }

  // Restart from the last pose: the current frame becomes the reference either way, so a
  // lost frame never produces a jump, only a gap in the trajectory.
  if (!current.points_c.empty()) {
    s.previous = std::move(current);
    s.has_previous = true;
  }

  result.state = s.state;
  result.T_w_c = s.T_w_c;
  result.pose_valid = tracked;
  if (tracked) {
    std::lock_guard<std::mutex> lock(s.trajectory_mutex);
    StampedPose sp;
    sp.t = frame.stamp_s();
    sp.T_w_c = s.T_w_c;
    s.trajectory.push_back(sp);
  }
  result.total_ms = MsSince(t_start);
  return result;
}

}  // namespace pl_slam
