// pl_slam_offline: runs the core pipeline on a dataset folder (EuRoC ASL, KITTI odometry) or
// a rosbag as fast as the CPU allows, without a ROS master. Writes the trajectory (TUM), the
// ground truth of the left camera when the dataset has one (TUM), and a per-frame timing CSV.
#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <mutex>
#include <thread>

#include <malloc.h>
#include <unistd.h>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include <Eigen/Geometry>

#include "pl_slam/camera/stereo_check.h"
#include "pl_slam/io/stereo_source.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/ros/bag_io.h"
#include "pl_slam/system/slam_system.h"
#include "pl_slam/util/cli.h"
#include "pl_slam/util/config_doc.h"
#include "pl_slam/util/error.h"
#include "pl_slam/util/logging.h"
#include "pl_slam/util/option_table.h"

namespace {

constexpr char kUsage[] =
    "usage: pl_slam_offline INPUT [options]\n"
    "  INPUT                 EuRoC ASL folder, KITTI odometry folder, or a .bag file\n"
    "  --out DIR             output folder (default: output/offline)\n"
    "  --max-frames N        stop after N frames (default: all)\n"
    "  --left-topic T        bag: left image topic (default /cam0/image_raw)\n"
    "  --right-topic T       bag: right image topic (default /cam1/image_raw)\n"
    "  --left-info T         bag: left camera_info topic (default /cam0/camera_info)\n"
    "  --right-info T        bag: right camera_info topic (default /cam1/camera_info)\n"
    "  --gt-topic T          bag: ground-truth PoseStamped topic (default /ground_truth/pose)\n"
    "  --config FILE.yaml    options file (see config/*.yaml; keys as printed by --print-config)\n"
    "  --mode M              features for tracking: points | lines | points_lines\n"
    "  --set K=V[,K=V...]    override options, e.g. --set tracker.points.max_points=600\n"
    "  --print-config        print every option with its value and meaning, then exit\n"
    "  --print-config-markdown  the same as a Markdown page (docs/configuration.md), then exit\n"
    "  --quiet               only the summary\n"
    "  --verbose             also debug messages (why each lost frame was lost)\n"
    "  --realtime            feed frames at the recording's rate (live-like threaded mapping)\n"
    "  --memory-every N      every N frames, log resident memory, map size and mapping queue\n"
    "                        length to DIR/memory.csv\n"
    "  --watchdog S          abort (exit 3) when one frame takes more than S seconds (soak runs)\n"
    "  --load-map FILE       start in a saved map (relocalises first; see --localization-only)\n"
    "  --localization-only   track in the map without adding keyframes\n"
    "  --save-map FILE       save the map at the end (atomic; versioned, checksummed)\n"
    "  --doffs PX|auto       the right principal point lies PX pixels right of the left one's,\n"
    "                        replacing the calibration's value (measure it with\n"
    "                        pl_slam_check_stereo when disparities look biased); auto:\n"
    "                        measure it first (a pass over up to 300 frames, as that tool\n"
    "                        does) and use it only when it clearly differs\n"
    "outputs: DIR/trajectory.tum, DIR/keyframes.tum (with mapping: the final keyframe poses),\n"
    "         DIR/groundtruth.tum (when known), DIR/timing.csv,\n"
    "         DIR/frames.txt (stamp of every frame read, for coverage),\n"
    "         DIR/odometry.csv (every frame's odom pose, REP-105, and the standard\n"
    "         deviations of its covariance: position m and rotation rad about the odom axes)\n";

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5));
  return v[k];
}

/// Resident set size of this process in MB (Linux /proc/self/statm), 0 when unknown.
double ResidentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  if (!(statm >> pages_total >> pages_resident)) return 0.0;
  return pages_resident * (sysconf(_SC_PAGESIZE) / 1048576.0);
}

