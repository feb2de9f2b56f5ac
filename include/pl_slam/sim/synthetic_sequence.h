// Deterministic synthetic stereo sequences with exact ground truth: a StereoSource that
// renders rectified stereo pairs of a built-in scene (see scenes.h) or of a custom world.
#pragma once

#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>

#include "pl_slam/io/stereo_source.h"
#include "pl_slam/sim/renderer.h"
#include "pl_slam/sim/scenes.h"
#include "pl_slam/sim/structural_edges.h"
#include "pl_slam/sim/world.h"

namespace pl_slam::sim {

/// Options of a synthetic sequence. The same options always give bit-identical images.
struct SequenceOptions {
  SceneKind scene = SceneKind::kRoom;  ///< which built-in scene to render
  int num_frames = 0;                  ///< sequence length; 0 = the scene's default length
  int loops = 1;                       ///< room: times round the loop (default length scales)
  double rate_hz = 20.0;               ///< frame rate; stamps are start_time_s + index / rate_hz
  int width = 752;                     ///< image width, pixels (EuRoC size)
  int height = 480;                    ///< image height, pixels
  double focal = 450.0;                ///< fx = fy, pixels; principal point at the image centre
  double baseline = 0.11;              ///< stereo baseline, metres (right camera at +x of the left)
  double noise_sigma = 2.0;            ///< Gaussian image noise std, grey levels (0 = none)
  bool exposure_change = false;        ///< vary gain and offset smoothly over the sequence
  double exposure_gain_amplitude = 0.3;     ///< gain = 1 + amplitude * sin(2 pi t / period)
  double exposure_offset_amplitude = 12.0;  ///< offset amplitude, grey levels
  double exposure_period_s = 8.0;           ///< period of the gain variation, seconds
  uint64_t seed = 1;                        ///< seeds the image noise
  uint64_t world_seed = 7;                  ///< seeds the procedural textures (the world itself)
  double start_time_s = 0.0;                ///< stamp of frame 0, seconds
  int edge_supersampling = 4;               ///< k x k rays per pixel on occlusion edges (1 = off)
  bool bare = false;  ///< lowtex scenes: the bare variant (no posters, tiles, grid, lights, seams)
  /// Gaussian blur (optics) std in pixels, applied to the radiance before vignetting, gain
  /// and noise; 0 = none; < 0 = the scene's default (0.6 for lowtex and street scenes, else
  /// none).
  double blur_sigma = -1.0;
  /// Vignetting: brightness falls as 1 - vignetting * (r / r_corner)^2 with the distance r
  /// from the principal point (the image corners lose this fraction); 0 = none; < 0 = the
  /// scene's default (0.08 for lowtex and street scenes, else none).
  double vignetting = -1.0;
  /// Constant exposure gain (a dim or bright camera; e.g. dim 0.45, bright 1.4), applied
  /// together with exposure_change's: grey = gain * radiance + offset, saturating at 0 and 255.
  double exposure_gain = 1.0;
  double exposure_offset = 0.0;  ///< constant exposure offset, grey levels

