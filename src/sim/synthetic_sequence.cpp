#include "pl_slam/sim/synthetic_sequence.h"
#include "pl_slam/util/validation.h"

#include <cmath>
#include <cstdlib>
#include <functional>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "pl_slam/sim/lowtex_scenes.h"
#include "pl_slam/sim/procedural_texture.h"
#include "pl_slam/sim/street_scenes.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"

namespace pl_slam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

template <typename T>
T ParseNumber(const std::string& key, const std::string& text) {
  // istream would silently wrap "-1" into a huge unsigned value.
  if (std::is_unsigned_v<T> && text.find('-') != std::string::npos) {
    throw ConfigError(key + "='" + text + "' must be a non-negative integer");
  }
  std::istringstream is(text);
  T value{};
  is >> value;
  if (is.fail() || !(is >> std::ws).eof()) {
    throw ConfigError(key + "='" + text + "' is not a valid number");
  }
  return value;
}

bool ParseBool(const std::string& key, const std::string& text) {
  if (text == "true" || text == "1" || text == "yes") return true;
  if (text == "false" || text == "0" || text == "no") return false;
  throw ConfigError(key + "='" + text + "' must be true or false");
}

template <typename T>
std::string Print(const T& v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// Shortest text that reads back to the same double (e.g. 0.11, but all the digits of a Unix
// start time), so that printed configurations can be replayed exactly.
std::string Print(double v) {
  std::string text;
  for (int precision = 6; precision <= 17; ++precision) {
    std::ostringstream os;
    os << std::setprecision(precision) << v;
    text = os.str();
    if (std::strtod(text.c_str(), nullptr) == v) break;
  }
  return text;
}

// One row per option: the key Set() accepts, how to parse it into the struct and how to print
// it, so that Set() and ToString() cannot disagree about the set of keys.
struct OptionField {
  std::string key;
  std::function<void(SequenceOptions*, const std::string&)> set;
  std::function<std::string(const SequenceOptions&)> get;
};

template <typename T>
OptionField NumberField(const std::string& key, T SequenceOptions::*member) {
  return {key,
          [key, member](SequenceOptions* o, const std::string& v) {
            o->*member = ParseNumber<T>(key, v);
          },
          [member](const SequenceOptions& o) { return Print(o.*member); }};
}

const std::vector<OptionField>& OptionFields() {
  static const std::vector<OptionField> fields = {
      {"scene", [](SequenceOptions* o, const std::string& v) { o->scene = ParseSceneKind(v); },
       [](const SequenceOptions& o) { return SceneKindName(o.scene); }},
      NumberField("num_frames", &SequenceOptions::num_frames),
      NumberField("loops", &SequenceOptions::loops),
      NumberField("rate_hz", &SequenceOptions::rate_hz),
      NumberField("width", &SequenceOptions::width),
      NumberField("height", &SequenceOptions::height),
      NumberField("focal", &SequenceOptions::focal),
      NumberField("baseline", &SequenceOptions::baseline),
      NumberField("noise_sigma", &SequenceOptions::noise_sigma),
      {"exposure_change",
       [](SequenceOptions* o, const std::string& v) {
         o->exposure_change = ParseBool("exposure_change", v);
       },
       [](const SequenceOptions& o) { return std::string(o.exposure_change ? "true" : "false"); }},
      NumberField("exposure_gain_amplitude", &SequenceOptions::exposure_gain_amplitude),
      NumberField("exposure_offset_amplitude", &SequenceOptions::exposure_offset_amplitude),
      NumberField("exposure_period_s", &SequenceOptions::exposure_period_s),
      NumberField("seed", &SequenceOptions::seed),
      NumberField("world_seed", &SequenceOptions::world_seed),
      NumberField("start_time_s", &SequenceOptions::start_time_s),
      NumberField("edge_supersampling", &SequenceOptions::edge_supersampling),
      {"bare", [](SequenceOptions* o, const std::string& v) { o->bare = ParseBool("bare", v); },
       [](const SequenceOptions& o) { return std::string(o.bare ? "true" : "false"); }},
      NumberField("blur_sigma", &SequenceOptions::blur_sigma),
      NumberField("vignetting", &SequenceOptions::vignetting),
      NumberField("exposure_gain", &SequenceOptions::exposure_gain),
      NumberField("exposure_offset", &SequenceOptions::exposure_offset),
  };
  return fields;
}

}  // namespace

