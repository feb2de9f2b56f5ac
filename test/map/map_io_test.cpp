// Map files: a hand-built map survives a round trip field by field, and every damaged or
// inconsistent file is refused with a message naming it while the destination map stays as it
// was; saves are atomic.
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <set>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "../test_util/temp_dir.h"
#include "pl_slam/map/map_io.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;
using testing_util::TempDir;

// --- building maps -------------------------------------------------------------------------

double Uniform(std::mt19937* rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(*rng);
}

Eigen::Vector3d RandomVector(std::mt19937* rng) {
  return Eigen::Vector3d(Uniform(rng, -5, 5), Uniform(rng, -5, 5), Uniform(rng, 0.5, 9));
}

cv::Mat RandomDescriptors(int rows, std::mt19937* rng) {
  cv::Mat d(rows, 32, CV_8U);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < 32; ++c) d.at<uint8_t>(r, c) = static_cast<uint8_t>((*rng)() & 0xff);
  return d;
}

SE3 RandomPose(std::mt19937* rng) {
  const Eigen::Quaterniond q(Uniform(rng, -1, 1), Uniform(rng, -1, 1), Uniform(rng, -1, 1),
                             Uniform(rng, -1, 1));
  return SE3(q, RandomVector(rng));
}

/// A keyframe with `n` point and `m` line features, every field random.
std::shared_ptr<Keyframe> RandomKeyframe(KeyframeId id, int n, int m, std::mt19937* rng) {
  auto kf = std::make_shared<Keyframe>();
  kf->id = id;
  kf->frame_index = static_cast<int>(7 * id + 3);
  kf->stamp_s = 100.0 + 0.1 * id + Uniform(rng, 0, 0.01);
  kf->T_w_c = RandomPose(rng);
  kf->parent = id == 0 ? kNoId : id - 1;
  for (int i = 0; i < n; ++i) {
    PointFeature p;
    p.uv = Eigen::Vector2d(Uniform(rng, 0, 640), Uniform(rng, 0, 480));
    p.octave = static_cast<int>((*rng)() % 8);
    p.has_depth = (*rng)() % 2 == 0;
    p.disparity = Uniform(rng, 1, 60);
    p.p_c = RandomVector(rng);
    kf->features.points.push_back(p);
  }
  for (int i = 0; i < m; ++i) {
    LineFeature l;
    l.s = Eigen::Vector2d(Uniform(rng, 0, 640), Uniform(rng, 0, 480));
    l.e = Eigen::Vector2d(Uniform(rng, 0, 640), Uniform(rng, 0, 480));
    l.l = RandomVector(rng).normalized();
    l.angle = Uniform(rng, -3, 3);
    l.length = Uniform(rng, 10, 300);
    l.octave = static_cast<int>((*rng)() % 4);
    l.has_depth = (*rng)() % 2 == 0;
    l.P_c = RandomVector(rng);
    l.Q_c = RandomVector(rng);
    kf->features.lines.push_back(l);
  }
  kf->features.point_descriptors = RandomDescriptors(n, rng);
  kf->features.line_descriptors = RandomDescriptors(m, rng);
  return kf;
}

/// Six keyframes in a chain with a loop edge, shared point and line landmarks, two culled
/// keyframes (a culled chain 2 -> 1 -> live 0) and culled landmarks.
void BuildMap(Map* map, int points_per_kf = 12, int lines_per_kf = 6) {
  std::mt19937 rng(42);
  auto lock = map->Lock();
  const int n_kf = 6;
  for (int k = 0; k < n_kf; ++k)
    map->AddKeyframeLocked(RandomKeyframe(k, points_per_kf, lines_per_kf, &rng));
  map->KeyframeLocked(0)->loop_edges.insert(5);
  map->KeyframeLocked(5)->loop_edges.insert(0);
  for (int k = 0; k < n_kf; ++k) {
    for (int i = 0; i < points_per_kf; i += 2) {
      const LandmarkId lm = map->AddPointLocked(RandomVector(&rng), k, i);
      ASSERT_NE(lm, kNoId);
      for (int other = k + 1; other < std::min(n_kf, k + 3); ++other)
        map->AddPointObservationLocked(lm, other, i + 1);
    }
    for (int i = 0; i < lines_per_kf; i += 2) {
      const LandmarkId lm = map->AddLineLocked(RandomVector(&rng), RandomVector(&rng), k, i);
      ASSERT_NE(lm, kNoId);
      if (k + 1 < n_kf) map->AddLineObservationLocked(lm, k + 1, i + 1);
    }
  }
  map->EraseKeyframeLocked(2);
  map->EraseKeyframeLocked(1);
  map->ErasePointLocked(map->KeyframeLocked(4)->point_landmarks[0]);
  map->EraseLineLocked(map->KeyframeLocked(4)->line_landmarks[0]);
}

