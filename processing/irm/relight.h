// Relighting a photograph with irradiance ratio maps (processing/irm/irm.h): per-vertex
// visibility and sun fractions for each photograph, IRMs from the vertices seen in both, then
// every source pixel multiplied by the ratio for its surface normal and sun fractions, found
// by casting the pixel's ray into the mesh (no OpenGL needed).
//
// Sun fractions are per vertex (the fraction of the sun's disk not blocked by other
// geometry, sampled over the 0.53 deg disk) and interpolated across triangles, as the paper
// interpolates its shadow bits; where a shadow edge crosses a triangle (its vertices
// disagree) each pixel casts its own rays instead (`exact_shadow_edges`), since interpolation
// smears the edge over the whole triangle. `use_penumbra_fractions = false` rounds fractions
// to the paper's bits. Where the sun is behind a surface (attached shadow) the fraction is reported as 1: the
// sun term is zero there anyway, and this keeps attached shadows out of the cast-shadow maps.
//
// Holes in the mesh: a ray toward the sun that escapes through a hole counts as unblocked
// (the paper's "sun leaking through holes"), so surfaces behind holes look lit. Close holes
// or add the missing occluders before relighting; relume does not guess geometry.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "core/image.h"
#include "core/mesh.h"
#include "core/pinhole.h"
#include "processing/geometry/ray_caster.h"
#include "processing/irm/irm.h"
#include "processing/irm/sky_shape.h"

