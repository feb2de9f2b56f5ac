#include "pl_slam/io/trajectory.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "pl_slam/io/text_util.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace {

namespace fs = std::filesystem;

[[noreturn]] void FailAt(const std::string& path, std::size_t line_no, const std::string& what) {
  throw InputError(path + ":" + std::to_string(line_no) + ": " + what);
}

// Parses fields[first, first + n) as doubles into out; names the first bad field.
void ParseNumbers(const std::vector<std::string_view>& fields, std::size_t first, std::size_t n,
                  double* out, const std::string& path, std::size_t line_no) {
  for (std::size_t i = 0; i < n; ++i) {
    if (!text::ParseDouble(fields[first + i], &out[i])) {
      FailAt(path, line_no,
             "column " + std::to_string(first + i + 1) + " ('" + std::string(fields[first + i]) +
                 "') is not a finite number");
    }
  }
}

// Rejects quaternions far from unit length (a zero or garbage quaternion, not rounding).
Eigen::Quaterniond CheckedQuaternion(double w, double x, double y, double z,
                                     const std::string& path, std::size_t line_no) {
  const Eigen::Quaterniond q(w, x, y, z);
  const double n = q.norm();
  if (std::abs(n - 1.0) > 1e-2) {
    std::ostringstream os;
    os << "quaternion norm " << n << " is not 1 (expected a unit quaternion)";
    FailAt(path, line_no, os.str());
  }
  return q.normalized();
}

void CheckTimeOrder(double t, const Trajectory& traj, const std::string& path,
                    std::size_t line_no) {
  if (!traj.empty() && t < traj.back().t) {
    std::ostringstream os;
    os.precision(17);
    os << "timestamp " << t << " is earlier than the previous one (" << traj.back().t << ")";
    FailAt(path, line_no, os.str());
  }
}

std::string FormatFixed9(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.9f", t);
  return buf;
}

int64_t SecondsToNs(double t) { return static_cast<int64_t>(std::llround(t * 1e9)); }

// The pose's stamp in nanoseconds: exact when known, else rounded from seconds.
int64_t StampNs(const StampedPose& p) { return p.t_ns >= 0 ? p.t_ns : SecondsToNs(p.t); }

// "S.NNNNNNNNN" from non-negative integer nanoseconds, digit for digit.
std::string FormatNs(int64_t ns) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%lld.%09lld", static_cast<long long>(ns / 1000000000),
                static_cast<long long>(ns % 1000000000));
  return buf;
}

}  // namespace

TrajectoryFormat ParseTrajectoryFormat(const std::string& name) {
  const std::string n = text::ToLower(text::Trim(name));
  if (n == "tum") return TrajectoryFormat::kTum;
  if (n == "kitti") return TrajectoryFormat::kKitti;
  if (n == "euroc") return TrajectoryFormat::kEuroc;
  throw InputError("trajectory format '" + name + "': unknown (expected tum, kitti or euroc)");
}

Trajectory ReadTumTrajectory(const std::string& path) {
  return ParseTumTrajectory(text::ReadFile(path), path);
}

Trajectory ParseTumTrajectory(const std::string& content, const std::string& path) {
  const auto lines = text::SplitLines(content);
  Trajectory traj;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (text::IsBlankOrComment(lines[i])) continue;
    const std::size_t line_no = i + 1;
    const auto fields = text::SplitWhitespace(lines[i], /*commas_too=*/true);
    if (fields.size() != 8) {
      FailAt(path, line_no,
             "expected 8 numbers (t tx ty tz qx qy qz qw), found " + std::to_string(fields.size()));
    }
    double v[8];
    ParseNumbers(fields, 0, 8, v, path, line_no);
    CheckTimeOrder(v[0], traj, path, line_no);
    StampedPose p;
    p.t = v[0];
    p.T_w_c = SE3(CheckedQuaternion(v[7], v[4], v[5], v[6], path, line_no),
                  Eigen::Vector3d(v[1], v[2], v[3]));
    traj.push_back(p);
  }
  return traj;
}

