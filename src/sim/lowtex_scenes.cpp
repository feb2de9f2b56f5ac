#include "pl_slam/sim/lowtex_scenes.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <utility>
#include <vector>

#include "lowtex_building.h"
#include "pl_slam/sim/procedural_texture.h"

namespace pl_slam::sim {
namespace {

using namespace lowtex;  // NOLINT: the builder and walk helpers of this file

// What a layout builder returns: the world and the camera motion (pose at time t) with its
// duration.
struct Layout {
  std::shared_ptr<const World> world;
  std::function<SE3(double)> pose;
  double duration = 0.0;
};

// Walks a Path2D with the gaze leading the walk, plus lateral and yaw sway.
Layout PathLayout(Builder* b, std::shared_ptr<const Path2D> path, double speed, double turn_speed,
                  double yaw_sway, double side_sway, bool build_world) {
  auto timing = std::make_shared<WalkTiming>(*path, speed, turn_speed);
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = timing->duration();
  l.pose = [path, timing, yaw_sway, side_sway](double t) {
    const double s = timing->ArcLength(t);
    const double h = path->Heading(s);
    const Vec2 side(-std::sin(h), std::cos(h));
    const Vec2 p = path->Position(s) + side_sway * std::sin(2 * kPi * t / 6.5) * side;
    const double yaw = path->Heading(timing->ArcLength(t + kGazeLead)) +
                       yaw_sway * std::sin(2 * kPi * t / 5.5 + 0.4);
    return WalkingPose(p, yaw, t);
  };
  return l;
}

// lowtex_corner: a Z-shaped corridor (two 90-degree corners, the middle leg to the left or
// right), walked along its centre with the gaze leading.
Layout CornerLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double a = rng.uniform(5.0, 6.5), mid = rng.uniform(3.5, 5.0), c = rng.uniform(4.5, 6.0);
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const Polygon centre = {{-1.2, 0.0}, {a, 0.0}, {a, side * mid}, {a + c, side * mid}};
  auto path = std::make_shared<Path2D>(
      Polygon{{0.0, 0.0}, {a, 0.0}, {a, side * mid}, {a + c - 1.6, side * mid}}, 1.0);
  if (build_world) {
    std::vector<int> right, left;
    const Polygon loop = CorridorLoop(centre, 1.0, &right, &left);
    std::vector<WallFeatures> f(loop.size());
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const double len = (loop[(i + 1) % loop.size()] - loop[i]).norm();
      if (len > 3.0) AutoDoors(len, rng, &f[i]);
    }
    for (int i : right) f[i].rail = true;
    for (int i : left) f[i].pipe = true;
    f[3].doors = {1.0};  // far end
    f[7].doors = {1.0};  // near end, behind the start
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.25, 0.85, 0.03, 0.05, build_world);
}

// lowtex_straight: a straight corridor, walked with the gaze swaying to the doors.
Layout StraightLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double walk = rng.uniform(11.0, 13.0);
  const Polygon centre = {{-1.2, 0.0}, {walk + 2.0, 0.0}};
  auto path = std::make_shared<Path2D>(Polygon{{0.0, 0.0}, {walk, 0.0}}, 1.0);
  if (build_world) {
    std::vector<int> right, left;
    const Polygon loop = CorridorLoop(centre, 1.0, &right, &left);
    std::vector<WallFeatures> f(loop.size());
    AutoDoors((loop[1] - loop[0]).norm(), rng, &f[0]);
    AutoDoors((loop[3] - loop[2]).norm(), rng, &f[2]);
    f[rng.uniform(0, 2) ? 0 : 2].rail = true;
    f[rng.uniform(0, 2) ? 0 : 2].pipe = true;
    f[1].doors = {1.0};
    f[3].doors = {1.0};
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.3, 1.3, 0.12, 0.12, build_world);
}

