#include "processing/radiosity/blocks.h"

#include <chrono>
#include <cmath>
#include <map>
#include <tuple>

#include "core/error.h"

namespace relume::radiosity {
namespace {

using Cell = std::tuple<int, int, int>;

Cell CellOf(const Eigen::Vector3d& p, const Eigen::Vector3d& origin, double size) {
  const Eigen::Vector3d c = (p - origin) / size;
  return {static_cast<int>(std::floor(c.x())), static_cast<int>(std::floor(c.y())),
          static_cast<int>(std::floor(c.z()))};
}

// Distance between a triangle's bounding box and a cell's box (0 when they overlap).
double DistanceToCell(const Triangle& t, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d tlo = t.v0.cwiseMin(t.v1).cwiseMin(t.v2);
  const Eigen::Vector3d thi = t.v0.cwiseMax(t.v1).cwiseMax(t.v2);
  const Eigen::Vector3d gap = (lo - thi).cwiseMax(tlo - hi).cwiseMax(0.0);
  return gap.norm();
}

}  // namespace

bool BlockOptions::IsValid(std::string* why) const {
  if (!(block_size_m > 0.0) || !(fine_edge_m > 0.0) || !(medium_edge_m >= fine_edge_m) ||
      !(coarse_edge_m >= medium_edge_m) || !std::isfinite(block_size_m + coarse_edge_m)) {
    if (why) *why = "need block_size_m > 0 and 0 < fine_edge_m <= medium_edge_m <= coarse_edge_m";
    return false;
  }
  return true;
}

BlockResult EstimateReflectanceInBlocks(const PatchHierarchy& full, const RayCaster& caster,
                                        const std::vector<RadianceObservation>& observations,
                                        const BlockOptions& options, const ReflectanceOptions& reflectance) {
  ThrowIfInvalid(options, "block options");
  const auto t0 = std::chrono::steady_clock::now();
  const int n = full.LeafCount();
  Eigen::Vector3d origin = Eigen::Vector3d::Constant(INFINITY);
  for (const Eigen::Vector3f& p : full.mesh().geometry.positions) origin = origin.cwiseMin(p.cast<double>());
  std::map<Cell, std::vector<int>> cells;
  for (int p = 0; p < n; ++p) cells[CellOf(full.leaf(p).centroid, origin, options.block_size_m)].push_back(p);

  BlockResult out;
  out.albedo.assign(n, Rgb::Constant(reflectance.prior_albedo));
  out.estimated.assign(n, false);
  long long total_patches = 0;
  for (const auto& [cell, patches] : cells) {
    const Eigen::Vector3d lo =
        origin + options.block_size_m * Eigen::Vector3d(std::get<0>(cell), std::get<1>(cell), std::get<2>(cell));
    const Eigen::Vector3d hi = lo + Eigen::Vector3d::Constant(options.block_size_m);
    HierarchyOptions ho;
    ho.max_patch_edge_m = options.fine_edge_m;
    ho.max_patch_edge_at = [&](const Triangle& t) {
      const double d = DistanceToCell(t, lo, hi);
      if (d <= 0.0) return options.fine_edge_m;
      return d <= options.block_size_m ? options.medium_edge_m : options.coarse_edge_m;
    };
    const PatchHierarchy block(full.mesh(), ho);
    std::vector<RadianceObservation> local = observations;
    for (size_t s = 0; s < observations.size(); ++s) {
      local[s].radiance = ResamplePatches(full, observations[s].radiance, block);
    }
    const ReflectanceResult r = EstimateReflectance(block, caster, local, reflectance);
    for (int p : patches) {
      const Node& leaf = full.leaf(p);
      const Node& node = block.nodes()[block.Find(leaf.root, leaf.level, leaf.path)];
      if (!node.IsLeaf()) continue;  // the block is refined at least as finely as `full`
      out.albedo[p] = r.albedo[node.leaf];
      out.estimated[p] = r.estimated[node.leaf];
    }
    ++out.blocks;
    out.max_block_patches = std::max(out.max_block_patches, block.LeafCount());
    total_patches += block.LeafCount();
    for (const auto& summary : r.last_solves) out.max_block_links = std::max(out.max_block_links, summary.links);
  }
  out.mean_block_patches = out.blocks > 0 ? static_cast<double>(total_patches) / out.blocks : 0.0;
  out.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace relume::radiosity
