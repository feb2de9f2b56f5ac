#include "pl_slam/map/map_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include <vector>

#include "map_io_internal.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/util/error.h"

namespace pl_slam {

// 64-bit FNV-1a (declared in map_io.h).
uint64_t MapFileChecksum(const char* data, size_t n) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) {
    h ^= static_cast<uint8_t>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

namespace {

using map_io_internal::Fail;
using map_io_internal::FormatError;
using map_io_internal::kDescriptorBytes;
using map_io_internal::Str;
using map_io_internal::ValidateContents;

constexpr char kMagic[8] = {'P', 'L', 'S', 'L', 'A', 'M', 'A', 'P'};
constexpr uint32_t kByteOrderMarker = 0x01020304u;
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8;
constexpr size_t kChecksumBytes = 8;

// Smallest encoded size of each record, to bound counts by the bytes that remain.
constexpr size_t kPoseBytes = 7 * 8;
constexpr size_t kKeyframeBytes = 8 + 4 + 8 + kPoseBytes + 8 + 8 + 8 + 8;
constexpr size_t kPointFeatureBytes = 16 + 4 + 1 + 8 + 24 + kDescriptorBytes + 8;
constexpr size_t kLineFeatureBytes = 16 + 16 + 24 + 8 + 8 + 4 + 1 + 24 + 24 + kDescriptorBytes + 8;
constexpr size_t kObservationBytes = 8 + 4;
constexpr size_t kPointLandmarkBytes = 8 + 24 + kDescriptorBytes + 4 + 8 + 4 + 8;
constexpr size_t kLineLandmarkBytes = 8 + 24 + 24 + kDescriptorBytes + 4 + 8 + 4 + 8;
constexpr size_t kCulledBytes = 8 + 8 + kPoseBytes;

uint64_t LoadLe(const char* p, int bytes) {
  uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(p[i]);
  return v;
}

// --- writing -------------------------------------------------------------------------------

class Writer {
 public:
  std::string& bytes() { return out_; }
  void U8(uint8_t v) { out_.push_back(static_cast<char>(v)); }
  void Le(uint64_t v, int bytes) {
    char buf[8];
    for (int i = 0; i < bytes; ++i) buf[i] = static_cast<char>((v >> (8 * i)) & 0xffu);
    out_.append(buf, bytes);
  }
  void U32(uint32_t v) { Le(v, 4); }
  void U64(uint64_t v) { Le(v, 8); }
  void I32(int32_t v) { Le(static_cast<uint32_t>(v), 4); }
  void I64(int64_t v) { Le(static_cast<uint64_t>(v), 8); }
  void F64(double v) {
    uint64_t b;
    std::memcpy(&b, &v, 8);
    Le(b, 8);
  }
  void Vec2(const Eigen::Vector2d& v) {
    F64(v.x());
    F64(v.y());
  }
  void Vec3(const Eigen::Vector3d& v) {
    F64(v.x());
    F64(v.y());
    F64(v.z());
  }
  void Pose(const SE3& T) {
    const Eigen::Quaterniond& q = T.so3();
    F64(q.x());
    F64(q.y());
    F64(q.z());
    F64(q.w());
    Vec3(T.translation());
  }
  void Bytes(const void* p, size_t n) { out_.append(static_cast<const char*>(p), n); }
  /// Starts a section; returns the position of its size field for EndSection().
  size_t BeginSection(const char* tag) {
    Bytes(tag, 4);
    const size_t at = out_.size();
    U64(0);
    return at;
  }
  void EndSection(size_t at) {
    const uint64_t size = out_.size() - at - 8;
    for (int i = 0; i < 8; ++i) out_[at + i] = static_cast<char>((size >> (8 * i)) & 0xffu);
  }

 private:
  std::string out_;
};

template <typename T>
std::vector<LandmarkId> SortedIds(const std::unordered_map<LandmarkId, T>& m) {
  std::vector<LandmarkId> ids;
  ids.reserve(m.size());
  for (const auto& kv : m) ids.push_back(kv.first);
  std::sort(ids.begin(), ids.end());
  return ids;
}

void WriteObservations(Writer* w, const std::map<KeyframeId, int>& observations) {
  w->U64(observations.size());
  for (const auto& [kf, index] : observations) {
    w->I64(kf);
    w->I32(index);
  }
}

/// The file bytes of `c`, which ValidateContents() accepted.
std::string Serialize(const MapContents& c) {
  Writer w;
  w.Bytes(kMagic, 8);
  w.U32(kMapFormatVersion);
  w.U32(kByteOrderMarker);
  w.U64(0);  // payload size, patched below

  size_t at = w.BeginSection("META");
  w.I64(c.next_landmark_id);
  w.I64(c.keyframes_inserted);
  w.U64(c.culled_points);
  w.U64(c.culled_lines);
  w.EndSection(at);

  at = w.BeginSection("KFRM");
  w.U64(c.keyframes.size());
  for (const auto& [id, kf] : c.keyframes) {
    w.I64(id);
    w.I32(kf->frame_index);
    w.F64(kf->stamp_s);
    w.Pose(kf->T_w_c);
    w.I64(kf->parent);
    w.U64(kf->loop_edges.size());
    for (KeyframeId loop : kf->loop_edges) w.I64(loop);
    const StereoFeatures& f = kf->features;
    w.U64(f.points.size());
    for (size_t i = 0; i < f.points.size(); ++i) {
      const PointFeature& p = f.points[i];
      w.Vec2(p.uv);
      w.I32(p.octave);
      w.U8(p.has_depth ? 1 : 0);
      w.F64(p.disparity);
      w.Vec3(p.p_c);
      w.Bytes(f.point_descriptors.ptr<uint8_t>(static_cast<int>(i)), kDescriptorBytes);
      w.I64(kf->point_landmarks[i]);
    }
    w.U64(f.lines.size());
    for (size_t i = 0; i < f.lines.size(); ++i) {
      const LineFeature& l = f.lines[i];
      w.Vec2(l.s);
      w.Vec2(l.e);
      w.Vec3(l.l);
      w.F64(l.angle);
      w.F64(l.length);
      w.I32(l.octave);
      w.U8(l.has_depth ? 1 : 0);
      w.Vec3(l.P_c);
      w.Vec3(l.Q_c);
      w.Bytes(f.line_descriptors.ptr<uint8_t>(static_cast<int>(i)), kDescriptorBytes);
      w.I64(kf->line_landmarks[i]);
    }
  }
  w.EndSection(at);

  at = w.BeginSection("PNTS");
  w.U64(c.points.size());
  for (LandmarkId id : SortedIds(c.points)) {
    const PointLandmark& p = *c.points.at(id);
    w.I64(id);
    w.Vec3(p.p_w);
    w.Bytes(p.descriptor.ptr<uint8_t>(0), kDescriptorBytes);
    w.I32(p.octave);
    w.I64(p.reference);
    w.I32(p.created_at);
    WriteObservations(&w, p.observations);
  }
  w.EndSection(at);

  at = w.BeginSection("LINE");
  w.U64(c.lines.size());
  for (LandmarkId id : SortedIds(c.lines)) {
    const LineLandmark& l = *c.lines.at(id);
    w.I64(id);
    w.Vec3(l.P_w);
    w.Vec3(l.Q_w);
    w.Bytes(l.descriptor.ptr<uint8_t>(0), kDescriptorBytes);
    w.I32(l.octave);
    w.I64(l.reference);
    w.I32(l.created_at);
    WriteObservations(&w, l.observations);
  }
  w.EndSection(at);

  at = w.BeginSection("CULL");
  w.U64(c.culled.size());
  std::vector<KeyframeId> culled_ids;
  for (const auto& kv : c.culled) culled_ids.push_back(kv.first);
  std::sort(culled_ids.begin(), culled_ids.end());
  for (KeyframeId id : culled_ids) {
    const auto& [parent, T_parent_kf] = c.culled.at(id);
    w.I64(id);
    w.I64(parent);
    w.Pose(T_parent_kf);
  }
  w.EndSection(at);

  std::string& out = w.bytes();
  const uint64_t payload = out.size() - kHeaderBytes;
  for (int i = 0; i < 8; ++i) out[16 + i] = static_cast<char>((payload >> (8 * i)) & 0xffu);
  w.U64(MapFileChecksum(out.data(), out.size()));
  return std::move(out);
}

// --- reading -------------------------------------------------------------------------------

/// Reads little-endian values from a byte range; every read is bounds-checked.
class Reader {
 public:
  Reader(const char* begin, const char* end, std::string where)
      : p_(begin), end_(end), where_(std::move(where)) {}
  size_t remaining() const { return static_cast<size_t>(end_ - p_); }

  const char* Take(size_t n, const char* what) {
    if (n > remaining())
      Fail("is corrupted: " + std::string(what) + " runs past the end of " + where_);
    const char* p = p_;
    p_ += n;
    return p;
  }
  uint8_t U8(const char* what) { return static_cast<uint8_t>(*Take(1, what)); }
  uint32_t U32(const char* what) { return static_cast<uint32_t>(LoadLe(Take(4, what), 4)); }
  uint64_t U64(const char* what) { return LoadLe(Take(8, what), 8); }
  int32_t I32(const char* what) { return static_cast<int32_t>(U32(what)); }
  int64_t I64(const char* what) { return static_cast<int64_t>(U64(what)); }
  double F64(const char* what) {
    const uint64_t b = U64(what);
    double v;
    std::memcpy(&v, &b, 8);
    return v;
  }
  bool Bool(const char* what) {
    const uint8_t v = U8(what);
    if (v > 1) Fail("is corrupted: " + std::string(what) + " is " + Str(v) + ", not 0 or 1");
    return v == 1;
  }
  Eigen::Vector2d Vec2(const char* what) {
    const double x = F64(what), y = F64(what);
    return Eigen::Vector2d(x, y);
  }
  Eigen::Vector3d Vec3(const char* what) {
    const double x = F64(what), y = F64(what), z = F64(what);
    return Eigen::Vector3d(x, y, z);
  }
  SE3 Pose(const char* what) {
    double v[7];
    for (double& x : v) x = F64(what);
    for (double x : v)
      if (!std::isfinite(x)) Fail("is invalid: " + std::string(what) + " is not finite");
    const Eigen::Quaterniond q(v[3], v[0], v[1], v[2]);
    if (std::abs(q.norm() - 1.0) > 1e-6)
      Fail("is invalid: " + std::string(what) + " has a rotation that is not a unit quaternion");
    return SE3(q, Eigen::Vector3d(v[4], v[5], v[6]));
  }
  void Descriptor(uint8_t* dst, const char* what) {
    std::memcpy(dst, Take(kDescriptorBytes, what), kDescriptorBytes);
  }
  /// A count of records of at least `record_bytes` each, bounded by the bytes that remain.
  size_t Count(size_t record_bytes, const char* what) {
    const uint64_t n = U64(what);
    if (n > remaining() / record_bytes || n > static_cast<uint64_t>(INT_MAX))
      Fail("is corrupted: " + std::string(what) + " " + std::to_string(n) +
           " needs more than the " + std::to_string(remaining()) + " bytes left in " + where_);
    return static_cast<size_t>(n);
  }
  /// The next section, which must carry `tag`.
  Reader Section(const char* tag) {
    const std::string want(tag, 4);
    const std::string got(Take(4, "section tag"), 4);
    if (got != want) Fail("is corrupted: expected section " + want + ", found another tag");
    const uint64_t size = U64("section size");
    if (size > remaining())
      Fail("is corrupted: section " + want + " says " + std::to_string(size) + " bytes, only " +
           std::to_string(remaining()) + " remain");
    const char* begin = Take(static_cast<size_t>(size), "section");
    return Reader(begin, begin + size, "section " + want);
  }
  void ExpectEnd() const {
    if (remaining() != 0)
      Fail("is corrupted: " + std::to_string(remaining()) + " unexpected bytes at the end of " +
           where_);
  }

 private:
  const char* p_;
  const char* end_;
  std::string where_;
};

void ReadObservations(Reader* r, LandmarkId id, std::map<KeyframeId, int>* observations) {
  const size_t n = r->Count(kObservationBytes, "observation count");
  for (size_t i = 0; i < n; ++i) {
    const KeyframeId kf = r->I64("observation keyframe");
    const int index = r->I32("observation index");
    if (!observations->emplace(kf, index).second)
      Fail("is invalid: landmark " + Str(id) + " has two observations in keyframe " + Str(kf));
  }
}

/// Parses the payload (the checksum has been verified) into map contents; ValidateContents()
/// checks them afterwards.
MapContents ParsePayload(const char* begin, const char* end) {
  Reader r(begin, end, "the payload");
  MapContents c;
  {
    Reader s = r.Section("META");
    c.next_landmark_id = s.I64("next landmark id");
    const int64_t inserted = s.I64("keyframes inserted");
    if (inserted < 0 || inserted > INT_MAX)
      Fail("is invalid: keyframes inserted " + Str(inserted) + " is out of range");
    c.keyframes_inserted = static_cast<int>(inserted);
    c.culled_points = s.U64("culled points");
    c.culled_lines = s.U64("culled lines");
    s.ExpectEnd();
  }
  {
    Reader s = r.Section("KFRM");
    const size_t n = s.Count(kKeyframeBytes, "keyframe count");
    for (size_t k = 0; k < n; ++k) {
      auto kf = std::make_shared<Keyframe>();
      kf->id = s.I64("keyframe id");
      kf->frame_index = s.I32("frame index");
      kf->stamp_s = s.F64("stamp");
      kf->T_w_c = s.Pose("keyframe pose");
      kf->parent = s.I64("parent");
      const size_t n_loops = s.Count(8, "loop edge count");
      for (size_t i = 0; i < n_loops; ++i) kf->loop_edges.insert(s.I64("loop edge"));
      StereoFeatures& f = kf->features;
      const size_t np = s.Count(kPointFeatureBytes, "point feature count");
      f.points.resize(np);
      f.point_descriptors = cv::Mat(static_cast<int>(np), kDescriptorBytes, CV_8U);
      kf->point_landmarks.resize(np);
      for (size_t i = 0; i < np; ++i) {
        PointFeature& p = f.points[i];
        p.uv = s.Vec2("point uv");
        p.octave = s.I32("point octave");
        p.has_depth = s.Bool("point has_depth");
        p.disparity = s.F64("point disparity");
        p.p_c = s.Vec3("point p_c");
        s.Descriptor(f.point_descriptors.ptr<uint8_t>(static_cast<int>(i)), "point descriptor");
        kf->point_landmarks[i] = s.I64("point landmark id");
      }
      const size_t nl = s.Count(kLineFeatureBytes, "line feature count");
      f.lines.resize(nl);
      f.line_descriptors = cv::Mat(static_cast<int>(nl), kDescriptorBytes, CV_8U);
      kf->line_landmarks.resize(nl);
      for (size_t i = 0; i < nl; ++i) {
        LineFeature& l = f.lines[i];
        l.s = s.Vec2("line s");
        l.e = s.Vec2("line e");
        l.l = s.Vec3("line l");
        l.angle = s.F64("line angle");
        l.length = s.F64("line length");
        l.octave = s.I32("line octave");
        l.has_depth = s.Bool("line has_depth");
        l.P_c = s.Vec3("line P_c");
        l.Q_c = s.Vec3("line Q_c");
        s.Descriptor(f.line_descriptors.ptr<uint8_t>(static_cast<int>(i)), "line descriptor");
        kf->line_landmarks[i] = s.I64("line landmark id");
      }
      const KeyframeId id = kf->id;
      if (!c.keyframes.emplace(id, std::move(kf)).second)
        Fail("is invalid: keyframe " + Str(id) + " appears twice");
    }
    s.ExpectEnd();
  }
  {
    Reader s = r.Section("PNTS");
    const size_t n = s.Count(kPointLandmarkBytes, "point landmark count");
    c.points.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      auto p = std::make_shared<PointLandmark>();
      p->id = s.I64("point landmark id");
      p->p_w = s.Vec3("point landmark p_w");
      p->descriptor = cv::Mat(1, kDescriptorBytes, CV_8U);
      s.Descriptor(p->descriptor.ptr<uint8_t>(0), "point landmark descriptor");
      p->octave = s.I32("point landmark octave");
      p->reference = s.I64("point landmark reference");
      p->created_at = s.I32("point landmark created_at");
      ReadObservations(&s, p->id, &p->observations);
      const LandmarkId id = p->id;
      if (!c.points.emplace(id, std::move(p)).second)
        Fail("is invalid: point landmark " + Str(id) + " appears twice");
    }
    s.ExpectEnd();
  }
  {
    Reader s = r.Section("LINE");
    const size_t n = s.Count(kLineLandmarkBytes, "line landmark count");
    c.lines.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      auto l = std::make_shared<LineLandmark>();
      l->id = s.I64("line landmark id");
      l->P_w = s.Vec3("line landmark P_w");
      l->Q_w = s.Vec3("line landmark Q_w");
      l->descriptor = cv::Mat(1, kDescriptorBytes, CV_8U);
      s.Descriptor(l->descriptor.ptr<uint8_t>(0), "line landmark descriptor");
      l->octave = s.I32("line landmark octave");
      l->reference = s.I64("line landmark reference");
      l->created_at = s.I32("line landmark created_at");
      ReadObservations(&s, l->id, &l->observations);
      const LandmarkId id = l->id;
      if (!c.lines.emplace(id, std::move(l)).second)
        Fail("is invalid: line landmark " + Str(id) + " appears twice");
    }
    s.ExpectEnd();
  }
  {
    Reader s = r.Section("CULL");
    const size_t n = s.Count(kCulledBytes, "culled keyframe count");
    c.culled.reserve(n);
    for (size_t k = 0; k < n; ++k) {
      const KeyframeId id = s.I64("culled keyframe id");
      const KeyframeId parent = s.I64("culled keyframe parent");
      const SE3 T_parent_kf = s.Pose("culled keyframe pose");
      if (!c.culled.emplace(id, std::make_pair(parent, T_parent_kf)).second)
        Fail("is invalid: culled keyframe " + Str(id) + " appears twice");
    }
    s.ExpectEnd();
  }
  r.ExpectEnd();
  return c;
}

