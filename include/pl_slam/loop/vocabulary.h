// A hierarchical bag-of-words vocabulary for 256-bit binary descriptors (ORB points and LBD
// lines use one type, trained separately): a k-majority tree (k-medians under the Hamming
// distance, a centre is the bitwise majority of its members) seeded k-means++ style, with
// TF-IDF word weights, the transform of a descriptor set into a sparse L1-normalised
// bag-of-words vector plus a direct index, the L1 score, and a versioned, checksummed binary
// file format.
//
// File format (all integers little-endian; version 1):
//   header, 80 bytes:
//     char[8]  magic "PLSLVOC\0"
//     u32      version (1)
//     u32      header size in bytes (80)
//     char[8]  descriptor kind, NUL-padded ("orb", "lbd", ...)
//     u32      descriptor size in bytes (32)
//     u32      branching factor k
//     u32      depth L
//     u32      weighting (1 = TF-IDF)
//     u32      number of nodes (root included)
//     u32      number of words (leaves)
//     u64      training images (descriptor sets the idf was computed from)
//     u64      training descriptors
//     u64      payload size in bytes
//     u64      FNV-1a 64-bit checksum of the payload
//   payload:
//     nodes 1 .. num_nodes-1 in breadth-first order (children of a node are contiguous and
//     follow their parent): u32 parent, 32 bytes centre descriptor;
//     then one f32 idf weight per word, words numbered by increasing node id of their leaf.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace pl_slam {

/// A 256-bit binary descriptor as four 64-bit words (bit order as the 32 bytes in memory).
using Descriptor256 = std::array<uint64_t, 4>;

/// Loads row `row` of a CV_8U matrix with 32 columns.
Descriptor256 DescriptorFromRow(const cv::Mat& descriptors, int row);

/// Hamming distance of two 256-bit descriptors.
inline int Hamming256(const Descriptor256& a, const Descriptor256& b) {
  return __builtin_popcountll(a[0] ^ b[0]) + __builtin_popcountll(a[1] ^ b[1]) +
         __builtin_popcountll(a[2] ^ b[2]) + __builtin_popcountll(a[3] ^ b[3]);
}

/// A sparse bag-of-words vector: (word id, weight) sorted by word id, weights > 0 summing to 1
/// (or empty when no descriptor was given).
using BowVector = std::vector<std::pair<uint32_t, float>>;

/// Direct index: (node id at the direct-index level, indices of the features under it) sorted
/// by node id. Two features can only correspond when they share a node, which restricts
/// descriptor matching between two frames.
using FeatureNodeIndex = std::vector<std::pair<uint32_t, std::vector<int>>>;

/// L1 similarity of two L1-normalised BoW vectors (DBoW2 style): 1 - 0.5 |a - b|_1, which for
/// non-negative weights is the sum over shared words of min(a_w, b_w). In [0, 1]; 1 for equal
/// vectors, 0 when no word is shared or either vector is empty.
double BowL1Score(const BowVector& a, const BowVector& b);

/// Options of vocabulary training.
struct VocabularyOptions {
  int branching = 10;        ///< k: children per node
  int depth = 4;             ///< L: levels below the root; up to k^L words
  int max_iterations = 15;   ///< k-majority iterations per node (stops earlier when stable)
  uint64_t seed = 1;         ///< seeds the k-means++ initialisation (training is deterministic)
  std::string kind = "orb";  ///< descriptor kind written to the file (1..8 characters)

  /// Empty when valid, else "key=value must be in [a, b]" for the first bad key.
  std::string Validate() const;
};

/// A trained vocabulary tree. Immutable after training or loading; every const method may run
/// concurrently from several threads.
class Vocabulary {
 public:
  /// Current file format version.
  static constexpr uint32_t kFileVersion = 1;

  /// An empty vocabulary (no words; Transform gives empty vectors).
  Vocabulary() = default;

  /// Trains on `images`: each element is one training image's descriptors (CV_8U, 32 columns,
  /// any number of rows). The tree is built from all descriptors; the idf of word w is
  /// log(N / n_w), N the number of images with at least one descriptor and n_w those with a
  /// descriptor in w. Throws ConfigError on invalid options, InputError on descriptors of the
  /// wrong type or width, or when there are no descriptors at all.
  static Vocabulary Train(const std::vector<cv::Mat>& images, const VocabularyOptions& options);

  /// Loads a file written by Save. Throws InputError "<path>: <what is wrong>" when the file
  /// cannot be read, is truncated, corrupted (checksum, structure), of another version, or of
  /// another descriptor kind than `expected_kind` (not checked when empty).
  static Vocabulary Load(const std::string& path, const std::string& expected_kind = "");

  /// Writes the file atomically (temporary file + rename). Throws InputError when the file
  /// cannot be written.
  void Save(const std::string& path) const;

  /// Word of one descriptor: descends from the root to the nearest child at every level.
  /// When `node_at_level` is not null it receives the node passed at depth `level` (1..depth;
  /// the leaf when the branch is shallower). Returns 0 for an empty vocabulary.
  uint32_t WordOf(const Descriptor256& d, int level = 0, uint32_t* node_at_level = nullptr) const;

  /// Transforms a descriptor set (CV_8U, 32 columns; may be empty) into a TF-IDF BoW vector,
  /// L1-normalised. With `node_index`, also fills the direct index at depth
  /// `direct_index_level` (1..depth; clamped). Throws InputError on a wrong matrix type.
  BowVector Transform(const cv::Mat& descriptors, FeatureNodeIndex* node_index = nullptr,
                      int direct_index_level = 2) const;

  /// True before training or loading (no words).
  bool empty() const { return word_node_.empty(); }
  /// Number of words (leaves).
  std::size_t num_words() const { return word_node_.size(); }
  /// Number of nodes, the root included.
  std::size_t num_nodes() const { return parent_.size(); }
  /// Branching factor k it was trained with.
  int branching() const { return branching_; }
  /// Depth L it was trained with.
  int depth() const { return depth_; }
  /// Descriptor kind tag ("orb", "lbd", ...).
  const std::string& kind() const { return kind_; }
  /// idf weight of a word.
  float word_weight(uint32_t word) const { return idf_[word]; }
  /// Training images (non-empty descriptor sets) the idf weights were computed from.
  uint64_t training_images() const { return training_images_; }
  /// Training descriptors the tree was built from.
  uint64_t training_descriptors() const { return training_descriptors_; }
  /// One line: kind, k, L, nodes, words, training set size.
  std::string Describe() const;

 private:
  void BuildChildren();

  std::string kind_;
  int branching_ = 0;
  int depth_ = 0;
  uint64_t training_images_ = 0;
  uint64_t training_descriptors_ = 0;
  // Per node (node 0 = root): parent, centre, first child and child count (children are
  // contiguous), depth, word id (or kNoWord for inner nodes).
  std::vector<uint32_t> parent_;
  std::vector<Descriptor256> centre_;
  std::vector<uint32_t> first_child_;
  std::vector<uint32_t> num_children_;
  std::vector<uint8_t> level_;
  std::vector<uint32_t> word_of_node_;
  // Per word: its leaf node and idf weight.
  std::vector<uint32_t> word_node_;
  std::vector<float> idf_;
};

/// The two vocabularies of the point + line loop detector.
struct PointLineVocabulary {
  Vocabulary points;  ///< ORB
  Vocabulary lines;   ///< LBD

  /// Loads `<folder>/orb.plvoc` and `<folder>/lbd.plvoc` (kinds checked). Throws InputError.
  static PointLineVocabulary LoadFolder(const std::string& folder);
};

}  // namespace pl_slam
