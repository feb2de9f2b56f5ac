#include "pl_slam/sim/street_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "street_building.h"

namespace pl_slam::sim {
namespace {

using street::At;
using street::BuildingStyle;
using street::kDeg;
using street::kPi;
using street::Polygon;
using street::StreetBuilder;
using street::StreetPath;
using street::StreetSpec;
using street::Vec2;

constexpr double kDriveSeconds = 32.5;     // cruising time of a drive: 300+ frames at 10 Hz
constexpr double kBehind = 60.0;           // centre lines start this far behind the car
constexpr double kBeyond = 170.0;          // streets go on this far past the end of the drive
constexpr double kSharpTurn = 1.0 / 60.0;  // curvature the car slows down for

// Arc length along a drive at each time step: the cruising speed varying by +-4 % over
// 180 m, slowed to turn_speed on arcs sharper than kSharpTurn (blended over 35 m).
class DriveTiming : public ArcLengthTable {
 public:
  DriveTiming(const StreetPath& path, double s_start, double length, double cruise,
              double turn_speed, double phase)
      : ArcLengthTable(length, [&](double s) {
          const double base = cruise * (1.0 + 0.04 * std::sin(2 * kPi * s / 180.0 + phase));
          const double turn = Smoothstep(path.DistanceToCurve(s_start + s, kSharpTurn) / 35.0);
          return turn_speed + (base - turn_speed) * turn;
        }) {}
};

// A layout: its world (when built) and the car's drive along a lane.
struct Layout {
  std::shared_ptr<const World> world;
  StreetPath lane;
  double s_start = 0.0, length = 0.0;
  double cruise = 10.0, turn_speed = 10.0, phase = 0.0;
};

// The camera on the car: in its lane with a slow +-12 cm weave, yaw along the lane (plus the
// weave's heading), and the small bounce, pitch and roll of a car body on its springs.
std::function<SE3(double)> DrivePoses(const Layout& l) {
  auto timing =
      std::make_shared<DriveTiming>(l.lane, l.s_start, l.length, l.cruise, l.turn_speed, l.phase);
  const StreetPath lane = l.lane;
  const double s_start = l.s_start, phase = l.phase;
  auto pose = [timing, lane, s_start, phase](double t) {
    const double s = s_start + timing->ArcLength(t);
    const double speed = (timing->ArcLength(t + 0.05) - timing->ArcLength(t - 0.05)) / 0.1;
    const double w = 2 * kPi / 9.0;
    const double weave = 0.12 * std::sin(w * t + phase);
    const double weave_rate = 0.12 * w * std::cos(w * t + phase);
    const Vec2 p = lane.Position(s) + weave * lane.Left(s);
    const double yaw = lane.Heading(s) + std::atan2(weave_rate, std::max(speed, 1.0));
    const double z = kStreetCameraHeight + 0.008 * std::sin(2 * kPi * 1.6 * t + phase) +
                     0.004 * std::sin(2 * kPi * 3.3 * t);
    const double pitch =
        0.004 * std::sin(2 * kPi * 0.9 * t + 0.3) + 0.002 * std::sin(2 * kPi * 2.3 * t);
    const double roll = 0.003 * std::sin(2 * kPi * 0.7 * t + 1.1);
    return CameraPoseFromYawPitchRoll(At(p, z), yaw, pitch, roll);
  };
  return pose;
}

// What one street carries: buildings on both sides over [s0, s1] except the ranges in `gaps`
// (cross streets), parked cars, posts and trees.
struct Furnishing {
  double occupancy = 0.65;  // parked cars
  double post_spacing = 32.0;
  double tree_spacing = 15.0;
  double tree_probability = 0.15;
};

void Furnish(StreetBuilder* b, const StreetSpec& st, double s0, double s1,
             const std::vector<std::pair<double, double>>& gaps, const BuildingStyle& style,
             const Furnishing& f) {
  std::vector<std::pair<double, double>> spans;
  double s = s0;
  for (const auto& [lo, hi] : gaps) {
    if (lo > s) spans.emplace_back(s, lo);
    s = std::max(s, hi);
  }
  if (s < s1) spans.emplace_back(s, s1);
  for (int side : {-1, 1}) {
    for (const auto& [lo, hi] : spans) b->BuildingRow(st, side, lo, hi, style);
    for (const auto& [lo, hi] : spans) {
      b->ParkedCars(st, side, lo + 3.0, hi - 8.0, f.occupancy);
      b->Posts(st, side, lo + 2.0, hi - 4.0, f.post_spacing);
      b->Trees(st, side, lo + 4.0, hi - 4.0, f.tree_spacing, f.tree_probability);
    }
  }
}

// A single street (straight, bent or S-shaped) driven along its right lane from kBehind.
Layout SingleStreet(StreetBuilder* b, StreetSpec st, const BuildingStyle& style,
                    const Furnishing& f, double lane_offset, double cruise, double length,
                    cv::RNG& rng, bool build_world) {
  Layout l;
  l.cruise = l.turn_speed = cruise;
  l.phase = rng.uniform(0.0, 2 * kPi);
  l.lane = st.centre.Offset(-lane_offset);
  l.s_start = kBehind;
  l.length = length;
  double lane_end = 0.0, centre_end = 0.0;
  st.centre.Project(l.lane.Position(kBehind + length), &centre_end, &lane_end);
  st.s_begin = 0.0;
  st.s_end = centre_end + kBeyond;
  st.crossings = {kBehind + rng.uniform(0.35, 0.65) * (centre_end - kBehind)};
  if (build_world) {
    b->Ground({&st});
    Furnish(b, st, kBehind - 25.0, st.s_end, {}, style, f);
    b->EndBuilding(st, st.s_end, 4.0, style);
    l.world = b->Take();
  }
  return l;
}

Layout StraightLayout(StreetBuilder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double cruise = rng.uniform(10.0, 13.0), length = cruise * kDriveSeconds;
  StreetSpec st;
  st.sidewalk = rng.uniform(3.0, 4.0);
  st.centre = StreetPath({{-kBehind, 0.0}, {length + kBeyond + 60.0, 0.0}}, {});
  return SingleStreet(b, st, BuildingStyle(), Furnishing(), st.lane_width / 2, cruise, length, rng,
                      build_world);
}

// A long bend: 60-90 m straight, then 60-90 degrees (left or right) of radius 120-180 m,
// then straight.
Layout CurveLayout(StreetBuilder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double cruise = rng.uniform(10.0, 12.5), length = cruise * kDriveSeconds;
  const double angle = rng.uniform(60.0, 90.0) * kDeg, radius = rng.uniform(120.0, 180.0);
  const double dir = rng.uniform(0, 2) ? 1.0 : -1.0, lead = rng.uniform(60.0, 90.0);
  const double t = radius * std::tan(angle / 2);
  const Vec2 corner(lead + t, 0.0);
  const double after = std::max(0.0, length - lead - radius * angle) + t + kBeyond + 60.0;
  StreetSpec st;
  st.sidewalk = rng.uniform(3.0, 4.0);
  st.centre = StreetPath(
      {{-kBehind, 0.0}, corner, corner + after * Vec2(std::cos(angle), dir * std::sin(angle))},
      {radius});
  return SingleStreet(b, st, BuildingStyle(), Furnishing(), st.lane_width / 2, cruise, length, rng,
                      build_world);
}

// Two opposite bends of 35-50 degrees (radius 90-130 m) 30-60 m apart.
Layout SBendLayout(StreetBuilder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double cruise = rng.uniform(9.0, 12.0), length = cruise * kDriveSeconds;
  const double a1 = rng.uniform(35.0, 50.0) * kDeg, a2 = a1 + rng.uniform(-5.0, 5.0) * kDeg;
  const double r1 = rng.uniform(90.0, 130.0), r2 = rng.uniform(90.0, 130.0);
  const double dir = rng.uniform(0, 2) ? 1.0 : -1.0;
  const double lead = rng.uniform(50.0, 70.0), mid = rng.uniform(30.0, 60.0);
  const double t1 = r1 * std::tan(a1 / 2), t2 = r2 * std::tan(a2 / 2);
  const Vec2 c1(lead + t1, 0.0);
  const Vec2 c2 = c1 + (t1 + mid + t2) * Vec2(std::cos(a1), dir * std::sin(a1));
  const double rest = std::max(0.0, length - lead - r1 * a1 - mid - r2 * a2) + t2 + kBeyond + 60.0;
  const Vec2 end = c2 + rest * Vec2(std::cos(a1 - a2), dir * std::sin(a1 - a2));
  StreetSpec st;
  st.sidewalk = rng.uniform(3.0, 4.0);
  st.centre = StreetPath({{-kBehind, 0.0}, c1, c2, end}, {r1, r2});
  BuildingStyle style;
  style.width_lo = 8.0;
  style.width_hi = 18.0;
  Furnishing f;
  f.tree_probability = 0.3;
  return SingleStreet(b, st, style, f, st.lane_width / 2, cruise, length, rng, build_world);
}

// A wide avenue: two lanes each way, 5-6 m pavements with a row of trees, wide and tall
// buildings with larger, sparser windows; driven in the inner right lane.
Layout AvenueLayout(StreetBuilder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double cruise = rng.uniform(11.0, 14.0), length = cruise * kDriveSeconds;
  StreetSpec st;
  st.lanes = 2;
  st.lane_width = 3.3;
  st.parking = 2.3;
  st.sidewalk = rng.uniform(5.0, 6.0);
  st.centre = StreetPath({{-kBehind, 0.0}, {length + kBeyond + 60.0, 0.0}}, {});
  BuildingStyle style;
  style.width_lo = 18.0;
  style.width_hi = 40.0;
  style.height_lo = 15.0;
  style.height_hi = 25.0;
  style.window_spacing_lo = 3.6;
  style.window_spacing_hi = 4.6;
  style.window_width_lo = 1.4;
  style.window_width_hi = 2.0;
  style.shop_fraction = 0.8;
  Furnishing f;
  f.post_spacing = 36.0;
  f.tree_spacing = rng.uniform(11.0, 14.0);
  f.tree_probability = 0.95;
  f.occupancy = 0.5;
  return SingleStreet(b, st, style, f, st.lane_width / 2, cruise, length, rng, build_world);
}

// A 90-degree turn (left or right) at a four-way junction ~14 s into the drive, slowing to
// 5-7 m/s for it; the cross street continues 50 m the other way, the first street 80 m on.
Layout JunctionLayout(StreetBuilder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double cruise = rng.uniform(10.0, 12.5);
  const double dir = rng.uniform(0, 2) ? 1.0 : -1.0;  // left or right turn
  // Left turns sweep wide across the junction, right turns hug the corner.
  const double radius = dir > 0 ? rng.uniform(11.0, 14.0) : rng.uniform(7.5, 9.0);
  const double xj = cruise * 14.0, after = cruise * 19.0;
  StreetSpec a, c;
  a.sidewalk = rng.uniform(3.0, 4.0);
  c.sidewalk = rng.uniform(3.0, 4.0);
  const double half = a.lane_width / 2;
  a.centre = StreetPath({{-kBehind, 0.0}, {xj + 100.0, 0.0}}, {});
  a.s_begin = 0.0;
  a.s_end = kBehind + xj + 80.0;
  const double jx = kBehind + xj;  // the junction's centre on a
  a.plain = {{jx - c.road_half(), jx + c.road_half()}};
  a.crossings = {jx - c.road_half() - 4.5};
  c.centre = StreetPath({{xj, -dir * kBehind}, {xj, dir * (after + kBeyond + 60.0)}}, {});
  c.s_begin = 0.0;
  c.s_end = kBehind + after + kBeyond;
  const double jc = kBehind;  // the junction's centre on c
  c.plain = {{jc - a.road_half(), jc + a.road_half()}};
  c.crossings = {jc + a.road_half() + 4.5};

  Layout l;
  l.cruise = cruise;
  l.turn_speed = std::min(7.0, std::sqrt(3.5 * radius));  // at most 3.5 m/s^2 sideways
  l.phase = rng.uniform(0.0, 2 * kPi);
  const Vec2 turn(xj + dir * half, -half);
  l.lane =
      StreetPath({{-kBehind, -half}, turn, turn + Vec2(0.0, dir * (after + kBeyond))}, {radius});
  l.s_start = kBehind;
  l.length = l.lane.length() - kBehind - kBeyond;
  if (build_world) {
    b->Ground({&a, &c});
    const BuildingStyle style;
    const Furnishing f;
    Furnish(b, a, kBehind - 25.0, a.s_end, {{jx - c.building_line(), jx + c.building_line()}},
            style, f);
    Furnish(b, c, c.s_begin, c.s_end, {{jc - a.building_line(), jc + a.building_line()}}, style, f);
    b->EndBuilding(a, a.s_end, 4.0, style);
    b->EndBuilding(c, c.s_end, 4.0, style);
    b->EndBuilding(c, c.s_begin, 4.0, style);
    l.world = b->Take();
  }
  return l;
}

Layout MakeLayout(SceneKind kind, uint64_t world_seed, bool build_world) {
  StreetBuilder b(world_seed);
  switch (kind) {
    case SceneKind::kStreetStraight:
      return StraightLayout(&b, build_world);
    case SceneKind::kStreetCurve:
      return CurveLayout(&b, build_world);
    case SceneKind::kStreetJunction:
      return JunctionLayout(&b, build_world);
    case SceneKind::kStreetAvenue:
      return AvenueLayout(&b, build_world);
    case SceneKind::kStreetSBend:
      return SBendLayout(&b, build_world);
    default:
      throw std::invalid_argument("street scenes: " + SceneKindName(kind) +
                                  " is not a street scene");
  }
}

Trajectory Sample(const Layout& l, int num_frames, double rate_hz, double start_time_s) {
  const auto pose = DrivePoses(l);
  const DriveTiming timing(l.lane, l.s_start, l.length, l.cruise, l.turn_speed, l.phase);
  const double duration = timing.duration();
  const int n = num_frames > 0 ? num_frames : static_cast<int>(std::floor(duration * rate_hz)) + 1;
  Trajectory traj;
  traj.reserve(n);
  for (int i = 0; i < n; ++i) {
    StampedPose sp;
    const double t = i / rate_hz;
    sp.t = start_time_s + t;
    sp.T_w_c = pose(std::min(t, duration));
    traj.push_back(sp);
  }
  return traj;
}

}  // namespace

bool IsStreetScene(SceneKind kind) {
  switch (kind) {
    case SceneKind::kStreetStraight:
    case SceneKind::kStreetCurve:
    case SceneKind::kStreetJunction:
    case SceneKind::kStreetAvenue:
    case SceneKind::kStreetSBend:
      return true;
    default:
      return false;
  }
}

int StreetDefaultNumFrames(SceneKind kind, uint64_t world_seed, double rate_hz) {
  const Layout l = MakeLayout(kind, world_seed, false);
  const DriveTiming timing(l.lane, l.s_start, l.length, l.cruise, l.turn_speed, l.phase);
  return static_cast<int>(std::floor(timing.duration() * rate_hz)) + 1;
}

Trajectory StreetGroundTruth(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                             uint64_t world_seed) {
  return Sample(MakeLayout(kind, world_seed, false), num_frames, rate_hz, start_time_s);
}

Scene BuildStreetScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                       uint64_t world_seed) {
  const Layout l = MakeLayout(kind, world_seed, true);
  Scene scene;
  scene.world = l.world;
  scene.ground_truth = Sample(l, num_frames, rate_hz, start_time_s);
  return scene;
}

}  // namespace pl_slam::sim