/// Checks the header, size and checksum of a whole file and parses and validates it.
MapContents ParseFile(const std::string& bytes) {
  const size_t n = bytes.size();
  const size_t magic_n = std::min<size_t>(n, 8);
  if (std::memcmp(bytes.data(), kMagic, magic_n) != 0)
    Fail("is not a pl_slam map file (it does not start with \"PLSLAMAP\")");
  if (n < kHeaderBytes)
    Fail("is truncated: " + std::to_string(n) + " bytes, shorter than the " +
         std::to_string(kHeaderBytes) + "-byte header");
  const uint32_t version = static_cast<uint32_t>(LoadLe(bytes.data() + 8, 4));
  if (version != kMapFormatVersion)
    Fail("has format version " + std::to_string(version) + ", this build reads " +
         std::to_string(kMapFormatVersion));
  const uint32_t order = static_cast<uint32_t>(LoadLe(bytes.data() + 12, 4));
  if (order != kByteOrderMarker)
    Fail("is corrupted: byte-order marker 0x" + [&] {
      char buf[16];
      std::snprintf(buf, sizeof(buf), "%08x", order);
      return std::string(buf);
    }() + " instead of 0x01020304");
  const uint64_t payload = LoadLe(bytes.data() + 16, 8);
  const uint64_t present = n - kHeaderBytes;
  if (present < kChecksumBytes || payload > present - kChecksumBytes)
    Fail("is truncated: " + std::to_string(n) + " bytes, the header announces " +
         std::to_string(payload) + " payload bytes plus header and checksum");
  if (payload < present - kChecksumBytes)
    Fail("is corrupted: " + std::to_string(present - kChecksumBytes - payload) +
         " unexpected bytes after the checksum");
  const size_t body_end = kHeaderBytes + static_cast<size_t>(payload);
  const uint64_t stored = LoadLe(bytes.data() + body_end, 8);
  if (stored != MapFileChecksum(bytes.data(), body_end))
    Fail("is corrupted: checksum mismatch (the file was damaged)");
  MapContents c = ParsePayload(bytes.data() + kHeaderBytes, bytes.data() + body_end);
  ValidateContents(c);
  return c;
}