MapContents Export(const Map& map) {
  auto lock = map.Lock();
  return map.ExportLocked();
}

void ExpectSameMat(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
  ASSERT_EQ(a.rows, b.rows) << what;
  if (a.rows == 0) return;
  ASSERT_EQ(a.cols, b.cols) << what;
  ASSERT_EQ(a.type(), b.type()) << what;
  for (int r = 0; r < a.rows; ++r)
    EXPECT_EQ(std::memcmp(a.ptr(r), b.ptr(r), a.cols * a.elemSize()), 0) << what << " row " << r;
}

void ExpectSamePose(const SE3& a, const SE3& b, const std::string& what) {
  EXPECT_LT((a.so3().coeffs() - b.so3().coeffs()).norm(), 1e-14) << what;
  EXPECT_EQ(a.translation(), b.translation()) << what;
}

void ExpectSameContents(const MapContents& a, const MapContents& b) {
  EXPECT_EQ(a.next_landmark_id, b.next_landmark_id);
  EXPECT_EQ(a.keyframes_inserted, b.keyframes_inserted);
  EXPECT_EQ(a.culled_points, b.culled_points);
  EXPECT_EQ(a.culled_lines, b.culled_lines);
  ASSERT_EQ(a.keyframes.size(), b.keyframes.size());
  for (const auto& [id, ka] : a.keyframes) {
    ASSERT_TRUE(b.keyframes.count(id)) << "keyframe " << id;
    const Keyframe& kb = *b.keyframes.at(id);
    const std::string name = "keyframe " + std::to_string(id);
    EXPECT_EQ(ka->id, kb.id);
    EXPECT_EQ(ka->frame_index, kb.frame_index) << name;
    EXPECT_EQ(ka->stamp_s, kb.stamp_s) << name;
    ExpectSamePose(ka->T_w_c, kb.T_w_c, name);
    EXPECT_EQ(ka->parent, kb.parent) << name;
    EXPECT_EQ(ka->loop_edges, kb.loop_edges) << name;
    EXPECT_EQ(ka->point_landmarks, kb.point_landmarks) << name;
    EXPECT_EQ(ka->line_landmarks, kb.line_landmarks) << name;
    const StereoFeatures& fa = ka->features;
    const StereoFeatures& fb = kb.features;
    ASSERT_EQ(fa.points.size(), fb.points.size()) << name;
    for (size_t i = 0; i < fa.points.size(); ++i) {
      const PointFeature& p = fa.points[i];
      const PointFeature& q = fb.points[i];
      EXPECT_EQ(p.uv, q.uv) << name;
      EXPECT_EQ(p.octave, q.octave) << name;
      EXPECT_EQ(p.has_depth, q.has_depth) << name;
      EXPECT_EQ(p.disparity, q.disparity) << name;
      EXPECT_EQ(p.p_c, q.p_c) << name;
    }
    ASSERT_EQ(fa.lines.size(), fb.lines.size()) << name;
    for (size_t i = 0; i < fa.lines.size(); ++i) {
      const LineFeature& p = fa.lines[i];
      const LineFeature& q = fb.lines[i];
      EXPECT_EQ(p.s, q.s) << name;
      EXPECT_EQ(p.e, q.e) << name;
      EXPECT_EQ(p.l, q.l) << name;
      EXPECT_EQ(p.angle, q.angle) << name;
      EXPECT_EQ(p.length, q.length) << name;
      EXPECT_EQ(p.octave, q.octave) << name;
      EXPECT_EQ(p.has_depth, q.has_depth) << name;
      EXPECT_EQ(p.P_c, q.P_c) << name;
      EXPECT_EQ(p.Q_c, q.Q_c) << name;
    }
    ExpectSameMat(fa.point_descriptors, fb.point_descriptors, name + " point descriptors");
    ExpectSameMat(fa.line_descriptors, fb.line_descriptors, name + " line descriptors");
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (const auto& [id, pa] : a.points) {
    ASSERT_TRUE(b.points.count(id)) << "point " << id;
    const PointLandmark& pb = *b.points.at(id);
    EXPECT_EQ(pa->id, pb.id);
    EXPECT_EQ(pa->p_w, pb.p_w);
    ExpectSameMat(pa->descriptor, pb.descriptor, "point landmark descriptor");
    EXPECT_EQ(pa->octave, pb.octave);
    EXPECT_EQ(pa->observations, pb.observations);
    EXPECT_EQ(pa->reference, pb.reference);
    EXPECT_EQ(pa->created_at, pb.created_at);
  }
  ASSERT_EQ(a.lines.size(), b.lines.size());
  for (const auto& [id, la] : a.lines) {
    ASSERT_TRUE(b.lines.count(id)) << "line " << id;
    const LineLandmark& lb = *b.lines.at(id);
    EXPECT_EQ(la->id, lb.id);
    EXPECT_EQ(la->P_w, lb.P_w);
    EXPECT_EQ(la->Q_w, lb.Q_w);
    ExpectSameMat(la->descriptor, lb.descriptor, "line landmark descriptor");
    EXPECT_EQ(la->octave, lb.octave);
    EXPECT_EQ(la->observations, lb.observations);
    EXPECT_EQ(la->reference, lb.reference);
    EXPECT_EQ(la->created_at, lb.created_at);
  }
  ASSERT_EQ(a.culled.size(), b.culled.size());
  for (const auto& [id, rec] : a.culled) {
    ASSERT_TRUE(b.culled.count(id)) << "culled " << id;
    EXPECT_EQ(rec.first, b.culled.at(id).first);
    ExpectSamePose(rec.second, b.culled.at(id).second, "culled " + std::to_string(id));
  }
}

// --- file helpers (independent of the implementation) --------------------------------------

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

uint64_t Fnv1a64(const std::string& bytes, size_t n) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<uint8_t>(bytes[i]);
    h *= 1099511628211ull;
  }
  return h;
}