// lowtex_spin: walks into the 3.2 x 3.2 m hub of a four-way junction, turns 270 degrees on
// the spot (left or right) and walks out along the branch then ahead.
Layout SpinLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const double west = rng.uniform(4.2, 5.0), east = rng.uniform(3.5, 4.5);
  const double out_arm = rng.uniform(4.8, 5.5), other_arm = rng.uniform(3.5, 4.5);
  // Walking out toward -y after a left turn (+270 deg), +y after a right one.
  const double south = side > 0 ? out_arm : other_arm, north = side > 0 ? other_arm : out_arm;
  if (build_world) {
    const double w = 1.0, hub = 1.6;
    const Polygon loop = {{-west, -w}, {-hub, -w}, {-hub, -hub}, {-w, -hub}, {-w, -south},
                          {w, -south}, {w, -hub},  {hub, -hub},  {hub, -w},  {east, -w},
                          {east, w},   {hub, w},   {hub, hub},   {w, hub},   {w, north},
                          {-w, north}, {-w, hub},  {-hub, hub},  {-hub, w},  {-west, w}};
    std::vector<WallFeatures> f(loop.size());
    for (std::size_t i = 0; i < loop.size(); ++i) {
      const double len = (loop[(i + 1) % loop.size()] - loop[i]).norm();
      if (len > 3.0) AutoDoors(len, rng, &f[i]);
      if (len < 1.0) f[i].switches = {len / 2};  // hub walls
    }
    f[4].doors = {1.0};
    f[9].doors = {1.0};
    f[14].doors = {1.0};
    f[19].doors = {1.0};
    f[0].rail = f[8].rail = true;
    f[18].pipe = f[3].pipe = true;
    AutoPosters(loop, 4, rng, &f);
    b->Loop(loop, f, true);
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  const double s = side, deg = kDeg;
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, -3.2, 0.0, 0.0, true},
      {1.5, -2.1, 0.0, 0.0},
      {3.2, -0.35, 0.02, 0.0},
      {4.3, 0.0, 0.0, s * 15 * deg},
      {5.3, 0.05, 0.03, s * 62 * deg},
      {6.3, 0.06, -0.02, s * 138 * deg},
      {7.3, 0.0, -0.03, s * 212 * deg},
      {8.3, 0.0, 0.0, s * 255 * deg},
      {9.1, 0.0, -s * 0.3, s * 270 * deg},
      {10.5, 0.0, -s * 1.8, s * 270 * deg},
      {11.8, 0.0, -s * 3.0, s * 270 * deg, true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d m = motion->At(t);
    return WalkingPose(m.head<2>(), m.z(), t);
  };
  return l;
}

// lowtex_doorway: along a corridor, through a doorway (1.1 m opening in a 12 cm wall) into a
// plain room, across it and a turn to one side.
Layout DoorwayLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;  // door in the left or right wall
  const double dx = rng.uniform(4.0, 5.0), corridor_end = dx + rng.uniform(3.5, 5.0);
  const double room_w = rng.uniform(4.5, 5.5), room_d = rng.uniform(4.2, 5.0);
  const double rx0 = dx - room_w / 2 + rng.uniform(-0.5, 0.5), rx1 = rx0 + room_w;
  const double y1 = 1.0, y2 = 1.0 + kWallThickness, y3 = y2 + room_d;
  // In the room the walk turns to its wider side.
  const double end_x =
      rx1 - dx > dx - rx0 ? std::min(dx + 2.0, rx1 - 1.2) : std::max(dx - 2.0, rx0 + 1.2);
  auto mirror = [side](Vec2 p) { return Vec2(p.x(), side * p.y()); };
  const double yc = y2 + room_d / 2 + 0.2;
  auto path = std::make_shared<Path2D>(
      Polygon{mirror({0.0, 0.0}), mirror({dx, 0.0}), mirror({dx, yc}), mirror({end_x, yc})}, 0.9);
  if (build_world) {
    const double o0 = dx - kOpeningHalf, o1 = dx + kOpeningHalf;
    Polygon loop = {{-1.2, -1.0},       {corridor_end, -1.0},
                    {corridor_end, y1}, {o1, y1},
                    {o1, y2},           {rx1, y2},
                    {rx1, y3},          {rx0, y3},
                    {rx0, y2},          {o0, y2},
                    {o0, y1},           {-1.2, y1}};
    for (Vec2& p : loop) p = mirror(p);
    std::vector<WallFeatures> f(loop.size());
    AutoDoors((loop[1] - loop[0]).norm(), rng, &f[0]);
    f[0].rail = true;
    f[1].doors = {1.0};
    f[2].frame_end = f[4].frame_start = f[8].frame_end = f[10].frame_start = true;
    f[2].pipe = f[10].pipe = true;
    f[4].switches = {0.35};
    f[6].doors = {room_w * rng.uniform(0.25, 0.75)};
    f[11].doors = {1.0};
    AutoPosters(loop, 3, rng, &f);
    std::vector<double> top(loop.size(), kHeight);
    top[3] = top[4] = top[9] = top[10] = kOpeningHeight;  // jambs end under the lintel
    b->Loop(loop, f, side > 0, top);
    // Lintel over the opening: both faces (continuing the adjoining walls, with the
    // architrave along the bottom) and the soffit.
    const double lh = kHeight - kOpeningHeight;
    for (double y : {y1, y2}) {
      const Vec2 n_in = mirror({0.0, y == y1 ? -1.0 : 1.0});
      const double grey = Builder::WallGrey(n_in);
      TextureCanvas face(2 * kOpeningHalf, lh, kWallTexel, grey);
      face.FillRect(0.0, lh - kFrame, 2 * kOpeningHalf, lh, grey * 0.8);
      b->Quad(At(mirror({o0, y}), kHeight), Vec3(2 * kOpeningHalf, 0, 0), Vec3(0, 0, -lh),
              b->FinishPlain(face, kWallTexel, 0.05, b->Tag(), o0));
      b->Edge(At(mirror({o0 - kFrame, y}), kOpeningHeight + kFrame),
              At(mirror({o1 + kFrame, y}), kOpeningHeight + kFrame));
      b->Edge(At(mirror({o0, y}), kOpeningHeight), At(mirror({o1, y}), kOpeningHeight));
    }
    TextureCanvas soffit(2 * kOpeningHalf, kWallThickness, kWallTexel, 150);
    const Vec2 s0 = mirror({o0, y1}), s1 = mirror({o0, y2});
    b->Quad(At(s0, kOpeningHeight), Vec3(2 * kOpeningHalf, 0, 0), At(s1 - s0, 0.0),
            b->FinishPlain(soffit, kWallTexel, 0.0, b->Tag()));
    Vec2 lo, hi;
    BoundingBox(loop, &lo, &hi);
    b->FloorAndCeiling(lo, hi);
  }
  return PathLayout(b, path, 1.2, 0.8, 0.03, 0.03, build_world);
}

