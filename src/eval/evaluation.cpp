#include "pl_slam/eval/evaluation.h"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "pl_slam/util/error.h"

namespace pl_slam {
namespace eval {

namespace {

std::string Fmt(const char* format, double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

// JSON number, or null when there is nothing to report.
std::string JsonNumber(double v, bool valid = true) {
  if (!valid || !std::isfinite(v)) return "null";
  return Fmt("%.9g", v);
}

std::string JsonString(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    switch (c) {
      case '"':
        out += "\\\"";
        break;
      case '\\':
        out += "\\\\";
        break;
      case '\n':
        out += "\\n";
        break;
      case '\t':
        out += "\\t";
        break;
      case '\r':
        out += "\\r";
        break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          char buf[8];
          std::snprintf(buf, sizeof(buf), "\\u%04x", static_cast<unsigned>(c));
          out += buf;
        } else {
          out += c;
        }
    }
  }
  return out + "\"";
}

std::string JsonStats(const ErrorStats& s) {
  const bool v = s.count > 0;
  std::ostringstream o;
  o << "{\"count\": " << s.count << ", \"rmse\": " << JsonNumber(s.rmse, v)
    << ", \"mean\": " << JsonNumber(s.mean, v) << ", \"median\": " << JsonNumber(s.median, v)
    << ", \"std\": " << JsonNumber(s.std, v) << ", \"min\": " << JsonNumber(s.min, v)
    << ", \"max\": " << JsonNumber(s.max, v) << "}";
  return o.str();
}

std::string JsonAte(const AteResult& a, const std::string& indent) {
  std::ostringstream o;
  const Eigen::Matrix4d T = a.alignment.T_gt_est.matrix();
  o << "{\n"
    << indent << "  \"alignment\": " << JsonString(AlignmentModeName(a.alignment.mode)) << ",\n"
    << indent << "  \"scale\": " << JsonNumber(a.alignment.scale) << ",\n"
    << indent << "  \"T_gt_est\": [";
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) o << (r + c > 0 ? ", " : "") << JsonNumber(T(r, c));
  }
  o << "],\n"
    << indent << "  \"translation_m\": " << JsonStats(a.translation) << ",\n"
    << indent << "  \"rotation_deg\": " << JsonStats(a.rotation_deg) << "\n"
    << indent << "}";
  return o.str();
}

std::string StatsOrNa(const ErrorStats& s, const char* format) {
  return s.count > 0 ? Fmt(format, s.rmse) : std::string("n/a");
}

}  // namespace

void EvaluationOptions::Validate() const {
  AssociationOptions{max_dt, interpolate}.Validate();
  for (int d : rpe_frame_deltas) {
    if (d < 1) {
      throw ConfigError("rpe_frame_deltas: " + std::to_string(d) + " is not an integer >= 1");
    }
  }
  for (double L : rpe_lengths) {
    if (!(std::isfinite(L) && L > 0.0)) {
      throw ConfigError("rpe_lengths: " + Fmt("%g", L) + " m is not a finite length > 0");
    }
  }
}

