// EuRoC ASL folders: camera calibration files, the stereo reader and the writer used by the
// synthetic generator (whose output the same reader reads back).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pl_slam/io/stereo_rectifier.h"
#include "pl_slam/io/stereo_source.h"

namespace pl_slam {

/// Reads one EuRoC camera sensor.yaml (also the sensorLeft.yaml / sensorRight.yaml of loose
/// pairs): intrinsics [fu, fv, cu, cv], resolution [w, h], distortion_model
/// radial-tangential (or none) with distortion_coefficients, camera_model pinhole, T_BS
/// {rows: 4, cols: 4, data: [16]}, optional rate_hz. A leading "%YAML:1.0" line (OpenCV
/// style) is accepted. Throws InputError "<path>[:line]: <key>: what is wrong".
RawCameraCalibration ReadEurocCameraYaml(const std::string& path);
/// The same, from the file's content; `path` only names it in errors (fuzzing, tests).
RawCameraCalibration ParseEurocCameraYaml(const std::string& content, const std::string& path);

/// Text of a sensor.yaml in the EuRoC schema for `calib` (numbers written exactly);
/// ReadEurocCameraYaml reads it back to the same values.
std::string FormatEurocCameraYaml(const RawCameraCalibration& calib, const std::string& comment);

/// A stereo sequence in EuRoC ASL layout: `path` is either the mav0 folder or its parent.
/// Reads cam0/ and cam1/ (data.csv + data/, sensor.yaml), pairs images by identical
/// timestamps, rectifies them (StereoRectifier) and, when
/// state_groundtruth_estimate0/data.csv exists, converts the body ground truth to the
/// rectified left camera: T_w_crect = T_w_b * T_b_s0 * T_c0_crect.
class EurocSource : public StereoSource {
 public:
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW

  /// Opens and checks the folder (calibration, csv files, that every listed image exists).
  /// Throws InputError naming the offending file.
  explicit EurocSource(const std::string& path);

  const StereoCamera& camera() const override { return rectifier_.camera(); }
  std::size_t size() const override { return frames_.size(); }
  bool Next(StereoFrame* frame) override;
  const Trajectory& ground_truth() const override { return ground_truth_; }
  std::string Describe() const override;

  /// Reads frame `index` (0-based) without moving the Next() cursor. Throws InputError on an
  /// unreadable image or one whose size differs from sensor.yaml; std::out_of_range past the end.
  void Read(std::size_t index, StereoFrame* frame) const;
  /// Restarts Next() from the first frame.
  void Rewind() { next_ = 0; }

  /// The mav0 folder actually read.
  const std::string& root() const { return root_; }
  /// Raw calibrations of cam0 and cam1.
  const RawCameraCalibration& raw_left() const { return raw_left_; }
  const RawCameraCalibration& raw_right() const { return raw_right_; }
  /// The rectification applied to every frame.
  const StereoRectifier& rectifier() const { return rectifier_; }
  /// Pose of the rectified left camera in the body frame, T_b_crect = T_b_s0 * T_c0_crect.
  const SE3& T_b_crect() const { return T_b_crect_; }
  /// Same as T_b_crect() (the name the rest of the project uses for "body to left camera").
  const SE3& T_B_C0() const { return T_b_crect_; }
  /// Ground truth of the body frame as the file gives it (empty when none).
  const Trajectory& ground_truth_body() const { return ground_truth_body_; }
  /// Timestamps (ns) of the paired frames, in order.
  std::vector<int64_t> stamps_ns() const;
  /// Images present in only one of cam0/data.csv and cam1/data.csv (skipped).
  std::size_t unpaired_count() const { return unpaired_; }

 private:
  struct Entry {
    int64_t stamp_ns;
    std::string left_path;
    std::string right_path;
  };

  std::string root_;
  RawCameraCalibration raw_left_;
  RawCameraCalibration raw_right_;
  StereoRectifier rectifier_;
  SE3 T_b_crect_;
  std::vector<Entry> frames_;
  std::size_t unpaired_ = 0;
  std::size_t next_ = 0;
  Trajectory ground_truth_body_;
  Trajectory ground_truth_;
};

/// Writes a rectified stereo sequence as an EuRoC ASL folder that EurocSource reads back
/// exactly: `folder`/mav0/cam0|cam1/{data/<ns>.png, data.csv, sensor.yaml}, body.yaml and
/// state_groundtruth_estimate0/data.csv. Both cameras get the rectified intrinsics and zero
/// distortion; cam0 T_BS = identity (body = left camera), cam1 T_BS = translation
/// (+baseline, 0, 0).
class EurocWriter {
 public:
  /// Creates the folder tree. Throws InputError when the camera is invalid, rate_hz <= 0 or
  /// the folders cannot be created.
  EurocWriter(const std::string& folder, const StereoCamera& rectified_camera, double rate_hz);

  /// Writes the frame's two images (PNG, lossless) named by its timestamp. Timestamps must
  /// increase; images must be CV_8UC1 of the camera's size. Throws InputError otherwise or
  /// when a file cannot be written.
  void Add(const StereoFrame& frame);

  /// Writes data.csv, sensor.yaml, body.yaml and, when non-empty, the ground truth of the
  /// left camera (= body) in EuRoC csv form. All text files are written atomically.
  void Finish(const Trajectory& T_w_c_ground_truth);

  /// The mav0 folder being written.
  const std::string& root() const { return root_; }
  /// Frames added so far.
  std::size_t size() const { return stamps_.size(); }

 private:
  std::string root_;
  StereoCamera camera_;
  double rate_hz_ = 0.0;
  std::vector<int64_t> stamps_;
};

}  // namespace pl_slam
