#include "processing/irm/indirect.h"

#include <algorithm>
#include <cmath>
#include <mutex>
#include <numbers>

#include "core/error.h"
#include "core/parallel.h"

namespace relume::irm {

IndirectGather IndirectGather::Build(const RayCaster& caster, int samples, const std::vector<std::uint8_t>* needed,
                                     int threads) {
  RELUME_CHECK(samples >= 1);
  const TriangleMesh& mesh = caster.mesh();
  const std::size_t n = mesh.vertex_count();
  RELUME_CHECK(needed == nullptr || needed->size() == n);
  RELUME_CHECK(mesh.normals.size() == n);
  // Rows are built per vertex in parallel, then gathered in order: the matrix does not depend
  // on the threads.
  std::vector<std::vector<Eigen::Triplet<float>>> rows(n);
  std::vector<std::int64_t> row_rays(n, 0), row_hits(n, 0);
  ParallelFor(
      0, static_cast<std::int64_t>(n),
      [&](std::int64_t begin, std::int64_t end) {
        std::vector<Eigen::Vector3f> directions;
        for (std::int64_t i = begin; i < end; ++i) {
          const auto k = static_cast<std::size_t>(i);
          if (needed != nullptr && (*needed)[k] == 0) continue;
          const Eigen::Vector3f normal = mesh.normals[k].normalized();
          if (!normal.allFinite()) continue;
          CosineWeightedDirections(normal, samples, &directions);
          const Eigen::Vector3f origin = mesh.positions[k] + normal * caster.surface_lift();
          const float weight = std::numbers::pi_v<float> / static_cast<float>(directions.size());
          std::vector<Eigen::Triplet<float>>& row = rows[k];
          for (const Eigen::Vector3f& d : directions) {
            const RayCaster::Hit hit =
                caster.Intersect(origin, d, caster.surface_skip(), std::numeric_limits<float>::infinity());
            if (!hit.valid) continue;
            const Eigen::Vector3i& tri = mesh.triangles[static_cast<std::size_t>(hit.triangle)];
            // The front of the surface faces back along the ray.
            if (caster.Interpolate(mesh.normals, hit).dot(d) >= 0.0f) continue;
            ++row_hits[k];
            const float w0 = 1.0f - hit.u - hit.v;
            row.emplace_back(static_cast<int>(k), tri[0], weight * w0);
            row.emplace_back(static_cast<int>(k), tri[1], weight * hit.u);
            row.emplace_back(static_cast<int>(k), tri[2], weight * hit.v);
          }
          row_rays[k] = static_cast<std::int64_t>(directions.size());
        }
      },
      threads, 64);
  IndirectGather gather;
  gather.referenced_.assign(n, 0);
  std::vector<Eigen::Triplet<float>> all;
  std::int64_t hits = 0;
  for (std::size_t k = 0; k < n; ++k) {
    gather.rays_ += row_rays[k];
    hits += row_hits[k];
    for (const Eigen::Triplet<float>& t : rows[k]) {
      all.push_back(t);
      gather.referenced_[static_cast<std::size_t>(t.col())] = 1;
    }
    std::vector<Eigen::Triplet<float>>().swap(rows[k]);
  }
  gather.weights_.resize(static_cast<Eigen::Index>(n), static_cast<Eigen::Index>(n));
  gather.weights_.setFromTriplets(all.begin(), all.end());
  gather.hit_share_ = gather.rays_ > 0 ? static_cast<double>(hits) / static_cast<double>(gather.rays_) : 0.0;
  return gather;
}

void IndirectAt(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal, int samples,
                std::span<const Eigen::Vector3f> radiance_a, std::span<const Eigen::Vector3f> radiance_b,
                Eigen::Vector3f* indirect_a, Eigen::Vector3f* indirect_b) {
  const TriangleMesh& mesh = caster.mesh();
  RELUME_CHECK(radiance_a.size() == mesh.vertex_count() && radiance_b.size() == mesh.vertex_count());
  const Eigen::Vector3f n = normal.normalized();
  thread_local std::vector<Eigen::Vector3f> directions;
  CosineWeightedDirections(n, samples, &directions);
  const Eigen::Vector3f origin = point + n * caster.surface_lift();
  Eigen::Vector3f sum_a = Eigen::Vector3f::Zero(), sum_b = Eigen::Vector3f::Zero();
  for (const Eigen::Vector3f& d : directions) {
    const RayCaster::Hit hit =
        caster.Intersect(origin, d, caster.surface_skip(), std::numeric_limits<float>::infinity());
    if (!hit.valid || caster.Interpolate(mesh.normals, hit).dot(d) >= 0.0f) continue;  // as Build
    const Eigen::Vector3i& tri = mesh.triangles[static_cast<std::size_t>(hit.triangle)];
    const float w0 = 1.0f - hit.u - hit.v;
    const auto v0 = static_cast<std::size_t>(tri[0]), v1 = static_cast<std::size_t>(tri[1]),
               v2 = static_cast<std::size_t>(tri[2]);
    sum_a += w0 * radiance_a[v0] + hit.u * radiance_a[v1] + hit.v * radiance_a[v2];
    sum_b += w0 * radiance_b[v0] + hit.u * radiance_b[v1] + hit.v * radiance_b[v2];
  }
  const float weight = std::numbers::pi_v<float> / static_cast<float>(directions.size());
  *indirect_a = weight * sum_a;
  *indirect_b = weight * sum_b;
}

std::vector<Eigen::Vector3f> IndirectGather::Apply(std::span<const Eigen::Vector3f> vertex_radiance) const {
  RELUME_CHECK(vertex_radiance.size() == referenced_.size());
  std::vector<Eigen::Vector3f> out(referenced_.size(), Eigen::Vector3f::Zero());
  for (Eigen::Index row = 0; row < weights_.outerSize(); ++row) {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    for (Eigen::SparseMatrix<float, Eigen::RowMajor>::InnerIterator it(weights_, row); it; ++it) {
      sum += it.value() * vertex_radiance[static_cast<std::size_t>(it.col())];
    }
    out[static_cast<std::size_t>(row)] = sum;
  }
  return out;
}

}  // namespace relume::irm
