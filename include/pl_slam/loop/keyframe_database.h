// Keyframe database for loop detection and relocalisation: keyframe bag-of-words vectors
// (points and lines) indexed by word, so a query touches only the keyframes that share a word
// with it (no scan over all keyframes), scored with a combined point + line similarity.
//
// Combined score of a query q and a keyframe c (paper Section VI, done with a vocabulary):
//   s = w_p * s_p + (1 - w_p) * s_l,  s_p / s_l the L1 BoW scores of points / lines,
//   w_p = (w_p(q) + w_p(c)) / 2,  w_p(f) = a_p / (a_p + a_l),
//   a_p = n_p * spread_p,  a_l = line_weight * n_l * spread_l,
// n the feature counts of the frame and spread the share of image grid cells holding a
// keypoint (points) or a segment midpoint (lines). A frame whose lines are few or bunched in
// one corner thus trusts its point score, and the other way round.
#pragma once

#include <cstdint>
#include <mutex>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "pl_slam/features/stereo_features.h"
#include "pl_slam/loop/vocabulary.h"

namespace pl_slam {

/// Options of the keyframe database and of ComputeKeyframeBow.
struct KeyframeDatabaseOptions {
  int grid_cols = 8;         ///< columns of the grid measuring feature spread
  int grid_rows = 6;         ///< rows of the grid measuring feature spread
  double line_weight = 1.0;  ///< weight of one line relative to one point in w_p (see above)
  double min_score = 0.0;    ///< query results with a combined score below this are dropped

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// What the database stores of one keyframe (and what a query is made of).
struct KeyframeBow {
  BowVector points;           ///< ORB BoW vector
  BowVector lines;            ///< LBD BoW vector
  int num_points = 0;         ///< point features of the frame
  int num_lines = 0;          ///< line features of the frame
  double point_spread = 0.0;  ///< share of grid cells holding a keypoint, [0, 1]
  double line_spread = 0.0;   ///< share of grid cells holding a segment midpoint, [0, 1]
};

/// BoW vectors and spreads of a frame's features. `width` x `height` is the image size. With
/// `point_nodes` / `line_nodes`, also the direct indices at depth `direct_index_level` (for
/// EstimateRelativePose's restricted matching). Throws ConfigError on invalid options or image
/// size, InputError on descriptors that do not fit the features.
KeyframeBow ComputeKeyframeBow(const StereoFeatures& features,
                               const PointLineVocabulary& vocabulary, int width, int height,
                               const KeyframeDatabaseOptions& options,
                               FeatureNodeIndex* point_nodes = nullptr,
                               FeatureNodeIndex* line_nodes = nullptr, int direct_index_level = 2);

/// Weight of the point score for a pair of frames, w_p above, in [0, 1].
double PointScoreWeight(const KeyframeBow& a, const KeyframeBow& b, double line_weight);

/// Combined point + line similarity of two frames (formula above), in [0, 1].
double CombinedScore(const KeyframeBow& a, const KeyframeBow& b, double line_weight);

/// One query result.
struct LoopCandidate {
  int id = -1;               ///< keyframe id
  double score = 0.0;        ///< combined score, [0, 1]
  double point_score = 0.0;  ///< L1 score of the ORB vectors
  double line_score = 0.0;   ///< L1 score of the LBD vectors
  int shared_words = 0;      ///< words (points and lines) present in both
};

/// Inverted-index database of keyframe BoW vectors, keyed by integer keyframe id.
///
/// Thread safety: one internal mutex guards all state; every public method takes it for its
/// whole duration and calls nothing outside the database while holding it, so the database
/// may be used from any thread (tracking / relocalisation queries while the loop closer adds
/// or removes keyframes) and never takes part in a lock-order cycle. Queries run one at a time.
class KeyframeDatabase {
 public:
  /// Throws ConfigError on invalid options.
  explicit KeyframeDatabase(const KeyframeDatabaseOptions& options = KeyframeDatabaseOptions());

  /// Adds keyframe `id`, replacing an earlier entry with the same id.
  void Add(int id, const KeyframeBow& bow);
  /// Removes keyframe `id`; false when it is not in the database.
  bool Remove(int id);
  /// Removes every keyframe.
  void Clear();
  /// True when keyframe `id` is in the database.
  bool Contains(int id) const;
  /// Combined score of `query` against keyframe `id` (CombinedScore with the options' line
  /// weight); false when `id` is not in the database.
  bool ScoreAgainst(const KeyframeBow& query, int id, double* score) const;
  /// Number of keyframes.
  std::size_t size() const;
  /// Ids of the keyframes in the database, increasing.
  std::vector<int> ids() const;

  /// The `max_results` keyframes most similar to `query` by combined score, best first
  /// (ties by increasing id), skipping the ids in `exclude` and scores below
  /// options.min_score. Only keyframes sharing at least one word with the query are
  /// considered (a keyframe sharing none scores 0).
  std::vector<LoopCandidate> Query(const KeyframeBow& query, int max_results,
                                   const std::unordered_set<int>* exclude = nullptr) const;

  /// The options in use.
  const KeyframeDatabaseOptions& options() const { return options_; }

 private:
  struct Posting {
    uint32_t slot;  // index into entries_
    float value;    // the keyframe's weight of this word
  };
  struct Entry {
    int id = -1;
    KeyframeBow bow;
  };
  using InvertedIndex = std::vector<std::vector<Posting>>;

  void RemoveLocked(int id);
  static void Insert(InvertedIndex* index, const BowVector& bow, uint32_t slot);
  static void Erase(InvertedIndex* index, const BowVector& bow, uint32_t slot);

  const KeyframeDatabaseOptions options_;
  mutable std::mutex mutex_;
  std::vector<Entry> entries_;  // by slot; id -1 = free
  std::vector<uint32_t> free_slots_;
  std::unordered_map<int, uint32_t> slot_of_id_;
  InvertedIndex point_index_;  // word -> keyframes having it
  InvertedIndex line_index_;
  // Query scratch (guarded by mutex_): per-slot accumulators and the touched slots.
  mutable std::vector<float> acc_points_, acc_lines_;
  mutable std::vector<int> acc_shared_;
  mutable std::vector<uint32_t> touched_;
};

}  // namespace pl_slam
