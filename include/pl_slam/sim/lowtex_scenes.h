// The low-texture scene family (scenes lowtex_*, see scenes.h): plain, faintly graded walls
// with the structural edges of real buildings (door frames, baseboards, handrails, pipes,
// light switches, shelves, room corners), walked at 1-1.4 m/s with the camera 1.5 m high.
//
// Every layout has a textured default (three or four small textured patches - posters,
// notice boards - on the walls, wall panel seams, a tiled floor, a ceiling grid with light
// panels) and a bare variant without any of those, where points alone cannot track. The
// structure (and its World::StructuralEdges) is the same in both variants. The world seed
// jitters the layout: corridor and room sizes, door positions, turn directions.
#pragma once

#include <cstdint>

#include "pl_slam/sim/scenes.h"

namespace pl_slam::sim {

/// True for the lowtex_* scene kinds.
bool IsLowtexScene(SceneKind kind);

/// Length (frames at rate_hz) of a lowtex scene's whole walk in the layout of world_seed.
int LowtexDefaultNumFrames(SceneKind kind, uint64_t world_seed, double rate_hz);

/// Builds a lowtex scene: num_frames poses (0 = the whole walk) stamped start_time_s +
/// i / rate_hz. Walking speed does not depend on num_frames: fewer frames cut the walk short,
/// more frames hold the last pose. Throws std::invalid_argument for a non-lowtex kind.
Scene BuildLowtexScene(SceneKind kind, int num_frames, double rate_hz, double start_time_s,
                       uint64_t world_seed, bool bare);

}  // namespace pl_slam::sim