std::string ReadWholeFile(const std::string& path) {
  const auto fail = [&](const std::string& what) {
    throw InputError("map file " + path + " cannot be read (" + what + ")");
  };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail(std::strerror(errno));
  struct stat st;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    fail("not a regular file");
  }
  std::string bytes(static_cast<size_t>(st.st_size), '\0');
  size_t got = 0;
  while (got < bytes.size()) {
    const ssize_t r = ::read(fd, &bytes[got], bytes.size() - got);
    if (r < 0 && errno == EINTR) continue;
    if (r < 0) {
      const int err = errno;
      ::close(fd);
      fail(std::strerror(err));
    }
    if (r == 0) break;  // shrank while reading: the size checks will report it
    got += static_cast<size_t>(r);
  }
  ::close(fd);
  bytes.resize(got);
  return bytes;
}

}  // namespace

std::string SerializeMap(const Map& map) {
  MapContents c;
  {
    auto lock = map.Lock();
    c = map.ExportLocked();
  }
  try {
    ValidateContents(c);
  } catch (const FormatError& e) {
    throw InputError("the map " + e.problem);
  }
  return Serialize(c);
}

void SaveMap(const Map& map, const std::string& path) {
  std::string bytes;
  try {
    bytes = SerializeMap(map);
  } catch (const InputError& e) {
    throw InputError("cannot save map to " + path + ": " + e.what());
  }
  WriteFileAtomic(path, bytes);
}

void LoadMapFromBytes(const std::string& bytes, const std::string& name, Map* map) {
  if (map == nullptr) throw std::invalid_argument("LoadMapFromBytes: map is null");
  MapContents c;
  try {
    c = ParseFile(bytes);
  } catch (const FormatError& e) {
    throw InputError("map file " + name + " " + e.problem);
  }
  auto lock = map->Lock();
  map->ReplaceLocked(std::move(c));
}

void LoadMap(const std::string& path, Map* map) {
  LoadMapFromBytes(ReadWholeFile(path), path, map);
}

}  // namespace pl_slam
