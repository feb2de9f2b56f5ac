#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "pl_slam/io/euroc.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;

void WriteImage(const std::string& path, const cv::Mat& image) {
  bool ok = false;
  std::string why = "encoder failed";
  try {
    ok = cv::imwrite(path, image);
  } catch (const cv::Exception& e) {
    why = e.msg;
  }
  if (!ok) throw InputError(path + ": cannot write image (" + why + ")");
}

}  // namespace

EurocWriter::EurocWriter(const std::string& folder, const StereoCamera& rectified_camera,
                         double rate_hz)
    : camera_(rectified_camera), rate_hz_(rate_hz) {
  const std::string err = camera_.Validate();
  if (!err.empty()) throw InputError(folder + ": EurocWriter: camera unusable: " + err);
  if (!std::isfinite(rate_hz) || rate_hz <= 0.0) {
    throw InputError(folder + ": EurocWriter: rate_hz=" + std::to_string(rate_hz) +
                     " must be positive");
  }
  const fs::path root = fs::path(folder) / "mav0";
  root_ = root.string();
  for (const char* sub : {"cam0/data", "cam1/data"}) {
    std::error_code ec;
    fs::create_directories(root / sub, ec);
    if (ec)
      throw InputError((root / sub).string() + ": cannot create folder (" + ec.message() + ")");
  }
}

void EurocWriter::Add(const StereoFrame& frame) {
  const std::string which = root_ + ": frame " + std::to_string(frame.index) + " (" +
                            std::to_string(frame.stamp_ns) + " ns): ";
  for (const cv::Mat* im : {&frame.left, &frame.right}) {
    if (im->type() != CV_8UC1 || im->cols != camera_.width || im->rows != camera_.height) {
      std::ostringstream os;
      os << which << (im == &frame.left ? "left" : "right") << " image is " << im->cols << "x"
         << im->rows << " type " << im->type() << ", expected " << camera_.width << "x"
         << camera_.height << " CV_8UC1";
      throw InputError(os.str());
    }
  }
  if (!stamps_.empty() && frame.stamp_ns <= stamps_.back()) {
    throw InputError(which + "timestamp does not increase (previous " +
                     std::to_string(stamps_.back()) + " ns)");
  }
  const std::string name = std::to_string(frame.stamp_ns) + ".png";
  WriteImage((fs::path(root_) / "cam0" / "data" / name).string(), frame.left);
  WriteImage((fs::path(root_) / "cam1" / "data" / name).string(), frame.right);
  stamps_.push_back(frame.stamp_ns);
}

void EurocWriter::Finish(const Trajectory& T_w_c_ground_truth) {
  const fs::path root(root_);
  std::string csv = "#timestamp [ns],filename\n";
  for (int64_t ns : stamps_) csv += std::to_string(ns) + "," + std::to_string(ns) + ".png\n";

  RawCameraCalibration calib;
  calib.width = camera_.width;
  calib.height = camera_.height;
  calib.fu = camera_.fx;
  calib.fv = camera_.fy;
  calib.cu = camera_.cx;
  calib.cv = camera_.cy;
  calib.distortion = {0.0, 0.0, 0.0, 0.0};
  calib.rate_hz = rate_hz_;
  for (int cam = 0; cam < 2; ++cam) {
    // Body = left camera; the right camera sits `baseline` along the left camera's +x.
    calib.T_b_s = SE3(Eigen::Matrix3d::Identity(),
                      Eigen::Vector3d(cam == 0 ? 0.0 : camera_.baseline, 0.0, 0.0));
    const fs::path dir = root / ("cam" + std::to_string(cam));
    calib.source = (dir / "sensor.yaml").string();
    WriteFileAtomic((dir / "data.csv").string(), csv);
    WriteFileAtomic(calib.source, FormatEurocCameraYaml(calib, std::string("pl_slam rectified ") +
                                                                   (cam == 0 ? "left" : "right") +
                                                                   " camera (no distortion)"));
  }
  WriteFileAtomic((root / "body.yaml").string(),
                  "# The body frame is the left (cam0) rectified camera frame.\n"
                  "comment: pl_slam synthetic stereo sequence\n");
  if (!T_w_c_ground_truth.empty()) {
    const fs::path gt_dir = root / "state_groundtruth_estimate0";
    std::error_code ec;
    fs::create_directories(gt_dir, ec);
    if (ec) throw InputError(gt_dir.string() + ": cannot create folder (" + ec.message() + ")");
    WriteTrajectory((root / "state_groundtruth_estimate0" / "data.csv").string(),
                    T_w_c_ground_truth, TrajectoryFormat::kEuroc);
  }
}

}  // namespace pl_slam
