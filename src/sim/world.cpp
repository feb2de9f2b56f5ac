#include "pl_slam/sim/world.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

namespace pl_slam::sim {
namespace {

void CheckQuad(const TexturedQuad& q) {
  if (!q.texture) throw std::invalid_argument("TexturedQuad: texture is null");
  if (!(q.size_u > 0.0) || !(q.size_v > 0.0) || !std::isfinite(q.size_u) ||
      !std::isfinite(q.size_v)) {
    throw std::invalid_argument("TexturedQuad: sizes must be positive and finite");
  }
  if (std::abs(q.axis_u.norm() - 1.0) > 1e-9 || std::abs(q.axis_v.norm() - 1.0) > 1e-9 ||
      std::abs(q.axis_u.dot(q.axis_v)) > 1e-9 || !q.origin.allFinite()) {
    throw std::invalid_argument("TexturedQuad: axes must be orthonormal, origin finite");
  }
}

}  // namespace

Eigen::Vector3d TexturedQuad::PointAtTexel(double x, double y) const {
  return PointAt(x / texels_per_m_u(), y / texels_per_m_v());
}

TexturedQuad MakeQuad(const Eigen::Vector3d& corner, const Eigen::Vector3d& edge_u,
                      const Eigen::Vector3d& edge_v, std::shared_ptr<const Texture> texture) {
  TexturedQuad q;
  q.origin = corner;
  q.size_u = edge_u.norm();
  q.size_v = edge_v.norm();
  if (!(q.size_u > 0.0) || !(q.size_v > 0.0)) {
    throw std::invalid_argument("MakeQuad: edges must have positive length");
  }
  q.axis_u = edge_u / q.size_u;
  q.axis_v = edge_v / q.size_v;
  q.texture = std::move(texture);
  CheckQuad(q);
  return q;
}

int World::AddQuad(const TexturedQuad& quad) {
  CheckQuad(quad);
  quads_.push_back(quad);
  return static_cast<int>(quads_.size()) - 1;
}

void World::AddStructuralEdge(const Eigen::Vector3d& a_w, const Eigen::Vector3d& b_w) {
  if (!((a_w - b_w).norm() > 1e-9) || !a_w.allFinite() || !b_w.allFinite()) return;
  Segment3D e;
  e.a = a_w;
  e.b = b_w;
  edges_.push_back(e);
}

RayHit World::RayCast(const Eigen::Vector3d& origin_w, const Eigen::Vector3d& dir_w,
                      double min_lambda) const {
  RayHit best;
  double best_lambda = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < quads_.size(); ++i) {
    const TexturedQuad& q = quads_[i];
    const Eigen::Vector3d n = q.normal();
    const double denom = n.dot(dir_w);
    const double lambda = n.dot(q.origin - origin_w) / denom;
    // Written so that NaN (ray inside the plane) and parallel rays fail the test.
    if (!(lambda > min_lambda) || !(lambda < best_lambda)) continue;
    const Eigen::Vector3d rel = origin_w + lambda * dir_w - q.origin;
    const double s = q.axis_u.dot(rel);
    const double t = q.axis_v.dot(rel);
    if (s < -kQuadEdgeEpsilon || s > q.size_u + kQuadEdgeEpsilon || t < -kQuadEdgeEpsilon ||
        t > q.size_v + kQuadEdgeEpsilon) {
      continue;
    }
    best_lambda = lambda;
    best.hit = true;
    best.quad = static_cast<int>(i);
    best.lambda = lambda;
    best.s = s;
    best.t = t;
    best.point_w = origin_w + lambda * dir_w;
  }
  return best;
}

float World::BaseRadiance(const RayHit& hit) const {
  if (!hit.hit) return background_;
  const TexturedQuad& q = quads_[hit.quad];
  return q.texture->SampleLevel(0, hit.s * q.texels_per_m_u(), hit.t * q.texels_per_m_v());
}

}  // namespace pl_slam::sim
