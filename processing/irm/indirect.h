// Light reflected onto a surface by the rest of the scene (interreflection, issue 26), for the
// IRMs' sun + sky model (irm.h): the irradiance a vertex receives from the mesh around it,
// gathered from the radiance the photographs observe.
//
// A vertex x with unit normal n receives from the other surfaces
//   I(x) = integral over the hemisphere of L(y(w)) max(0, n . w) dw  ~  pi / N sum_k L(y_k)
// with N cosine-weighted directions w_k (the sky view's pattern, SkyViewMoments) and y_k the
// first surface each meets; directions that leave the mesh are the sky's (the model's sky term)
// or, below the horizon, the earth beyond the mesh, which counts as black. L(y) is the radiance
// leaving y toward x: for a Lambertian surface, the radiance its photograph shows, interpolated
// from the hit triangle's vertices. A ray that meets a triangle's back (the inside of a closed
// solid) brings nothing.
//
// IndirectGather holds the sum as a sparse operator on per-vertex radiance (each hit spreads
// pi / N over its triangle's three vertices by its barycentric weights), so the same rays serve
// both photographs and every refinement of the unobserved vertices' radiance.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "processing/geometry/ray_caster.h"

namespace relume::irm {

class IndirectGather {
 public:
  // Casts `samples` cosine-weighted rays from every vertex whose `needed` entry is non-zero
  // (every vertex with null). `samples` >= 1.
  static IndirectGather Build(const RayCaster& caster, int samples, const std::vector<std::uint8_t>* needed,
                              int threads);

  // I per vertex (zero for vertices not gathered) from per-vertex radiance L (the same units
  // out as in). A NaN radiance on a vertex some ray needs makes that vertex's I NaN: fill them
  // first (referenced()).
  std::vector<Eigen::Vector3f> Apply(std::span<const Eigen::Vector3f> vertex_radiance) const;
  // Vertices whose radiance some ray reads.
  const std::vector<std::uint8_t>& referenced() const { return referenced_; }
  // Share of the cast rays that met the front of a surface (the rest: sky, earth, backs).
  double hit_share() const { return hit_share_; }
  std::int64_t rays() const { return rays_; }
  std::size_t vertex_count() const { return referenced_.size(); }

 private:
  Eigen::SparseMatrix<float, Eigen::RowMajor> weights_;  // vertices x vertices
  std::vector<std::uint8_t> referenced_;
  double hit_share_ = 0.0;
  std::int64_t rays_ = 0;
};

// The same gather at one surface point (a pixel's): `samples` rays along the same directions,
// radiance interpolated from two per-vertex arrays (each photograph's) at the hits. For pixels
// where a vertex's value cannot be interpolated (the ground at a wall's foot, where the light
// from the wall changes within a triangle).
void IndirectAt(const RayCaster& caster, const Eigen::Vector3f& point, const Eigen::Vector3f& normal, int samples,
                std::span<const Eigen::Vector3f> radiance_a, std::span<const Eigen::Vector3f> radiance_b,
                Eigen::Vector3f* indirect_a, Eigen::Vector3f* indirect_b);

}  // namespace relume::irm
