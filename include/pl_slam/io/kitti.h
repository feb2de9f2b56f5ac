// KITTI odometry sequences (already rectified grayscale stereo).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pl_slam/io/stereo_source.h"

namespace pl_slam {

/// Reads a KITTI calib.txt: the rectified projections "P0:" and "P1:" (12 numbers each;
/// other lines are ignored). fx = P0[0], fy = P0[5], cx = P0[2], cy = P0[6],
/// baseline = -(P1[3] - P0[3]) / P1[0]. The image size is not in the file and is taken from
/// the arguments. Throws InputError "<path>[:line]: what is wrong".
StereoCamera ReadKittiCalibration(const std::string& path, int width, int height);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
StereoCamera ParseKittiCalibration(const std::string& content, const std::string& path, int width,
                                   int height);

/// Reads a KITTI times.txt (one time in seconds per line). Throws InputError with file:line.
std::vector<double> ReadKittiTimes(const std::string& path);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
std::vector<double> ParseKittiTimes(const std::string& content, const std::string& path);

/// A KITTI odometry sequence folder: calib.txt, image_0/ and image_1/ (same file names,
/// sorted), optional times.txt (else 10 Hz from 0) and optional poses.txt (left camera
/// poses, one per image).
class KittiSource : public StereoSource {
 public:
  /// Opens and checks the folder. Throws InputError naming the offending file.
  explicit KittiSource(const std::string& folder);

  const StereoCamera& camera() const override { return camera_; }
  std::size_t size() const override { return frames_.size(); }
  bool Next(StereoFrame* frame) override;
  const Trajectory& ground_truth() const override { return ground_truth_; }
  std::string Describe() const override;

  /// Reads frame `index` (0-based) without moving the Next() cursor. Throws InputError on an
  /// unreadable image; std::out_of_range past the end.
  void Read(std::size_t index, StereoFrame* frame) const;
  /// Restarts Next() from the first frame.
  void Rewind() { next_ = 0; }

  /// The sequence folder.
  const std::string& folder() const { return folder_; }
  /// Images present in only one of image_0/ and image_1/ (skipped).
  std::size_t unpaired_count() const { return unpaired_; }

 private:
  struct Entry {
    int64_t stamp_ns;
    std::string left_path;
    std::string right_path;
  };

  std::string folder_;
  StereoCamera camera_;
  std::vector<Entry> frames_;
  std::size_t unpaired_ = 0;
  std::size_t next_ = 0;
  Trajectory ground_truth_;
};

}  // namespace pl_slam
