// Vocabulary: k-majority training, transform, scoring, file format and its error handling.
#include "pl_slam/loop/vocabulary.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <set>

#include "pl_slam/util/error.h"
#include "test_util/temp_dir.h"

namespace pl_slam {
namespace {

using testing_util::TempDir;

Descriptor256 RandomDescriptor(std::mt19937_64* rng) {
  return {(*rng)(), (*rng)(), (*rng)(), (*rng)()};
}

Descriptor256 FlipBits(Descriptor256 d, int bits, std::mt19937_64* rng) {
  std::uniform_int_distribution<int> bit(0, 255);
  for (int i = 0; i < bits; ++i) {
    const int b = bit(*rng);
    d[b / 64] ^= uint64_t{1} << (b % 64);
  }
  return d;
}

cv::Mat ToMat(const std::vector<Descriptor256>& ds) {
  cv::Mat m(static_cast<int>(ds.size()), 32, CV_8UC1);
  for (std::size_t i = 0; i < ds.size(); ++i)
    std::memcpy(m.ptr(static_cast<int>(i)), ds[i].data(), 32);
  return m;
}

// `clusters` clusters in groups of 10: group centres are random (~128 bits apart), cluster
// centres 20 random bit flips from their group centre (~40 bits apart), members 3 flips from
// their cluster centre; members are spread over `images` training images. A k = 10, L = 2
// tree should find the groups at level 1 and the clusters at level 2.
struct ClusteredData {
  std::vector<Descriptor256> centres;
  std::vector<std::vector<Descriptor256>> members;  // per cluster
  std::vector<cv::Mat> images;
};

ClusteredData MakeClusteredData(int clusters, int per_cluster, int images, uint64_t seed) {
  std::mt19937_64 rng(seed);
  ClusteredData data;
  std::vector<std::vector<Descriptor256>> per_image(images);
  Descriptor256 group{};
  for (int c = 0; c < clusters; ++c) {
    if (c % 10 == 0) group = RandomDescriptor(&rng);
    data.centres.push_back(FlipBits(group, 20, &rng));
    data.members.emplace_back();
    for (int i = 0; i < per_cluster; ++i) {
      const Descriptor256 d = FlipBits(data.centres.back(), 3, &rng);
      data.members.back().push_back(d);
      per_image[(c * per_cluster + i) % images].push_back(d);
    }
  }
  for (const auto& ds : per_image) data.images.push_back(ToMat(ds));
  return data;
}

TEST(VocabularyTest, TrainedTreeRecoversClustersAndDescriptorsMapToTheirOwnCluster) {
  const ClusteredData data = MakeClusteredData(100, 20, 40, 3);
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 2;
  const Vocabulary voc = Vocabulary::Train(data.images, options);
  EXPECT_EQ(voc.branching(), 10);
  EXPECT_EQ(voc.depth(), 2);
  EXPECT_EQ(voc.training_images(), 40u);
  EXPECT_EQ(voc.training_descriptors(), 2000u);
  EXPECT_LE(voc.num_words(), 100u);

  // Every member of a cluster lands in the word of its centre, and each cluster owns a word.
  int same = 0, total = 0;
  std::set<uint32_t> words_of_centres;
  for (std::size_t c = 0; c < data.centres.size(); ++c) {
    const uint32_t w = voc.WordOf(data.centres[c]);
    words_of_centres.insert(w);
    for (const Descriptor256& d : data.members[c]) {
      same += voc.WordOf(d) == w ? 1 : 0;
      ++total;
    }
  }
  EXPECT_GE(same, total * 99 / 100) << same << " of " << total;
  EXPECT_GE(words_of_centres.size(), 97u);
}

TEST(VocabularyTest, TrainingIsDeterministicAndSeedDependent) {
  const ClusteredData data = MakeClusteredData(30, 10, 10, 5);
  VocabularyOptions options;
  options.branching = 4;
  options.depth = 3;
  const Vocabulary a = Vocabulary::Train(data.images, options);
  const Vocabulary b = Vocabulary::Train(data.images, options);
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  for (const cv::Mat& img : data.images) EXPECT_EQ(a.Transform(img), b.Transform(img));
}

TEST(VocabularyTest, TransformScoresIdenticalSetsOneAndDisjointSetsZero) {
  const ClusteredData data = MakeClusteredData(100, 20, 40, 7);
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 3;
  const Vocabulary voc = Vocabulary::Train(data.images, options);

  // A set from clusters 0..49 and one from clusters 50..99 (fresh noisy members).
  std::mt19937_64 rng(11);
  std::vector<Descriptor256> first, second;
  for (int c = 0; c < 100; ++c) {
    for (int i = 0; i < 4; ++i) {
      (c < 50 ? first : second).push_back(FlipBits(data.centres[c], 6, &rng));
    }
  }
  FeatureNodeIndex nodes;
  const BowVector a = voc.Transform(ToMat(first), &nodes, 1);
  const BowVector b = voc.Transform(ToMat(second));
  ASSERT_FALSE(a.empty());
  double sum = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    sum += a[i].second;
    EXPECT_GT(a[i].second, 0.0f);
    if (i > 0) EXPECT_LT(a[i - 1].first, a[i].first);
  }
  EXPECT_NEAR(sum, 1.0, 1e-5);
  EXPECT_NEAR(BowL1Score(a, a), 1.0, 1e-5);
  EXPECT_NEAR(BowL1Score(a, voc.Transform(ToMat(first))), 1.0, 1e-6);
  EXPECT_LT(BowL1Score(a, b), 0.05);
  EXPECT_EQ(BowL1Score(a, BowVector()), 0.0);
  // Half of a set shared: a score in between.
  std::vector<Descriptor256> mixed(first.begin(), first.begin() + 100);
  mixed.insert(mixed.end(), second.begin(), second.begin() + 100);
  const double s_mixed = BowL1Score(a, voc.Transform(ToMat(mixed)));
  EXPECT_GT(s_mixed, 0.3);
  EXPECT_LT(s_mixed, 0.7);

