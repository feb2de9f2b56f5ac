#include "pl_slam/loop/keyframe_database.h"

#include <algorithm>
#include <sstream>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

namespace {

// Share of grid cells holding at least one of the pixels.
template <typename PixelOf>
double GridOccupancy(std::size_t n, PixelOf pixel_of, int width, int height, int cols, int rows) {
  if (n == 0) return 0.0;
  std::vector<uint8_t> occupied(static_cast<std::size_t>(cols) * rows, 0);
  int count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d uv = pixel_of(i);
    if (!(uv.x() >= 0.0 && uv.y() >= 0.0 && uv.x() < width && uv.y() < height)) continue;
    const int c = std::min(cols - 1, static_cast<int>(uv.x() * cols / width));
    const int r = std::min(rows - 1, static_cast<int>(uv.y() * rows / height));
    uint8_t& cell = occupied[static_cast<std::size_t>(r) * cols + c];
    if (!cell) {
      cell = 1;
      ++count;
    }
  }
  return static_cast<double>(count) / (static_cast<double>(cols) * rows);
}

double FramePointWeight(const KeyframeBow& f, double line_weight) {
  const double a_p = f.num_points * f.point_spread;
  const double a_l = line_weight * f.num_lines * f.line_spread;
  if (a_p + a_l <= 0.0) return 0.5;
  return a_p / (a_p + a_l);
}

}  // namespace

std::string KeyframeDatabaseOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("grid_cols", grid_cols, 1, 256));
  check(CheckRange("grid_rows", grid_rows, 1, 256));
  check(CheckRange("line_weight", line_weight, 0.0, 100.0));
  check(CheckRange("min_score", min_score, 0.0, 1.0));
  return first;
}

KeyframeBow ComputeKeyframeBow(const StereoFeatures& features,
                               const PointLineVocabulary& vocabulary, int width, int height,
                               const KeyframeDatabaseOptions& options,
                               FeatureNodeIndex* point_nodes, FeatureNodeIndex* line_nodes,
                               int direct_index_level) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("keyframe_database: " + err);
  if (width <= 0 || height <= 0) {
    std::ostringstream os;
    os << "ComputeKeyframeBow: image size " << width << "x" << height << " must be positive";
    throw ConfigError(os.str());
  }
  if (features.point_descriptors.rows != static_cast<int>(features.points.size()) ||
      features.line_descriptors.rows != static_cast<int>(features.lines.size())) {
    throw InputError("ComputeKeyframeBow: descriptor rows do not match the feature counts");
  }
  KeyframeBow bow;
  bow.points =
      vocabulary.points.Transform(features.point_descriptors, point_nodes, direct_index_level);
  bow.lines = vocabulary.lines.Transform(features.line_descriptors, line_nodes, direct_index_level);
  bow.num_points = static_cast<int>(features.points.size());
  bow.num_lines = static_cast<int>(features.lines.size());
  bow.point_spread = GridOccupancy(
      features.points.size(), [&](std::size_t i) { return features.points[i].uv; }, width, height,
      options.grid_cols, options.grid_rows);
  bow.line_spread = GridOccupancy(
      features.lines.size(),
      [&](std::size_t i) -> Eigen::Vector2d {
        return 0.5 * (features.lines[i].s + features.lines[i].e);
      },
      width, height, options.grid_cols, options.grid_rows);
  return bow;
}

double PointScoreWeight(const KeyframeBow& a, const KeyframeBow& b, double line_weight) {
  return 0.5 * (FramePointWeight(a, line_weight) + FramePointWeight(b, line_weight));
}

double CombinedScore(const KeyframeBow& a, const KeyframeBow& b, double line_weight) {
  const double w = PointScoreWeight(a, b, line_weight);
  return w * BowL1Score(a.points, b.points) + (1.0 - w) * BowL1Score(a.lines, b.lines);
}

KeyframeDatabase::KeyframeDatabase(const KeyframeDatabaseOptions& options) : options_(options) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("keyframe_database: " + err);
}

void KeyframeDatabase::Insert(InvertedIndex* index, const BowVector& bow, uint32_t slot) {
  if (!bow.empty() && bow.back().first >= index->size()) index->resize(bow.back().first + 1);
  for (const auto& [word, value] : bow) (*index)[word].push_back({slot, value});
}

void KeyframeDatabase::Erase(InvertedIndex* index, const BowVector& bow, uint32_t slot) {
  for (const auto& [word, value] : bow) {
    std::vector<Posting>& list = (*index)[word];
    for (std::size_t i = 0; i < list.size(); ++i) {
      if (list[i].slot == slot) {
        list[i] = list.back();
        list.pop_back();
        break;
      }
    }
  }
}