// lowtex_wall: in a plain room, walks up to a bare wall until it fills the view at 0.6-0.8 m,
// then turns away (left or right) and walks off.
Layout WallLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double rx = rng.uniform(6.0, 7.0), ry = rng.uniform(5.0, 6.0);
  const double X = rx / 2, Y = ry / 2;
  const double ty = rng.uniform(-0.5, 0.5), stop = rng.uniform(0.6, 0.8);
  const double side = rng.uniform(0, 2) ? 1.0 : -1.0;
  const double sw = rng.uniform(0, 2) ? 0.3 : -0.3;  // switch beside the target point
  if (build_world) {
    const Polygon loop = {{-X, -Y}, {X, -Y}, {X, Y}, {-X, Y}};
    std::vector<WallFeatures> f(4);
    f[0].doors = {rng.uniform(1.5, rx - 1.5)};
    f[2].doors = {rng.uniform(1.5, rx - 1.5)};
    f[2].switches = {f[2].doors[0] + 0.75};
    f[3].doors = {Y + rng.uniform(-1.0, 1.0)};
    f[1].switches_at = {{Y + ty + sw, 1.3}};
    f[rng.uniform(0, 2) ? 0 : 2].pipe = true;
    f[1].posters_at = {Y + ty - 1.6 * sw};  // partly in view at the closest point
    AutoPosters(loop, 2, rng, &f);
    b->Loop(loop, f, true);
    b->FloorAndCeiling({-X - 0.5, -Y - 0.5}, {X + 0.5, Y + 0.5});
  }
  const double s = side, deg = kDeg;
  const double xs = X - stop;
  const Vec2 away(std::cos(s * 150 * deg), std::sin(s * 150 * deg));
  const Vec2 p_turned(xs - 0.45, ty + s * 0.1);
  const Vec2 p_walk1 = p_turned + 0.8 * away, p_walk2 = p_turned + 2.0 * away;
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, X - 4.6, ty + 0.2, 0.0, true},
      {1.5, X - 3.5, ty + 0.1, 2 * deg},
      {3.0, X - 1.9, ty, 0.0},
      {4.3, X - 1.0, ty, 0.0},
      {5.3, xs, ty, 0.0, true},
      {6.0, xs - 0.02, ty, s * 3 * deg},
      {7.2, xs - 0.2, ty + s * 0.03, s * 60 * deg},
      {8.4, p_turned.x(), p_turned.y(), s * 135 * deg},
      {9.4, p_walk1.x(), p_walk1.y(), s * 150 * deg},
      {11.0, p_walk2.x(), p_walk2.y(), s * 150 * deg, true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d m = motion->At(t);
    return WalkingPose(m.head<2>(), m.z(), t, 0.0);
  };
  return l;
}