  /// blur_sigma with the scene default resolved.
  double EffectiveBlurSigma() const;
  /// vignetting with the scene default resolved.
  double EffectiveVignetting() const;

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
  /// Sets one option from text (e.g. from a command line "key=value"); throws ConfigError on
  /// an unknown key or a value that does not parse (range is checked by Validate).
  void Set(const std::string& key, const std::string& value);
  /// The effective configuration, one "key: value" per line, for logs.
  std::string ToString() const;
};

/// The options a scene is meant to be rendered with: SequenceOptions() for `kind`, with the
/// street scenes' car camera (street_scenes.h: 1241x376 px, focal 718.856 px, baseline
/// 0.54 m, 10 Hz) instead of the EuRoC-like defaults.
SequenceOptions DefaultSequenceOptions(SceneKind kind);

/// Sets exposure_gain and exposure_offset from a preset name: "normal" (1, 0), "dim"
/// (0.45, 0: underexposed, compressed contrast) or "bright" (1.4, 0: overexposed, light
/// surfaces clip at 255). Throws ConfigError naming the value and the allowed names.
void ApplyExposurePreset(const std::string& preset, SequenceOptions* options);

/// Gain and offset applied to a frame's radiance before noise: grey = gain * radiance +
/// offset + noise.
struct Exposure {
  double gain = 1.0;    ///< multiplicative
  double offset = 0.0;  ///< additive, grey levels
};

/// A StereoSource rendering frames on demand (Next() moves forward only; Render() renders
/// any frame) with exact ground truth: T_w_c of the left camera per frame, and per-pixel
/// depth. The right camera is the left one translated by +baseline along the left camera's
/// x axis, with the same intrinsics, so the pair is rectified: a point at depth Z has
/// disparity fx * baseline / Z. Images are CV_8UC1.
class SyntheticSequence : public StereoSource {
 public:
  /// A built-in scene. Throws ConfigError when options.Validate() fails.
  explicit SyntheticSequence(const SequenceOptions& options);
  /// A custom world and left-camera trajectory (tests, experiments); options.scene and
  /// options.num_frames are ignored, the length is ground_truth.size(). Throws ConfigError
  /// on invalid options, an empty trajectory or a null world.
  SyntheticSequence(const SequenceOptions& options, std::shared_ptr<const World> world,
                    Trajectory ground_truth);

  /// Rectified calibration: fx = fy = focal, cx = (width - 1) / 2, cy = (height - 1) / 2.
  const StereoCamera& camera() const override { return camera_; }
  /// Number of frames.
  std::size_t size() const override { return ground_truth_.size(); }
  /// Renders the next frame; false after the last one.
  bool Next(StereoFrame* frame) override;
  /// Exact poses of the left camera, stamped like the frames.
  const Trajectory& ground_truth() const override { return ground_truth_; }
  /// E.g. "synthetic room: 480 frames at 20 Hz, 752x480, seed 1".
  std::string Describe() const override;

  /// Renders frame `index` (any order, thread-safe). Throws std::out_of_range.
  StereoFrame Render(int index) const;
  /// Noise-free ground truth of frame `index` for the left (or right) camera: radiance
  /// before exposure, depth per pixel, visible quad per pixel.
  RenderedView RenderGroundTruth(int index, bool right = false) const;
  /// Depth (CV_32FC1, metres, 0 = nothing) of each left-image pixel of frame `index`.
  cv::Mat RenderDepth(int index) const { return RenderGroundTruth(index).depth; }
  /// The world's structural edges visible in the left image of frame `index`
  /// (ProjectStructuralEdges against the frame's rendered depth); empty for worlds without
  /// recorded edges (room, corridor, fast_turn).
  std::vector<VisibleEdge, Eigen::aligned_allocator<VisibleEdge>> VisibleStructuralEdges(
      int index, const EdgeVisibilityOptions& options = EdgeVisibilityOptions()) const;
  /// Pose of the right camera at frame `index`.
  SE3 RightPose(int index) const;
  /// Exposure of frame `index`: exposure_gain and exposure_offset, modulated over time when
  /// exposure_change is on.
  Exposure ExposureAt(int index) const;
  /// Restarts Next() from the first frame.
  void Rewind() { next_ = 0; }

  /// The world being rendered.
  const World& world() const { return *world_; }
  /// Shared handle to the world (e.g. to build another sequence in the same world).
  std::shared_ptr<const World> shared_world() const { return world_; }
  /// The options this sequence was built with.
  const SequenceOptions& options() const { return options_; }

 private:
  void Init();
  void CheckIndex(int index) const;
  cv::Mat Finish(const cv::Mat& radiance, const Exposure& exposure, int index, int cam) const;
  // Per-pixel vignetting factors (empty when off).
  cv::Mat vignette_;

  SequenceOptions options_;
  std::shared_ptr<const World> world_;
  Trajectory ground_truth_;
  StereoCamera camera_;
  std::unique_ptr<Renderer> renderer_;
  std::size_t next_ = 0;
  bool custom_world_ = false;
};

}  // namespace pl_slam::sim
