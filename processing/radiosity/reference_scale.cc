#include "processing/radiosity/reference_scale.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>
#include <sstream>

#include "core/error.h"

namespace relume::radiosity {

namespace {

struct Sample {
  double rho = 0.0;       // known albedo, one channel
  double direct = 0.0;    // E_direct at the patch's pixels, W m^-2
  double radiance = 0.0;  // relative
  int patch = -1;
  int channel = 0;
};

double Percentile(std::vector<double> values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1) + 0.5);
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

// Per-sample scales rho (E_direct + E_indirect) / (pi L) under `indirect` (per leaf, W m^-2 at the
// current scale; empty: none).
std::vector<double> SampleScales(const std::vector<Sample>& samples, const std::vector<Rgb>& indirect) {
  std::vector<double> k;
  k.reserve(samples.size());
  for (const Sample& s : samples) {
    const double e = s.direct + (indirect.empty() ? 0.0 : indirect[s.patch][s.channel]);
    k.push_back(s.rho * e / (std::numbers::pi * s.radiance));
  }
  return k;
}

}  // namespace

bool ReferenceScaleOptions::IsValid(std::string* why) const {
  const auto fail = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  if (max_solves < 1 || max_solves > 50) return fail("max_solves must be in [1, 50]");
  if (!(tolerance > 0.0 && tolerance < 1.0)) return fail("tolerance must be in (0, 1)");
  if (!(min_albedo >= 0.0 && min_albedo < 1.0)) return fail("min_albedo must be in [0, 1)");
  if (!(min_irradiance_fraction >= 0.0 && min_irradiance_fraction < 1.0)) {
    return fail("min_irradiance_fraction must be in [0, 1)");
  }
  return true;
}

ReferenceScaleResult EstimateReferenceScale(const PatchHierarchy& hierarchy, const RayCaster& caster,
                                            const std::vector<RadianceObservation>& observations,
                                            const std::vector<ReferencePatch>& references,
                                            const ReflectanceOptions& reflectance,
                                            const ReferenceScaleOptions& options) {
  ThrowIfInvalid(options, "reference scale options");
  ThrowIfInvalid(reflectance, "reflectance options");
  if (observations.empty()) throw InvalidArgumentError("reference scale: no radiance images given");
  const auto t0 = std::chrono::steady_clock::now();
  const int n = hierarchy.LeafCount();
  std::vector<std::vector<Eigen::Vector3f>> points(n);
  for (const ReferencePatch& r : references) {
    if (r.patch < 0 || r.patch >= n) {
      throw InvalidArgumentError("reference scale: reference patch " + std::to_string(r.patch) +
                                 " is not a leaf of the hierarchy (" + std::to_string(n) + " leaves)");
    }
    if (r.points.empty()) {
      throw InvalidArgumentError("reference scale: reference patch " + std::to_string(r.patch) +
                                 " has no pixel points");
    }
    points[r.patch].insert(points[r.patch].end(), r.points.begin(), r.points.end());
  }
  const DirectLightAtPoints direct =
      ComputeDirectLightAtPoints(hierarchy, caster, observations.front().lighting, points, reflectance.direct);
  double brightest = 0.0;
  for (const ReferencePatch& r : references) brightest = std::max(brightest, direct.irradiance[r.patch].maxCoeff());
  std::vector<Sample> samples;
  ReferenceScaleResult out;
  for (const ReferencePatch& r : references) {
    const Rgb& e = direct.irradiance[r.patch];
    if (!(e.maxCoeff() > options.min_irradiance_fraction * brightest)) continue;
    bool used = false;
    for (int c = 0; c < 3; ++c) {
      if (!(r.albedo[c] >= options.min_albedo) || !(r.radiance[c] > 0.0) || !std::isfinite(r.radiance[c])) continue;
      samples.push_back({r.albedo[c], e[c], r.radiance[c], r.patch, c});
      used = true;
    }
    out.patches += used ? 1 : 0;
  }
  if (samples.empty()) {
    throw InvalidArgumentError(
        "reference scale: no reference patch is both lit by the lamps and bright enough (albedo >= " +
        std::to_string(options.min_albedo) + ", radiance > 0) in the first bracket; " +
        std::to_string(references.size()) + " reference patch(es) were seen");
  }
  out.samples = static_cast<int>(samples.size());

  // f(k): run the reflectance estimate at scale k and re-measure the scale with its indirect light.
  std::vector<Rgb> indirect;
  auto evaluate = [&](double k) {
    std::vector<RadianceObservation> scaled = observations;
    for (RadianceObservation& o : scaled) {
      for (Rgb& v : o.radiance) v *= k;
    }
    ReflectanceOptions quiet = reflectance;
    quiet.on_iteration = nullptr;
    const ReflectanceResult result = EstimateReflectance(hierarchy, caster, scaled, quiet);
    ++out.solves;
    indirect = result.image_indirect.empty() ? std::vector<Rgb>(n, Rgb::Zero()) : result.image_indirect.front();
    const double next = Percentile(SampleScales(samples, indirect), 0.5);
    out.history.push_back(next);
    return next;
  };
  out.direct_only_scale = Percentile(SampleScales(samples, {}), 0.5);
  double k_prev = out.direct_only_scale;
  double g_prev = evaluate(k_prev) - k_prev;
  double k = k_prev + g_prev;  // one fixed-point step
  out.reason = "stopped after max_solves = " + std::to_string(options.max_solves) + " reflectance estimates";
  while (out.solves < options.max_solves) {
    const double g = evaluate(k) - k;
    if (std::abs(g) < options.tolerance * k) {
      k += g;
      out.converged = true;
      std::ostringstream reason;
      reason << "the scale changed by " << std::abs(g) / k << " < " << options.tolerance << " (relative) after "
             << out.solves << " reflectance estimates";
      out.reason = reason.str();
      break;
    }
    // Secant step on g(k) = f(k) - k; a plain fixed-point step when the secant is unusable.
    double next = k + g;
    if (std::abs(g - g_prev) > 1e-12 * std::abs(k)) {
      const double secant = k - g * (k - k_prev) / (g - g_prev);
      if (std::isfinite(secant) && secant > 0.0) next = secant;
    }
    k_prev = k;
    g_prev = g;
    k = next;
  }
  out.scale = k;
  std::vector<double> scales = SampleScales(samples, indirect);
  const double p16 = Percentile(scales, 0.16), p84 = Percentile(scales, 0.84);
  out.relative_spread = 0.5 * (p84 - p16) / k;
  double direct_sum = 0.0, indirect_sum = 0.0;
  for (const Sample& s : samples) {
    direct_sum += s.direct;
    indirect_sum += indirect[s.patch][s.channel];
  }
  out.indirect_share = indirect_sum / std::max(direct_sum + indirect_sum, 1e-300);
  out.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace relume::radiosity
