// Test data for this library (not a renderer): a furnished room with known albedo, a point
// lamp moved to several places, and "photographs" made from a converged fine radiosity
// solution. The full simulated world lives in sim/; integration with it comes later.
//
// Conventions: see scene.h. The room spans [0, 4] x [0, 3] x [0, 2.6] m, z up.
#pragma once

#include <cstdint>
#include <vector>

#include "processing/radiosity/geometry.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/reflectance.h"
#include "processing/radiosity/scene.h"

namespace relume::radiosity::testing {

struct TestRoom {
  Mesh mesh;
  int floor = 0, ceiling = 0, walls = 0, desk = 0;  // material ids
  std::vector<Eigen::Vector3d> lamp_positions_m;    // one image per position
  Rgb lamp_intensity_w_per_sr = Rgb(12.0, 11.0, 9.0);
  Eigen::Vector3d camera_position_m = Eigen::Vector3d(3.8, 2.8, 2.3);
};

// Floor, ceiling (albedo 0.9, the near-white case), walls, and a desk (a top slab on four
// legs: casts shadows, and the floor under it is lit only indirectly). `lamp_count` in [1, 8].
TestRoom MakeTestRoom(int lamp_count = 6);

struct RenderOptions {
  DirectLightOptions direct{16, 64};
  RadiosityOptions radiosity;  // defaults are made stricter by RenderPhotographs
};

// Radiance per patch (B / pi of a converged radiosity solution with the mesh's albedo) for
// each lamp position, NaN where the camera does not see the patch centroid.
std::vector<RadianceObservation> RenderPhotographs(const TestRoom& room, const PatchHierarchy& hierarchy,
                                                   const RayCaster& caster, const RenderOptions& options = {});

// Multiplies every radiance by its own Gaussian factor (1 + sigma * N(0, 1)), deterministic for
// a seed; the noise is kept apart from the ground truth on purpose.
void AddCameraNoise(double relative_sigma, std::uint64_t seed, std::vector<RadianceObservation>* observations);

// Multiplies image s by scales[s] (an EV-only camera's unknown exposure).
void ApplyImageScales(const std::vector<double>& scales, std::vector<RadianceObservation>* observations);

struct MaterialError {
  int material = 0;
  int patches = 0;              // observed patches of this material
  double mean_abs_error = 0.0;  // mean over patches and channels of |estimate - truth|
  double spread = 0.0;          // within-material standard deviation of the estimate (mean of channels)
  double range = 0.0;           // 95th - 5th percentile of the estimate (mean of channels)
};
// Per material, over the patches where `estimated` is true.
std::vector<MaterialError> CompareAlbedo(const PatchHierarchy& hierarchy, const std::vector<Rgb>& albedo,
                                         const std::vector<bool>& estimated);

}  // namespace relume::radiosity::testing