std::string SequenceOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("num_frames", num_frames, 0, 1000000));
  check(CheckRange("loops", loops, 1, 1000));
  check(CheckRange("rate_hz", rate_hz, 0.0, 1000.0, true));
  check(CheckRange("width", width, 16, 8192));
  check(CheckRange("height", height, 16, 8192));
  check(CheckRange("focal", focal, 1.0, 100000.0));
  check(CheckRange("baseline", baseline, 0.0, 10.0, true));
  check(CheckRange("noise_sigma", noise_sigma, 0.0, 100.0));
  check(CheckRange("exposure_gain_amplitude", exposure_gain_amplitude, 0.0, 0.9));
  check(CheckRange("exposure_offset_amplitude", exposure_offset_amplitude, 0.0, 100.0));
  check(CheckRange("exposure_period_s", exposure_period_s, 0.0, 1e6, true));
  // Stamps are int64 nanoseconds (overflow past 9.2e9 s); dataset clocks are Unix times.
  check(CheckRange("start_time_s", start_time_s, 0.0, 4e9));
  check(CheckRange("edge_supersampling", edge_supersampling, 1, 16));
  check(CheckRange("blur_sigma", blur_sigma, -1.0, 20.0));
  check(CheckRange("vignetting", vignetting, -1.0, 0.9));
  check(CheckRange("exposure_gain", exposure_gain, 0.05, 10.0));
  check(CheckRange("exposure_offset", exposure_offset, -255.0, 255.0));
  return first;
}

double SequenceOptions::EffectiveBlurSigma() const {
  if (blur_sigma >= 0.0) return blur_sigma;
  return IsLowtexScene(scene) || IsStreetScene(scene) ? 0.6 : 0.0;
}

double SequenceOptions::EffectiveVignetting() const {
  if (vignetting >= 0.0) return vignetting;
  return IsLowtexScene(scene) || IsStreetScene(scene) ? 0.08 : 0.0;
}

SequenceOptions DefaultSequenceOptions(SceneKind kind) {
  SequenceOptions o;
  o.scene = kind;
  if (IsStreetScene(kind)) {
    o.width = kStreetImageWidth;
    o.height = kStreetImageHeight;
    o.focal = kStreetFocal;
    o.baseline = kStreetBaseline;
    o.rate_hz = kStreetRateHz;
  }
  return o;
}

void ApplyExposurePreset(const std::string& preset, SequenceOptions* options) {
  if (preset == "normal") {
    options->exposure_gain = 1.0;
    options->exposure_offset = 0.0;
  } else if (preset == "dim") {
    options->exposure_gain = 0.45;
    options->exposure_offset = 0.0;
  } else if (preset == "bright") {
    options->exposure_gain = 1.4;
    options->exposure_offset = 0.0;
  } else {
    throw ConfigError("exposure='" + preset + "' is not a preset; allowed: normal, dim, bright");
  }
}

void SequenceOptions::Set(const std::string& key, const std::string& value) {
  for (const OptionField& f : OptionFields()) {
    if (key == f.key) {
      f.set(this, value);
      return;
    }
  }
  std::string known;
  for (const OptionField& f : OptionFields()) known += (known.empty() ? "" : ", ") + f.key;
  throw ConfigError("unknown synthetic-sequence option '" + key + "'; known: " + known);
}

std::string SequenceOptions::ToString() const {
  std::string out;
  for (const OptionField& f : OptionFields()) out += f.key + ": " + f.get(*this) + "\n";
  return out;
}

SyntheticSequence::SyntheticSequence(const SequenceOptions& options) : options_(options) {
  const std::string bad = options_.Validate();
  if (!bad.empty()) throw ConfigError("synthetic sequence: " + bad);
  Scene scene =
      BuildScene(options_.scene, options_.num_frames, options_.rate_hz, options_.start_time_s,
                 options_.world_seed, options_.loops, options_.bare);
  world_ = std::move(scene.world);
  ground_truth_ = std::move(scene.ground_truth);
  Init();
}

SyntheticSequence::SyntheticSequence(const SequenceOptions& options,
                                     std::shared_ptr<const World> world, Trajectory ground_truth)
    : options_(options),
      world_(std::move(world)),
      ground_truth_(std::move(ground_truth)),
      custom_world_(true) {
  const std::string bad = options_.Validate();
  if (!bad.empty()) throw ConfigError("synthetic sequence: " + bad);
  if (!world_) throw ConfigError("synthetic sequence: custom world is null");
  if (ground_truth_.empty()) throw ConfigError("synthetic sequence: custom trajectory is empty");
  options_.num_frames = static_cast<int>(ground_truth_.size());
  Init();
}

void SyntheticSequence::Init() {
  camera_.fx = options_.focal;
  camera_.fy = options_.focal;
  // Pixel centres are at integer coordinates, so the centre of the image is (w - 1) / 2.
  camera_.cx = (options_.width - 1) / 2.0;
  camera_.cy = (options_.height - 1) / 2.0;
  camera_.baseline = options_.baseline;
  camera_.width = options_.width;
  camera_.height = options_.height;
  renderer_ = std::make_unique<Renderer>(world_, camera_, options_.edge_supersampling);
  const double vignetting = options_.EffectiveVignetting();
  if (vignetting > 0.0) {
    vignette_.create(options_.height, options_.width, CV_32F);
    const double r2_corner = camera_.cx * camera_.cx + camera_.cy * camera_.cy;
    for (int v = 0; v < options_.height; ++v) {
      float* row = vignette_.ptr<float>(v);
      for (int u = 0; u < options_.width; ++u) {
        const double du = u - camera_.cx, dv = v - camera_.cy;
        row[u] = static_cast<float>(1.0 - vignetting * (du * du + dv * dv) / r2_corner);
      }
    }
  }
  PL_LOG_DEBUG("synthetic sequence options:\n" << options_.ToString());
  PL_LOG_INFO(Describe() << " (" << world_->quads().size() << " quads)");
}

