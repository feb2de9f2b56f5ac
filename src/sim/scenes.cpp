#include "pl_slam/sim/scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <opencv2/core.hpp>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "pl_slam/sim/lowtex_scenes.h"
#include "pl_slam/sim/street_scenes.h"
#include "pl_slam/util/error.h"

namespace pl_slam::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Room dimensions (metres), centred on the world origin in x and y.
constexpr double kRoomLx = 8.0;
constexpr double kRoomLy = 6.0;
constexpr double kRoomH = 3.0;
// Texel size of the rich textures: a wall 1.5-4 m away is then sampled at or below texel
// rate, so its texture is sharp but not magnified into blur.
constexpr double kRoomTexel = 0.005;

// Corridor dimensions and walk.
constexpr double kCorridorWidth = 2.0;
constexpr double kCorridorHeight = 2.6;
constexpr double kCorridorBack = -1.0;     // x of the wall behind the start
constexpr double kCorridorSpeed = 0.8;     // m/s along +x
constexpr double kCorridorMaxWalk = 40.0;  // longer sequences walk slower (bounded textures)
constexpr double kCorridorBeyond = 8.0;    // corridor continues this far past the last pose
constexpr double kCorridorTexel = 0.005;

// Seeds of the individual surfaces are derived from the world seed and a per-surface tag so
// that adding a surface does not reshuffle the others.
uint64_t SurfaceSeed(uint64_t world_seed, uint64_t tag) { return MixSeed(world_seed, tag); }

void AddRect(World* world, const Eigen::Vector3d& corner, const Eigen::Vector3d& edge_u,
             const Eigen::Vector3d& edge_v, std::shared_ptr<const Texture> texture) {
  world->AddQuad(MakeQuad(corner, edge_u, edge_v, std::move(texture)));
}

std::shared_ptr<const World> BuildRoomWorld(uint64_t seed) {
  auto world = std::make_shared<World>();
  const double x0 = -kRoomLx / 2, x1 = kRoomLx / 2, y0 = -kRoomLy / 2, y1 = kRoomLy / 2;
  const double h = kRoomH;
  const Eigen::Vector3d down(0, 0, -h);
  AddRect(world.get(), {x0, y0, 0}, {kRoomLx, 0, 0}, {0, kRoomLy, 0},
          MakeSurfaceTexture(SurfaceStyle::kFloorTiles, kRoomLx, kRoomLy, 0.006, 120,
                             SurfaceSeed(seed, 1)));
  AddRect(world.get(), {x0, y0, h}, {kRoomLx, 0, 0}, {0, kRoomLy, 0},
          MakeSurfaceTexture(SurfaceStyle::kCeiling, kRoomLx, kRoomLy, 0.006, 195,
                             SurfaceSeed(seed, 2)));
  // Different base greys per wall make the room's corners visible edges.
  AddRect(world.get(), {x0, y0, h}, {kRoomLx, 0, 0}, down,
          MakeSurfaceTexture(SurfaceStyle::kClutter, kRoomLx, h, kRoomTexel, 150,
                             SurfaceSeed(seed, 3)));
  AddRect(world.get(), {x1, y1, h}, {-kRoomLx, 0, 0}, down,
          MakeSurfaceTexture(SurfaceStyle::kClutter, kRoomLx, h, kRoomTexel, 120,
                             SurfaceSeed(seed, 4)));
  AddRect(world.get(), {x0, y1, h}, {0, -kRoomLy, 0}, down,
          MakeSurfaceTexture(SurfaceStyle::kClutter, kRoomLy, h, kRoomTexel, 165,
                             SurfaceSeed(seed, 5)));
  AddRect(world.get(), {x1, y0, h}, {0, kRoomLy, 0}, down,
          MakeSurfaceTexture(SurfaceStyle::kClutter, kRoomLy, h, kRoomTexel, 105,
                             SurfaceSeed(seed, 6)));
  // Central pillar: inside the walking loop, gives parallax and occlusion boundaries.
  AddBox(world.get(), {-0.25, -0.25, 0}, {0.25, 0.25, h}, false, SurfaceStyle::kClutter, 140,
         kRoomTexel, SurfaceSeed(seed, 10));
  // Boxes and furniture along the walls, outside the loop (>= 0.6 m from the path).
  AddBox(world.get(), {2.95, 1.95, 0}, {3.85, 2.65, 1.0}, true, SurfaceStyle::kWood, 130,
         kRoomTexel, SurfaceSeed(seed, 20));
  AddBox(world.get(), {-3.8, -2.8, 0}, {-3.0, -2.0, 0.8}, true, SurfaceStyle::kWood, 150,
         kRoomTexel, SurfaceSeed(seed, 30));
  AddBox(world.get(), {-3.65, -2.65, 0.8}, {-3.15, -2.15, 1.2}, true, SurfaceStyle::kClutter, 110,
         kRoomTexel, SurfaceSeed(seed, 40));
  AddBox(world.get(), {-0.5, 2.3, 0}, {0.9, 2.8, 0.75}, true, SurfaceStyle::kWood, 100, kRoomTexel,
         SurfaceSeed(seed, 50));
  AddBox(world.get(), {-1.0, -2.85, 0}, {0.0, -2.45, 1.2}, true, SurfaceStyle::kClutter, 170,
         kRoomTexel, SurfaceSeed(seed, 60));
  AddBox(world.get(), {3.2, -1.6, 0}, {3.75, -0.4, 0.6}, true, SurfaceStyle::kWood, 90, kRoomTexel,
         SurfaceSeed(seed, 70));
  return world;
}

