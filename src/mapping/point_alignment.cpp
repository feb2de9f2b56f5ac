#include "pl_slam/matching/patch_alignment.h"

#include <algorithm>

#include <Eigen/Dense>

#include "mapping_steps.h"

namespace pl_slam {
namespace mapping {

void AlignPointObservations(const Context& ctx, Keyframe* kf, const cv::Mat& image) {
  constexpr double kMaxOffset = 2.5;  // pixels
  Map& map = *ctx.map;
  struct Job {
    int index;
    LandmarkId landmark;
    std::vector<uint8_t> patch;
  };
  std::vector<Job> jobs;
  const size_t n = kf->features.points.size();
  {
    auto lock = map.Lock();
    if (!map.KeyframeLocked(kf->id)) return;
    kf->point_offsets.assign(n, Eigen::Vector2f::Zero());
    const SE3 T_c_w = kf->T_w_c.inverse();
    const PreviousImage* prev = ctx.previous_image;
    const auto prev_kf =
        prev && prev->id != kNoId ? map.KeyframeLocked(prev->id) : std::shared_ptr<Keyframe>();
    for (size_t j = 0; j < n; ++j) {
      const auto p = map.PointLocked(kf->point_landmarks[j]);
      if (!p) continue;
      if (p->patch.empty()) {
        if (p->reference == kf->id) {
          p->patch = TakePatch(image, kf->features.points[j].uv);
        } else if (prev_kf && p->reference == prev_kf->id) {
          const auto obs = p->observations.find(prev_kf->id);
          if (obs != p->observations.end())
            p->patch = TakePatch(prev->image, prev_kf->features.points[obs->second].uv);
        }
      }
      if (p->reference == kf->id || p->patch.empty()) continue;
      const auto ref = map.KeyframeLocked(p->reference);
      const auto ref_obs = p->observations.find(p->reference);
      if (!ref || ref_obs == p->observations.end()) continue;
      const double z_ref = (ref->T_w_c.inverse() * p->p_w).z();
      if (!(z_ref > 0.0) || (T_c_w * p->p_w).z() <= 0.0) continue;
      if (PatchWarp(ctx.camera, T_c_w * ref->T_w_c, ref->features.points[ref_obs->second].uv,
                    z_ref) > kMaxPatchWarp)
        continue;
      jobs.push_back({static_cast<int>(j), p->id, p->patch});
    }
  }
  std::vector<std::pair<int, Eigen::Vector2f>> results;
  for (const Job& job : jobs) {
    Eigen::Vector2d offset;
    if (AlignPatch(job.patch, image, kf->features.points[job.index].uv, kMaxOffset, &offset))
      results.emplace_back(job.index, offset.cast<float>());
  }
  {
    auto lock = map.Lock();
    if (map.KeyframeLocked(kf->id) && kf->point_offsets.size() == n) {
      size_t k = 0;
      for (const auto& [index, offset] : results) {
        while (k < jobs.size() && jobs[k].index != index) ++k;
        // Still the same landmark (not fused or removed since).
        if (k < jobs.size() && kf->point_landmarks[index] == jobs[k].landmark)
          kf->point_offsets[index] = offset;
      }
      map.TouchLocked();
    }
  }
  if (ctx.previous_image) {
    ctx.previous_image->id = kf->id;
    ctx.previous_image->image = image;
  }
}

}  // namespace mapping
}  // namespace pl_slam