Trajectory ReadKittiTrajectory(const std::string& path, const std::vector<double>& times) {
  return ParseKittiTrajectory(text::ReadFile(path), path, times);
}

Trajectory ParseKittiTrajectory(const std::string& content, const std::string& path,
                                const std::vector<double>& times) {
  const auto lines = text::SplitLines(content);
  Trajectory traj;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (text::IsBlankOrComment(lines[i])) continue;
    const std::size_t line_no = i + 1;
    const auto fields = text::SplitWhitespace(lines[i]);
    if (fields.size() != 12) {
      FailAt(path, line_no,
             "expected 12 numbers (row-major 3x4 pose), found " + std::to_string(fields.size()));
    }
    double v[12];
    ParseNumbers(fields, 0, 12, v, path, line_no);
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) R(r, c) = v[4 * r + c];
      t(r) = v[4 * r + 3];
    }
    const double ortho_err =
        (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (ortho_err > 1e-2 || R.determinant() <= 0.0) {
      std::ostringstream os;
      os << "the 3x3 block is not a rotation (|R^T R - I| = " << ortho_err
         << ", det = " << R.determinant() << ")";
      FailAt(path, line_no, os.str());
    }
    StampedPose p;
    p.t = static_cast<double>(traj.size());
    p.T_w_c = SE3(R, t);
    traj.push_back(p);
  }
  if (!times.empty()) {
    if (times.size() != traj.size()) {
      throw InputError(path + ": " + std::to_string(traj.size()) + " poses but " +
                       std::to_string(times.size()) + " timestamps");
    }
    for (std::size_t i = 0; i < traj.size(); ++i) traj[i].t = times[i];
  }
  return traj;
}

Trajectory ReadEurocTrajectory(const std::string& path) {
  return ParseEurocTrajectory(text::ReadFile(path), path);
}

Trajectory ParseEurocTrajectory(const std::string& content, const std::string& path) {
  const auto lines = text::SplitLines(content);
  Trajectory traj;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    if (text::IsBlankOrComment(lines[i])) continue;
    const std::size_t line_no = i + 1;
    const auto fields = text::SplitOn(lines[i], ',');
    if (fields.size() < 8) {
      FailAt(path, line_no,
             "expected at least 8 comma-separated columns (timestamp [ns], p_x, p_y, p_z, q_w, "
             "q_x, q_y, q_z), found " +
                 std::to_string(fields.size()));
    }
    int64_t ns = 0;
    if (!text::ParseInt64(fields[0], &ns)) {
      FailAt(path, line_no,
             "timestamp '" + std::string(fields[0]) + "' is not an integer nanosecond count");
    }
    double v[7];
    ParseNumbers(fields, 1, 7, v, path, line_no);
    StampedPose p;
    p.t = static_cast<double>(ns) * 1e-9;  // same conversion as StereoFrame::stamp_s()
    CheckTimeOrder(p.t, traj, path, line_no);
    p.T_w_c = SE3(CheckedQuaternion(v[3], v[4], v[5], v[6], path, line_no),
                  Eigen::Vector3d(v[0], v[1], v[2]));
    traj.push_back(p);
  }
  return traj;
}

Trajectory ReadTrajectory(const std::string& path, TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return ReadTumTrajectory(path);
    case TrajectoryFormat::kKitti:
      return ReadKittiTrajectory(path);
    case TrajectoryFormat::kEuroc:
      return ReadEurocTrajectory(path);
  }
  throw InputError(path + ": unknown trajectory format");
}

TrajectoryFormat GuessTrajectoryFormat(const std::string& path) {
  if (text::ToLower(fs::path(path).extension().string()) == ".csv") return TrajectoryFormat::kEuroc;
  const std::string content = text::ReadFile(path);
  for (const auto line : text::SplitLines(content)) {
    if (text::IsBlankOrComment(line)) continue;
    if (text::SplitWhitespace(line).size() == 12) return TrajectoryFormat::kKitti;
    if (text::SplitOn(line, ',').size() >= 8) return TrajectoryFormat::kEuroc;
    return TrajectoryFormat::kTum;
  }
  return TrajectoryFormat::kTum;
}

