#include "pl_slam/eval/evaluate_cli.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "pl_slam/eval/plot.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

namespace {

constexpr const char* kProgram = "pl_slam_evaluate";

bool ParseDouble(const std::string& s, double* v) {
  if (s.empty()) return false;
  errno = 0;
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return errno == 0 && end == s.c_str() + s.size() && std::isfinite(*v);
}

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::string cur;
  for (char c : s) {
    if (c == ',' || std::isspace(static_cast<unsigned char>(c))) {
      if (!cur.empty()) out.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open for reading");
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string BaseName(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  std::string base = slash == std::string::npos ? path : path.substr(slash + 1);
  const std::size_t dot = base.find_last_of('.');
  if (dot != std::string::npos && dot > 0) base = base.substr(0, dot);
  return base;
}

// Median spacing of sorted stamps (0 with fewer than two).
double MedianPeriod(std::vector<double> t) {
  if (t.size() < 2) return 0.0;
  std::sort(t.begin(), t.end());
  std::vector<double> d;
  for (std::size_t i = 1; i < t.size(); ++i) d.push_back(t[i] - t[i - 1]);
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

std::vector<double> Stamps(const Trajectory& traj) {
  std::vector<double> t;
  t.reserve(traj.size());
  for (const StampedPose& p : traj) t.push_back(p.t);
  return t;
}

// An input error raised while handling `file`, so the one-line message can name it.
struct FileError {
  std::string file;
  std::string what;
};

template <typename F>
auto WithFile(const std::string& file, F&& f) -> decltype(f()) {
  try {
    return f();
  } catch (const InputError& e) {
    throw FileError{file, e.what()};
  } catch (const ConfigError& e) {
    throw FileError{file, e.what()};
  } catch (const std::exception& e) {
    throw FileError{file, e.what()};
  }
}

}  // namespace

std::string EvaluateUsage() {
  return "usage: pl_slam_evaluate --est EST --gt GT [options]\n"
         "\n"
         "Compares an estimated trajectory with ground truth: ATE (SE3 and Sim3 alignment),\n"
         "RPE per frame step and per travelled distance, frame coverage; optional PNG plot\n"
         "and JSON report.\n"
         "\n"
         "  --est FILE              estimated camera trajectory\n"
         "  --gt FILE               ground-truth trajectory\n"
         "  --est-format F          tum | kitti | euroc (default: guessed from the file)\n"
         "  --gt-format F           tum | kitti | euroc (default: guessed from the file)\n"
         "  --gt-times FILE         time stamps of a KITTI ground-truth file (times.txt)\n"
         "  --est-times FILE        time stamps of a KITTI estimate file\n"
         "  --t-bs SENSOR_YAML      EuRoC cam0/sensor.yaml: ground truth (body) becomes\n"
         "                          camera poses, T_w_c = T_w_b * T_BS\n"
         "  --T_B_C \"16 numbers\"    the same from a row-major 4x4 matrix\n"
         "  --align MODE            se3 | sim3 | none | first-pose (default se3)\n"
         "  --max-dt SECONDS        association window (default 0.02)\n"
         "  --rpe-frames LIST       RPE frame steps, e.g. 1,10 (default 1,10)\n"
         "  --rpe-lengths LIST      RPE segment lengths in metres (default 1,2,5,10)\n"
         "  --frame-times FILE|none stamps of the frames to cover, e.g. cam0/data.csv\n"
         "                          (default: the ground-truth stamps; none: no coverage)\n"
         "  --plot FILE.png         write a plot of the trajectories and the error\n"
         "  --no-error-panel        plot without the error-over-time panel\n"
         "  --name NAME             sequence name for the report and plot title\n"
         "  --json FILE             write the results as JSON\n"
         "  -h, --help              show this text\n"
         "\n"
         "Exit status: 0 ok, 1 bad input file, 2 bad usage.\n";
}

EvaluateCliArgs ParseEvaluateArgs(const std::vector<std::string>& args) {
  EvaluateCliArgs a;
  bool have_t_bs = false;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& flag = args[i];
    auto value = [&]() -> const std::string& {
      if (i + 1 >= args.size()) throw UsageError(flag + " needs a value");
      return args[++i];
    };
    if (flag == "-h" || flag == "--help") {
      a.help = true;
    } else if (flag == "--est") {
      a.est_path = value();
    } else if (flag == "--gt") {
      a.gt_path = value();
    } else if (flag == "--est-format" || flag == "--gt-format") {
      const std::string v = value();
      try {
        ParseTrajectoryFormat(v);
      } catch (const std::exception&) {
        throw UsageError(flag + " '" + v + "': expected tum, kitti or euroc");
      }
      (flag == "--est-format" ? a.est_format : a.gt_format) = v;
    } else if (flag == "--gt-times") {
      a.gt_times_path = value();
    } else if (flag == "--est-times") {
      a.est_times_path = value();
    } else if (flag == "--t-bs") {
      a.t_bs_path = value();
      have_t_bs = true;
    } else if (flag == "--T_B_C" || flag == "--T-B-C") {
      const std::string v = value();
      try {
        a.T_B_C = ParseRigidTransform16(v, flag);
      } catch (const InputError& e) {
        throw UsageError(e.what());
      }
      a.has_T_B_C = true;
    } else if (flag == "--align") {
      const std::string v = value();
      try {
        a.options.alignment = ParseAlignmentMode(v);
      } catch (const ConfigError& e) {
        throw UsageError("--align " + std::string(e.what()));
      }
    } else if (flag == "--max-dt") {
      const std::string v = value();
      double dt = 0.0;
      if (!ParseDouble(v, &dt) || dt <= 0.0) {
        throw UsageError("--max-dt '" + v + "': expected a number of seconds > 0");
      }
      a.options.max_dt = dt;
    } else if (flag == "--rpe-frames") {
      const std::string v = value();
      a.options.rpe_frame_deltas.clear();
      for (const std::string& tok : SplitList(v)) {
        double d = 0.0;
        if (!ParseDouble(tok, &d) || d < 1.0 || d != std::floor(d) || d > 1e6) {
          throw UsageError("--rpe-frames '" + v + "': expected integers >= 1, e.g. 1,10");
        }
        a.options.rpe_frame_deltas.push_back(static_cast<int>(d));
      }
    } else if (flag == "--rpe-lengths") {
      const std::string v = value();
      a.options.rpe_lengths.clear();
      for (const std::string& tok : SplitList(v)) {
        double L = 0.0;
        if (!ParseDouble(tok, &L) || L <= 0.0) {
          throw UsageError("--rpe-lengths '" + v + "': expected lengths in metres > 0, e.g. 1,2,5");
        }
        a.options.rpe_lengths.push_back(L);
      }
    } else if (flag == "--frame-times") {
      a.frame_times = value();
    } else if (flag == "--plot") {
      a.plot_path = value();
    } else if (flag == "--no-error-panel") {
      a.error_panel = false;
    } else if (flag == "--name") {
      a.name = value();
    } else if (flag == "--json") {
      a.json_path = value();
    } else {
      throw UsageError("unknown argument '" + flag + "'");
    }
  }
  if (a.help) return a;
  if (a.est_path.empty()) throw UsageError("--est is required");
  if (a.gt_path.empty()) throw UsageError("--gt is required");
  if (have_t_bs && a.has_T_B_C) throw UsageError("--t-bs and --T_B_C are exclusive");
  return a;
}

std::vector<double> ReadTimestamps(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open for reading");
  std::vector<double> out;
  std::string line;
  int line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    const std::size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::size_t end = line.find_first_of(", \t\r", start);
    const std::string tok =
        line.substr(start, end == std::string::npos ? std::string::npos : end - start);
    const bool integer = !tok.empty() && std::all_of(tok.begin(), tok.end(), [](char c) {
      return std::isdigit(static_cast<unsigned char>(c));
    });
    double t = 0.0;
    if (integer && tok.size() >= 16) {
      // Nanoseconds: split so the seconds keep their full precision.
      const std::string sec = tok.substr(0, tok.size() - 9);
      const std::string nsec = tok.substr(tok.size() - 9);
      t = std::strtod(sec.c_str(), nullptr) + std::strtod(nsec.c_str(), nullptr) * 1e-9;
    } else if (!ParseDouble(tok, &t)) {
      throw InputError(path + ":" + std::to_string(line_no) + ": '" + tok +
                       "' is not a time stamp (seconds, or integer nanoseconds)");
    }
    out.push_back(t);
  }
  if (out.empty()) throw InputError(path + ": no time stamps");
  return out;
}

SE3 ParseRigidTransform16(const std::string& text, const std::string& what) {
  const std::vector<std::string> toks = SplitList(text);
  if (toks.size() != 16) {
    throw InputError(what + ": expected 16 numbers (row-major 4x4), got " +
                     std::to_string(toks.size()));
  }
  Eigen::Matrix4d T;
  for (int k = 0; k < 16; ++k) {
    double v = 0.0;
    if (!ParseDouble(toks[k], &v)) {
      throw InputError(what + ": '" + toks[k] + "' is not a number");
    }
    T(k / 4, k % 4) = v;
  }
  if ((T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-6) {
    throw InputError(what + ": the last row must be 0 0 0 1");
  }
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  const double ortho = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (ortho > 1e-4 || R.determinant() < 0.0) {
    throw InputError(what + ": the rotation block is not a rotation (|R^T R - I| = " +
                     std::to_string(ortho) + ", det = " + std::to_string(R.determinant()) + ")");
  }
  return SE3::FromMatrix(T);
}

SE3 ReadSensorYamlTBS(const std::string& path) {
  const std::string text = ReadWholeFile(path);
  const std::size_t key = text.find("T_BS");
  if (key == std::string::npos) throw InputError(path + ": no T_BS entry");
  const std::size_t data = text.find("data", key);
  if (data == std::string::npos) throw InputError(path + ": T_BS has no data entry");
  const std::size_t open = text.find('[', data);
  const std::size_t close = open == std::string::npos ? open : text.find(']', open);
  if (open == std::string::npos || close == std::string::npos) {
    throw InputError(path + ": T_BS data is not a [...] list");
  }
  return ParseRigidTransform16(text.substr(open + 1, close - open - 1), path + ": T_BS");
}

int RunEvaluateCli(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  EvaluateCliArgs a;
  try {
    a = ParseEvaluateArgs(args);
  } catch (const std::exception& e) {
    err << kProgram << ": " << e.what() << "\n" << EvaluateUsage();
    return 2;
  }
  if (a.help) {
    out << EvaluateUsage();
    return 0;
  }
  try {
    try {
      const std::vector<double> gt_times =
          a.gt_times_path.empty()
              ? std::vector<double>()
              : WithFile(a.gt_times_path, [&] { return ReadTimestamps(a.gt_times_path); });
      const std::vector<double> est_times =
          a.est_times_path.empty()
              ? std::vector<double>()
              : WithFile(a.est_times_path, [&] { return ReadTimestamps(a.est_times_path); });
      SE3 T_B_C = a.T_B_C;
      const bool convert_gt = a.has_T_B_C || !a.t_bs_path.empty();
      if (!a.t_bs_path.empty()) {
        T_B_C = WithFile(a.t_bs_path, [&] { return ReadSensorYamlTBS(a.t_bs_path); });
      }

      auto read = [&](const std::string& path, const std::string& format_name,
                      const std::vector<double>& times, const char* times_flag) {
        return WithFile(path, [&] {
          const TrajectoryFormat format = format_name.empty() ? GuessTrajectoryFormat(path)
                                                              : ParseTrajectoryFormat(format_name);
          if (format == TrajectoryFormat::kKitti) return ReadKittiTrajectory(path, times);
          if (!times.empty()) {
            err << kProgram << ": warning: " << times_flag
                << " ignored: it only applies to KITTI files\n";
          }
          return ReadTrajectory(path, format);
        });
      };
      const Trajectory est = read(a.est_path, a.est_format, est_times, "--est-times");
      Trajectory gt = read(a.gt_path, a.gt_format, gt_times, "--gt-times");
      if (convert_gt) gt = TransformTrajectory(gt, T_B_C);

      std::vector<double> frames;
      const bool coverage_off = a.frame_times == "none";
      if (!a.frame_times.empty() && !coverage_off) {
        frames = WithFile(a.frame_times, [&] { return ReadTimestamps(a.frame_times); });
      }

      const std::string name = a.name.empty() ? BaseName(a.est_path) : a.name;
      EvaluationResult result =
          WithFile(a.est_path, [&] { return EvaluateTrajectory(est, gt, frames, a.options); });
      if (coverage_off) result.coverage = CoverageResult{};

      out << FormatEvaluationTable(result, name);
      if (a.frame_times.empty()) {
        const double gt_period = MedianPeriod(Stamps(gt));
        const double est_period = MedianPeriod(Stamps(est));
        if (gt_period > 0.0 && est_period > 0.0 && gt_period < 0.5 * est_period) {
          out << "  note: coverage counts ground-truth stamps (" << std::lround(1.0 / gt_period)
              << " Hz) against a " << std::lround(1.0 / est_period)
              << " Hz estimate; pass --frame-times with the image stamps\n";
        }
      }

      if (!a.plot_path.empty()) {
        PlotOptions plot;
        plot.name = name;
        plot.error_panel_height = a.error_panel ? plot.error_panel_height : 0;
        const Trajectory est_all = ApplyAlignment(SortedByTime(est), result.ate.alignment);
        WithFile(a.plot_path, [&] {
          WriteTrajectoryPlot(a.plot_path, SortedByTime(gt), est_all, result.ate, plot);
          return 0;
        });
        out << "  plot           " << a.plot_path << "\n";
      }
      if (!a.json_path.empty()) {
        WithFile(a.json_path, [&] {
          WriteFileAtomic(a.json_path, FormatEvaluationJson(result, name));
          return 0;
        });
        out << "  json           " << a.json_path << "\n";
      }
      return 0;
    } catch (const FileError& e) {
      // Messages from the readers usually start with the path already.
      const bool named = e.what.compare(0, e.file.size(), e.file) == 0;
      std::string what = e.what;
      std::replace(what.begin(), what.end(), '\n', ' ');
      err << kProgram << ": error: " << (named ? "" : e.file + ": ") << what << "\n";
      return 1;
    }
  } catch (const std::exception& e) {
    err << kProgram << ": error: " << e.what() << "\n";
    return 1;
  } catch (...) {
    err << kProgram << ": error: unexpected failure\n";
    return 1;
  }
}

}  // namespace eval
}  // namespace pl_slam