void PutLe(std::string* bytes, size_t at, uint64_t v, int n) {
  for (int i = 0; i < n; ++i) (*bytes)[at + i] = static_cast<char>((v >> (8 * i)) & 0xff);
}

/// Recomputes the trailing checksum so that only the deliberate damage remains.
void Reseal(std::string* bytes) {
  const size_t n = bytes->size() - 8;
  PutLe(bytes, n, Fnv1a64(*bytes, n), 8);
}

size_t FindTag(const std::string& bytes, const std::string& tag) {
  const size_t at = bytes.find(tag, 24);
  EXPECT_NE(at, std::string::npos) << tag;
  return at;
}

/// A map that a failed load must leave exactly as it was.
class Destination {
 public:
  Destination() {
    BuildMap(&map_, 3, 2);
    counts_ = map_.counts();
    version_ = map_.version();
  }
  Map& map() { return map_; }
  void ExpectUntouched() {
    const MapCounts c = map_.counts();
    EXPECT_EQ(c.keyframes, counts_.keyframes);
    EXPECT_EQ(c.points, counts_.points);
    EXPECT_EQ(c.lines, counts_.lines);
    EXPECT_EQ(c.culled_keyframes, counts_.culled_keyframes);
    EXPECT_EQ(map_.version(), version_);
  }

 private:
  Map map_;
  MapCounts counts_;
  uint64_t version_ = 0;
};