/// Bytes the allocator has handed out and not got back, over all arenas (every thread may
/// allocate from its own), MB: glibc's malloc_info totals, memory obtained from the system
/// minus the free chunks, plus mmapped blocks. Resident memory growing while this stays flat
/// is the allocator keeping memory (fragmentation), not the program holding more. -1 when
/// unavailable.
double HeapInUseMegabytes() {
  char* buffer = nullptr;
  size_t size = 0;
  FILE* f = open_memstream(&buffer, &size);
  if (!f) return -1.0;
  const int rc = malloc_info(0, f);
  std::fclose(f);
  const std::string xml(buffer ? buffer : "", size);
  std::free(buffer);
  if (rc != 0) return -1.0;
  // The totals over all arenas follow the last </heap>.
  const size_t tail = xml.rfind("</heap>");
  const std::string totals = tail == std::string::npos ? xml : xml.substr(tail);
  auto value = [&](const std::string& tag) -> double {
    const size_t at = totals.find(tag);
    if (at == std::string::npos) return 0.0;
    const size_t q = totals.find("size=\"", at);
    return q == std::string::npos ? 0.0 : std::atof(totals.c_str() + q + 6);
  };
  const double in_use = value("<system type=\"current\"") - value("<total type=\"fast\"") -
                        value("<total type=\"rest\"") + value("<total type=\"mmap\"");
  return in_use / 1048576.0;
}

/// The per-frame timing record, kept on disk rather than in memory so that a long (soak) run
/// holds nothing per frame: each frame is appended to DIR/timing.csv.rows as it is processed;
/// Finish() turns that file into DIR/timing.csv (one column per stage, in first-seen order) and
/// DIR/frames.txt, both written atomically, and returns the per-frame total times. The odometry
/// (every frame's odom pose and its covariance's standard deviations) streams the same way to
/// DIR/odometry.csv.
class TimingLog {
 public:
  explicit TimingLog(const std::string& out_dir)
      : out_dir_(out_dir),
        rows_path_(out_dir + "/timing.csv.rows"),
        odom_path_(out_dir + "/odometry.csv.rows") {
    rows_.open(rows_path_, std::ios::trunc);
    if (!rows_) throw pl_slam::InputError(rows_path_ + ": cannot write");
    rows_ << std::fixed;
    odom_.open(odom_path_, std::ios::trunc);
    if (!odom_) throw pl_slam::InputError(odom_path_ + ": cannot write");
    odom_ << "frame,stamp,state,tx,ty,tz,qx,qy,qz,qw,sd_x,sd_y,sd_z,sd_rx,sd_ry,sd_rz\n"
          << std::fixed << std::setprecision(9);
  }
  void Add(int index, double stamp, const pl_slam::FrameResult& r) {
    // The kFixed columns (the header's, total_ms last) then stage=ms pairs; stage names are
    // identifiers (no commas or '=').
    rows_ << index << "," << std::setprecision(9) << stamp << ","
          << pl_slam::TrackingStateName(r.state) << "," << r.points_detected << ","
          << r.lines_detected << "," << r.points_stereo << "," << r.lines_stereo << ","
          << r.point_matches << "," << r.line_matches << "," << r.point_inliers << ","
          << r.line_inliers << "," << std::setprecision(3) << r.total_ms;
    for (const auto& [name, ms] : r.stage_ms) {
      if (std::find(stages_.begin(), stages_.end(), name) == stages_.end()) stages_.push_back(name);
      rows_ << "," << name << "=" << ms;
    }
    rows_ << "\n";
    const Eigen::Vector3d t = r.T_odom_c.translation();
    const Eigen::Quaterniond q(r.T_odom_c.rotation());
    const pl_slam::Vector6d sd = r.odom_covariance.diagonal().cwiseMax(0.0).cwiseSqrt();
    odom_ << index << "," << stamp << "," << pl_slam::TrackingStateName(r.state) << "," << t.x()
          << "," << t.y() << "," << t.z() << "," << q.x() << "," << q.y() << "," << q.z() << ","
          << q.w();
    for (int i = 0; i < 6; ++i) odom_ << "," << sd(i);
    odom_ << "\n";
    ++count_;
  }
  int count() const { return count_; }

