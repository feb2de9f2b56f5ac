#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>

#include "pl_slam/io/euroc.h"
#include "pl_slam/io/image_io.h"
#include "pl_slam/io/text_util.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;

struct CsvImage {
  int64_t stamp_ns;
  std::string path;
};

// Reads a camN/data.csv ("#timestamp [ns],filename"); every listed image must exist.
std::vector<CsvImage> ReadImageCsv(const fs::path& csv, const fs::path& data_dir) {
  const std::string csv_path = csv.string();
  const std::string content = text::ReadFile(csv_path);
  const auto lines = text::SplitLines(content);
  std::vector<CsvImage> images;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (text::IsBlankOrComment(lines[i])) continue;
    const std::string where = csv_path + ":" + std::to_string(i + 1) + ": ";
    const auto fields = text::SplitOn(lines[i], ',');
    if (fields.size() < 2 || fields[1].empty()) {
      throw InputError(where + "expected 'timestamp [ns],filename', found '" +
                       std::string(text::Trim(lines[i])) + "'");
    }
    CsvImage im;
    if (!text::ParseInt64(fields[0], &im.stamp_ns)) {
      throw InputError(where + "timestamp '" + std::string(fields[0]) +
                       "' is not an integer nanosecond count");
    }
    im.path = (data_dir / std::string(fields[1])).string();
    std::error_code ec;
    if (!fs::is_regular_file(im.path, ec)) {
      throw InputError(im.path + ": image listed in " + csv_path + ":" + std::to_string(i + 1) +
                       " does not exist");
    }
    images.push_back(std::move(im));
  }
  std::stable_sort(images.begin(), images.end(),
                   [](const CsvImage& a, const CsvImage& b) { return a.stamp_ns < b.stamp_ns; });
  for (std::size_t i = 1; i < images.size(); ++i) {
    if (images[i].stamp_ns == images[i - 1].stamp_ns) {
      throw InputError(csv_path + ": timestamp " + std::to_string(images[i].stamp_ns) +
                       " is listed twice");
    }
  }
  return images;
}

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

}  // namespace

EurocSource::EurocSource(const std::string& path) {
  const fs::path folder(path);
  std::error_code ec;
  if (!fs::exists(folder, ec)) throw InputError(path + ": no such folder");
  if (!IsDir(folder)) throw InputError(path + ": not a folder");
  fs::path root;
  if (IsDir(folder / "mav0")) {
    root = folder / "mav0";
  } else if (IsDir(folder / "cam0") && IsDir(folder / "cam1")) {
    root = folder;
  } else {
    throw InputError(path + ": not an EuRoC ASL folder (expected mav0/ or cam0/ and cam1/)");
  }
  root_ = root.string();

  raw_left_ = ReadEurocCameraYaml((root / "cam0" / "sensor.yaml").string());
  raw_right_ = ReadEurocCameraYaml((root / "cam1" / "sensor.yaml").string());
  rectifier_ = StereoRectifier(raw_left_, raw_right_);
  T_b_crect_ = raw_left_.T_b_s * rectifier_.T_c0_crect();

  const auto left = ReadImageCsv(root / "cam0" / "data.csv", root / "cam0" / "data");
  const auto right = ReadImageCsv(root / "cam1" / "data.csv", root / "cam1" / "data");
  std::map<int64_t, const CsvImage*> right_by_stamp;
  for (const auto& im : right) right_by_stamp.emplace(im.stamp_ns, &im);
  for (const auto& im : left) {
    const auto it = right_by_stamp.find(im.stamp_ns);
    if (it == right_by_stamp.end()) continue;
    frames_.push_back({im.stamp_ns, im.path, it->second->path});
  }
  unpaired_ = (left.size() - frames_.size()) + (right.size() - frames_.size());
  if (frames_.empty()) {
    throw InputError(root_ + ": no stereo pairs (cam0/data.csv lists " +
                     std::to_string(left.size()) + " images, cam1/data.csv " +
                     std::to_string(right.size()) + ", with no common timestamp)");
  }
  if (unpaired_ > 0) {
    PL_LOG_WARN("EuRoC " << root_ << ": " << unpaired_
                         << " images without a partner of the same timestamp were skipped");
  }

  const fs::path gt = root / "state_groundtruth_estimate0" / "data.csv";
  if (fs::is_regular_file(gt, ec)) {
    ground_truth_body_ = ReadEurocTrajectory(gt.string());
    ground_truth_ = TransformTrajectory(ground_truth_body_, T_b_crect_);
  }
  PL_LOG_INFO(Describe());
}

bool EurocSource::Next(StereoFrame* frame) {
  if (next_ >= frames_.size()) return false;
  Read(next_, frame);
  ++next_;
  return true;
}

void EurocSource::Read(std::size_t index, StereoFrame* frame) const {
  const Entry& e = frames_.at(index);
  cv::Mat rectified[2];
  ReadImagePair(
      e.left_path, e.right_path, raw_left_.width, raw_left_.height,
      [this](int side, const cv::Mat& raw, cv::Mat* out) {
        if (side == 0) {
          rectifier_.RectifyLeft(raw, out);
        } else {
          rectifier_.RectifyRight(raw, out);
        }
      },
      &rectified[0], &rectified[1]);
  frame->stamp_ns = e.stamp_ns;
  frame->index = static_cast<int>(index);
  frame->left = rectified[0];
  frame->right = rectified[1];
}

std::vector<int64_t> EurocSource::stamps_ns() const {
  std::vector<int64_t> out;
  out.reserve(frames_.size());
  for (const auto& e : frames_) out.push_back(e.stamp_ns);
  return out;
}

std::string EurocSource::Describe() const {
  const StereoCamera& c = camera();
  std::ostringstream os;
  os << "EuRoC ASL folder " << root_ << ": " << frames_.size() << " stereo frames, raw "
     << raw_left_.width << "x" << raw_left_.height << " -> rectified fx=" << c.fx << " fy=" << c.fy
     << " cx=" << c.cx << " cy=" << c.cy << " baseline=" << c.baseline << " m"
     << (rectifier_.is_identity() ? " (already rectified)" : "")
     << ", ground truth: " << ground_truth_.size() << " poses";
  return os.str();
}

}  // namespace pl_slam