/// Loads `bytes` named `name` into `dest`; expects InputError naming `name` and containing
/// `expected` (when not empty), and `dest` untouched. Returns the message.
std::string ExpectRejected(const std::string& bytes, Destination* dest,
                           const std::string& expected = "",
                           const std::string& name = "/maps/damaged.plmap") {
  try {
    LoadMapFromBytes(bytes, name, &dest->map());
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    EXPECT_NE(msg.find(expected), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    dest->ExpectUntouched();
    return msg;
  }
  ADD_FAILURE() << "accepted a bad map file (expected: " << expected << ")";
  return "";
}

// --- tests ---------------------------------------------------------------------------------

TEST(MapIoTest, RoundTripKeepsEverythingAndIdsDoNotAlias) {
  TempDir dir("map_io");
  Map original;
  BuildMap(&original);
  const MapCounts counts = original.counts();
  ASSERT_EQ(counts.culled_keyframes, 2u);
  ASSERT_GT(counts.culled_points, 0u);
  ASSERT_GT(counts.culled_lines, 0u);
  const std::string path = dir.File("map.plmap");
  SaveMap(original, path);

  Map loaded;
  const uint64_t version_before = loaded.version();
  LoadMap(path, &loaded);
  EXPECT_GT(loaded.version(), version_before);
  const MapContents a = Export(original);
  const MapContents b = Export(loaded);
  ExpectSameContents(a, b);
  const MapCounts c = loaded.counts();
  EXPECT_EQ(c.keyframes, counts.keyframes);
  EXPECT_EQ(c.culled_points, counts.culled_points);
  EXPECT_EQ(c.culled_lines, counts.culled_lines);

  // Culled keyframes still resolve to the same pose.
  SE3 Ta, Tb;
  ASSERT_TRUE(original.KeyframePose(2, &Ta));
  ASSERT_TRUE(loaded.KeyframePose(2, &Tb));
  EXPECT_LT((Ta.matrix() - Tb.matrix()).norm(), 1e-12);

  // Saving the loaded map gives a file of the same layout (poses may differ in the last bit:
  // SE3 re-normalises the quaternion).
  EXPECT_EQ(SerializeMap(loaded).size(), ReadFile(path).size());

  // New landmarks get ids no landmark ever had, in the loaded map too.
  std::set<LandmarkId> used;
  for (const auto& kv : a.points) used.insert(kv.first);
  for (const auto& kv : a.lines) used.insert(kv.first);
  auto lock = loaded.Lock();
  EXPECT_EQ(loaded.KeyframesInsertedLocked(), 6);
  const auto kf = loaded.KeyframeLocked(0);
  int free_index = -1;
  for (size_t i = 0; i < kf->point_landmarks.size(); ++i)
    if (kf->point_landmarks[i] == kNoId) free_index = static_cast<int>(i);
  ASSERT_GE(free_index, 0);
  const LandmarkId fresh = loaded.AddPointLocked(Eigen::Vector3d(1, 2, 3), 0, free_index);
  ASSERT_NE(fresh, kNoId);
  EXPECT_GE(fresh, a.next_landmark_id);
  EXPECT_FALSE(used.count(fresh));
  EXPECT_EQ(loaded.PointLocked(fresh)->created_at, 6);
}

TEST(MapIoTest, LoadingNeverLowersTheLandmarkIdCounter) {
  TempDir dir("map_io");
  Map small;
  {
    std::mt19937 rng(1);
    auto lock = small.Lock();
    small.AddKeyframeLocked(RandomKeyframe(0, 4, 2, &rng));
    small.AddPointLocked(Eigen::Vector3d(0, 0, 1), 0, 0);
  }
  const std::string path = dir.File("small.plmap");
  SaveMap(small, path);
  Map big;  // has handed out many more ids than `small`
  BuildMap(&big);
  const LandmarkId big_next = Export(big).next_landmark_id;
  ASSERT_GT(big_next, 1);
  LoadMap(path, &big);
  EXPECT_EQ(big.counts().keyframes, 1u);
  auto lock = big.Lock();
  EXPECT_GE(big.AddPointLocked(Eigen::Vector3d(0, 0, 2), 0, 1), big_next);
}

TEST(MapIoTest, EveryTruncationIsRejected) {
  Map map;
  BuildMap(&map, 4, 2);
  const std::string bytes = SerializeMap(map);
  Destination dest;
  for (size_t cut = 0; cut < bytes.size(); ++cut) {
    ExpectRejected(bytes.substr(0, cut), &dest, "truncated");
    if (::testing::Test::HasFailure()) FAIL() << "cut at " << cut << " of " << bytes.size();
  }
}

TEST(MapIoTest, TruncatedFileOnDiskIsRejectedByName) {
  TempDir dir("map_io");
  Map map;
  BuildMap(&map);
  const std::string path = dir.File("cut.plmap");
  SaveMap(map, path);
  const std::string bytes = ReadFile(path);
  WriteFile(path, bytes.substr(0, bytes.size() / 2));
  Destination dest;
  try {
    LoadMap(path, &dest.map());
    FAIL() << "accepted a truncated file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
  }
  dest.ExpectUntouched();
}

TEST(MapIoTest, EveryFlippedByteIsRejected) {
  Map map;
  BuildMap(&map, 4, 2);
  const std::string bytes = SerializeMap(map);
  Destination dest;
  std::mt19937 rng(7);
  for (size_t i = 0; i < bytes.size(); ++i) {
    std::string damaged = bytes;
    damaged[i] = static_cast<char>(damaged[i] ^ (1 + rng() % 255));
    ExpectRejected(damaged, &dest);
    if (::testing::Test::HasFailure()) FAIL() << "flipped byte " << i << " of " << bytes.size();
  }
  // Bytes within the payload are caught by the checksum.
  std::string damaged = bytes;
  damaged[bytes.size() / 2] ^= 0x10;
  ExpectRejected(damaged, &dest, "checksum");
}

TEST(MapIoTest, WrongMagicIsRejected) {
  Map map;
  BuildMap(&map, 4, 2);
  std::string bytes = SerializeMap(map);
  bytes[0] = 'X';
  Reseal(&bytes);
  Destination dest;
  ExpectRejected(bytes, &dest, "not a pl_slam map file");
  ExpectRejected("hello world, this is not a map at all", &dest, "not a pl_slam map file");
}

TEST(MapIoTest, OtherFormatVersionIsRejectedClearly) {
  Map map;
  BuildMap(&map, 4, 2);
  std::string bytes = SerializeMap(map);
  PutLe(&bytes, 8, 2, 4);
  Reseal(&bytes);
  Destination dest;
  const std::string msg =
      ExpectRejected(bytes, &dest, "has format version 2, this build reads 1", "/m/v2.plmap");
  EXPECT_EQ(msg, "map file /m/v2.plmap has format version 2, this build reads 1");
}

TEST(MapIoTest, AbsurdCountsWithValidChecksumAreRejectedWithoutHugeAllocations) {
  Map map;
  BuildMap(&map, 4, 2);
  const std::string bytes = SerializeMap(map);
  Destination dest;
  // Keyframe count (after the tag and the section size).
  std::string damaged = bytes;
  PutLe(&damaged, FindTag(bytes, "KFRM") + 12, uint64_t{1} << 60, 8);
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "keyframe count");
  // Point landmark count.
  damaged = bytes;
  PutLe(&damaged, FindTag(bytes, "PNTS") + 12, 0xffffffffffffull, 8);
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "point landmark count");
  // Section size.
  damaged = bytes;
  PutLe(&damaged, FindTag(bytes, "LINE") + 4, ~uint64_t{0}, 8);
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "section LINE");
  // Payload size in the header.
  damaged = bytes;
  PutLe(&damaged, 16, ~uint64_t{0} - 4, 8);
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "truncated");
}

