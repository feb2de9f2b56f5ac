// The synthetic world: a set of textured planar rectangles ("quads") in a world frame.
//
// World frame used by the built-in scenes: right-handed, z up, floor at z = 0 (x and y span
// the floor). Custom worlds (tests) may use any frame; only consistency with the camera
// poses matters.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <Eigen/StdVector>
#include <memory>
#include <vector>

#include "pl_slam/sim/texture.h"

namespace pl_slam::sim {

/// A textured rectangle: the points origin + s * axis_u + t * axis_v for s in [0, size_u],
/// t in [0, size_v]. The texture spans the whole rectangle: base texel column 0 lies at
/// s = 0, row 0 at t = 0, and the texture's far corner at (size_u, size_v). Quads are
/// two-sided (visible from both sides).
struct TexturedQuad {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();   ///< corner at (s, t) = (0, 0), world
  Eigen::Vector3d axis_u = Eigen::Vector3d::UnitX();  ///< unit vector along s (texture columns)
  Eigen::Vector3d axis_v =
      Eigen::Vector3d::UnitY();            ///< unit vector along t (rows), orthogonal to axis_u
  double size_u = 1.0;                     ///< extent along axis_u, metres
  double size_v = 1.0;                     ///< extent along axis_v, metres
  std::shared_ptr<const Texture> texture;  ///< never null in a World

  /// Unit normal axis_u x axis_v.
  Eigen::Vector3d normal() const { return axis_u.cross(axis_v); }
  /// World point at plane coordinates (s, t) in metres.
  Eigen::Vector3d PointAt(double s, double t) const { return origin + s * axis_u + t * axis_v; }
  /// World point at continuous base-texel coordinates (x, y) of the texture (see Texture).
  Eigen::Vector3d PointAtTexel(double x, double y) const;
  /// Texels per metre along axis_u and axis_v.
  double texels_per_m_u() const { return texture->width() / size_u; }
  double texels_per_m_v() const { return texture->height() / size_v; }
};

/// Builds a quad from a corner and two edge vectors (their lengths are the quad's size).
/// Throws std::invalid_argument when the edges are degenerate or not orthogonal, or the
/// texture is null.
TexturedQuad MakeQuad(const Eigen::Vector3d& corner, const Eigen::Vector3d& edge_u,
                      const Eigen::Vector3d& edge_v, std::shared_ptr<const Texture> texture);

/// The nearest intersection of a ray with the world.
struct RayHit {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  bool hit = false;     ///< false when the ray escapes
  int quad = -1;        ///< index into World::quads()
  double lambda = 0.0;  ///< ray parameter: point = origin + lambda * dir
  double s = 0.0;       ///< plane coordinate along axis_u, metres
  double t = 0.0;       ///< plane coordinate along axis_v, metres
  Eigen::Vector3d point_w = Eigen::Vector3d::Zero();  ///< hit point, world frame
};

/// A straight 3D edge of the world's structure (a room corner, the top of a baseboard, a door
/// frame's outline, a rail's or pipe's edge): ground truth for line detectors. Endpoints are
/// in the world frame.
struct Segment3D {
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  ///< first endpoint, world
  Eigen::Vector3d b = Eigen::Vector3d::Zero();  ///< second endpoint, world
};

/// A static scene of textured quads. Built once, then shared read-only by renderers.
class World {
 public:
  /// Appends a quad (validated as in MakeQuad) and returns its index.
  int AddQuad(const TexturedQuad& quad);

  /// All quads, in insertion order (the order only breaks exact depth ties).
  const std::vector<TexturedQuad, Eigen::aligned_allocator<TexturedQuad>>& quads() const {
    return quads_;
  }

  /// Records a structural edge (see Segment3D). Scenes that record them list every straight
  /// intensity edge of their structure that a line detector should find; texture detail
  /// (posters, tiles, ceiling grid) is not listed. Zero-length edges are ignored.
  void AddStructuralEdge(const Eigen::Vector3d& a_w, const Eigen::Vector3d& b_w);
  /// The recorded structural edges (empty for worlds that record none: room, corridor).
  const std::vector<Segment3D, Eigen::aligned_allocator<Segment3D>>& StructuralEdges() const {
    return edges_;
  }

  /// Grey level seen where a ray hits nothing.
  float background() const { return background_; }
  /// Sets the background grey level.
  void set_background(float value) { background_ = value; }

  /// Nearest intersection of origin + lambda * dir with lambda > min_lambda. With dir the
  /// camera-frame direction (x, y, 1) rotated into the world, lambda is the depth Z.
  RayHit RayCast(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& dir_w,
                 double min_lambda = 1e-9) const;

  /// Texture value (base level, bilinear) at the hit, or background when there is none.
  float BaseRadiance(const RayHit& hit) const;

 private:
  std::vector<TexturedQuad, Eigen::aligned_allocator<TexturedQuad>> quads_;
  std::vector<Segment3D, Eigen::aligned_allocator<Segment3D>> edges_;
  float background_ = 0.0f;
};

/// Tolerance (metres) on the quad bounds in hit tests, so that a ray through the shared edge
/// of two adjoining quads hits one of them despite rounding.
inline constexpr double kQuadEdgeEpsilon = 1e-9;

}  // namespace pl_slam::sim