// A corridor wall: near-uniform paint with straight structure only. Coordinates on the
// canvas are metres along the corridor (x) and down from the ceiling (y).
std::shared_ptr<const Texture> CorridorWall(double length, double grey,
                                            const std::vector<double>& door_x, uint64_t seed) {
  cv::RNG rng(seed);
  const double h = kCorridorHeight;
  TextureCanvas c(length, h, kCorridorTexel, grey);
  c.FillRect(0, 0, length, 0.05, grey - 30);  // cornice under the ceiling
  // Panel joints, skipped near doors; they stop at the cornice and the skirting.
  for (double x = 0.6; x < length; x += 1.2) {
    bool near_door = false;
    for (double d : door_x) near_door = near_door || std::abs(x - d) < 0.7;
    if (!near_door) c.Line({x, 0.05}, {x, h - 0.12}, 0.005, grey - 45);
  }
  c.FillRect(0, h - 0.12, length, h, 70);           // skirting board
  c.FillRect(0, h - 0.125, length, h - 0.115, 45);  // its top edge
  for (double d : door_x) {
    const double half = 0.45, top = h - 2.05, frame = 0.07;
    c.FillRect(d - half - frame, top - frame, d + half + frame, h, 85);    // door frame
    c.FillRect(d - half, top, d + half, h, rng.uniform(105.0, 140.0));     // door leaf
    c.FillRect(d + half - 0.16, h - 1.03, d + half - 0.06, h - 0.99, 55);  // handle
  }
  return c.Finish(0.025, 2.0, 1.0, rng);
}