std::string FormatTrajectory(const Trajectory& traj, TrajectoryFormat format) {
  std::string out;
  out.reserve(traj.size() * 160 + 128);
  auto num = [&out](double v) { out += text::FormatDouble(v); };
  switch (format) {
    case TrajectoryFormat::kTum:
      out += "# timestamp tx ty tz qx qy qz qw\n";
      for (const auto& p : traj) {
        const Eigen::Quaterniond& q = p.T_w_c.so3();
        const Eigen::Vector3d& t = p.T_w_c.translation();
        out += p.t_ns >= 0 ? FormatNs(p.t_ns) : FormatFixed9(p.t);
        for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
          out += ' ';
          num(v);
        }
        out += '\n';
      }
      break;
    case TrajectoryFormat::kKitti:
      // No header: the KITTI devkit and most tools do not accept comment lines.
      for (const auto& p : traj) {
        const Eigen::Matrix<double, 3, 4> m = p.T_w_c.matrix3x4();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 4; ++c) {
            if (r > 0 || c > 0) out += ' ';
            num(m(r, c));
          }
        }
        out += '\n';
      }
      break;
    case TrajectoryFormat::kEuroc:
      out +=
          "#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
          "q_RS_y [], q_RS_z []\n";
      for (const auto& p : traj) {
        const Eigen::Quaterniond& q = p.T_w_c.so3();
        const Eigen::Vector3d& t = p.T_w_c.translation();
        out += std::to_string(StampNs(p));
        for (double v : {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()}) {
          out += ',';
          num(v);
        }
        out += '\n';
      }
      break;
  }
  return out;
}

void WriteTrajectory(const std::string& path, const Trajectory& traj, TrajectoryFormat format) {
  WriteFileAtomic(path, FormatTrajectory(traj, format));
}

int RemoveStaleTemporaryFiles(const std::string& path) {
  const fs::path target(path);
  fs::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  // WriteFileAtomic's name: ".<file name>.tmp.<pid>.<counter>". A file whose writer process
  // is gone (killed mid-write) is stale; a live writer's (this process, another saving the
  // same file) is left alone.
  const std::string prefix = "." + target.filename().string() + ".tmp.";
  int removed = 0;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = name.substr(prefix.size());
    const std::size_t dot = rest.find('.');
    int64_t pid = 0;
    if (dot == std::string::npos || !text::ParseInt64(rest.substr(0, dot), &pid) || pid <= 0 ||
        pid > INT32_MAX)
      continue;
    const auto writer = static_cast<pid_t>(pid);
    if (writer == ::getpid() || ::kill(writer, 0) == 0 || errno != ESRCH) continue;
    std::error_code remove_ec;
    if (fs::remove(it->path(), remove_ec)) ++removed;
  }
  return removed;
}

void WriteFileAtomic(const std::string& path, const std::string& content) {
  static std::atomic<unsigned> counter{0};
  const fs::path target(path);
  fs::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  RemoveStaleTemporaryFiles(path);
  const std::string tmp =
      (dir / ("." + target.filename().string() + ".tmp." + std::to_string(::getpid()) + "." +
              std::to_string(counter.fetch_add(1))))
          .string();
  auto fail = [&](const std::string& what, int err) {
    throw InputError(path + ": cannot write (" + what + ": " + std::strerror(err) + ")");
  };

  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) fail("create " + tmp, errno);
  const char* data = content.data();
  std::size_t left = content.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      ::unlink(tmp.c_str());
      fail("write", err);
    }
    data += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    fail("fsync", err);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    fail("close", err);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    fail("rename", err);
  }
  // Make the rename itself durable; failure here only weakens crash safety, so it is ignored.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    (void)::fsync(dfd);
    ::close(dfd);
  }
}

Trajectory TransformTrajectory(const Trajectory& traj, const SE3& T_right) {
  Trajectory out;
  out.reserve(traj.size());
  for (const auto& p : traj) {
    StampedPose q = p;
    q.T_w_c = p.T_w_c * T_right;
    out.push_back(q);
  }
  return out;
}

}  // namespace pl_slam
