// Iterative diffuse reflectance (albedo) estimation from radiance images of a scene whose
// geometry and lights are known (Loscos et al., "Low-cost photometric calibration for
// interactive relighting"; confidence weights after Debevec et al., "Digitizing the
// Parthenon"), with radiosity for the indirect light.
//
// Per image s and patch i (per channel):  albedo_is = pi * a_s * L_is / (E_direct_is + I_is)
//  - L_is: observed radiance of patch i in image s (a Lambertian patch has B = pi L).
//  - E_direct_is: direct irradiance from image s's lights with visibility (direct_light.h);
//    the paper's F_is V_is E_s.
//  - I_is: indirect irradiance. Iteration 0 uses one ambient value per image (mean observed
//    radiosity times the scene's mean enclosure, our stand-in for the paper's user-given mean
//    reflectance); iterations 1.. gather sum_j F_ij B_j over the radiosity links, with B_j the
//    observed radiosity pi a_s L_js where image s saw patch j and the radiosity solution with
//    the current albedo elsewhere (indirect_from_observed, default). With
//    indirect_from_observed = false every B_j comes from the solution, as in Loscos et al.;
//    that fixed-point iteration amplifies errors when indirect light exceeds roughly half of
//    the total (it diverged in our test room), so it is not the default.
//  - a_s: radiance scale of image s (1, or fitted for an EV-only camera, RadianceScaleFactor).
// The estimates of all images are combined per patch, weighted by a confidence in [0, 1]: the
// product of (directly lit: unlit_weight .. 1), (cosine of the viewing angle), (distance from
// shadow boundaries: light visibility over a disc around the patch far from 1/2) and
// (distance from occlusion boundaries: camera visibility over the same disc).
// Iteration stops when no patch's albedo changes by more than albedo_tolerance.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "processing/radiosity/direct_light.h"
#include "processing/radiosity/hierarchy.h"
#include "processing/radiosity/radiosity_solver.h"

namespace relume::radiosity {

// One radiance image, already mapped to the hierarchy's patches.
struct RadianceObservation {
  Lighting lighting;                                 // the lights on when the image was taken
  std::vector<Rgb> radiance;                         // per patch, linear; NaN = patch not seen in this image
  std::optional<Eigen::Vector3d> camera_position_m;  // enables viewing-angle and occlusion weights
  // Optional, per patch: the surface points whose radiance `radiance` averages (where the
  // camera's pixel rays hit the patch, one per pixel used). When given, a patch's albedo in
  // this image divides by the direct irradiance averaged over exactly these points
  // (ComputeDirectLightAtPoints) instead of over samples spread on the patch: the two then
  // describe the same surface, weighted alike. The radiosity solve keeps the patch's
  // area-averaged direct light. Empty (the default) or an empty list for a patch: spread samples.
  std::vector<std::vector<Eigen::Vector3f>> pixel_points;
};

struct ReflectanceOptions {
  int max_iterations = 6;                // radiosity iterations after the ambient estimate
  double albedo_tolerance = 0.002;       // stop when max |change| of any patch albedo is below
  bool fit_image_scales = false;         // EV-only camera: fit a_s per image, image 0 the reference
  double unlit_weight = 0.05;            // confidence factor of a patch in shadow (paper: low)
  double boundary_radius_m = 0.1;        // disc radius for shadow/occlusion-boundary weights
  int boundary_samples = 8;              // rays per disc (0 disables both boundary weights)
  double indirect_skip_tolerance = 0.0;  // > 0: skip radiosity when the indirect share is below
  double prior_albedo = 0.5;             // for patches no image saw (and no same-material patch did)
  // Patches no image saw take the confidence-weighted mean albedo of the seen patches with the
  // same mesh material (a user's segmentation), when there are any.
  bool unseen_from_material = true;
  // Patches of materials no image saw take the confidence-weighted mean albedo of every seen
  // patch (instead of prior_albedo): the scene's own average stands in for an unknown surface.
  bool unseen_from_scene_mean = false;
  bool indirect_from_observed = true;  // see the header comment
  DirectLightOptions direct;
  RadiosityOptions radiosity;
  // Optional observer: called with the combined albedo after iteration 0 (ambient indirect)
  // and after each radiosity iteration, with that iteration's image scales (convergence plots).
  std::function<void(int iteration, const std::vector<Rgb>& albedo, const std::vector<double>& image_scale)>
      on_iteration;
  bool IsValid(std::string* why) const;
};

struct ReflectanceResult {
  std::vector<Rgb> albedo;          // per patch, in [0, 1]
  std::vector<Rgb> initial_albedo;  // iteration 0 (ambient indirect), for comparison
  std::vector<double> confidence;   // per patch: sum of image weights
  std::vector<bool> estimated;      // false: no image saw the patch with weight > 0 (prior)
  std::vector<double> image_scale;  // a_s per image (1 unless fitted)
  std::vector<int> scale_samples;   // patches used to fit a_s (0: not fitted, a_s = 1)
  int iterations = 0;               // radiosity iterations run
  bool converged = false;
  std::string reason;
  std::vector<double> max_change;   // per iteration, max |albedo change| (any channel)
  std::vector<double> mean_change;  // per iteration, mean |albedo change|
  int clamped = 0;                  // patch estimates clamped into [0, 1] (last iteration)
  IndirectShareEstimate indirect;
  bool radiosity_skipped = false;
  std::vector<RadiositySummary> last_solves;  // one per image, last iteration
  // Per image and patch, as the last combination used them: the indirect irradiance (W m^-2;
  // zero when radiosity was skipped) and the confidence weight. With them a caller can form
  // per-pixel reflectance, pi a_s L(x) / (E_direct(x) + indirect), weighted across images.
  std::vector<std::vector<Rgb>> image_indirect;
  std::vector<std::vector<double>> image_weight;
  double time_s = 0.0;
};

// Throws InvalidArgumentError for invalid options, no observations, or arrays whose size
// differs from the patch count.
ReflectanceResult EstimateReflectance(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                      const std::vector<RadianceObservation>& observations,
                                      const ReflectanceOptions& options);

// Loscos et al. eq. 3: the scale a minimising sum_i |a L_i - L_ref_i|^2 over the patches (or
// pixels) where mask is true, per channel, through core's ScaleFitter (the one least-squares
// scale of the project, shared with calibration/): a = sum L.L_ref / sum L.L over the channels
// where both values are finite and > 0. Returns 1 with *used = 0 when there is no such pair;
// *used counts the patches that contributed.
double RadianceScaleFactor(const std::vector<Rgb>& radiance, const std::vector<Rgb>& reference,
                           const std::vector<bool>& mask, int* used = nullptr);

}  // namespace relume::radiosity