void KeyframeDatabase::Add(int id, const KeyframeBow& bow) {
  std::lock_guard<std::mutex> lock(mutex_);
  RemoveLocked(id);
  uint32_t slot;
  if (!free_slots_.empty()) {
    slot = free_slots_.back();
    free_slots_.pop_back();
  } else {
    slot = static_cast<uint32_t>(entries_.size());
    entries_.emplace_back();
  }
  entries_[slot].id = id;
  entries_[slot].bow = bow;
  slot_of_id_[id] = slot;
  Insert(&point_index_, bow.points, slot);
  Insert(&line_index_, bow.lines, slot);
}

void KeyframeDatabase::RemoveLocked(int id) {
  const auto it = slot_of_id_.find(id);
  if (it == slot_of_id_.end()) return;
  const uint32_t slot = it->second;
  Erase(&point_index_, entries_[slot].bow.points, slot);
  Erase(&line_index_, entries_[slot].bow.lines, slot);
  entries_[slot] = Entry();
  free_slots_.push_back(slot);
  slot_of_id_.erase(it);
}

bool KeyframeDatabase::Remove(int id) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (slot_of_id_.count(id) == 0) return false;
  RemoveLocked(id);
  return true;
}

void KeyframeDatabase::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.clear();
  free_slots_.clear();
  slot_of_id_.clear();
  point_index_.clear();
  line_index_.clear();
}

bool KeyframeDatabase::Contains(int id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return slot_of_id_.count(id) > 0;
}

bool KeyframeDatabase::ScoreAgainst(const KeyframeBow& query, int id, double* score) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = slot_of_id_.find(id);
  if (it == slot_of_id_.end()) return false;
  *score = CombinedScore(query, entries_[it->second].bow, options_.line_weight);
  return true;
}

std::size_t KeyframeDatabase::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return slot_of_id_.size();
}

std::vector<int> KeyframeDatabase::ids() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<int> out;
  out.reserve(slot_of_id_.size());
  for (const auto& [id, slot] : slot_of_id_) out.push_back(id);
  std::sort(out.begin(), out.end());
  return out;
}

std::vector<LoopCandidate> KeyframeDatabase::Query(const KeyframeBow& query, int max_results,
                                                   const std::unordered_set<int>* exclude) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<LoopCandidate> out;
  if (max_results <= 0 || slot_of_id_.empty()) return out;
  if (acc_points_.size() < entries_.size()) {
    acc_points_.resize(entries_.size(), 0.0f);
    acc_lines_.resize(entries_.size(), 0.0f);
    acc_shared_.resize(entries_.size(), 0);
  }
  touched_.clear();
  // Histogram intersection over the shared words: sum of min(q_w, c_w) is the L1 score.
  auto accumulate = [this](const InvertedIndex& index, const BowVector& bow,
                           std::vector<float>* acc) {
    for (const auto& [word, q] : bow) {
      if (word >= index.size()) continue;
      for (const Posting& p : index[word]) {
        if (acc_shared_[p.slot] == 0) touched_.push_back(p.slot);
        ++acc_shared_[p.slot];
        (*acc)[p.slot] += std::min(q, p.value);
      }
    }
  };
  accumulate(point_index_, query.points, &acc_points_);
  accumulate(line_index_, query.lines, &acc_lines_);

  out.reserve(touched_.size());
  for (uint32_t slot : touched_) {
    const Entry& e = entries_[slot];
    if (!exclude || exclude->count(e.id) == 0) {
      LoopCandidate c;
      c.id = e.id;
      c.point_score = std::clamp<double>(acc_points_[slot], 0.0, 1.0);
      c.line_score = std::clamp<double>(acc_lines_[slot], 0.0, 1.0);
      const double w = PointScoreWeight(query, e.bow, options_.line_weight);
      c.score = w * c.point_score + (1.0 - w) * c.line_score;
      c.shared_words = acc_shared_[slot];
      if (c.score >= options_.min_score) out.push_back(c);
    }
    acc_points_[slot] = 0.0f;
    acc_lines_[slot] = 0.0f;
    acc_shared_[slot] = 0;
  }
  const auto better = [](const LoopCandidate& a, const LoopCandidate& b) {
    return a.score != b.score ? a.score > b.score : a.id < b.id;
  };
  const std::size_t n = std::min<std::size_t>(out.size(), max_results);
  std::partial_sort(out.begin(), out.begin() + n, out.end(), better);
  out.resize(n);
  return out;
}

}  // namespace pl_slam