std::shared_ptr<const World> BuildCorridorWorld(double x_end, uint64_t seed) {
  auto world = std::make_shared<World>();
  const double length = x_end - kCorridorBack;
  const double w = kCorridorWidth, h = kCorridorHeight;
  const double y0 = -w / 2, y1 = w / 2;
  cv::RNG rng(SurfaceSeed(seed, 100));
  std::vector<double> left_doors, right_doors;  // canvas x (from the back wall)
  for (double x = 3.0; x < length - 1.0; x += 4.5) left_doors.push_back(x + rng.uniform(-0.5, 0.5));
  for (double x = 5.2; x < length - 1.0; x += 4.5)
    right_doors.push_back(x + rng.uniform(-0.5, 0.5));
  const Eigen::Vector3d down(0, 0, -h);
  // Left wall (y = +w/2) and right wall (y = -w/2), both parametrised along +x.
  AddRect(world.get(), {kCorridorBack, y1, h}, {length, 0, 0}, down,
          CorridorWall(length, 178, left_doors, SurfaceSeed(seed, 101)));
  AddRect(world.get(), {kCorridorBack, y0, h}, {length, 0, 0}, down,
          CorridorWall(length, 160, right_doors, SurfaceSeed(seed, 102)));
  {  // Floor: plain with a darker runner whose long edges are lines without corners.
    cv::RNG frng(SurfaceSeed(seed, 103));
    TextureCanvas c(length, w, 0.01, 100);
    c.FillRect(0, 0.55, length, 1.45, 78);
    AddRect(world.get(), {kCorridorBack, y0, 0}, {length, 0, 0}, {0, w, 0},
            c.Finish(0.03, 3.0, 1.0, frng));
  }
  {  // Ceiling with light strips along the corridor.
    cv::RNG crng(SurfaceSeed(seed, 104));
    TextureCanvas c(length, w, 0.01, 200);
    for (double x = 1.0; x + 1.2 < length; x += 3.0) {
      c.FillRect(x - 0.02, 0.88, x + 1.22, 1.12, 150);
      c.FillRect(x, 0.9, x + 1.2, 1.1, 252);
    }
    AddRect(world.get(), {kCorridorBack, y0, h}, {length, 0, 0}, {0, w, 0},
            c.Finish(0.02, 3.0, 1.0, crng));
  }
  // End walls, each with a door in the middle.
  AddRect(world.get(), {kCorridorBack, y0, h}, {0, w, 0}, down,
          CorridorWall(w, 170, {w / 2}, SurfaceSeed(seed, 105)));
  AddRect(world.get(), {x_end, y1, h}, {0, -w, 0}, down,
          CorridorWall(w, 170, {w / 2}, SurfaceSeed(seed, 106)));
  return world;
}

// Samples pose(t_rel) at the frame times.
Trajectory SampleTrajectory(int n, double rate_hz, double start_time_s,
                            const std::function<SE3(int, double)>& pose) {
  Trajectory traj;
  traj.reserve(n);
  for (int i = 0; i < n; ++i) {
    StampedPose sp;
    const double t_rel = i / rate_hz;
    sp.t = start_time_s + t_rel;
    sp.T_w_c = pose(i, t_rel);
    traj.push_back(sp);
  }
  return traj;
}

// The room loop at loop parameter theta (radians round the ellipse).
SE3 RoomLoopPose(double theta) {
  const double a = 2.4, b = 1.5;
  auto position = [&](double th) {
    const double r = 1.0 + 0.03 * std::sin(3 * th);
    return Eigen::Vector3d(a * std::cos(th) * r, b * std::sin(th) * r,
                           1.4 + 0.04 * std::sin(4 * th));
  };
  const Eigen::Vector3d p = position(theta);
  const Eigen::Vector3d tangent = position(theta + 1e-4) - position(theta - 1e-4);
  const double heading = std::atan2(tangent.y(), tangent.x());
  const double yaw = heading + 0.25 * std::sin(2 * theta + 0.4);
  const double pitch = 0.03 + 0.06 * std::sin(3 * theta + 1.0);
  const double roll = 0.025 * std::sin(5 * theta);
  return CameraPoseFromYawPitchRoll(p, yaw, pitch, roll);
}

}  // namespace

const std::vector<SceneKind>& AllSceneKinds() {
  static const std::vector<SceneKind> kinds = {
      SceneKind::kRoom,           SceneKind::kCorridor,       SceneKind::kFastTurn,
      SceneKind::kLowtexCorner,   SceneKind::kLowtexStraight, SceneKind::kLowtexSpin,
      SceneKind::kLowtexDoorway,  SceneKind::kLowtexWall,     SceneKind::kLowtexOffice,
      SceneKind::kStreetStraight, SceneKind::kStreetCurve,    SceneKind::kStreetJunction,
      SceneKind::kStreetAvenue,   SceneKind::kStreetSBend};
  return kinds;
}

