// The built-in synthetic scenes: worlds of textured quads plus the left-camera trajectory
// walked through them.
//
// World frame: right-handed, z up, floor at z = 0. Camera poses are T_w_c of the LEFT camera
// in its optical frame (z forward, x right, y down). Camera attitude is generated as yaw
// (about world z, 0 = looking along +x), pitch (> 0 looks down) and roll (about the viewing
// direction), see CameraPoseFromYawPitchRoll.
//
//   room      8 x 6 x 3 m room: clutter-textured walls, tiled floor, ceiling with light
//             panels, a central pillar and six boxes (one stacked on another), 40 quads. The
//             camera walks an ellipse (semi-axes 2.4 x 1.5 m, 1.4 m high) once round plus 2 %
//             more, looking roughly along the path with a gentle look-around, so the last
//             frames revisit the first view from ~0.3 m further on (loop closure). Speed 0.4-0.65
//             m/s with the default 480 frames at 20 Hz; the loop is stretched to fit num_frames.
//   corridor  2 m wide, 2.6 m high corridor with near-uniform walls carrying doors with
//             frames, skirting boards, panel joints, a floor runner and ceiling light strips:
//             straight edges plentiful, corners scarce. The camera walks along +x at 0.8 m/s
//             with gentle sway (default 300 frames = 12 m; walks longer than 40 m are slowed
//             down to 40 m to bound texture memory); the corridor is sized to the walk.
//   fast_turn the room; the camera drifts slowly (0.16 m/s) on a 0.35 m circle while yawing
//             left up to 85 deg/s and back (period 10 s; default 200 frames).
//
// The low-texture family (lowtex_scenes.h): 2.6 m high, plain walls with a faint smooth
// gradient and the structural edges of real buildings, camera 1.5 m high, walking 1-1.4 m/s;
// each has a textured default and a bare variant (SequenceOptions::bare). The world seed
// jitters sizes, door positions and turn directions; the default length is the whole walk
// (seed-dependent, 200-280 frames at 20 Hz). Their sequences default to 0.6 px blur and 8 %
// vignetting (SequenceOptions::blur_sigma, vignetting).
//   lowtex_corner    Z-shaped 2 m wide corridor (legs 5-6.5, 3.5-5, 4.5-6 m, middle leg left
//                    or right), walked at 1.25 m/s slowing to 0.85 m/s in the two 90-degree
//                    turns (radius 1 m, ~1.8 s each), gaze leading the walk by 0.5 s.
//   lowtex_straight  straight 2 m wide corridor, 11-13 m walked at 1.3 m/s, gaze swaying
//                    +-7 degrees.
//   lowtex_spin      four-way junction with a 3.2 x 3.2 m hub: walks in, turns 270 degrees on
//                    the spot (up to ~80 deg/s, left or right) and walks out a branch.
//   lowtex_doorway   corridor, a 90-degree turn through a 1.1 m doorway in a 12 cm wall into
//                    a plain 4.5-5.5 x 4.2-5 m room, across it and a turn to its wider side.
//   lowtex_wall      plain room: walks up to a bare wall until it fills the view at 0.6-0.8 m
//                    (a light switch in view; textured: a poster partly in view), turns away
//                    150 degrees and walks off.
//   lowtex_office    plain room with three shelf units seen head-on (approached, then passed
//                    sideways at 1.8 m; textured: books), a desk, a whiteboard the walk turns
//                    to at the end.
//
// The street family (street_scenes.h): a car driving city streets at 8-15 m/s with a
// KITTI-like camera (1.65 m high, 0.54 m baseline, 1241x376 px, focal 718.856 px, 10 Hz; the
// sequences' defaults, see DefaultSequenceOptions): building fronts with windows, doors and
// shop fronts, parked cars, lamp posts, trees, lane markings, a plain sky. The world seed
// jitters building widths, heights and setbacks, parked cars, the speed and the bends. The
// default length is the whole drive (seed-dependent, 324-370 frames at 10 Hz), and the
// sequences default to the lowtex family's blur and vignetting.
//   street_straight  a straight street, one lane each way with parking strips, 10-13 m/s.
//   street_curve     60-90 m straight, then a long bend of 60-90 degrees (left or right,
//                    radius 120-180 m), then straight; 10-12.5 m/s.
//   street_junction  a 90-degree turn (left, radius 11-14 m, or right, 7.5-9 m) at a four-way
//                    junction ~14 s in, slowing from 10-12.5 m/s to 5-7 m/s for it.
//   street_avenue    a wide straight avenue: two lanes each way, tree-lined pavements, wider
//                    and taller buildings with sparser, larger windows; 11-14 m/s.
//   street_s_bend    two opposite bends of 35-50 degrees (radius 90-130 m) 30-60 m apart,
//                    narrower buildings; 9-12 m/s.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "pl_slam/geometry/se3.h"
#include "pl_slam/io/trajectory.h"
#include "pl_slam/sim/procedural_texture.h"
#include "pl_slam/sim/world.h"