/// One keyframe with 3 point features, one point landmark observed at feature 1.
std::string TinyMapBytes() {
  Map map;
  std::mt19937 rng(3);
  {
    auto lock = map.Lock();
    map.AddKeyframeLocked(RandomKeyframe(0, 3, 0, &rng));
    EXPECT_EQ(map.AddPointLocked(Eigen::Vector3d(1, 2, 3), 0, 1), 0);
  }
  return SerializeMap(map);
}

TEST(MapIoTest, InconsistentContentWithValidChecksumIsRejected) {
  const std::string bytes = TinyMapBytes();
  Destination dest;
  // PNTS: tag 4, size 8, count 8, then id 8, p_w 24, descriptor 32, octave 4, reference 8,
  // created_at 4, observation count 8, observation keyframe 8, observation index 4.
  const size_t lm = FindTag(bytes, "PNTS") + 20;
  const size_t obs = lm + 8 + 24 + 32 + 4 + 8 + 4 + 8;

  std::string damaged = bytes;
  PutLe(&damaged, obs + 8, 2, 4);  // observed at feature 2, but the keyframe says feature 1
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "point landmark 0");

  damaged = bytes;
  PutLe(&damaged, obs, 9, 8);  // observed in a keyframe that does not exist
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "point landmark 0");

  damaged = bytes;
  PutLe(&damaged, lm, 5, 8);  // the keyframe refers to landmark 0, which is now missing
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "landmark");

  damaged = bytes;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  uint64_t nan_bits;
  std::memcpy(&nan_bits, &nan, 8);
  PutLe(&damaged, lm + 8, nan_bits, 8);  // p_w.x
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "non-finite");

  damaged = bytes;
  PutLe(&damaged, FindTag(bytes, "META") + 12, 0, 8);  // next landmark id 0 aliases landmark 0
  Reseal(&damaged);
  ExpectRejected(damaged, &dest, "next landmark id");
}