  std::vector<double> Finish() {
    rows_.close();
    if (!rows_) throw pl_slam::InputError(rows_path_ + ": write failed (disk full?)");
    std::ifstream in(rows_path_);
    std::ostringstream csv, frames;
    csv << "frame,stamp,state,points,lines,points_stereo,lines_stereo,point_matches,line_matches,"
           "point_inliers,line_inliers";
    for (const auto& s : stages_) csv << "," << s << "_ms";
    csv << ",total_ms\n";
    std::vector<double> totals;
    std::string line;
    std::vector<std::string> values(stages_.size());
    while (std::getline(in, line)) {
      std::vector<std::string> fields;
      std::stringstream ss(line);
      std::string f;
      while (std::getline(ss, f, ',')) fields.push_back(f);
      if (fields.size() < kFixed)
        throw pl_slam::InputError(rows_path_ + ": malformed row: " + line);
      std::fill(values.begin(), values.end(), "0.000");
      for (size_t i = kFixed; i < fields.size(); ++i) {
        const size_t eq = fields[i].find('=');
        const auto it = std::find(stages_.begin(), stages_.end(), fields[i].substr(0, eq));
        if (eq != std::string::npos && it != stages_.end())
          values[it - stages_.begin()] = fields[i].substr(eq + 1);
      }
      for (size_t i = 0; i + 1 < kFixed; ++i) csv << (i ? "," : "") << fields[i];
      for (const auto& v : values) csv << "," << v;
      csv << "," << fields[kFixed - 1] << "\n";
      frames << fields[1] << "\n";
      totals.push_back(std::atof(fields[kFixed - 1].c_str()));
    }
    pl_slam::WriteFileAtomic(out_dir_ + "/timing.csv", csv.str());
    // Every frame read (tracked or not): what coverage is measured against.
    pl_slam::WriteFileAtomic(out_dir_ + "/frames.txt", frames.str());
    std::filesystem::remove(rows_path_);
    odom_.close();
    if (!odom_) throw pl_slam::InputError(odom_path_ + ": write failed (disk full?)");
    std::filesystem::rename(odom_path_, out_dir_ + "/odometry.csv");
    return totals;
  }

 private:
  static constexpr size_t kFixed = 12;  // columns before the stages, total_ms the last
  std::string out_dir_, rows_path_, odom_path_;
  std::ofstream rows_, odom_;
  std::vector<std::string> stages_;
  int count_ = 0;
};

/// Aborts the process when a frame takes longer than the limit: a soak run must fail on a
/// deadlock or a stall instead of hanging. Start()/Stop() around each frame; 0 s = off.
class Watchdog {
 public:
  explicit Watchdog(double limit_s) : limit_s_(limit_s) {
    if (limit_s_ > 0.0) thread_ = std::thread([this] { Loop(); });
  }
  ~Watchdog() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }
  void Start(int frame) {
    std::lock_guard<std::mutex> lock(mutex_);
    frame_ = frame;
    running_ = true;
    ++generation_;
    started_ = std::chrono::steady_clock::now();
    cv_.notify_all();
  }
  void Stop() {
    std::lock_guard<std::mutex> lock(mutex_);
    running_ = false;
  }

 private:
  void Loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto limit = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(limit_s_));
    while (!quit_) {
      if (!running_) {
        cv_.wait(lock, [this] { return quit_ || running_; });
        continue;
      }
      const uint64_t generation = generation_;
      const auto deadline = started_ + limit;
      cv_.wait_until(lock, deadline,
                     [&] { return quit_ || !running_ || generation_ != generation; });
      if (running_ && generation_ == generation && std::chrono::steady_clock::now() >= deadline) {
        std::cerr << "pl_slam_offline: watchdog: "
                  << (frame_ < 0 ? std::string("the final flush")
                                 : "frame " + std::to_string(frame_))
                  << " took more than " << limit_s_ << " s (deadlock or stall); aborting"
                  << std::endl;
        std::_Exit(3);
      }
      // Stop() does not notify: a finished frame is seen at its deadline or the next Start().
    }
  }
  double limit_s_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool quit_ = false, running_ = false;
  int frame_ = 0;
  uint64_t generation_ = 0;
  std::chrono::steady_clock::time_point started_;
};