  // Direct index: every feature once, grouped under level-1 nodes.
  std::size_t indexed = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    indexed += nodes[i].second.size();
    if (i > 0) EXPECT_LT(nodes[i - 1].first, nodes[i].first);
  }
  EXPECT_EQ(indexed, first.size());
  EXPECT_LE(nodes.size(), 10u);
}

TEST(VocabularyTest, IdfDownweightsWordsSeenInEveryImage) {
  std::mt19937_64 rng(13);
  const Descriptor256 common = RandomDescriptor(&rng);
  const Descriptor256 rare = RandomDescriptor(&rng);
  std::vector<cv::Mat> images;
  for (int i = 0; i < 10; ++i) {
    std::vector<Descriptor256> ds{common};
    if (i == 0) ds.push_back(rare);
    images.push_back(ToMat(ds));
  }
  VocabularyOptions options;
  options.branching = 2;
  options.depth = 1;
  const Vocabulary voc = Vocabulary::Train(images, options);
  ASSERT_EQ(voc.num_words(), 2u);
  EXPECT_NEAR(voc.word_weight(voc.WordOf(common)), 0.0, 1e-6);
  EXPECT_NEAR(voc.word_weight(voc.WordOf(rare)), std::log(10.0), 1e-5);
}

TEST(VocabularyTest, InvalidOptionsAndInputAreRefused) {
  VocabularyOptions o;
  o.branching = 1;
  EXPECT_NE(o.Validate().find("branching=1"), std::string::npos) << o.Validate();
  try {
    Vocabulary::Train({cv::Mat::zeros(3, 32, CV_8UC1)}, o);
    FAIL() << "no ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("branching=1"), std::string::npos);
  }
  o = VocabularyOptions();
  o.kind = "much_too_long";
  EXPECT_NE(o.Validate().find("kind"), std::string::npos);
  EXPECT_THROW(Vocabulary::Train({cv::Mat::zeros(3, 16, CV_8UC1)}, VocabularyOptions()),
               InputError);
  EXPECT_THROW(Vocabulary::Train({cv::Mat()}, VocabularyOptions()), InputError);
  // A single descriptor still gives a usable one-word vocabulary.
  const Vocabulary one = Vocabulary::Train({cv::Mat::ones(1, 32, CV_8UC1)}, VocabularyOptions());
  EXPECT_EQ(one.num_words(), 1u);
  EXPECT_EQ(one.Transform(cv::Mat::ones(2, 32, CV_8UC1)).size(), 1u);
}

// --- File format ----------------------------------------------------------------------------

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