std::string SyntheticSequence::Describe() const {
  std::ostringstream os;
  os << "synthetic "
     << (custom_world_ ? std::string("custom world") : SceneKindName(options_.scene)) << ": "
     << size() << " frames at " << options_.rate_hz << " Hz, " << options_.width << "x"
     << options_.height << ", seed " << options_.seed;
  if (!custom_world_ && IsLowtexScene(options_.scene)) {
    os << ", world seed " << options_.world_seed << (options_.bare ? ", bare" : ", textured");
  }
  if (!custom_world_ && IsStreetScene(options_.scene)) {
    os << ", world seed " << options_.world_seed;
  }
  return os.str();
}

void SyntheticSequence::CheckIndex(int index) const {
  if (index < 0 || static_cast<std::size_t>(index) >= ground_truth_.size()) {
    throw std::out_of_range("synthetic sequence: frame index " + std::to_string(index) +
                            " outside [0, " + std::to_string(ground_truth_.size()) + ")");
  }
}

SE3 SyntheticSequence::RightPose(int index) const {
  CheckIndex(index);
  return ground_truth_[index].T_w_c *
         SE3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(options_.baseline, 0.0, 0.0));
}

Exposure SyntheticSequence::ExposureAt(int index) const {
  Exposure e;
  e.gain = options_.exposure_gain;
  e.offset = options_.exposure_offset;
  if (!options_.exposure_change) return e;
  const double t = index / options_.rate_hz;
  const double w = 2.0 * kPi / options_.exposure_period_s;
  e.gain *= 1.0 + options_.exposure_gain_amplitude * std::sin(w * t);
  // A different period than the gain's, so that gain and offset are not locked together.
  e.offset += options_.exposure_offset_amplitude * std::sin(0.7 * w * t + 1.0);
  return e;
}

std::vector<VisibleEdge, Eigen::aligned_allocator<VisibleEdge>>
SyntheticSequence::VisibleStructuralEdges(int index, const EdgeVisibilityOptions& options) const {
  CheckIndex(index);
  if (world_->StructuralEdges().empty()) return {};
  return ProjectStructuralEdges(*world_, camera_, ground_truth_[index].T_w_c, RenderDepth(index),
                                options);
}

RenderedView SyntheticSequence::RenderGroundTruth(int index, bool right) const {
  CheckIndex(index);
  return renderer_->Render(right ? RightPose(index) : ground_truth_[index].T_w_c);
}

cv::Mat SyntheticSequence::Finish(const cv::Mat& radiance, const Exposure& exposure, int index,
                                  int cam) const {
  // Optics first (blur, vignetting), then the sensor (exposure, noise, 8-bit quantisation).
  cv::Mat optical = radiance;
  const double blur = options_.EffectiveBlurSigma();
  if (blur > 0.0) {
    cv::GaussianBlur(radiance, optical, cv::Size(0, 0), blur, blur, cv::BORDER_REPLICATE);
  }
  if (!vignette_.empty()) optical = optical.mul(vignette_);
  cv::Mat grey;
  optical.convertTo(grey, CV_32F, exposure.gain, exposure.offset);
  if (options_.noise_sigma > 0.0) {
    // An independent, reproducible noise stream per (seed, frame, camera).
    cv::RNG rng(
        MixSeed(MixSeed(options_.seed, static_cast<uint64_t>(index)), static_cast<uint64_t>(cam)));
    cv::Mat noise(grey.size(), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options_.noise_sigma);
    grey += noise;
  }
  cv::Mat out;
  grey.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

StereoFrame SyntheticSequence::Render(int index) const {
  CheckIndex(index);
  StereoFrame frame;
  frame.index = index;
  frame.stamp_ns = std::llround(ground_truth_[index].t * 1e9);
  const Exposure exposure = ExposureAt(index);
  frame.left = Finish(renderer_->Render(ground_truth_[index].T_w_c).radiance, exposure, index, 0);
  frame.right = Finish(renderer_->Render(RightPose(index)).radiance, exposure, index, 1);
  return frame;
}

bool SyntheticSequence::Next(StereoFrame* frame) {
  if (next_ >= ground_truth_.size()) return false;
  *frame = Render(static_cast<int>(next_));
  ++next_;
  return true;
}

}  // namespace pl_slam::sim