int Run(int argc, char** argv) {
  const pl_slam::CommandLine cl(
      argc, argv,
      {"out", "max-frames", "left-topic", "right-topic", "left-info", "right-info", "gt-topic",
       "config", "mode", "set", "memory-every", "watchdog", "load-map", "save-map", "doffs"},
      {"quiet", "verbose", "help", "print-config", "print-config-markdown", "realtime",
       "localization-only"});
  if (cl.Has("help")) {
    std::cout << kUsage;
    return 0;
  }
  pl_slam::SystemOptions options;
  const pl_slam::OptionTable table = pl_slam::MakeOptionTable(&options);
  if (cl.Has("config")) pl_slam::LoadYamlOptions(cl.Get("config", ""), table);
  if (cl.Has("mode")) table.Set("tracker.mode", cl.Get("mode", ""));
  if (cl.Has("set")) table.SetAssignments(cl.Get("set", ""));
  if (cl.Has("print-config")) {
    std::cout << table.Describe();
    return 0;
  }
  if (cl.Has("print-config-markdown")) {
    std::cout << pl_slam::OptionTableMarkdown(table);
    return 0;
  }
  // The vocabulary: the package's by default, relative paths relative to the package.
  if (options.loop.vocabulary.empty())
    options.loop.vocabulary = std::string(PL_SLAM_PACKAGE_DIR) + "/vocabulary";
  else if (options.loop.vocabulary[0] != '/')
    options.loop.vocabulary = std::string(PL_SLAM_PACKAGE_DIR) + "/" + options.loop.vocabulary;
  const std::string invalid = options.Validate();
  if (!invalid.empty()) throw pl_slam::ConfigError(invalid);
  if (cl.positional().size() != 1) {
    std::cerr << kUsage;
    return 2;
  }
  const std::string input = cl.positional()[0];
  const std::string out_dir = cl.Get("out", "output/offline");
  const int max_frames = cl.GetInt("max-frames", -1);
  if (cl.Has("quiet") && cl.Has("verbose"))
    throw pl_slam::ConfigError("--quiet and --verbose contradict each other: give one");
  if (cl.Has("quiet")) pl_slam::SetLogLevel(pl_slam::LogLevel::kWarn);
  if (cl.Has("verbose")) pl_slam::SetLogLevel(pl_slam::LogLevel::kDebug);

  auto open_source = [&]() -> std::unique_ptr<pl_slam::StereoSource> {
    if (std::filesystem::is_regular_file(input) ||
        (input.size() > 4 && input.substr(input.size() - 4) == ".bag")) {
      pl_slam::ros_layer::BagTopics topics;
      topics.left_image = cl.Get("left-topic", topics.left_image);
      topics.right_image = cl.Get("right-topic", topics.right_image);
      topics.left_info = cl.Get("left-info", topics.left_info);
      topics.right_info = cl.Get("right-info", topics.right_info);
      topics.ground_truth = cl.Get("gt-topic", topics.ground_truth);
      return std::make_unique<pl_slam::ros_layer::BagStereoSource>(input, topics);
    }
    return pl_slam::OpenDatasetFolder(input);
  };
  std::unique_ptr<pl_slam::StereoSource> source = open_source();

  pl_slam::StereoCamera cam = source->camera();
  if (cl.Has("doffs") && cl.Get("doffs", "") == "auto") {
    // A first pass over (at most 300 of) the frames, as pl_slam_check_stereo does; the offset
    // is used only when the images clearly imply one, else the calibration's stays.
    const pl_slam::StereoOffsetMeasurement m = pl_slam::MeasureStereoOffset(source.get(), 300);
    std::ostringstream what;
    what << std::fixed << std::setprecision(2);
    if (!m.conclusive()) {
      what << "only " << m.summary.pairs << " of " << m.tried
           << " frame pairs usable, keeping the calibration's " << cam.doffs << " px";
    } else if (!pl_slam::StereoOffsetDiffers(m.summary, cam.doffs)) {
      what << "the images imply " << m.summary.doffs << " +- " << m.summary.doffs_error
           << " px, consistent with the calibration's " << cam.doffs << " px: kept";
    } else {
      what << "the images imply " << m.summary.doffs << " +- " << m.summary.doffs_error
           << " px against the calibration's " << cam.doffs << " px: using " << m.summary.doffs;
      cam.doffs = m.summary.doffs;
    }
    std::cout << "pl_slam_offline: --doffs auto: " << what.str() << "\n";
    source = open_source();  // from the first frame again
  } else if (cl.Has("doffs")) {
    cam.doffs = cl.GetDouble("doffs", 0.0);
    const std::string err = cam.Validate();
    if (!err.empty()) throw pl_slam::ConfigError("--doffs: " + err);
  }
  std::cout << "pl_slam_offline: " << source->Describe() << ", " << source->size() << " frames, "
            << cam.width << "x" << cam.height << ", fx=" << cam.fx << " baseline=" << cam.baseline
            << " m" << (cam.doffs != 0.0 ? ", doffs=" + std::to_string(cam.doffs) + " px" : "")
            << ", mode " << pl_slam::FeatureModeName(options.tracker.mode) << "\n";
  pl_slam::SlamSystem system(cam, options);
  if (cl.Has("load-map")) system.LoadMap(cl.Get("load-map", ""));
  if (cl.Has("localization-only")) system.SetLocalizationOnly(true);
  const double watchdog_s = cl.GetDouble("watchdog", 0.0);
  if (!(watchdog_s >= 0.0)) throw pl_slam::ConfigError("--watchdog: must be >= 0 seconds");
  Watchdog watchdog(watchdog_s);

  std::filesystem::create_directories(out_dir);
  TimingLog timing(out_dir);
  int lost = 0;
  pl_slam::StereoFrame frame;
  const bool realtime = cl.Has("realtime");
  const int memory_every = cl.GetInt("memory-every", 0);
  // Written row by row (flushed), so a long run that is stopped or aborts keeps its record.
  std::ofstream memory_csv;
  if (memory_every > 0) {
    memory_csv.open(out_dir + "/memory.csv", std::ios::trunc);
    if (!memory_csv) throw pl_slam::InputError(out_dir + "/memory.csv: cannot write");
    memory_csv << "frame,rss_mb,keyframes,points,lines,culled_keyframes,mapping_queue,heap_mb"
               << std::endl;
  }
  const auto wall_start = std::chrono::steady_clock::now();
  double first_stamp = -1.0;
  while ((max_frames < 0 || timing.count() < max_frames) && source->Next(&frame)) {
    if (realtime) {
      if (first_stamp < 0.0) first_stamp = frame.stamp_s();
      std::this_thread::sleep_until(
          wall_start + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                           std::chrono::duration<double>(frame.stamp_s() - first_stamp)));
    }
    watchdog.Start(frame.index);
    const pl_slam::FrameResult r = system.Process(frame);
    watchdog.Stop();
    timing.Add(frame.index, frame.stamp_s(), r);
    if (memory_every > 0 && timing.count() % memory_every == 0) {
      const pl_slam::MapCounts mc = system.map().counts();
      memory_csv << timing.count() << "," << ResidentMegabytes() << "," << mc.keyframes << ","
                 << mc.points << "," << mc.lines << "," << mc.culled_keyframes << ","
                 << system.mapping_stats().queue_length << "," << HeapInUseMegabytes() << std::endl;
    }
    if (!r.pose_valid) ++lost;
  }
  watchdog.Start(-1);
  system.Flush();  // the keyframes still queued for mapping
  watchdog.Stop();
  if (cl.Has("save-map")) {
    system.SaveMap(cl.Get("save-map", ""));
    std::cout << "wrote map " << cl.Get("save-map", "") << "\n";
  }
  const pl_slam::Trajectory traj = system.trajectory();
  const std::string traj_path = out_dir + "/trajectory.tum";
  pl_slam::WriteTrajectory(traj_path, traj, pl_slam::TrajectoryFormat::kTum);
  std::string keyframes_path;
  if (options.mapping.enabled) {
    // The keyframes as the map holds them at the end (after the last bundle adjustment and
    // loop correction), by time, like ORB-SLAM's KeyFrameTrajectory.txt.
    const pl_slam::MapSnapshot snap = system.map().Snapshot();
    pl_slam::Trajectory keyframes;
    for (const auto& kf : snap.keyframes) keyframes.push_back({kf.stamp_s, kf.T_w_c});
    std::sort(
        keyframes.begin(), keyframes.end(),
        [](const pl_slam::StampedPose& a, const pl_slam::StampedPose& b) { return a.t < b.t; });
    keyframes_path = out_dir + "/keyframes.tum";
    pl_slam::WriteTrajectory(keyframes_path, keyframes, pl_slam::TrajectoryFormat::kTum);
  }
  const std::vector<double> totals = timing.Finish();
  if (!source->ground_truth().empty()) {
    pl_slam::WriteTrajectory(out_dir + "/groundtruth.tum", source->ground_truth(),
                             pl_slam::TrajectoryFormat::kTum);
  }
  std::cout << std::fixed << std::setprecision(2) << "frames " << totals.size() << ", with pose "
            << traj.size() << ", without pose " << lost << "; tracking time median "
            << Percentile(totals, 0.5) << " ms, p95 " << Percentile(totals, 0.95) << " ms\n"
            << "wrote " << traj_path << ", " << out_dir << "/timing.csv, " << out_dir
            << "/frames.txt, " << out_dir << "/odometry.csv"
            << (keyframes_path.empty() ? "" : ", " + keyframes_path)
            << (source->ground_truth().empty() ? "" : ", " + out_dir + "/groundtruth.tum") << "\n";
  if (options.mapping.enabled) {
    const pl_slam::MappingStats ms = system.mapping_stats();
    const pl_slam::MapCounts mc = system.map().counts();
    std::cout << "map: " << mc.keyframes << " keyframes (" << ms.keyframes_processed
              << " inserted, " << ms.keyframes_culled << " culled, " << ms.keyframes_dropped
              << " dropped), " << mc.points << " points (" << mc.culled_points << " culled), "
              << mc.lines << " lines (" << mc.culled_lines << " culled); local BA median "
              << Percentile(ms.ba_ms, 0.5) << " ms, p95 " << Percentile(ms.ba_ms, 0.95)
              << " ms; keyframe mapping median " << Percentile(ms.keyframe_ms, 0.5) << " ms\n";
    const pl_slam::LoopStats ls = system.loop_stats();
    std::cout << "loops: " << ls.loops_detected << " detected, " << ls.loops_corrected
              << " corrected, " << ls.candidates_verified << " candidates verified, "
              << ls.relocalizations << " relocalisations, " << ls.database_keyframes
              << " keyframes in the database; query median " << Percentile(ls.query_ms, 0.5)
              << " ms, correction median " << Percentile(ls.correction_ms, 0.5) << " ms\n";
    if (ms.global_bas + ms.global_bas_discarded > 0)
      std::cout << "global BA: " << ms.global_bas << " merged, " << ms.global_bas_discarded
                << " discarded (" << ms.global_ba_followups << " follow-ups); solve median "
                << Percentile(ms.global_ba_ms, 0.5) << " ms, max "
                << Percentile(ms.global_ba_ms, 1.0) << " ms\n";
    for (const auto& l : ls.loops)
      std::cout << "  loop: keyframe " << l.query << " -> " << l.candidate << " (frames "
                << l.query_frame << " -> " << l.candidate_frame << ", " << l.inliers
                << " inliers)\n";
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  return pl_slam::RunTool("pl_slam_offline", [&] { return Run(argc, argv); });
}