void WriteAll(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The InputError message of loading `path`, or "" when it loads.
std::string LoadError(const std::string& path, const std::string& kind = "") {
  try {
    Vocabulary::Load(path, kind);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class VocabularyFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ClusteredData data = MakeClusteredData(60, 10, 20, 17);
    VocabularyOptions options;
    options.branching = 6;
    options.depth = 3;
    options.kind = "lbd";
    voc_ = Vocabulary::Train(data.images, options);
    images_ = data.images;
    path_ = dir_.File("voc.plvoc");
    voc_.Save(path_);
    bytes_ = ReadAll(path_);
  }
  TempDir dir_{"vocabulary"};
  Vocabulary voc_;
  std::vector<cv::Mat> images_;
  std::string path_, bytes_;
};

TEST_F(VocabularyFileTest, RoundTripGivesTheSameVocabulary) {
  EXPECT_EQ(bytes_.size(), 80 + (voc_.num_nodes() - 1) * 36 + voc_.num_words() * 4);
  const Vocabulary loaded = Vocabulary::Load(path_, "lbd");
  EXPECT_EQ(loaded.kind(), "lbd");
  EXPECT_EQ(loaded.branching(), 6);
  EXPECT_EQ(loaded.depth(), 3);
  EXPECT_EQ(loaded.num_nodes(), voc_.num_nodes());
  EXPECT_EQ(loaded.num_words(), voc_.num_words());
  EXPECT_EQ(loaded.training_images(), voc_.training_images());
  EXPECT_EQ(loaded.training_descriptors(), voc_.training_descriptors());
  for (const cv::Mat& img : images_) {
    FeatureNodeIndex na, nb;
    EXPECT_EQ(loaded.Transform(img, &na), voc_.Transform(img, &nb));
    EXPECT_EQ(na, nb);
  }
  // Saving the loaded vocabulary reproduces the file byte for byte.
  const std::string again = dir_.File("again.plvoc");
  loaded.Save(again);
  EXPECT_EQ(ReadAll(again), bytes_);
}

TEST_F(VocabularyFileTest, CorruptedTruncatedAndWrongVersionFilesAreRejected) {
  const std::string bad = dir_.File("bad.plvoc");
  // Missing file.
  EXPECT_NE(LoadError(dir_.File("missing.plvoc")).find("cannot open"), std::string::npos);
  // Truncated payload and truncated header.
  WriteAll(bad, bytes_.substr(0, bytes_.size() - 7));
  std::string e = LoadError(bad);
  EXPECT_NE(e.find(bad), std::string::npos) << e;
  EXPECT_NE(e.find("truncated"), std::string::npos) << e;
  WriteAll(bad, bytes_.substr(0, 40));
  EXPECT_NE(LoadError(bad).find("truncated"), std::string::npos);
  WriteAll(bad, "");
  EXPECT_NE(LoadError(bad).find("truncated"), std::string::npos);
  // Trailing garbage.
  WriteAll(bad, bytes_ + "xyz");
  EXPECT_NE(LoadError(bad).find("trailing"), std::string::npos);
  // One flipped bit in a descriptor: checksum.
  std::string flipped = bytes_;
  flipped[80 + 36 * 3 + 10] ^= 0x10;
  WriteAll(bad, flipped);
  e = LoadError(bad);
  EXPECT_NE(e.find("checksum"), std::string::npos) << e;
  // Another version.
  std::string v2 = bytes_;
  v2[8] = 2;
  WriteAll(bad, v2);
  e = LoadError(bad);
  EXPECT_NE(e.find("version 2"), std::string::npos) << e;
  // Not a vocabulary at all.
  std::string magic = bytes_;
  magic[0] = 'X';
  WriteAll(bad, magic);
  EXPECT_NE(LoadError(bad).find("magic"), std::string::npos);
  // Header counts that do not fit the payload.
  std::string counts = bytes_;
  counts[44] ^= 0x01;  // number of words
  WriteAll(bad, counts);
  EXPECT_NE(LoadError(bad).find("corrupted"), std::string::npos) << LoadError(bad);
  // The right file for the wrong descriptor.
  e = LoadError(path_, "orb");
  EXPECT_NE(e.find("kind 'lbd', expected 'orb'"), std::string::npos) << e;
  EXPECT_EQ(LoadError(path_, "lbd"), "");
}

TEST(DefaultVocabularyTest, ShippedVocabularyLoadsFastAndFitsTheSizeBudget) {
  const std::string dir = std::string(PL_SLAM_SOURCE_DIR) + "/vocabulary";
  for (const char* name : {"orb.plvoc", "lbd.plvoc"}) {
    const auto size = std::filesystem::file_size(dir + "/" + name);
    EXPECT_LT(size, 1000000u) << name;
  }
  const auto t0 = std::chrono::steady_clock::now();
  const PointLineVocabulary voc = PointLineVocabulary::LoadFolder(dir);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "[ info ] default vocabulary loaded in " << s * 1e3
            << " ms: " << voc.points.Describe() << "; " << voc.lines.Describe() << "\n";
  EXPECT_LT(s, 1.0);
  EXPECT_EQ(voc.points.kind(), "orb");
  EXPECT_EQ(voc.lines.kind(), "lbd");
  EXPECT_GE(voc.points.num_words(), 1000u);
  EXPECT_GE(voc.lines.num_words(), 500u);
}

}  // namespace
}  // namespace pl_slam
