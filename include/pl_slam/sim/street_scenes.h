// The street scene family (scenes street_*, see scenes.h): a car driving through city streets
// at 8-15 m/s, seen by a forward-looking stereo camera like KITTI's (1.65 m above the road,
// 0.54 m baseline, 1241x376 px, focal 718.856 px, 10 Hz).
//
// Streets are canyons of building fronts (windows, doors, shop fronts with signs, cornices:
// drawn into their textures, every outline also a World::StructuralEdge), with parked cars,
// lamp posts with traffic signs, trees, a paved pavement and an asphalt road with lane
// markings and zebra crossings. The sky is the world's plain background: rays that miss every
// surface see a uniform grey with no depth, so it cannot make features at a finite depth.
// Every street ends in a building across it, so the view ahead is closed at a finite depth.
// The world seed jitters the layout: building widths, heights and setbacks, which parking
// places are taken, the speed, and the bend angles and directions.
#pragma once

#include <cstdint>

#include "pl_slam/io/trajectory.h"
#include "pl_slam/sim/scenes.h"

namespace pl_slam::sim {

/// The street scenes' camera: KITTI-like image size, focal length, baseline and rate.
inline constexpr int kStreetImageWidth = 1241;
inline constexpr int kStreetImageHeight = 376;
inline constexpr double kStreetFocal = 718.856;
inline constexpr double kStreetBaseline = 0.54;
inline constexpr double kStreetRateHz = 10.0;
/// Height of the left camera above the road, metres.
inline constexpr double kStreetCameraHeight = 1.65;

/// True for the street_* scene kinds.
bool IsStreetScene(SceneKind kind);

/// Length (frames at rate_hz) of a street scene's whole drive in the layout of world_seed.
int StreetDefaultNumFrames(SceneKind kind, uint64_t world_seed, double rate_hz);

/// The left-camera trajectory of a street scene (num_frames poses, 0 = the whole drive,
/// stamped start_time_s + i / rate_hz) without building its world. Frames past the end of
/// the drive hold the last pose. Throws std::invalid_argument for a non-street kind.
Trajectory StreetGroundTruth(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                             uint64_t world_seed);

/// Builds a street scene: its world and StreetGroundTruth(kind, ...).
Scene BuildStreetScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                       uint64_t world_seed);

}  // namespace pl_slam::sim
