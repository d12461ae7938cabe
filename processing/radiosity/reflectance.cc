#include "processing/radiosity/reflectance.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/error.h"
#include "core/scale_fit.h"

namespace relume::radiosity {
namespace {

bool Usable(const Rgb& radiance) {
  return radiance.allFinite() && radiance.minCoeff() >= 0.0;
}

// Fraction of points on a disc around the patch centroid that the camera sees.
double CameraVisibilityOverDisc(const Node& node, const RayCaster& caster, const Eigen::Vector3d& camera,
                                double radius_m, int samples) {
  const Eigen::Vector3d n = node.normal;
  const Eigen::Vector3d t = (node.triangle.v1 - node.triangle.v0).normalized();
  const Eigen::Vector3d b = n.cross(t);
  int seen = 0;
  for (int k = 0; k < samples; ++k) {
    const Eigen::Vector2d uv = Hammersley(k, samples, 0.25, 0.5);
    const double r = radius_m * std::sqrt(uv.x());
    const double phi = 2.0 * std::numbers::pi * uv.y();
    const Eigen::Vector3d x = node.centroid + r * (std::cos(phi) * t + std::sin(phi) * b);
    if (n.dot(camera - x) > 0.0 && !caster.SegmentOccluded(x, n, camera, Eigen::Vector3d::Zero())) ++seen;
  }
  return static_cast<double>(seen) / samples;
}

struct ImageData {
  DirectLight direct;          // area-averaged over each patch: what the radiosity solve takes
  std::vector<Rgb> seen;       // the direct irradiance the observed radiance is divided by: averaged
                               // over the observation's pixel points where given, else `direct`'s
  std::vector<double> weight;  // confidence per patch
  std::vector<double> lit;     // directly lit fraction per patch (0 when the light cannot reach)
  std::vector<Rgb> indirect;   // current indirect irradiance estimate per patch
  double scale = 1.0;
  int scale_samples = 0;
};

// Per-image albedo estimate for patch p; false when undefined (unseen or no light arrives).
bool ImageAlbedo(const RadianceObservation& obs, const ImageData& d, int p, double max_irradiance, Rgb* albedo) {
  const Rgb& l = obs.radiance[p];
  if (!Usable(l) || !(d.weight[p] > 0.0)) return false;
  const Rgb h = d.seen[p] + d.indirect[p];
  const double floor = 1e-9 * max_irradiance;
  if (!(h.minCoeff() > floor)) return false;
  *albedo = (std::numbers::pi * d.scale * l).cwiseQuotient(h);
  return albedo->allFinite();
}

// Confidence-weighted combination over images; returns how many estimates were clamped.
int Combine(const PatchHierarchy& h, const std::vector<RadianceObservation>& observations,
            const std::vector<ImageData>& images, const std::vector<double>& max_irradiance,
            const ReflectanceOptions& options, ReflectanceResult* out) {
  const double prior = options.prior_albedo;
  const size_t n = out->albedo.size();
  int clamped = 0;
  for (size_t p = 0; p < n; ++p) {
    Rgb sum = Rgb::Zero();
    double w = 0.0;
    for (size_t s = 0; s < observations.size(); ++s) {
      Rgb rho;
      if (!ImageAlbedo(observations[s], images[s], static_cast<int>(p), max_irradiance[s], &rho)) continue;
      sum += images[s].weight[p] * rho;
      w += images[s].weight[p];
    }
    out->confidence[p] = w;
    out->estimated[p] = w > 0.0;
    if (!(w > 0.0)) {
      out->albedo[p] = Rgb::Constant(prior);
      continue;
    }
    Rgb rho = sum / w;
    if (rho.maxCoeff() > 1.0 || rho.minCoeff() < 0.0) ++clamped;
    out->albedo[p] = rho.cwiseMax(0.0).cwiseMin(1.0);
  }
  if (options.unseen_from_material) {
    const size_t m = h.mesh().materials.size();
    std::vector<Rgb> sum(m, Rgb::Zero());
    std::vector<double> weight(m, 0.0);
    for (size_t p = 0; p < n; ++p) {
      if (!out->estimated[p]) continue;
      const int mat = h.leaf(static_cast<int>(p)).material;
      const double w = out->confidence[p] * h.leaf(static_cast<int>(p)).area_m2;
      sum[mat] += w * out->albedo[p];
      weight[mat] += w;
    }
    for (size_t p = 0; p < n; ++p) {
      const int mat = h.leaf(static_cast<int>(p)).material;
      if (!out->estimated[p] && weight[mat] > 0.0) out->albedo[p] = sum[mat] / weight[mat];
    }
  }
  if (options.unseen_from_scene_mean) {
    Rgb sum = Rgb::Zero();
    double weight = 0.0;
    std::vector<bool> material_seen(h.mesh().materials.size(), false);
    for (size_t p = 0; p < n; ++p) {
      if (!out->estimated[p]) continue;
      const double w = out->confidence[p] * h.leaf(static_cast<int>(p)).area_m2;
      sum += w * out->albedo[p];
      weight += w;
      material_seen[h.leaf(static_cast<int>(p)).material] = true;
    }
    for (size_t p = 0; p < n && weight > 0.0; ++p) {
      const bool from_material = options.unseen_from_material && material_seen[h.leaf(static_cast<int>(p)).material];
      if (!out->estimated[p] && !from_material) out->albedo[p] = sum / weight;
    }
  }
  return clamped;
}

// Loscos eq. 2-3: expected radiance from image 0's reflectance under image s's light, fitted
// over patches directly lit in both images.
void FitScales(const PatchHierarchy& h, const std::vector<RadianceObservation>& observations,
               std::vector<ImageData>* images, const std::vector<double>& max_irradiance) {
  const int n = h.LeafCount();
  ImageData& ref = (*images)[0];
  std::vector<Rgb> rho_ref(n, Rgb::Constant(NAN));
  for (int p = 0; p < n; ++p) {
    Rgb rho;
    if (ref.lit[p] >= 0.999 && ImageAlbedo(observations[0], ref, p, max_irradiance[0], &rho)) rho_ref[p] = rho;
  }
  for (size_t s = 1; s < observations.size(); ++s) {
    ImageData& d = (*images)[s];
    std::vector<Rgb> expected(n, Rgb::Constant(NAN));
    std::vector<bool> mask(n, false);
    for (int p = 0; p < n; ++p) {
      if (!rho_ref[p].allFinite() || d.lit[p] < 0.999 || !(d.weight[p] > 0.0)) continue;
      expected[p] = rho_ref[p].cwiseProduct(d.seen[p] + d.indirect[p]) / std::numbers::pi;
      mask[p] = true;
    }
    int used = 0;
    d.scale = RadianceScaleFactor(observations[s].radiance, expected, mask, &used);
    d.scale_samples = used;
  }
}

}  // namespace

bool ReflectanceOptions::IsValid(std::string* why) const {
  const auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (max_iterations < 0 || max_iterations > 100) return fail("max_iterations must be in [0, 100]");
  if (!(albedo_tolerance > 0.0)) return fail("albedo_tolerance must be > 0");
  if (!(unlit_weight >= 0.0 && unlit_weight <= 1.0)) return fail("unlit_weight must be in [0, 1]");
  if (!(boundary_radius_m >= 0.0) || !std::isfinite(boundary_radius_m)) return fail("boundary_radius_m must be >= 0");
  if (boundary_samples < 0 || boundary_samples > 1024) return fail("boundary_samples must be in [0, 1024]");
  if (!(indirect_skip_tolerance >= 0.0)) return fail("indirect_skip_tolerance must be >= 0");
  if (!(prior_albedo >= 0.0 && prior_albedo <= 1.0)) return fail("prior_albedo must be in [0, 1]");
  std::string inner;
  if (!direct.IsValid(&inner) || !radiosity.IsValid(&inner)) {
    if (why) *why = inner;
    return false;
  }
  return true;
}

double RadianceScaleFactor(const std::vector<Rgb>& radiance, const std::vector<Rgb>& reference,
                           const std::vector<bool>& mask, int* used) {
  RELUME_CHECK(radiance.size() == reference.size() && radiance.size() == mask.size());
  ScaleFitter fitter;
  int count = 0;
  for (size_t i = 0; i < radiance.size(); ++i) {
    if (!mask[i] || !radiance[i].allFinite() || !reference[i].allFinite()) continue;
    const long long before = fitter.samples();
    for (int c = 0; c < 3; ++c) fitter.Add(radiance[i][c], reference[i][c]);
    if (fitter.samples() > before) ++count;
  }
  const ScaleFit fit = fitter.Fit();
  if (used != nullptr) *used = fit.usable ? count : 0;
  return fit.scale;
}

ReflectanceResult EstimateReflectance(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                      const std::vector<RadianceObservation>& observations,
                                      const ReflectanceOptions& options) {
  ThrowIfInvalid(options, "reflectance options");
  if (observations.empty()) throw InvalidArgumentError("reflectance: no radiance images given");
  const int n = hierarchy.LeafCount();
  for (size_t s = 0; s < observations.size(); ++s) {
    if (static_cast<int>(observations[s].radiance.size()) != n) {
      throw InvalidArgumentError("reflectance: image " + std::to_string(s) + " has " +
                                 std::to_string(observations[s].radiance.size()) + " patch radiances; expected " +
                                 std::to_string(n));
    }
    if (!observations[s].pixel_points.empty() && static_cast<int>(observations[s].pixel_points.size()) != n) {
      throw InvalidArgumentError("reflectance: image " + std::to_string(s) + " has pixel points for " +
                                 std::to_string(observations[s].pixel_points.size()) + " patches; expected " +
                                 std::to_string(n) + " (or none)");
    }
    if (observations[s].camera_position_m && !observations[s].camera_position_m->allFinite()) {
      throw InvalidArgumentError("reflectance: image " + std::to_string(s) + " has a non-finite camera position");
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  ReflectanceResult out;
  out.albedo.assign(n, Rgb::Constant(options.prior_albedo));
  out.confidence.assign(n, 0.0);
  out.estimated.assign(n, false);

  // Direct light and confidence weights, once per image.
  std::vector<ImageData> images(observations.size());
  std::vector<double> max_irradiance(observations.size(), 0.0);
  for (size_t s = 0; s < observations.size(); ++s) {
    const RadianceObservation& obs = observations[s];
    ImageData& d = images[s];
    d.direct = ComputeDirectLight(hierarchy, caster, obs.lighting, options.direct);
    d.seen = d.direct.irradiance;
    std::vector<double> seen_visible = d.direct.visible_fraction;
    if (!obs.pixel_points.empty()) {
      const DirectLightAtPoints at =
          ComputeDirectLightAtPoints(hierarchy, caster, obs.lighting, obs.pixel_points, options.direct);
      for (int p = 0; p < n; ++p) {
        if (!at.has_points[p]) continue;
        d.seen[p] = at.irradiance[p];
        seen_visible[p] = at.visible_fraction[p];
      }
    }
    d.weight.assign(n, 0.0);
    d.lit.assign(n, 0.0);
    for (int p = 0; p < n; ++p) {
      max_irradiance[s] = std::max({max_irradiance[s], d.direct.irradiance[p].maxCoeff(), d.seen[p].maxCoeff()});
    }
    for (int p = 0; p < n; ++p) {
      if (!Usable(obs.radiance[p])) continue;
      const Node& node = hierarchy.leaf(p);
      const bool reached = d.seen[p].maxCoeff() > 1e-9 * max_irradiance[s];
      d.lit[p] = reached ? seen_visible[p] : 0.0;
      double w = options.unlit_weight + (1.0 - options.unlit_weight) * d.lit[p];
      if (options.boundary_samples > 0 && options.boundary_radius_m > 0.0 && reached) {
        const double f = LightVisibilityOverDisc(hierarchy, p, caster, obs.lighting, options.boundary_radius_m,
                                                 options.boundary_samples);
        w *= std::max(0.0, 1.0 - 4.0 * f * (1.0 - f));
      }
      if (obs.camera_position_m) {
        const Eigen::Vector3d to_camera = *obs.camera_position_m - node.centroid;
        const double cos_view = node.normal.dot(to_camera) / std::max(1e-12, to_camera.norm());
        w *= std::max(0.0, cos_view);
        if (w > 0.0 && options.boundary_samples > 0 && options.boundary_radius_m > 0.0) {
          const double f = CameraVisibilityOverDisc(node, caster, *obs.camera_position_m, options.boundary_radius_m,
                                                    options.boundary_samples);
          w *= f * f;
        }
      }
      d.weight[p] = w;
    }
  }

  // Iteration 0: one ambient indirect irradiance per image.
  std::vector<Rgb> zero(n, Rgb::Zero());
  {
    std::vector<Rgb> direct_only_albedo(n, Rgb::Constant(options.prior_albedo));
    out.indirect = EstimateIndirectShare(hierarchy, caster, direct_only_albedo, images[0].direct.irradiance,
                                         std::max(options.indirect_skip_tolerance, 1e-300));
  }
  for (size_t s = 0; s < observations.size(); ++s) {
    double sum = 0.0, area = 0.0;
    Rgb b_sum = Rgb::Zero();
    for (int p = 0; p < n; ++p) {
      if (!Usable(observations[s].radiance[p])) continue;
      const double a = hierarchy.leaf(p).area_m2;
      b_sum += a * std::numbers::pi * observations[s].radiance[p];
      area += a;
      sum += a;
    }
    const Rgb ambient = area > 0.0 ? Rgb(b_sum / area * out.indirect.mean_enclosure) : Rgb::Zero();
    images[s].indirect.assign(n, ambient);
  }
  if (options.fit_image_scales) FitScales(hierarchy, observations, &images, max_irradiance);
  out.clamped = Combine(hierarchy, observations, images, max_irradiance, options, &out);
  out.initial_albedo = out.albedo;
  auto report = [&](int iteration) {
    if (!options.on_iteration) return;
    std::vector<double> scales;
    for (const auto& d : images) scales.push_back(d.scale);
    options.on_iteration(iteration, out.albedo, scales);
  };

  // Skip radiosity when the scene has too little indirect light to matter.
  if (options.indirect_skip_tolerance > 0.0) {
    double share = 0.0;
    for (size_t s = 0; s < observations.size(); ++s) {
      share = std::max(share, EstimateIndirectShare(hierarchy, caster, out.albedo, images[s].direct.irradiance,
                                                    options.indirect_skip_tolerance)
                                  .indirect_share);
    }
    out.indirect = EstimateIndirectShare(hierarchy, caster, out.albedo, images[0].direct.irradiance,
                                         options.indirect_skip_tolerance);
    out.indirect.indirect_share = std::max(out.indirect.indirect_share, share);
    out.indirect.skip = out.indirect.indirect_share < options.indirect_skip_tolerance;
    if (out.indirect.skip) {
      // Direct light only: the estimate without any indirect term.
      for (auto& d : images) d.indirect = zero;
      if (options.fit_image_scales) FitScales(hierarchy, observations, &images, max_irradiance);
      out.clamped = Combine(hierarchy, observations, images, max_irradiance, options, &out);
      out.radiosity_skipped = true;
      out.converged = true;
      out.reason = out.indirect.reason;
    }
  }
  report(0);

  if (!out.radiosity_skipped) {
    RadiositySolver solver(hierarchy, caster, options.radiosity);
    const std::vector<Rgb> emission = hierarchy.LeafEmission();
    out.reason = "max_iterations reached before the albedo settled";
    for (int it = 0; it < options.max_iterations; ++it) {
      out.last_solves.clear();
      for (size_t s = 0; s < observations.size(); ++s) {
        RadiositySolution solution;
        out.last_solves.push_back(solver.Solve(out.albedo, images[s].direct.irradiance, emission, &solution));
        if (options.indirect_from_observed) {
          std::vector<Rgb> b = solution.radiosity;
          for (int p = 0; p < n; ++p) {
            const Rgb& l = observations[s].radiance[p];
            if (Usable(l)) b[p] = std::numbers::pi * images[s].scale * l;
          }
          images[s].indirect = solver.Gather(b);
        } else {
          images[s].indirect = solution.indirect_irradiance;
        }
      }
      if (options.fit_image_scales) FitScales(hierarchy, observations, &images, max_irradiance);
      const std::vector<Rgb> previous = out.albedo;
      out.clamped = Combine(hierarchy, observations, images, max_irradiance, options, &out);
      double max_change = 0.0, mean_change = 0.0;
      int counted = 0;
      for (int p = 0; p < n; ++p) {
        if (!out.estimated[p]) continue;
        const double c = (out.albedo[p] - previous[p]).cwiseAbs().maxCoeff();
        max_change = std::max(max_change, c);
        mean_change += c;
        ++counted;
      }
      out.max_change.push_back(max_change);
      out.mean_change.push_back(counted > 0 ? mean_change / counted : 0.0);
      out.iterations = it + 1;
      report(it + 1);
      if (max_change < options.albedo_tolerance) {
        out.converged = true;
        std::ostringstream reason;
        reason << "albedo changed by at most " << max_change << " < " << options.albedo_tolerance << " in iteration "
               << it + 1;
        out.reason = reason.str();
        break;
      }
    }
    if (options.max_iterations == 0) out.reason = "max_iterations = 0: ambient estimate only";
  }
  out.image_scale.clear();
  out.scale_samples.clear();
  for (const auto& d : images) {
    out.image_scale.push_back(d.scale);
    out.scale_samples.push_back(d.scale_samples);
    out.image_indirect.push_back(d.indirect);
    out.image_weight.push_back(d.weight);
  }
  out.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace relume::radiosity