// lowtex_office: a plain room with three shelf units on one wall seen head-on (approached,
// then passed sideways), a desk, and a whiteboard the walk turns to at the end. Mirrored
// left/right by the seed.
Layout OfficeLayout(Builder* b, bool build_world) {
  cv::RNG rng(b->Tag());
  const double rx = rng.uniform(6.0, 7.0), ry = rng.uniform(5.0, 5.6);
  const double X = rx / 2, Y = ry / 2;
  const double m = rng.uniform(0, 2) ? 1.0 : -1.0;  // mirror x
  if (build_world) {
    const Polygon loop = {{-X, -Y}, {X, -Y}, {X, Y}, {-X, Y}};
    std::vector<WallFeatures> f(4);
    // East (or west when mirrored) wall: the whiteboard, centred 0.5 m south of the middle.
    const int board_wall = m > 0 ? 1 : 3;
    f[board_wall].whiteboard = m > 0 ? Y - 0.5 : Y + 0.5;
    f[0].doors = {X + m * rng.uniform(-2.2, -1.4)};
    f[0].switches = {f[0].doors[0] + 0.75};
    f[4 - board_wall].doors = {Y + rng.uniform(-0.8, 0.8)};
    f[0].pipe = true;
    AutoPosters(loop, 3, rng, &f);
    b->Loop(loop, f, true);
    // Shelves on the north wall (y = Y), walked along at ~1.8 m.
    const Vec2 u = Vec2(-1.0, 0.0), n = Vec2(0.0, -1.0);  // north wall seen from the room
    for (int k = 0; k < 3; ++k) {
      const double width = rng.uniform(0.8, 1.0);
      const double cx = m * (-1.6 + 1.35 * k) + rng.uniform(-0.1, 0.1);
      b->Shelf(Vec2(cx + width / 2, Y), u, n, width, 0.35, rng.uniform(1.8, 2.0), rng.uniform(4, 6),
               rng.uniform(120.0, 160.0));
    }
    const double dx0 = m > 0 ? 0.2 : -1.6;
    b->Box({dx0, -Y + 0.02, 0.0}, {dx0 + 1.4, -Y + 0.72, 0.75}, 135);
    b->FloorAndCeiling({-X - 0.5, -Y - 0.5}, {X + 0.5, Y + 0.5});
  }
  const double deg = kDeg;
  auto yaw = [m](double a) { return m > 0 ? a : kPi - a; };
  auto motion = std::make_shared<KeyedMotion>(std::vector<Key>{
      {0.0, m * -2.0, -1.5, yaw(90 * deg), true},
      {1.6, m * -1.8, -0.4, yaw(90 * deg)},
      {3.0, m * -1.4, 0.5, yaw(88 * deg)},
      {5.0, m * -0.2, 0.7, yaw(92 * deg)},
      {7.0, m * 1.0, 0.6, yaw(85 * deg)},
      {8.4, m * 1.7, 0.3, yaw(40 * deg)},
      {9.8, m * 2.0, -0.5, yaw(0.0)},
      {11.2, m * 2.1, -1.2, yaw(-20 * deg), true},
  });
  Layout l;
  if (build_world) l.world = b->Take();
  l.duration = motion->duration();
  l.pose = [motion](double t) {
    const Eigen::Vector3d v = motion->At(t);
    return WalkingPose(v.head<2>(), v.z(), t);
  };
  return l;
}

Layout MakeLayout(SceneKind kind, uint64_t world_seed, bool bare, bool build_world) {
  Builder b(world_seed, bare);
  switch (kind) {
    case SceneKind::kLowtexCorner:
      return CornerLayout(&b, build_world);
    case SceneKind::kLowtexStraight:
      return StraightLayout(&b, build_world);
    case SceneKind::kLowtexSpin:
      return SpinLayout(&b, build_world);
    case SceneKind::kLowtexDoorway:
      return DoorwayLayout(&b, build_world);
    case SceneKind::kLowtexWall:
      return WallLayout(&b, build_world);
    case SceneKind::kLowtexOffice:
      return OfficeLayout(&b, build_world);
    default:
      throw std::invalid_argument("BuildLowtexScene: " + SceneKindName(kind) +
                                  " is not a lowtex scene");
  }
}

}  // namespace

bool IsLowtexScene(SceneKind kind) {
  switch (kind) {
    case SceneKind::kLowtexCorner:
    case SceneKind::kLowtexStraight:
    case SceneKind::kLowtexSpin:
    case SceneKind::kLowtexDoorway:
    case SceneKind::kLowtexWall:
    case SceneKind::kLowtexOffice:
      return true;
    default:
      return false;
  }
}

int LowtexDefaultNumFrames(SceneKind kind, uint64_t world_seed, double rate_hz) {
  const Layout l = MakeLayout(kind, world_seed, true, false);
  return static_cast<int>(std::floor(l.duration * rate_hz)) + 1;
}

Scene BuildLowtexScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                       uint64_t world_seed, bool bare) {
  const Layout l = MakeLayout(kind, world_seed, bare, true);
  const int n =
      num_frames > 0 ? num_frames : static_cast<int>(std::floor(l.duration * rate_hz)) + 1;
  Scene scene;
  scene.world = l.world;
  scene.ground_truth.reserve(n);
  for (int i = 0; i < n; ++i) {
    StampedPose sp;
    const double t = i / rate_hz;
    sp.t = start_time_s + t;
    sp.T_w_c = l.pose(std::min(t, l.duration));
    scene.ground_truth.push_back(sp);
  }
  return scene;
}

}  // namespace pl_slam::sim
