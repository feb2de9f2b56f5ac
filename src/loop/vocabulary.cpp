#include "pl_slam/loop/vocabulary.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <sstream>

#include "pl_slam/util/error.h"
#include "pl_slam/util/validation.h"

namespace pl_slam {

namespace {

constexpr char kMagic[8] = {'P', 'L', 'S', 'L', 'V', 'O', 'C', '\0'};
constexpr uint32_t kHeaderSize = 80;
constexpr uint32_t kDescriptorBytes = 32;
constexpr uint32_t kWeightingTfIdf = 1;
constexpr uint32_t kNoWord = std::numeric_limits<uint32_t>::max();
constexpr std::size_t kNodeRecordBytes = 4 + kDescriptorBytes;

void CheckDescriptorMatrix(const cv::Mat& m, const char* what) {
  if (m.empty()) return;
  if (m.type() != CV_8UC1 || m.cols != static_cast<int>(kDescriptorBytes)) {
    std::ostringstream os;
    os << what << ": descriptors must be CV_8UC1 with 32 columns (got type " << m.type() << ", "
       << m.cols << " columns)";
    throw InputError(os.str());
  }
}

// Little-endian serialisation, independent of the host byte order.
void PutU32(std::string* out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
void PutU64(std::string* out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}
uint32_t GetU32(const char* p) {
  uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= static_cast<uint32_t>(static_cast<uint8_t>(p[i])) << (8 * i);
  return v;
}
uint64_t GetU64(const char* p) {
  uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<uint64_t>(static_cast<uint8_t>(p[i])) << (8 * i);
  return v;
}

uint64_t Fnv1a64(const char* data, std::size_t n) {
  uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<uint8_t>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

// Bitwise majority of the member descriptors (ties give 0).
Descriptor256 Majority(const std::vector<Descriptor256>& all, const std::vector<uint32_t>& members,
                       const std::vector<int>& assignment, int cluster, std::vector<int>* counts) {
  std::fill(counts->begin(), counts->end(), 0);
  int n = 0;
  for (std::size_t i = 0; i < members.size(); ++i) {
    if (assignment[i] != cluster) continue;
    ++n;
    const Descriptor256& d = all[members[i]];
    for (int w = 0; w < 4; ++w) {
      uint64_t bits = d[w];
      while (bits) {
        const int b = __builtin_ctzll(bits);
        ++(*counts)[w * 64 + b];
        bits &= bits - 1;
      }
    }
  }
  Descriptor256 c{0, 0, 0, 0};
  for (int b = 0; b < 256; ++b) {
    if (2 * (*counts)[b] > n) c[b / 64] |= uint64_t{1} << (b % 64);
  }
  return c;
}

// k-majority clustering of `members` (indices into `all`): k-means++ seeding (probability
// proportional to the squared Hamming distance to the nearest chosen centre), then
// assignment / bitwise-majority update until stable. Returns the non-empty clusters.
std::vector<std::pair<Descriptor256, std::vector<uint32_t>>> KMajority(
    const std::vector<Descriptor256>& all, const std::vector<uint32_t>& members, int k,
    int max_iterations, std::mt19937_64* rng) {
  std::vector<std::pair<Descriptor256, std::vector<uint32_t>>> clusters;
  if (members.size() <= static_cast<std::size_t>(k)) {
    // As many clusters as descriptors (DBoW2 does the same): each becomes a leaf below.
    for (uint32_t m : members) clusters.push_back({all[m], {m}});
    return clusters;
  }
  const std::size_t n = members.size();
  std::vector<Descriptor256> centres;
  centres.push_back(all[members[std::uniform_int_distribution<std::size_t>(0, n - 1)(*rng)]]);
  std::vector<double> d2(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double d = Hamming256(all[members[i]], centres[0]);
    d2[i] = d * d;
  }
  while (static_cast<int>(centres.size()) < k) {
    double total = 0.0;
    for (double v : d2) total += v;
    if (total <= 0.0) break;  // every descriptor equals a centre already
    double r = std::uniform_real_distribution<double>(0.0, total)(*rng);
    std::size_t pick = n - 1;
    for (std::size_t i = 0; i < n; ++i) {
      r -= d2[i];
      if (r <= 0.0 && d2[i] > 0.0) {
        pick = i;
        break;
      }
    }
    if (d2[pick] <= 0.0) break;
    centres.push_back(all[members[pick]]);
    for (std::size_t i = 0; i < n; ++i) {
      const double d = Hamming256(all[members[i]], centres.back());
      d2[i] = std::min(d2[i], d * d);
    }
  }

  const int kc = static_cast<int>(centres.size());
  std::vector<int> assignment(n, -1);
  std::vector<int> counts(256);
  for (int it = 0; it < max_iterations; ++it) {
    bool changed = false;
    for (std::size_t i = 0; i < n; ++i) {
      const Descriptor256& d = all[members[i]];
      int best = 0, best_dist = Hamming256(d, centres[0]);
      for (int c = 1; c < kc; ++c) {
        const int dist = Hamming256(d, centres[c]);
        if (dist < best_dist) {
          best_dist = dist;
          best = c;
        }
      }
      if (assignment[i] != best) {
        assignment[i] = best;
        changed = true;
      }
    }
    if (!changed) break;
    for (int c = 0; c < kc; ++c) {
      centres[c] = Majority(all, members, assignment, c, &counts);
    }
  }
  std::vector<std::vector<uint32_t>> groups(kc);
  for (std::size_t i = 0; i < n; ++i) groups[assignment[i]].push_back(members[i]);
  for (int c = 0; c < kc; ++c) {
    if (!groups[c].empty()) clusters.push_back({centres[c], std::move(groups[c])});
  }
  return clusters;
}

}  // namespace

Descriptor256 DescriptorFromRow(const cv::Mat& descriptors, int row) {
  Descriptor256 d;
  std::memcpy(d.data(), descriptors.ptr<uint8_t>(row), kDescriptorBytes);
  return d;
}

double BowL1Score(const BowVector& a, const BowVector& b) {
  double s = 0.0;
  auto ia = a.begin(), ib = b.begin();
  while (ia != a.end() && ib != b.end()) {
    if (ia->first < ib->first) {
      ++ia;
    } else if (ib->first < ia->first) {
      ++ib;
    } else {
      s += std::min(ia->second, ib->second);
      ++ia;
      ++ib;
    }
  }
  return std::clamp(s, 0.0, 1.0);
}

std::string VocabularyOptions::Validate() const {
  std::string first;
  auto check = [&first](const std::string& error) {
    if (first.empty()) first = error;
  };
  check(CheckRange("branching", branching, 2, 64));
  check(CheckRange("depth", depth, 1, 8));
  check(CheckRange("max_iterations", max_iterations, 1, 1000));
  if (first.empty() && (kind.empty() || kind.size() > 8)) {
    first = "kind='" + kind + "' must have 1 to 8 characters";
  }
  if (first.empty() && std::pow(static_cast<double>(branching), depth) > 1e7) {
    std::ostringstream os;
    os << "branching=" << branching << ", depth=" << depth
       << ": branching^depth must be at most 1e7 words";
    first = os.str();
  }
  return first;
}

Vocabulary Vocabulary::Train(const std::vector<cv::Mat>& images, const VocabularyOptions& options) {
  const std::string err = options.Validate();
  if (!err.empty()) throw ConfigError("vocabulary: " + err);
  std::vector<Descriptor256> all;
  std::vector<uint32_t> image_of;
  uint64_t num_images = 0;
  for (std::size_t i = 0; i < images.size(); ++i) {
    CheckDescriptorMatrix(images[i], "vocabulary training image");
    if (images[i].rows == 0) continue;
    for (int r = 0; r < images[i].rows; ++r) {
      all.push_back(DescriptorFromRow(images[i], r));
      image_of.push_back(static_cast<uint32_t>(num_images));
    }
    ++num_images;
  }
  if (all.empty()) throw InputError("vocabulary training: no descriptors given");

  Vocabulary voc;
  voc.kind_ = options.kind;
  voc.branching_ = options.branching;
  voc.depth_ = options.depth;
  voc.training_images_ = num_images;
  voc.training_descriptors_ = all.size();
  voc.parent_.push_back(0);
  voc.centre_.push_back(Descriptor256{0, 0, 0, 0});

  // Breadth-first: the children of a node are created together (contiguous ids) and after
  // their parent, which the file format relies on.
  struct Task {
    uint32_t node;
    int level;
    std::vector<uint32_t> members;
  };
  std::deque<Task> queue;
  {
    std::vector<uint32_t> members(all.size());
    for (std::size_t i = 0; i < all.size(); ++i) members[i] = static_cast<uint32_t>(i);
    queue.push_back({0, 0, std::move(members)});
  }
  while (!queue.empty()) {
    Task task = std::move(queue.front());
    queue.pop_front();
    if (task.level >= options.depth || (task.members.size() <= 1 && task.level > 0)) continue;
    // Per-node seed: the result does not depend on how the queue is processed.
    std::mt19937_64 rng(options.seed * 0x9E3779B97F4A7C15ull + task.node);
    auto clusters = KMajority(all, task.members, options.branching, options.max_iterations, &rng);
    if (clusters.size() <= 1 && task.level > 0) continue;  // cannot split: stays a leaf
    for (auto& [centre, members] : clusters) {
      const uint32_t id = static_cast<uint32_t>(voc.parent_.size());
      voc.parent_.push_back(task.node);
      voc.centre_.push_back(centre);
      queue.push_back({id, task.level + 1, std::move(members)});
    }
  }
  voc.BuildChildren();

  // idf from the training images: log(N / n_w).
  std::vector<uint32_t> images_with_word(voc.num_words(), 0);
  std::vector<uint32_t> last_image(voc.num_words(), kNoWord);
  for (std::size_t i = 0; i < all.size(); ++i) {
    const uint32_t w = voc.WordOf(all[i]);
    if (last_image[w] != image_of[i]) {
      last_image[w] = image_of[i];
      ++images_with_word[w];
    }
  }
  voc.idf_.assign(voc.num_words(), 1.0f);
  if (num_images > 1) {
    const double n = static_cast<double>(num_images);
    for (std::size_t w = 0; w < voc.num_words(); ++w) {
      const double nw = std::max<uint32_t>(images_with_word[w], 1);
      voc.idf_[w] = static_cast<float>(std::log(n / nw));
    }
  }
  return voc;
}

void Vocabulary::BuildChildren() {
  const std::size_t n = parent_.size();
  first_child_.assign(n, 0);
  num_children_.assign(n, 0);
  level_.assign(n, 0);
  word_of_node_.assign(n, kNoWord);
  word_node_.clear();
  for (std::size_t i = 1; i < n; ++i) {
    const uint32_t p = parent_[i];
    if (num_children_[p] == 0) first_child_[p] = static_cast<uint32_t>(i);
    ++num_children_[p];
    level_[i] = static_cast<uint8_t>(level_[p] + 1);
  }
  for (std::size_t i = 1; i < n; ++i) {
    if (num_children_[i] == 0) {
      word_of_node_[i] = static_cast<uint32_t>(word_node_.size());
      word_node_.push_back(static_cast<uint32_t>(i));
    }
  }
}

uint32_t Vocabulary::WordOf(const Descriptor256& d, int level, uint32_t* node_at_level) const {
  if (word_node_.empty()) return 0;
  uint32_t node = 0;
  while (num_children_[node] > 0) {
    const uint32_t begin = first_child_[node], end = begin + num_children_[node];
    uint32_t best = begin;
    int best_dist = Hamming256(d, centre_[begin]);
    for (uint32_t c = begin + 1; c < end; ++c) {
      const int dist = Hamming256(d, centre_[c]);
      if (dist < best_dist) {
        best_dist = dist;
        best = c;
      }
    }
    node = best;
    if (node_at_level && level_[node] == level) *node_at_level = node;
  }
  if (node_at_level && level_[node] < level) *node_at_level = node;
  return word_of_node_[node];
}

BowVector Vocabulary::Transform(const cv::Mat& descriptors, FeatureNodeIndex* node_index,
                                int direct_index_level) const {
  CheckDescriptorMatrix(descriptors, "Vocabulary::Transform");
  BowVector bow;
  if (node_index) node_index->clear();
  if (word_node_.empty() || descriptors.empty()) return bow;
  const int level = std::clamp(direct_index_level, 1, std::max(depth_, 1));
  std::vector<std::pair<uint32_t, int>> node_feature;
  if (node_index) node_feature.reserve(descriptors.rows);
  bow.reserve(descriptors.rows);
  for (int r = 0; r < descriptors.rows; ++r) {
    uint32_t node = 0;
    const uint32_t w = WordOf(DescriptorFromRow(descriptors, r), level, &node);
    if (node_index) node_feature.emplace_back(node, r);
    if (idf_[w] > 0.0f) bow.emplace_back(w, idf_[w]);
  }
  std::sort(bow.begin(), bow.end());
  std::size_t out = 0;
  double total = 0.0;
  for (std::size_t i = 0; i < bow.size(); ++i) {
    total += bow[i].second;
    if (out > 0 && bow[out - 1].first == bow[i].first) {
      bow[out - 1].second += bow[i].second;
    } else {
      bow[out++] = bow[i];
    }
  }
  bow.resize(out);
  if (total > 0.0) {
    for (auto& [w, v] : bow) v = static_cast<float>(v / total);
  }
  if (node_index) {
    std::sort(node_feature.begin(), node_feature.end());
    for (const auto& [node, feature] : node_feature) {
      if (node_index->empty() || node_index->back().first != node)
        node_index->push_back({node, {}});
      node_index->back().second.push_back(feature);
    }
  }
  return bow;
}

std::string Vocabulary::Describe() const {
  std::ostringstream os;
  os << "vocabulary '" << kind_ << "': k=" << branching_ << ", L=" << depth_ << ", " << num_nodes()
     << " nodes, " << num_words() << " words, trained on " << training_images_ << " images / "
     << training_descriptors_ << " descriptors";
  return os.str();
}

void Vocabulary::Save(const std::string& path) const {
  std::string payload;
  payload.reserve((num_nodes() - 1) * kNodeRecordBytes + num_words() * 4);
  for (std::size_t i = 1; i < num_nodes(); ++i) {
    PutU32(&payload, parent_[i]);
    payload.append(reinterpret_cast<const char*>(centre_[i].data()), kDescriptorBytes);
  }
  for (float w : idf_) {
    uint32_t bits;
    std::memcpy(&bits, &w, 4);
    PutU32(&payload, bits);
  }
  std::string file(kMagic, kMagic + 8);
  PutU32(&file, kFileVersion);
  PutU32(&file, kHeaderSize);
  char kind[8] = {0};
  std::memcpy(kind, kind_.data(), std::min<std::size_t>(kind_.size(), 8));
  file.append(kind, 8);
  PutU32(&file, kDescriptorBytes);
  PutU32(&file, static_cast<uint32_t>(branching_));
  PutU32(&file, static_cast<uint32_t>(depth_));
  PutU32(&file, kWeightingTfIdf);
  PutU32(&file, static_cast<uint32_t>(num_nodes()));
  PutU32(&file, static_cast<uint32_t>(num_words()));
  PutU64(&file, training_images_);
  PutU64(&file, training_descriptors_);
  PutU64(&file, payload.size());
  PutU64(&file, Fnv1a64(payload.data(), payload.size()));
  file += payload;

  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot open for writing");
    out.write(file.data(), static_cast<std::streamsize>(file.size()));
    if (!out) throw InputError(path + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw InputError(path + ": cannot rename the temporary file: " + ec.message());
}

Vocabulary Vocabulary::Load(const std::string& path, const std::string& expected_kind) {
  auto fail = [&path](const std::string& what) -> InputError {
    return InputError(path + ": " + what);
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) throw fail("cannot open vocabulary file");
  const std::string file((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (file.size() < kHeaderSize) {
    std::ostringstream os;
    os << "truncated vocabulary file: " << file.size() << " bytes, the header alone has "
       << kHeaderSize;
    throw fail(os.str());
  }
  const char* h = file.data();
  if (std::memcmp(h, kMagic, 8) != 0) throw fail("not a pl_slam vocabulary file (bad magic)");
  const uint32_t version = GetU32(h + 8);
  if (version != kFileVersion) {
    std::ostringstream os;
    os << "vocabulary file format version " << version << ", this build reads version "
       << kFileVersion << " (retrain with pl_slam_train_vocabulary)";
    throw fail(os.str());
  }
  if (GetU32(h + 12) != kHeaderSize) throw fail("corrupted header (header size)");
  std::string kind(h + 16, 8);
  kind = kind.substr(0, kind.find('\0'));
  if (!expected_kind.empty() && kind != expected_kind) {
    throw fail("descriptor kind '" + kind + "', expected '" + expected_kind + "'");
  }
  const uint32_t desc_bytes = GetU32(h + 24);
  const uint32_t k = GetU32(h + 28), depth = GetU32(h + 32), weighting = GetU32(h + 36);
  const uint32_t num_nodes = GetU32(h + 40), num_words = GetU32(h + 44);
  const uint64_t images = GetU64(h + 48), descriptors = GetU64(h + 56);
  const uint64_t payload_bytes = GetU64(h + 64), checksum = GetU64(h + 72);
  std::ostringstream bad;
  if (desc_bytes != kDescriptorBytes) {
    bad << "descriptor size " << desc_bytes << " bytes, expected " << kDescriptorBytes;
  } else if (weighting != kWeightingTfIdf) {
    bad << "unknown weighting " << weighting;
  } else if (k < 2 || k > 64 || depth < 1 || depth > 8) {
    bad << "corrupted header: k=" << k << ", L=" << depth;
  } else if (num_nodes < 2 || num_words < 1 || num_words >= num_nodes) {
    bad << "corrupted header: " << num_nodes << " nodes, " << num_words << " words";
  }
  if (!bad.str().empty()) throw fail(bad.str());
  const uint64_t expected_payload =
      uint64_t{num_nodes - 1} * kNodeRecordBytes + uint64_t{num_words} * 4;
  if (payload_bytes != expected_payload) {
    throw fail("corrupted header: payload size does not match the node and word counts");
  }
  if (file.size() - kHeaderSize < payload_bytes) {
    std::ostringstream os;
    os << "truncated vocabulary file: " << file.size() << " bytes, expected "
       << kHeaderSize + payload_bytes;
    throw fail(os.str());
  }
  if (file.size() - kHeaderSize > payload_bytes) {
    std::ostringstream os;
    os << "unexpected " << file.size() - kHeaderSize - payload_bytes
       << " trailing bytes after the vocabulary";
    throw fail(os.str());
  }
  const char* p = h + kHeaderSize;
  if (Fnv1a64(p, payload_bytes) != checksum) {
    throw fail("corrupted vocabulary file: checksum mismatch");
  }

  Vocabulary voc;
  voc.kind_ = kind;
  voc.branching_ = static_cast<int>(k);
  voc.depth_ = static_cast<int>(depth);
  voc.training_images_ = images;
  voc.training_descriptors_ = descriptors;
  voc.parent_.resize(num_nodes);
  voc.centre_.resize(num_nodes);
  voc.parent_[0] = 0;
  voc.centre_[0] = Descriptor256{0, 0, 0, 0};
  for (uint32_t i = 1; i < num_nodes; ++i, p += kNodeRecordBytes) {
    const uint32_t parent = GetU32(p);
    // Breadth-first order: parents come first and siblings are contiguous.
    if (parent >= i || parent < voc.parent_[i - 1]) {
      throw fail("corrupted vocabulary file: nodes out of breadth-first order");
    }
    voc.parent_[i] = parent;
    std::memcpy(voc.centre_[i].data(), p + 4, kDescriptorBytes);
  }
  voc.BuildChildren();
  for (uint32_t i = 0; i < num_nodes; ++i) {
    if (voc.num_children_[i] > k || voc.level_[i] > depth) {
      throw fail("corrupted vocabulary file: tree exceeds k or L of the header");
    }
  }
  if (voc.num_words() != num_words) {
    throw fail("corrupted vocabulary file: leaf count differs from the word count");
  }
  voc.idf_.resize(num_words);
  for (uint32_t w = 0; w < num_words; ++w, p += 4) {
    const uint32_t bits = GetU32(p);
    float v;
    std::memcpy(&v, &bits, 4);
    if (!std::isfinite(v) || v < 0.0f) throw fail("corrupted vocabulary file: bad word weight");
    voc.idf_[w] = v;
  }
  return voc;
}

PointLineVocabulary PointLineVocabulary::LoadFolder(const std::string& folder) {
  PointLineVocabulary v;
  v.points = Vocabulary::Load(folder + "/orb.plvoc", "orb");
  v.lines = Vocabulary::Load(folder + "/lbd.plvoc", "lbd");
  return v;
}

}  // namespace pl_slam
