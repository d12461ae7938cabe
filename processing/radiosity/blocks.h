// Reflectance estimation for large scenes, one spatial block at a time (after the
// multiresolution scheme of Debevec et al., "Digitizing the Parthenon"): the block being
// solved gets full-resolution patches, its neighbours medium ones, the rest of the scene
// coarse ones, so each solve sees a much smaller system while shadows and indirect light from
// the whole scene are still modelled.
//
// Conventions: see scene.h and hierarchy.h. Blocks are cubes of side block_size_m on a grid
// anchored at the mesh's bounding-box minimum; a patch belongs to the block holding its
// centroid. "Resolution" is the radiosity patch size (the quadtree level); ray-cast
// visibility always uses the input mesh (decimating a scanned mesh is not done here).
#pragma once

#include <string>
#include <vector>

#include "processing/radiosity/reflectance.h"

namespace relume::radiosity {

struct BlockOptions {
  double block_size_m = 2.0;
  double fine_edge_m = 0.3;    // patch edge inside the block (= the full-resolution hierarchy's)
  double medium_edge_m = 0.6;  // within one block of it
  double coarse_edge_m = 1.2;  // everywhere else
  bool IsValid(std::string* why) const;
};

struct BlockResult {
  std::vector<Rgb> albedo;      // per patch of the full-resolution hierarchy
  std::vector<bool> estimated;  // as ReflectanceResult::estimated
  int blocks = 0;               // non-empty blocks solved
  int max_block_patches = 0;    // largest patch count of one block's system
  double mean_block_patches = 0.0;
  long long max_block_links = 0;
  double time_s = 0.0;
};

// `full` must be built with max_patch_edge_m = options.fine_edge_m; observations are per
// patch of `full`. Throws InvalidArgumentError for invalid options.
BlockResult EstimateReflectanceInBlocks(const PatchHierarchy& full, const RayCaster& caster,
                                        const std::vector<RadianceObservation>& observations,
                                        const BlockOptions& options, const ReflectanceOptions& reflectance);

}  // namespace relume::radiosity