SceneKind ParseSceneKind(const std::string& name) {
  std::string allowed;
  for (SceneKind kind : AllSceneKinds()) {
    if (name == SceneKindName(kind)) return kind;
    allowed += (allowed.empty() ? "" : ", ") + SceneKindName(kind);
  }
  throw ConfigError("scene='" + name + "' is not a scene; allowed: " + allowed);
}

std::string SceneKindName(SceneKind kind) {
  switch (kind) {
    case SceneKind::kRoom:
      return "room";
    case SceneKind::kCorridor:
      return "corridor";
    case SceneKind::kFastTurn:
      return "fast_turn";
    case SceneKind::kLowtexCorner:
      return "lowtex_corner";
    case SceneKind::kLowtexStraight:
      return "lowtex_straight";
    case SceneKind::kLowtexSpin:
      return "lowtex_spin";
    case SceneKind::kLowtexDoorway:
      return "lowtex_doorway";
    case SceneKind::kLowtexWall:
      return "lowtex_wall";
    case SceneKind::kLowtexOffice:
      return "lowtex_office";
    case SceneKind::kStreetStraight:
      return "street_straight";
    case SceneKind::kStreetCurve:
      return "street_curve";
    case SceneKind::kStreetJunction:
      return "street_junction";
    case SceneKind::kStreetAvenue:
      return "street_avenue";
    case SceneKind::kStreetSBend:
      return "street_s_bend";
  }
  return "unknown";
}

int DefaultNumFrames(SceneKind kind) {
  switch (kind) {
    case SceneKind::kRoom:
      return 480;
    case SceneKind::kCorridor:
      return 300;
    case SceneKind::kFastTurn:
      return 200;
    default:
      if (IsStreetScene(kind)) return StreetDefaultNumFrames(kind, 7, kStreetRateHz);
      return LowtexDefaultNumFrames(kind, 7, 20.0);
  }
}

SE3 CameraPoseFromYawPitchRoll(const Eigen::Vector3d& p_w, double yaw, double pitch, double roll) {
  // Body frame: x forward, y left, z up; the optical frame looks along body x with its x
  // to the body's right (-y) and its y down (-z).
  Eigen::Matrix3d R_b_c;
  // clang-format off
  R_b_c << 0, 0, 1,
          -1, 0, 0,
           0, -1, 0;
  // clang-format on
  const Eigen::Matrix3d R_w_b = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
  return SE3(R_w_b * R_b_c, p_w);
}

int AddBox(World* world, const Eigen::Vector3d& min_w, const Eigen::Vector3d& max_w, bool with_top,
           SurfaceStyle style, double base_grey, double texel_m, uint64_t seed) {
  const double dx = max_w.x() - min_w.x(), dy = max_w.y() - min_w.y(), dz = max_w.z() - min_w.z();
  const double x0 = min_w.x(), y0 = min_w.y(), x1 = max_w.x(), y1 = max_w.y(), z1 = max_w.z();
  const Eigen::Vector3d down(0, 0, -dz);
  int face = 0;
  auto texture = [&](double w, double h) {
    // Slightly different brightness per face, as under directional lighting.
    const double grey = base_grey + 12.0 * ((face % 3) - 1);
    return MakeSurfaceTexture(style, w, h, texel_m, grey, MixSeed(seed, face++));
  };
  AddRect(world, {x0, y0, z1}, {dx, 0, 0}, down, texture(dx, dz));
  AddRect(world, {x1, y1, z1}, {-dx, 0, 0}, down, texture(dx, dz));
  AddRect(world, {x0, y1, z1}, {0, -dy, 0}, down, texture(dy, dz));
  AddRect(world, {x1, y0, z1}, {0, dy, 0}, down, texture(dy, dz));
  if (with_top) AddRect(world, {x0, y0, z1}, {dx, 0, 0}, {0, dy, 0}, texture(dx, dy));
  return with_top ? 5 : 4;
}

