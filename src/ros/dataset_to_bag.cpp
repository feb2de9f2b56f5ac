#include "pl_slam/ros/dataset_to_bag.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>

#include "pl_slam/io/euroc.h"
#include "pl_slam/io/image_io.h"
#include "pl_slam/io/kitti.h"
#include "pl_slam/io/text_util.h"
#include "pl_slam/ros/conversions.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace ros_layer {

namespace {

namespace fs = std::filesystem;

// stamp -> image path of one EuRoC camera folder (camN/data.csv); EurocSource has already
// checked the file, so only the pairs are read back here.
std::map<int64_t, std::string> ReadEurocImageList(const fs::path& cam_dir) {
  const std::string csv = (cam_dir / "data.csv").string();
  std::map<int64_t, std::string> out;
  const std::string content = text::ReadFile(csv);  // the views below point into it
  for (std::string_view line : text::SplitLines(content)) {
    if (text::IsBlankOrComment(line)) continue;
    const auto fields = text::SplitOn(line, ',');
    int64_t stamp = 0;
    if (fields.size() < 2 || !text::ParseInt64(fields[0], &stamp)) {
      throw InputError(csv + ": malformed line '" + std::string(text::Trim(line)) + "'");
    }
    out[stamp] = (cam_dir / "data" / std::string(text::Trim(fields[1]))).string();
  }
  return out;
}

// camera_info of one raw EuRoC camera: its own K and distortion, the rectification R and P.
sensor_msgs::CameraInfo RawInfo(const RawCameraCalibration& raw, const cv::Mat& R, const cv::Mat& P,
                                const std::string& frame) {
  sensor_msgs::CameraInfo info;
  info.header.frame_id = frame;
  info.width = static_cast<uint32_t>(raw.width);
  info.height = static_cast<uint32_t>(raw.height);
  info.distortion_model = "plumb_bob";
  info.D.assign(5, 0.0);  // k1 k2 p1 p2 k3
  for (std::size_t i = 0; i < raw.distortion.size() && i < 5; ++i) info.D[i] = raw.distortion[i];
  info.K = {raw.fu, 0.0, raw.cu, 0.0, raw.fv, raw.cv, 0.0, 0.0, 1.0};
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) info.R[r * 3 + c] = R.at<double>(r, c);
    for (int c = 0; c < 4; ++c) info.P[r * 4 + c] = P.at<double>(r, c);
  }
  return info;
}

Trajectory Offset(const Trajectory& in, double offset_s, double first_s, double last_s) {
  Trajectory out;
  for (const StampedPose& p : in) {
    // Ground truth covering the converted frames only, with a margin that keeps the samples
    // bracketing the first and last frame (EuRoC's is 200 Hz) for interpolation.
    if (p.t < first_s - 0.05 || p.t > last_s + 0.05) continue;
    StampedPose q = p;
    q.t += offset_s;
    out.push_back(q);
  }
  return out;
}

}  // namespace

ConvertSummary ConvertDatasetToBag(const std::string& input, const std::string& output,
                                   const ConvertOptions& options,
                                   const std::function<void(std::size_t, std::size_t)>& progress) {
  if (options.max_frames < 0) {
    throw ConfigError("--max-frames " + std::to_string(options.max_frames) + " must be >= 0");
  }
  if (std::isfinite(options.time_offset_s) && options.time_offset_s < 0.0) {
    throw ConfigError("--time-offset must be >= 0 s (ROS time cannot be negative)");
  }
  std::unique_ptr<StereoSource> source = OpenDatasetFolder(input);
  auto* euroc = dynamic_cast<EurocSource*>(source.get());
  auto* kitti = dynamic_cast<KittiSource*>(source.get());
  ConvertSummary summary;
  summary.kind = euroc ? "EuRoC" : "KITTI";
  summary.raw = options.raw;
  summary.camera = source->camera();
  if (options.raw && !euroc) {
    throw InputError(input + ": --raw applies to EuRoC folders only (KITTI images are rectified)");
  }
  if (!euroc && !kitti) throw InputError(input + ": unsupported dataset layout");

  const std::size_t total = options.max_frames > 0
                                ? std::min<std::size_t>(source->size(), options.max_frames)
                                : source->size();
  if (total == 0) throw InputError(input + ": the sequence holds no stereo frames");

  // The first stamp decides the automatic offset.
  StereoFrame first;
  if (euroc) {
    euroc->Read(0, &first);
  } else {
    kitti->Read(0, &first);
  }
  double offset_s = options.time_offset_s;
  if (!std::isfinite(offset_s)) offset_s = first.stamp_s() < 1.0 ? 1000.0 : 0.0;
  summary.time_offset_s = offset_s;
  const int64_t offset_ns = static_cast<int64_t>(std::llround(offset_s * 1e9));

  const fs::path out_path(output);
  if (out_path.has_parent_path()) {
    std::error_code ec;
    fs::create_directories(out_path.parent_path(), ec);
    if (ec) {
      throw InputError(out_path.parent_path().string() + ": cannot create folder (" + ec.message() +
                       ")");
    }
  }

  std::unique_ptr<StereoBagWriter> writer;
  std::map<int64_t, std::string> raw_left, raw_right;
  if (options.raw) {
    const StereoRectifier& rect = euroc->rectifier();
    const sensor_msgs::CameraInfo left_info =
        RawInfo(euroc->raw_left(), rect.R1(), rect.P1(), options.left_frame);
    const sensor_msgs::CameraInfo right_info =
        RawInfo(euroc->raw_right(), rect.R2(), rect.P2(), options.right_frame);
    writer = std::make_unique<StereoBagWriter>(output, left_info, right_info, options.topics);
    raw_left = ReadEurocImageList(fs::path(euroc->root()) / "cam0");
    raw_right = ReadEurocImageList(fs::path(euroc->root()) / "cam1");
  } else {
    writer = std::make_unique<StereoBagWriter>(output, source->camera(), options.topics,
                                               options.left_frame, options.right_frame);
  }

  const std::vector<int64_t> euroc_stamps = euroc ? euroc->stamps_ns() : std::vector<int64_t>();
  double first_s = 0.0, last_s = 0.0;
  for (std::size_t i = 0; i < total; ++i) {
    StereoFrame frame;
    if (options.raw) {
      const int64_t stamp = euroc_stamps[i];
      const RawCameraCalibration& cal = euroc->raw_left();
      ReadImagePair(raw_left.at(stamp), raw_right.at(stamp), cal.width, cal.height, nullptr,
                    &frame.left, &frame.right);
      frame.stamp_ns = stamp;
      frame.index = static_cast<int>(i);
    } else if (i == 0) {
      frame = first;
    } else if (euroc) {
      euroc->Read(i, &frame);
    } else {
      kitti->Read(i, &frame);
    }
    if (i == 0) first_s = frame.stamp_s();
    last_s = frame.stamp_s();
    frame.stamp_ns += offset_ns;
    writer->Write(frame);
    ++summary.frames;
    if (progress) progress(summary.frames, total);
  }
  const Trajectory gt = Offset(source->ground_truth(), offset_s, first_s, last_s);
  writer->WriteGroundTruth(gt, options.world_frame);
  summary.poses = gt.size();
  writer->Close();
  return summary;
}

}  // namespace ros_layer
}  // namespace pl_slam