namespace pl_slam::sim {

/// The built-in scenes.
enum class SceneKind {
  kRoom,
  kCorridor,
  kFastTurn,
  kLowtexCorner,
  kLowtexStraight,
  kLowtexSpin,
  kLowtexDoorway,
  kLowtexWall,
  kLowtexOffice,
  kStreetStraight,
  kStreetCurve,
  kStreetJunction,
  kStreetAvenue,
  kStreetSBend,
};

/// Every scene kind, in declaration order.
const std::vector<SceneKind>& AllSceneKinds();

/// Parses a scene name (SceneKindName of any kind: "room", "corridor", "fast_turn",
/// "lowtex_corner", ...); throws pl_slam::ConfigError naming the value and the allowed names.
SceneKind ParseSceneKind(const std::string& name);

/// The name ParseSceneKind accepts for this kind.
std::string SceneKindName(SceneKind kind);

/// Default sequence length (frames) of a scene. Lowtex scenes: the whole walk at 20 Hz in the
/// layout of world seed 7 (other seeds and rates: LowtexDefaultNumFrames); street scenes: the
/// whole drive at 10 Hz in the layout of world seed 7 (StreetDefaultNumFrames).
int DefaultNumFrames(SceneKind kind);

/// A world and the trajectory of the left camera through it.
struct Scene {
  std::shared_ptr<const World> world;  ///< the static geometry and textures
  Trajectory ground_truth;             ///< T_w_c of the left camera, stamps in seconds
};

/// Builds scene `kind` with num_frames poses (0 = DefaultNumFrames) stamped start_time_s +
/// i / rate_hz. world_seed drives the procedural textures and layout jitter. Throws
/// ConfigError on num_frames < 0 or rate_hz <= 0. `loops` > 1 sends the room's camera round
/// its loop that many times (the default length scales with it; long-run and soak tests);
/// the other scenes ignore it. `bare` selects the lowtex scenes' bare variant (ignored by
/// the others).
Scene BuildScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                 uint64_t world_seed, int loops = 1, bool bare = false);

/// Left-camera pose at world position p_w with the given attitude: yaw about world z
/// (0 = optical axis along +x), pitch > 0 tilts the optical axis down, roll about it.
SE3 CameraPoseFromYawPitchRoll(const Eigen::Vector3d& p_w, double yaw, double pitch, double roll);

/// Adds an axis-aligned box [min, max] as five quads (no bottom face, it would sit on the
/// floor) or four (`with_top` false, e.g. a pillar reaching the ceiling), each face with its
/// own texture of the given style. Returns the number of quads added.
int AddBox(World* world, const Eigen::Vector3d& min_w, const Eigen::Vector3d& max_w, bool with_top,
           SurfaceStyle style, double base_grey, double texel_m, uint64_t seed);

}  // namespace pl_slam::sim