Scene BuildScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                 uint64_t world_seed, int loops, bool bare) {
  if (num_frames < 0) {
    throw ConfigError("num_frames=" + std::to_string(num_frames) + " must be >= 0");
  }
  if (!(rate_hz > 0.0) || !std::isfinite(rate_hz)) {
    std::ostringstream os;
    os << "rate_hz=" << rate_hz << " must be a positive number";
    throw ConfigError(os.str());
  }
  if (IsLowtexScene(kind)) {
    return BuildLowtexScene(kind, num_frames, rate_hz, start_time_s, world_seed, bare);
  }
  if (IsStreetScene(kind)) {
    return BuildStreetScene(kind, num_frames, rate_hz, start_time_s, world_seed);
  }
  loops = std::max(1, loops);
  const int n =
      num_frames > 0 ? num_frames : DefaultNumFrames(kind) * (kind == SceneKind::kRoom ? loops : 1);
  Scene scene;
  switch (kind) {
    case SceneKind::kRoom: {
      scene.world = BuildRoomWorld(world_seed);
      // The loop is stretched over the whole sequence and overshoots the start by 2 %, so
      // the final frames look at what the first ones saw from ~0.3 m further on.
      scene.ground_truth = SampleTrajectory(n, rate_hz, start_time_s, [n, loops](int i, double) {
        const double frac = n > 1 ? static_cast<double>(i) / (n - 1) : 0.0;
        return RoomLoopPose(-kPi / 2 + 2 * kPi * (loops + 0.02) * frac);
      });
      break;
    }
    case SceneKind::kCorridor: {
      // Texture memory grows with the corridor's length, so very long sequences walk slower
      // instead of further.
      const double duration = (n - 1) / rate_hz;
      const double walk = std::min(kCorridorSpeed * duration, kCorridorMaxWalk);
      const double speed = duration > 0.0 ? walk / duration : 0.0;
      scene.world = BuildCorridorWorld(walk + kCorridorBeyond, world_seed);
      scene.ground_truth = SampleTrajectory(n, rate_hz, start_time_s, [speed](int, double t) {
        const Eigen::Vector3d p(speed * t, 0.15 * std::sin(2 * kPi * t / 7.0),
                                1.5 + 0.015 * std::sin(2 * kPi * 1.8 * t));
        const double yaw = 0.12 * std::sin(2 * kPi * t / 9.0 + 0.5);
        const double pitch = 0.02 + 0.02 * std::sin(2 * kPi * t / 5.0);
        const double roll = 0.01 * std::sin(2 * kPi * 0.9 * t);
        return CameraPoseFromYawPitchRoll(p, yaw, pitch, roll);
      });
      break;
    }
    case SceneKind::kFastTurn: {
      scene.world = BuildRoomWorld(world_seed);
      scene.ground_truth = SampleTrajectory(n, rate_hz, start_time_s, [](int, double t) {
        const double period = 10.0;
        // Yaw = A (1 - cos(2 pi t / P)) peaks at A * 2 pi / P = 85 deg/s.
        const double amplitude = 85.0 * kDeg * period / (2 * kPi);
        const Eigen::Vector3d p(-1.6 + 0.35 * std::cos(2 * kPi * t / 14.0),
                                0.4 + 0.35 * std::sin(2 * kPi * t / 14.0),
                                1.4 + 0.03 * std::sin(2 * kPi * t / 3.0));
        const double yaw = amplitude * (1.0 - std::cos(2 * kPi * t / period));
        const double pitch = 0.03 + 0.05 * std::sin(2 * kPi * t / 3.7);
        const double roll = 0.03 * std::sin(2 * kPi * t / 2.9);
        return CameraPoseFromYawPitchRoll(p, yaw, pitch, roll);
      });
      break;
    }
    default:
      break;
  }
  return scene;
}

}  // namespace pl_slam::sim