EvaluationResult EvaluateTrajectory(const Trajectory& est, const Trajectory& gt,
                                    const std::vector<double>& frame_times,
                                    const EvaluationOptions& options) {
  options.Validate();
  if (est.empty()) throw InputError("the estimated trajectory has no poses");
  if (gt.empty()) throw InputError("the ground-truth trajectory has no poses");

  EvaluationResult r;
  r.options = options;
  r.est_poses = est.size();
  r.gt_poses = gt.size();
  r.association =
      AssociateTrajectories(est, gt, AssociationOptions{options.max_dt, options.interpolate});
  if (r.association.empty()) {
    const Trajectory se = SortedByTime(est);
    const Trajectory sg = SortedByTime(gt);
    throw InputError(
        "no estimate pose has ground truth within max_dt = " + Fmt("%g", options.max_dt) +
        " s (estimate spans " + Fmt("%.3f", se.front().t) + ".." + Fmt("%.3f", se.back().t) +
        " s, ground truth " + Fmt("%.3f", sg.front().t) + ".." + Fmt("%.3f", sg.back().t) + " s)");
  }
  const Association& a = r.association;
  r.est_duration = a.est.back().t - a.est.front().t;
  r.gt_path_length = PathLength(a.gt);

  r.ate = ComputeAte(a, options.alignment);
  r.est_aligned = ApplyAlignment(a.est, r.ate.alignment);

  // The summary always reports both rigid and similarity alignment; a degenerate Sim3 (all
  // positions identical) only blanks its row unless Sim3 is the requested alignment, in which
  // case ComputeAte above has already thrown.
  r.ate_se3 = options.alignment == AlignmentMode::kSE3 ? r.ate : ComputeAte(a, AlignmentMode::kSE3);
  r.se3_valid = true;
  try {
    r.ate_sim3 =
        options.alignment == AlignmentMode::kSim3 ? r.ate : ComputeAte(a, AlignmentMode::kSim3);
    r.sim3_valid = true;
  } catch (const InputError& e) {
    r.sim3_note = e.what();
  }

  for (int d : options.rpe_frame_deltas)
    r.rpe_frames.push_back(ComputeRpeFrames(r.est_aligned, a.gt, d));
  r.rpe_distance = ComputeRpeDistance(r.est_aligned, a.gt, options.rpe_lengths);

  if (frame_times.empty()) {
    std::vector<double> gt_times;
    gt_times.reserve(gt.size());
    for (const StampedPose& p : gt) gt_times.push_back(p.t);
    r.coverage = ComputeCoverage(gt_times, est, options.max_dt);
  } else {
    r.coverage = ComputeCoverage(frame_times, est, options.max_dt);
  }
  return r;
}

std::string FormatEvaluationTable(const EvaluationResult& r, const std::string& name) {
  std::ostringstream o;
  char line[256];
  if (!name.empty()) o << name << "\n";
  std::snprintf(line, sizeof(line),
                "  poses          estimate %zu, ground truth %zu, associated %zu "
                "(%zu interpolated), unmatched %zu\n",
                r.est_poses, r.gt_poses, r.association.size(), r.association.interpolated,
                r.association.unmatched);
  o << line;
  std::snprintf(line, sizeof(line), "  span           %.2f s, ground-truth path %.2f m\n",
                r.est_duration, r.gt_path_length);
  o << line;
  if (r.coverage.frames > 0) {
    std::snprintf(line, sizeof(line), "  coverage       %zu / %zu frames (%.1f %%)\n",
                  r.coverage.covered, r.coverage.frames, 100.0 * r.coverage.ratio);
  } else {
    std::snprintf(line, sizeof(line), "  coverage       n/a (not measured)\n");
  }
  o << line;

  auto ate_row = [&](const char* label, const AteResult& a) {
    const ErrorStats& t = a.translation;
    std::snprintf(line, sizeof(line),
                  "  %-14s rmse %.4f m  mean %.4f  median %.4f  std %.4f  max %.4f  "
                  "rot rmse %.3f deg",
                  label, t.rmse, t.mean, t.median, t.std, t.max, a.rotation_deg.rmse);
    o << line;
    if (a.alignment.mode == AlignmentMode::kSim3) o << Fmt("  scale %.4f", a.alignment.scale);
    o << "\n";
  };
  if (r.options.alignment != AlignmentMode::kSE3 && r.options.alignment != AlignmentMode::kSim3) {
    ate_row(("ATE " + AlignmentModeName(r.options.alignment)).c_str(), r.ate);
  }
  if (r.se3_valid) ate_row("ATE SE3", r.ate_se3);
  if (r.sim3_valid) {
    ate_row("ATE Sim3", r.ate_sim3);
  } else {
    o << "  ATE Sim3       n/a (" << r.sim3_note << ")\n";
  }

  for (const RpeFramesResult& f : r.rpe_frames) {
    const std::string label =
        "RPE " + std::to_string(f.delta) + (f.delta == 1 ? " frame" : " frames");
    std::snprintf(line, sizeof(line), "  %-14s ", label.c_str());
    o << line;
    if (f.translation.count == 0) {
      o << "n/a (fewer than " << f.delta + 1 << " associated poses)\n";
      continue;
    }
    o << "trans rmse " << StatsOrNa(f.translation, "%.4f") << " m   rot rmse "
      << StatsOrNa(f.rotation_deg, "%.3f") << " deg   (" << f.translation.count << " pairs)\n";
  }
  for (const RpeDistanceResult& d : r.rpe_distance) {
    const std::string label = "drift " + Fmt("%g", d.length) + " m";
    std::snprintf(line, sizeof(line), "  %-14s ", label.c_str());
    o << line;
    if (d.segments == 0) {
      o << Fmt("n/a (longer than the %.2f m path)\n", r.gt_path_length);
      continue;
    }
    std::snprintf(line, sizeof(line), "trans %.3f %%   rot %.4f deg/m   (%zu segments)\n",
                  d.translation_pct, d.rotation_deg_per_m, d.segments);
    o << line;
  }
  return o.str();
}

