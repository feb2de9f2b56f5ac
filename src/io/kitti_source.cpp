#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "pl_slam/io/image_io.h"
#include "pl_slam/io/kitti.h"
#include "pl_slam/io/text_util.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

// Sorted file names of the PNG images in a folder.
std::vector<std::string> ListPngs(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    if (text::ToLower(it->path().extension().string()) == ".png") {
      names.push_back(it->path().filename().string());
    }
  }
  if (ec) throw InputError(dir.string() + ": cannot list folder (" + ec.message() + ")");
  std::sort(names.begin(), names.end());
  return names;
}

}  // namespace

StereoCamera ReadKittiCalibration(const std::string& path, int width, int height) {
  return ParseKittiCalibration(text::ReadFile(path), path, width, height);
}

StereoCamera ParseKittiCalibration(const std::string& content, const std::string& path, int width,
                                   int height) {
  const auto lines = text::SplitLines(content);
  std::map<std::string, std::array<double, 12>> P;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const auto fields = text::SplitWhitespace(lines[i]);
    if (fields.empty() || (fields[0] != "P0:" && fields[0] != "P1:")) continue;
    const std::string name(fields[0].substr(0, 2));
    const std::string where = path + ":" + std::to_string(i + 1) + ": " + name + ": ";
    if (fields.size() != 13) {
      throw InputError(where + "expected 12 numbers (row-major 3x4 projection), found " +
                       std::to_string(fields.size() - 1));
    }
    std::array<double, 12> v{};
    for (int k = 0; k < 12; ++k) {
      if (!text::ParseDouble(fields[k + 1], &v[k])) {
        throw InputError(where + "value " + std::to_string(k + 1) + " ('" +
                         std::string(fields[k + 1]) + "') is not a finite number");
      }
    }
    P[name] = v;
  }
  for (const char* name : {"P0", "P1"}) {
    if (!P.count(name)) {
      throw InputError(path + ": missing line '" + name + ":' (12 numbers, row-major 3x4)");
    }
  }
  const auto& p0 = P["P0"];
  const auto& p1 = P["P1"];
  auto same = [](double a, double b) {
    return std::abs(a - b) <= 1e-6 * std::max(1.0, std::abs(a));
  };
  if (!same(p0[0], p1[0]) || !same(p0[5], p1[5]) || !same(p0[6], p1[6])) {
    throw InputError(path +
                     ": P0 and P1 have different focal lengths or principal point rows "
                     "(expected a rectified pair)");
  }
  StereoCamera cam;
  cam.fx = p0[0];
  cam.cx = p0[2];
  cam.fy = p0[5];
  cam.cy = p0[6];
  cam.baseline = -(p1[3] - p0[3]) / p1[0];
  cam.doffs = p1[2] - p0[2];
  cam.width = width;
  cam.height = height;
  const std::string err = cam.Validate();
  if (!err.empty()) throw InputError(path + ": camera unusable: " + err);
  return cam;
}

std::vector<double> ReadKittiTimes(const std::string& path) {
  return ParseKittiTimes(text::ReadFile(path), path);
}

std::vector<double> ParseKittiTimes(const std::string& content, const std::string& path) {
  const auto lines = text::SplitLines(content);
  std::vector<double> times;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (text::IsBlankOrComment(lines[i])) continue;
    const std::string where = path + ":" + std::to_string(i + 1) + ": ";
    double t = 0.0;
    if (!text::ParseDouble(lines[i], &t)) {
      throw InputError(where + "'" + std::string(text::Trim(lines[i])) +
                       "' is not a time in seconds");
    }
    if (!times.empty() && t < times.back()) {
      throw InputError(where + "time " + text::FormatDouble(t) +
                       " is earlier than the previous one");
    }
    times.push_back(t);
  }
  return times;
}

KittiSource::KittiSource(const std::string& folder) : folder_(folder) {
  const fs::path dir(folder);
  std::error_code ec;
  if (!fs::exists(dir, ec)) throw InputError(folder + ": no such folder");
  if (!IsDir(dir)) throw InputError(folder + ": not a folder");
  for (const char* sub : {"image_0", "image_1"}) {
    if (!IsDir(dir / sub)) {
      throw InputError((dir / sub).string() + ": missing folder (KITTI odometry layout)");
    }
  }
  const auto left = ListPngs(dir / "image_0");
  const auto right = ListPngs(dir / "image_1");
  if (left.empty()) throw InputError((dir / "image_0").string() + ": no .png images");
  const std::set<std::string> right_set(right.begin(), right.end());

  std::vector<double> times;
  const fs::path times_path = dir / "times.txt";
  if (IsFile(times_path)) {
    times = ReadKittiTimes(times_path.string());
    if (times.size() != left.size()) {
      throw InputError(times_path.string() + ": " + std::to_string(times.size()) +
                       " times but image_0 has " + std::to_string(left.size()) + " images");
    }
  } else {
    for (std::size_t i = 0; i < left.size(); ++i) times.push_back(0.1 * static_cast<double>(i));
  }
  // The frame clock is integer ns; ground truth uses the same rounded times.
  std::vector<int64_t> stamps;
  std::vector<double> stamp_s;
  for (double t : times) {
    stamps.push_back(static_cast<int64_t>(std::llround(t * 1e9)));
    stamp_s.push_back(static_cast<double>(stamps.back()) * 1e-9);
  }

  for (std::size_t i = 0; i < left.size(); ++i) {
    if (!right_set.count(left[i])) continue;
    frames_.push_back(
        {stamps[i], (dir / "image_0" / left[i]).string(), (dir / "image_1" / left[i]).string()});
  }
  unpaired_ = (left.size() - frames_.size()) + (right.size() - frames_.size());
  if (frames_.empty()) {
    throw InputError(folder + ": image_0/ and image_1/ share no file name");
  }
  if (unpaired_ > 0) {
    PL_LOG_WARN("KITTI " << folder << ": " << unpaired_
                         << " images without a partner of the same name were skipped");
  }

  const cv::Mat first = ReadGrayImage(frames_.front().left_path);
  camera_ = ReadKittiCalibration((dir / "calib.txt").string(), first.cols, first.rows);

  const fs::path poses_path = dir / "poses.txt";
  if (IsFile(poses_path)) ground_truth_ = ReadKittiTrajectory(poses_path.string(), stamp_s);
  PL_LOG_INFO(Describe());
}

bool KittiSource::Next(StereoFrame* frame) {
  if (next_ >= frames_.size()) return false;
  Read(next_, frame);
  ++next_;
  return true;
}

void KittiSource::Read(std::size_t index, StereoFrame* frame) const {
  const Entry& e = frames_.at(index);
  cv::Mat left, right;
  ReadImagePair(e.left_path, e.right_path, camera_.width, camera_.height, nullptr, &left, &right);
  frame->stamp_ns = e.stamp_ns;
  frame->index = static_cast<int>(index);
  frame->left = left;
  frame->right = right;
}

std::string KittiSource::Describe() const {
  std::ostringstream os;
  os << "KITTI odometry folder " << folder_ << ": " << frames_.size() << " stereo frames, "
     << camera_.width << "x" << camera_.height << " fx=" << camera_.fx << " fy=" << camera_.fy
     << " cx=" << camera_.cx << " cy=" << camera_.cy << " baseline=" << camera_.baseline
     << " m, ground truth: " << ground_truth_.size() << " poses";
  return os.str();
}

}  // namespace pl_slam
