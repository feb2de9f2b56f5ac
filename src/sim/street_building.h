// Internal to the street scenes (street_scenes.cpp): centre lines of straight pieces and arcs,
// the street description, and the world builder (ground, building rows, parked cars, posts,
// trees) with the structural edges it records.
#pragma once

#include <Eigen/Core>
#include <Eigen/StdVector>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <utility>
#include <vector>

#include "pl_slam/sim/procedural_texture.h"
#include "pl_slam/sim/world.h"
#include "motion_timing.h"

namespace pl_slam::sim::street {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Polygon = std::vector<Vec2, Eigen::aligned_allocator<Vec2>>;

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

inline Vec3 At(const Vec2& p, double z) { return Vec3(p.x(), p.y(), z); }

// A planar curve of straight pieces and circular arcs, parametrised by arc length s. Beyond
// its ends it continues straight (Position, Heading, Project).
class StreetPath {
 public:
  StreetPath() = default;
  // Waypoints joined by straight legs; interior waypoint i (1 .. n-2) is rounded by an arc of
  // radius radii[i - 1] tangent to both legs.
  StreetPath(const Polygon& waypoints, const std::vector<double>& radii);

  double length() const;
  Vec2 Position(double s) const;
  double Heading(double s) const;
  // Signed curvature at s (> 0 turning left).
  double Curvature(double s) const;
  // Unit vector to the left of the direction of travel at s.
  Vec2 Left(double s) const;
  // The same curve shifted `lateral` metres to the left (right when negative): lines move,
  // arcs change radius; arc length is that of the new curve.
  StreetPath Offset(double lateral) const;
  // Arc length of the point of the curve (or its straight continuations) nearest p, and the
  // signed distance of p to its left.
  void Project(const Vec2& p, double* s, double* lateral) const;
  // Distance along the curve from s to the nearest arc with |curvature| >= k_min (0 on one;
  // a large number when there is none).
  double DistanceToCurve(double s, double k_min) const;

 private:
  struct Piece {
    Vec2 p0;
    double h0 = 0.0, s0 = 0.0, len = 0.0, k = 0.0;  // start heading, arc length, length, curvature
  };
  void Add(const Vec2& p0, double h0, double len, double k);
  const Piece& Find(double s) const;
  static Vec2 PieceAt(const Piece& p, double r);
  std::vector<Piece> pieces_;
};

// One street: its centre line and cross-section. Lateral offsets are from the centre line,
// positive to its left.
struct StreetSpec {
  StreetPath centre;
  double s_begin = 0.0, s_end = 0.0;  // paved extent along the centre line
  int lanes = 1;                      // driving lanes each way
  double lane_width = 3.25;
  double parking = 2.2;   // parking strip each side, outside the lanes
  double sidewalk = 3.5;  // kerb to the nominal building line
  // Centre line arc length ranges without lane markings (the boxes of junctions).
  std::vector<std::pair<double, double>> plain;
  std::vector<double> crossings;  // zebra crossings centred here (stop line before the first)

  double road_half() const { return lanes * lane_width + parking; }
  double building_line() const { return road_half() + sidewalk; }
};

// How a row of buildings looks.
struct BuildingStyle {
  double width_lo = 9.0, width_hi = 24.0;     // front width
  double height_lo = 10.0, height_hi = 21.0;  // to the top of the parapet
  double setback_hi = 1.2;                    // extra distance behind the building line
  double window_spacing_lo = 2.3, window_spacing_hi = 3.3;
  double window_width_lo = 1.0, window_width_hi = 1.5;
  double shop_fraction = 0.6;  // buildings with shop fronts on the ground floor
};

// Builds one street world: quads, structural edges and layout randomness.
class StreetBuilder {
 public:
  explicit StreetBuilder(uint64_t seed);

  World* world() { return world_.get(); }
  std::shared_ptr<const World> Take() { return std::move(world_); }
  // A fresh, reproducible seed per surface (in creation order).
  uint64_t Tag() { return MixSeed(seed_, next_tag_++); }

  // Ground tiles (road, kerbs, pavement) covering every street's paved band; where streets
  // overlap (junctions) the road is plain asphalt.
  void Ground(const std::vector<const StreetSpec*>& streets);
  // Buildings along one side (+1 left, -1 right) of a street from s0 to s1 (centre line arc
  // length): fronts on the building line (plus a random setback), walls between fronts of
  // different setbacks or heights, and at both ends.
  void BuildingRow(const StreetSpec& st, int side, double s0, double s1,
                   const BuildingStyle& style);
  // A building across the street at s, facing back along it, as wide as the street between
  // the building lines plus `overhang` each side.
  void EndBuilding(const StreetSpec& st, double s, double overhang, const BuildingStyle& style);
  // Parked cars in the parking strip on one side between s0 and s1, a place taken with
  // probability `occupancy`.
  void ParkedCars(const StreetSpec& st, int side, double s0, double s1, double occupancy);
  // Lamp posts on the pavement every `spacing` metres (jittered), some with a traffic sign.
  void Posts(const StreetSpec& st, int side, double s0, double s1, double spacing);
  // Trees on the pavement every `spacing` metres (jittered), each present with `probability`.
  void Trees(const StreetSpec& st, int side, double s0, double s1, double spacing,
             double probability);

  cv::RNG& rng() { return rng_; }

 private:
  using Face = std::function<std::shared_ptr<const Texture>(int face, double w, double h)>;
  // A box centred on c (ground plan) with its length along `heading`, from z0 to z1. Faces:
  // 0 front (+length), 1 back, 2 left, 3 right, 4 top, 5 bottom; `faces` is a bit mask of the
  // ones to build. Records its 12 edges.
  void Box(const Vec2& c, double heading, double half_len, double half_wid, double z0, double z1,
           int faces, const Face& texture);
  void Car(const Vec2& c, double heading);
  void Quad(const Vec3& corner, const Vec3& edge_u, const Vec3& edge_v,
            std::shared_ptr<const Texture> texture);
  void Edge(const Vec3& a, const Vec3& b) { world_->AddStructuralEdge(a, b); }
  // A building front from a to b (ground plan; a is its left end as seen from the street),
  // `height` high, with its drawing and its edges.
  void Front(const Vec2& a, const Vec2& b, double height, const BuildingStyle& style);

  std::shared_ptr<World> world_;
  uint64_t seed_;
  uint64_t next_tag_ = 1000;
  cv::RNG rng_;
};

}  // namespace pl_slam::sim::street