TEST(MapIoTest, InconsistentMapIsNotSaved) {
  TempDir dir("map_io");
  Map map;
  BuildMap(&map, 4, 2);
  const std::string path = dir.File("map.plmap");
  SaveMap(map, path);
  const std::string before = ReadFile(path);
  {
    auto lock = map.Lock();
    map.KeyframeLocked(0)->point_landmarks[0] = 12345;  // a landmark that does not exist
  }
  try {
    SaveMap(map, path);
    FAIL() << "saved an inconsistent map";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("12345"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadFile(path), before);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);
}

TEST(MapIoTest, SavingIntoAMissingFolderFailsAndLeavesNothing) {
  TempDir dir("map_io");
  Map map;
  BuildMap(&map, 4, 2);
  const std::string path = dir.File("missing/sub/map.plmap");
  try {
    SaveMap(map, path);
    FAIL() << "saved into a missing folder";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.path() / "missing"));
  EXPECT_TRUE(fs::is_empty(dir.path()));
}

TEST(MapIoTest, FailedSaveLeavesTheExistingFileIntact) {
  TempDir dir("map_io");
  Map map;
  BuildMap(&map, 4, 2);
  // Target that is a (non-empty) folder: the final rename fails, no temporary file remains.
  const fs::path folder = dir.path() / "is_a_folder";
  fs::create_directories(folder);
  WriteFile((folder / "keep.txt").string(), "keep");
  EXPECT_THROW(SaveMap(map, folder.string()), InputError);
  EXPECT_EQ(ReadFile((folder / "keep.txt").string()), "keep");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator()), 1);

  // Read-only folder holding an old map: the save fails and the old map stays loadable.
  const fs::path ro = dir.path() / "read_only";
  fs::create_directories(ro);
  const std::string path = (ro / "map.plmap").string();
  Map old_map;
  BuildMap(&old_map, 3, 1);
  SaveMap(old_map, path);
  const std::string before = ReadFile(path);
  ::chmod(ro.c_str(), 0555);
  if (::geteuid() != 0) {  // root ignores permissions
    try {
      SaveMap(map, path);
      ADD_FAILURE() << "saved into a read-only folder";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    EXPECT_EQ(ReadFile(path), before);
    EXPECT_EQ(std::distance(fs::directory_iterator(ro), fs::directory_iterator()), 1);
  }
  ::chmod(ro.c_str(), 0755);

  // A write that fails half way (file size limit, which binds root too): same outcome.
  const std::string new_bytes = SerializeMap(map);
  ASSERT_GT(new_bytes.size(), 1000u);
  struct rlimit saved_limit;
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &saved_limit), 0);
  const auto saved_handler = std::signal(SIGXFSZ, SIG_IGN);
  struct rlimit small_limit = saved_limit;
  small_limit.rlim_cur = new_bytes.size() / 2;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small_limit), 0);
  bool threw = false;
  std::string message;
  try {
    SaveMap(map, path);
  } catch (const InputError& e) {
    threw = true;
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &saved_limit);
  std::signal(SIGXFSZ, saved_handler);
  EXPECT_TRUE(threw) << "a save that could not write the whole file succeeded";
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_EQ(ReadFile(path), before);
  EXPECT_EQ(std::distance(fs::directory_iterator(ro), fs::directory_iterator()), 1);

  Map reloaded;
  LoadMap(path, &reloaded);
  EXPECT_EQ(reloaded.counts().keyframes, old_map.counts().keyframes);

  // A successful save over an existing file replaces it completely.
  SaveMap(map, path);
  EXPECT_EQ(ReadFile(path), SerializeMap(map));
}

TEST(MapIoTest, MissingFileOrFolderIsRejectedByName) {
  TempDir dir("map_io");
  Destination dest;
  const std::string missing = dir.File("nope.plmap");
  for (const std::string& path : {missing, dir.path().string()}) {
    try {
      LoadMap(path, &dest.map());
      ADD_FAILURE() << "loaded " << path;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
    dest.ExpectUntouched();
  }
}

TEST(MapIoTest, EmptyMapRoundTrips) {
  Map empty;
  const std::string bytes = SerializeMap(empty);
  Destination dest;
  LoadMapFromBytes(bytes, "empty", &dest.map());
  EXPECT_EQ(dest.map().counts().keyframes, 0u);
  EXPECT_EQ(dest.map().counts().points, 0u);
  EXPECT_EQ(dest.map().LastKeyframe(), kNoId);
}

}  // namespace
}  // namespace pl_slam