std::string FormatEvaluationJson(const EvaluationResult& r, const std::string& name) {
  std::ostringstream o;
  o << "{\n"
    << "  \"name\": " << JsonString(name) << ",\n"
    << "  \"alignment\": " << JsonString(AlignmentModeName(r.options.alignment)) << ",\n"
    << "  \"max_dt\": " << JsonNumber(r.options.max_dt) << ",\n"
    << "  \"counts\": {\"estimate\": " << r.est_poses << ", \"ground_truth\": " << r.gt_poses
    << ", \"associated\": " << r.association.size()
    << ", \"interpolated\": " << r.association.interpolated
    << ", \"unmatched\": " << r.association.unmatched << "},\n"
    << "  \"duration_s\": " << JsonNumber(r.est_duration) << ",\n"
    << "  \"gt_path_length_m\": " << JsonNumber(r.gt_path_length) << ",\n"
    << "  \"coverage\": {\"frames\": " << r.coverage.frames
    << ", \"covered\": " << r.coverage.covered
    << ", \"ratio\": " << JsonNumber(r.coverage.ratio, r.coverage.frames > 0) << "},\n"
    << "  \"ate\": " << JsonAte(r.ate, "  ") << ",\n"
    << "  \"ate_se3\": " << (r.se3_valid ? JsonAte(r.ate_se3, "  ") : "null") << ",\n"
    << "  \"ate_sim3\": " << (r.sim3_valid ? JsonAte(r.ate_sim3, "  ") : "null") << ",\n";
  if (!r.sim3_valid) o << "  \"ate_sim3_note\": " << JsonString(r.sim3_note) << ",\n";
  o << "  \"rpe_frames\": [";
  for (std::size_t i = 0; i < r.rpe_frames.size(); ++i) {
    const RpeFramesResult& f = r.rpe_frames[i];
    o << (i ? "," : "") << "\n    {\"delta\": " << f.delta << ", \"pairs\": " << f.translation.count
      << ", \"translation_m\": " << JsonStats(f.translation)
      << ", \"rotation_deg\": " << JsonStats(f.rotation_deg) << "}";
  }
  o << (r.rpe_frames.empty() ? "" : "\n  ") << "],\n";
  o << "  \"rpe_distance\": [";
  for (std::size_t i = 0; i < r.rpe_distance.size(); ++i) {
    const RpeDistanceResult& d = r.rpe_distance[i];
    const bool v = d.segments > 0;
    o << (i ? "," : "") << "\n    {\"length_m\": " << JsonNumber(d.length)
      << ", \"segments\": " << d.segments
      << ", \"translation_pct\": " << JsonNumber(d.translation_pct, v)
      << ", \"rotation_deg_per_m\": " << JsonNumber(d.rotation_deg_per_m, v) << "}";
  }
  o << (r.rpe_distance.empty() ? "" : "\n  ") << "]\n";
  o << "}\n";
  return o.str();
}

}  // namespace eval
}  // namespace pl_slam