namespace relume::irm {

// With exact_shadow_edges, a triangle whose vertices' sky views span more than this casts its
// pixels' own sky-view rays (2026-12-02: on random outdoor scenes, bench/irm_suite.cc, such
// triangles along walls' feet held 83-99 % of the shadow region's squared error).
inline constexpr float kSkyViewEdgeSpread = 0.1f;
// With exact_shadow_edges and indirect light, a triangle whose vertices' indirect irradiance
// spans more than this share of its largest (in either photograph, the channels' sum) gathers
// its pixels' own (the ground at a wall's foot, where what the wall sends falls steeply with
// the distance and vertices 0.5 m apart cannot carry it). Measured 2026-12-03 on the IRM suite
// with 3 bounces (quick, seed 3, 6 scenes): shadow median / p90 2.14 / 3.81 % with these own
// gathers, 2.47 / 6.56 % without (lit 0.60 / 0.83 against 0.79 / 1.05 %). (On the simulated
// building it had shown no gain, 5.78 -> 5.87 %, while its error was the vertex radiance read
// across a shadow's edge, since fixed.)
inline constexpr float kIndirectEdgeSpread = 0.25f;

struct RelightOptions {
  IrmOptions irm;
  int sun_samples = 16;  // rays per vertex over the sun's disk
  // Cosine-weighted rays per vertex for its sky view (SkyViewFraction; irm.h says how the sun +
  // sky model uses it). 0: not computed, every surface counts as open to the sky.
  int sky_samples = 144;
  // Measure the sky's brightness against elevation in each photograph's own sky pixels
  // (FitSkyShape) and weigh each surface's sky by it (irm.h). Needs sky_samples > 0; without
  // enough sky in a photograph its sky is taken as uniform, and the view geometry says why.
  bool sky_gradient = true;
  SkyShapeOptions sky_shape;
  float sun_angular_radius_rad = 0.5f * 0.533f * 3.14159265f / 180.0f;
  bool use_penumbra_fractions = true;
  // Pixels on triangles whose vertices disagree about the sun (a shadow edge crosses them)
  // get their own sun fraction by ray casting instead of the interpolated one; likewise their
  // own sky view where the vertices' sky views differ by more than kSkyViewEdgeSpread (a
  // vertex under a wall: ground that runs beneath a building sees no sky there, and its
  // triangle's visible part would get a fraction of its sky view).
  bool exact_shadow_edges = true;
  // Interreflection (indirect.h, irm.h): gather each vertex's light from the other surfaces out
  // of the photographs' radiance with `indirect_samples` cosine-weighted rays, fit it into the
  // sun + sky model and carry it per pixel (only with sky views: sky_samples > 0).
  // `indirect_passes` refinements of the radiance of
  // surfaces a photograph does not show (their albedo times the model's irradiance), each a
  // gather and a refit.
  bool indirect = true;
  int indirect_samples = 144;
  int indirect_passes = 2;
  int threads = 0;  // 0: core/parallel.h's DefaultThreads() (RELUME_THREADS, a Slurm task's share, the CPUs)
  bool IsValid(std::string* why) const;
};

// One photograph: linear radiance, its camera, and the sun direction (unit, toward the sun)
// in the mesh's frame at its capture time.
struct View {
  const RadianceImage* image = nullptr;
  PinholeCamera camera;
  Eigen::Vector3f sun_dir = Eigen::Vector3f::UnitZ();
  // CV_8UC1, non-zero where the radiance is not to be trusted (saturated or black in every
  // exposure): never sampled for the IRMs, and left untouched (kMasked) in a relit source.
  // Empty: every pixel is usable.
  cv::Mat mask;
};

struct RelightSummary {
  int vertices = 0;
  int visible_in_both = 0;
  int consistent_samples = 0;  // of those, not on a crease, occlusion or shadow edge in either image
  std::string irm_summary;
  std::int64_t pixels_relit = 0;
  std::int64_t pixels_without_geometry = 0;  // sky, background: left untouched
  std::int64_t pixels_without_ratio = 0;     // geometry but no IRM value or model: left untouched
  std::int64_t pixels_masked = 0;            // View::mask of the source: left untouched
  // Pixels that cast their own sun rays (a shadow edge across their triangle, or a vertex
  // without a fraction) or sky-view rays (a vertex without a sky view): most of the per-pixel
  // cost beyond the camera rays when there are many.
  std::int64_t pixels_with_own_sun_rays = 0;
  std::int64_t pixels_with_own_sky_rays = 0;
  std::int64_t pixels_with_own_indirect_rays = 0;  // kIndirectEdgeSpread
  // Interreflection (RelightOptions::indirect): rays cast, the share that met a surface, and
  // vertices whose radiance in a photograph was filled by the model (not seen in it).
  std::int64_t indirect_rays = 0;
  double indirect_hit_share = 0.0;
  int indirect_filled_source = 0, indirect_filled_target = 0;
  double indirect_s = 0.0;
  double overlap_rms_before = 0.0;  // relative RMS target vs source at vertices seen in both
  double overlap_rms_after = 0.0;   // ... vs relit source
  double preprocess_s = 0.0;
  double build_s = 0.0;
  double relight_s = 0.0;
};

enum PixelStatus : std::uint8_t { kNoGeometry = 0, kRelit = 1, kNoRatio = 2, kMasked = 3 };

struct RelightResult {
  RadianceImage relit;  // the source under the target's light; untouched where status != kRelit
  cv::Mat status;       // CV_8UC1 PixelStatus
  cv::Mat source_sun;   // CV_32FC1 per-pixel sun fractions (NaN without geometry)
  cv::Mat target_sun;
  IrmSet irms;
  RelightSummary summary;
};

// Bilinear sample of a linear RGB (CV_32FC3) image at a continuous image point (pixel centres
// at +0.5); NaN outside the image.
Eigen::Vector3f SampleBilinear(const cv::Mat& image, const Eigen::Vector2d& point);

// Per-vertex: 1 when the vertex is inside the image, faces the camera and nothing blocks it.
std::vector<std::uint8_t> VertexVisibility(const RayCaster& caster, const PinholeCamera& camera);
// Per-vertex sun fractions (see the top of this file); with `needed`, only where needed[i] is
// non-zero (NaN elsewhere).
std::vector<float> VertexSunFractions(const RayCaster& caster, const Eigen::Vector3f& sun_dir, int samples,
                                      float angular_radius_rad, int threads,
                                      const std::vector<std::uint8_t>* needed = nullptr);
// Per-vertex sky views (SkyViewFraction) where needed[i] is non-zero (all with null), NaN elsewhere;
// with `zenith_moments`, the same vertices' zenith moments from the same rays (SkyViewMoments).
std::vector<float> VertexSkyViews(const RayCaster& caster, int samples, int threads,
                                  const std::vector<std::uint8_t>* needed = nullptr,
                                  std::vector<float>* zenith_moments = nullptr);
// Vertices in front of the camera whose projection falls within the image widened by half its
// size on every side: the vertices a photograph's pixels can interpolate from.
std::vector<std::uint8_t> VerticesNearView(const TriangleMesh& mesh, const PinholeCamera& camera);

// What one photograph says about every vertex: the first stage, cached per photograph by
// `relume process --pipeline irm`. Sun fractions are rounded to 0/1 when the options ask for
// the paper's bits (use_penumbra_fractions = false).
struct ViewGeometry {
  std::vector<std::uint8_t> visible;  // VertexVisibility
  // VertexSunFractions for the vertices near the view (VerticesNearView), NaN elsewhere: a
  // pixel whose triangle has a NaN vertex casts its own sun rays.
  std::vector<float> sun_fraction;
  // Visible vertices in cast shadow (sun fraction below the IRM's lit threshold): when both
  // photographs have none, one IRM is enough (the planner's decision).
  int visible_in_cast_shadow = 0;
  // Sky view (SkyViewFraction) of the vertices near the view, NaN elsewhere; empty when
  // RelightOptions::sky_samples is 0 or `with_sky_view` was false. It depends on the geometry
  // only, and only the source photograph's is used (its pixels are the ones relit).
  std::vector<float> sky_view;
  // The same vertices' zenith moments (SkyViewMoments), with sky_view; empty without.
  std::vector<float> sky_moment;
  // The sky's shape measured in this photograph (RelightOptions::sky_gradient; not measured:
  // gradient 0, a uniform sky, with the reason).
  SkyShape sky_shape;
  double seconds = 0.0;
};
ViewGeometry ComputeViewGeometry(const RayCaster& caster, const View& view, const RelightOptions& options,
                                 bool with_sky_view = true);

// The second stage: samples from the vertices seen in both photographs, then the IRMs. Fills
// the summary's sample counts, overlap errors and build_s.
IrmSet BuildIrmsFromViews(const RayCaster& caster, const View& source, const View& target,
                          const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                          const RelightOptions& options, RelightSummary* summary);

// The third stage: every source pixel times the ratio for its surface (relit, status, per-pixel
// sun fractions). Fills the summary's pixel counts and relight_s. `irms` is copied into the result.
RelightResult RelightPixels(const RayCaster& caster, const View& source, const View& target,
                            const ViewGeometry& source_geometry, const ViewGeometry& target_geometry,
                            const IrmSet& irms, const RelightOptions& options, RelightSummary summary);

// Checks the inputs (InvalidArgumentError saying what is wrong): options, images, cameras,
// sun directions, vertex normals.
void CheckRelightInputs(const RayCaster& caster, const View& source, const View& target, const RelightOptions& options);

// All three stages. The mesh needs per-vertex normals. Throws InvalidArgumentError for invalid inputs.
RelightResult RelightImage(const RayCaster& caster, const View& source, const View& target,
                           const RelightOptions& options);

}  // namespace relume::irm
