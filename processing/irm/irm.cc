#include "processing/irm/irm.h"

#include <Eigen/QR>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <sstream>

#include "core/error.h"

namespace relume::irm {

namespace {
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
float SignNotZero(float v) {
  return v >= 0.0f ? 1.0f : -1.0f;
}
float SkyFactor(const Eigen::Vector3f& n) {
  return 0.5f * (1.0f + n.z());
}
// The sky view v when known, else the open plane's.
float SkyView(const Eigen::Vector3f& n, float sky_view) {
  return std::isfinite(sky_view) ? sky_view : SkyFactor(n);
}
// The sky term of one photograph and channel: v + g m with the sky's shape g (top of irm.h);
// v alone (a uniform sky) when the view or the moment is unknown.
float SkyTerm(const Eigen::Vector3f& n, float sky_view, float sky_moment, float gradient) {
  if (!std::isfinite(sky_view) || !std::isfinite(sky_moment)) return SkyView(n, sky_view);
  return sky_view + gradient * sky_moment;
}

enum class State { kLit, kShadow, kPenumbra };
State Classify(float fraction, const IrmOptions& o) {
  if (fraction >= o.lit_threshold) return State::kLit;
  if (fraction <= o.shadow_threshold) return State::kShadow;
  return State::kPenumbra;
}
MapKind KindOf(State source, State target) {
  if (source == State::kLit) return target == State::kLit ? MapKind::kLitToLit : MapKind::kLitToShadow;
  return target == State::kLit ? MapKind::kShadowToLit : MapKind::kShadowToShadow;
}
bool Finite(const Eigen::Vector3f& v) {
  return v.allFinite();
}
}  // namespace

const char* ToString(MapKind kind) {
  switch (kind) {
    case MapKind::kLitToLit: return "lit_to_lit";
    case MapKind::kShadowToShadow: return "shadow_to_shadow";
    case MapKind::kLitToShadow: return "lit_to_shadow";
    case MapKind::kShadowToLit: return "shadow_to_lit";
  }
  return "unknown";
}

const char* ToString(FillMethod method) {
  switch (method) {
    case FillMethod::kNone: return "none";
    case FillMethod::kSmoothing: return "smoothing";
    case FillMethod::kSunSkyModel: return "sun_sky_model";
  }
  return "unknown";
}

bool IrmOptions::IsValid(std::string* why) const {
  auto fail = [why](const char* reason) {
    if (why) *why = reason;
    return false;
  };
  if (bins < 2 || bins > 1024) return fail("bins must be within 2..1024");
  if (!(shadow_threshold >= 0.0f && shadow_threshold < lit_threshold && lit_threshold <= 1.0f)) {
    return fail("need 0 <= shadow_threshold < lit_threshold <= 1");
  }
  if (min_samples_per_bin < 1) return fail("min_samples_per_bin must be >= 1");
  if (!(trim_fraction >= 0.0f && trim_fraction < 0.5f)) return fail("trim_fraction must be in [0, 0.5)");
  if (!(min_source_radiance > 0.0f)) return fail("min_source_radiance must be positive");
  if (!(smoothing_sigma_rad > 0.0f && smoothing_sigma_rad < 3.2f)) return fail("smoothing sigma must be in (0, pi]");
  return true;
}

Eigen::Vector2f OctahedralFromDirection(const Eigen::Vector3f& direction) {
  const Eigen::Vector3f n = direction / direction.cwiseAbs().sum();
  Eigen::Vector2f p(n.x(), n.y());
  if (n.z() < 0.0f) {
    p = Eigen::Vector2f((1.0f - std::abs(n.y())) * SignNotZero(n.x()), (1.0f - std::abs(n.x())) * SignNotZero(n.y()));
  }
  return (p + Eigen::Vector2f::Ones()) * 0.5f;
}

Eigen::Vector3f DirectionFromOctahedral(const Eigen::Vector2f& uv) {
  const Eigen::Vector2f p = uv * 2.0f - Eigen::Vector2f::Ones();
  Eigen::Vector3f n(p.x(), p.y(), 1.0f - std::abs(p.x()) - std::abs(p.y()));
  if (n.z() < 0.0f) {
    const float x = n.x();
    n.x() = (1.0f - std::abs(n.y())) * SignNotZero(x);
    n.y() = (1.0f - std::abs(x)) * SignNotZero(n.y());
  }
  return n.normalized();
}

int RatioMap::BinOf(const Eigen::Vector3f& normal) const {
  const Eigen::Vector2f uv = OctahedralFromDirection(normal);
  const int i = std::clamp(static_cast<int>(uv.x() * static_cast<float>(bins)), 0, bins - 1);
  const int j = std::clamp(static_cast<int>(uv.y() * static_cast<float>(bins)), 0, bins - 1);
  return j * bins + i;
}

Eigen::Vector3f RatioMap::Interpolate(const Eigen::Vector3f& normal) const {
  return Interpolate(normal, [](std::size_t) { return Eigen::Vector3f::Ones().eval(); });
}

template <typename Correction>
Eigen::Vector3f RatioMap::Interpolate(const Eigen::Vector3f& normal, const Correction& correction) const {
  auto value = [&](std::size_t b) -> Eigen::Vector3f {
    if (b >= model_ratio.size() || !model_ratio[b].allFinite()) return ratio[b];
    const Eigen::Vector3f c = correction(b);
    return c.allFinite() ? ratio[b].cwiseProduct(c).eval() : ratio[b];
  };
  const Eigen::Vector2f uv =
      OctahedralFromDirection(normal) * static_cast<float>(bins) - Eigen::Vector2f::Constant(0.5f);
  const int i0 = static_cast<int>(std::floor(uv.x())), j0 = static_cast<int>(std::floor(uv.y()));
  const float fx = uv.x() - static_cast<float>(i0), fy = uv.y() - static_cast<float>(j0);
  // Measured bins first: filled values (smoothing, model) only where no measured neighbour is.
  for (const bool measured_only : {true, false}) {
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    float weight = 0.0f;
    for (int dj = 0; dj <= 1; ++dj) {
      for (int di = 0; di <= 1; ++di) {
        const int i = std::clamp(i0 + di, 0, bins - 1), j = std::clamp(j0 + dj, 0, bins - 1);
        const std::size_t b = static_cast<std::size_t>(j * bins + i);
        if (!ratio[b].allFinite() || (measured_only && source[b] != 1)) continue;
        const float w = std::max(1e-4f, (di ? fx : 1.0f - fx) * (dj ? fy : 1.0f - fy));
        sum += w * value(b);
        weight += w;
      }
    }
    if (weight > 0.0f) return sum / weight;
  }
  return value(static_cast<std::size_t>(BinOf(normal)));
}

int RatioMap::measured_bins() const {
  return static_cast<int>(std::count(source.begin(), source.end(), std::uint8_t{1}));
}

void SunSkyModel::Irradiance(const Eigen::Vector3f& n, float source_sun, float target_sun, float sky_view,
                             float sky_moment, const Eigen::Vector3f& indirect_source,
                             const Eigen::Vector3f& indirect_target, Eigen::Vector3f* source,
                             Eigen::Vector3f* target) const {
  const float a_s = source_sun * std::max(0.0f, n.dot(sun_dir_source));
  const float a_t = target_sun * std::max(0.0f, n.dot(sun_dir_target));
  for (int c = 0; c < 3; ++c) {
    // A NaN indirect irradiance (not gathered) counts as none.
    const float i_s = std::isfinite(indirect_source[c]) ? indirect_scale[c] * indirect_source[c] : 0.0f;
    const float i_t = std::isfinite(indirect_target[c]) ? indirect_scale[c] * indirect_target[c] : 0.0f;
    (*source)[c] = sun_source[c] * a_s + SkyTerm(n, sky_view, sky_moment, sky_gradient_source[c]) + i_s;
    (*target)[c] = sun_target[c] * a_t + sky_target[c] * SkyTerm(n, sky_view, sky_moment, sky_gradient_target[c]) + i_t;
  }
}

Eigen::Vector3f SunSkyModel::Ratio(const Eigen::Vector3f& n, float source_sun, float target_sun, float sky_view,
                                   float sky_moment, const Eigen::Vector3f& indirect_source,
                                   const Eigen::Vector3f& indirect_target) const {
  if (!valid) return Eigen::Vector3f::Constant(kNaN);
  Eigen::Vector3f source, target;
  Irradiance(n, source_sun, target_sun, sky_view, sky_moment, indirect_source, indirect_target, &source, &target);
  Eigen::Vector3f ratio;
  for (int c = 0; c < 3; ++c) {
    ratio[c] = source[c] > 1e-6f ? target[c] / source[c] : kNaN;  // a downward normal sees neither sun nor sky
  }
  return ratio;
}

namespace {

Eigen::Vector3f TrimmedMean(std::vector<Eigen::Vector3f>& values, float trim) {
  Eigen::Vector3f mean;
  std::vector<float> channel(values.size());
  for (int c = 0; c < 3; ++c) {
    for (std::size_t i = 0; i < values.size(); ++i) channel[i] = values[i][c];
    std::sort(channel.begin(), channel.end());
    const std::size_t drop = static_cast<std::size_t>(trim * static_cast<float>(channel.size()));
    double sum = 0.0;
    for (std::size_t i = drop; i < channel.size() - drop; ++i) sum += channel[i];
    mean[c] = static_cast<float>(sum / static_cast<double>(channel.size() - 2 * drop));
  }
  return mean;
}

// How FitModel treats the samples' indirect light (top of irm.h).
enum class IndirectFit {
  kNone,    // q = 0: the model without it
  kFixed,   // q given (from the source photograph's sky radiance)
  kFitted,  // q an unknown
  kTied     // q = K_t x fixed_scale (the target photograph's sky radiance alone: 1 / (pi a_t)), K_t fitted
};

// Fits the model to the measured bins (robust means, so sampling noise is averaged out
// first), each bin a row weighted by the square root of its sample count. `sky_target`, when
// finite, is K_t known (the photographs' sky radiances) rather than an unknown. With indirect
// light (`indirect` not kNone, q = `fixed_scale` for kFixed), rows are reweighted by the fitted
// source irradiance (iteratively reweighted least squares): dividing by ratio * h_s weighs a lit
// row's relative error by E_s / h_s, five to ten times a shadowed row's, and the shadowed rows
// carry most of the indirect light.
SunSkyModel FitModel(std::span<const Sample> samples, std::span<const double> counts, const Eigen::Vector3f& sun_s,
                     const Eigen::Vector3f& sun_t, const Eigen::Vector3f& gradient_s, const Eigen::Vector3f& gradient_t,
                     IndirectFit indirect = IndirectFit::kNone,
                     const Eigen::Vector3f& fixed_scale = Eigen::Vector3f::Zero(),
                     const Eigen::Vector3f& sky_target = Eigen::Vector3f::Constant(kNaN)) {
  SunSkyModel model;
  model.sun_dir_source = sun_s.normalized();
  model.sun_dir_target = sun_t.normalized();
  model.sky_gradient_source = gradient_s;
  model.sky_gradient_target = gradient_t;
  std::vector<std::size_t> rows;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    if (SkyView(samples[i].normal, samples[i].sky_view) > 0.05f) rows.push_back(i);
  }
  const bool fitted = indirect == IndirectFit::kFitted;
  const bool tied = indirect == IndirectFit::kTied;
  const bool sky_known = sky_target.allFinite();
  RELUME_CHECK(!(tied && sky_known));
  // Columns: S_s, S_t, then K_t unless known, then q when fitted (kTied: K_t's column carries
  // q's term too, q = K_t fixed_scale).
  const int k_column = sky_known ? -1 : 2;
  const int q_column = fitted ? (sky_known ? 2 : 3) : -1;
  const int unknowns = 2 + (sky_known ? 0 : 1) + (fitted ? 1 : 0);
  if (rows.size() < static_cast<std::size_t>(unknowns) + 1) {
    model.reason = "fewer than " + std::to_string(unknowns + 1) + " measured bins";
    return model;
  }
  double squared = 0.0;
  const int rounds = indirect == IndirectFit::kNone ? 1 : 3;
  std::vector<double> denominator(rows.size());
  Eigen::MatrixXd a(static_cast<Eigen::Index>(rows.size()), unknowns);
  Eigen::VectorXd b(static_cast<Eigen::Index>(rows.size()));
  for (int c = 0; c < 3; ++c) {
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const Sample& s = samples[rows[r]];
      denominator[r] = SkyTerm(s.normal, s.sky_view, s.sky_moment, gradient_s[c]);
    }
    const double q_fixed = indirect == IndirectFit::kFixed ? fixed_scale[c] : 0.0;
    const double k_fixed = sky_known ? sky_target[c] : 0.0;
    Eigen::VectorXd x;
    double q = q_fixed, k = k_fixed;
    for (int round = 0; round < rounds; ++round) {
      for (std::size_t r = 0; r < rows.size(); ++r) {
        const Sample& s = samples[rows[r]];
        const double ratio = s.target_rgb[c] / s.source_rgb[c];
        const double h_s = SkyTerm(s.normal, s.sky_view, s.sky_moment, gradient_s[c]);
        const double h_t = SkyTerm(s.normal, s.sky_view, s.sky_moment, gradient_t[c]);
        const double a_s = s.source_sun * std::max(0.0f, s.normal.dot(model.sun_dir_source));
        const double a_t = s.target_sun * std::max(0.0f, s.normal.dot(model.sun_dir_target));
        const double i_s = std::isfinite(s.source_indirect[c]) ? s.source_indirect[c] : 0.0;
        const double i_t = std::isfinite(s.target_indirect[c]) ? s.target_indirect[c] : 0.0;
        // S_t a_t + K_t h_t + q (I_t - ratio I_s) - ratio a_s S_s = ratio h_s (known terms move
        // to the right), divided by ratio * h_s (or ratio * E_s, above) so that every row weighs
        // its relative error.
        const double w = std::sqrt(counts[rows[r]]) / (ratio * denominator[r]);
        const auto row = static_cast<Eigen::Index>(r);
        a(row, 0) = -ratio * a_s * w;
        a(row, 1) = a_t * w;
        if (k_column >= 0) a(row, k_column) = (h_t + (tied ? fixed_scale[c] * (i_t - ratio * i_s) : 0.0)) * w;
        if (q_column >= 0) a(row, q_column) = (i_t - ratio * i_s) * w;
        b(row) = (ratio * h_s - q_fixed * (i_t - ratio * i_s) - k_fixed * h_t) * w;
      }
      Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(a);
      qr.setThreshold(1e-8);
      if (qr.rank() < unknowns) {
        model.reason = "the samples cannot separate sun from sky" + std::string(fitted ? " and indirect light" : "") +
                       " (rank " + std::to_string(qr.rank()) +
                       "): too few normals facing the sun in one of the photographs";
        return model;
      }
      // Sun and sky separate only when the normals and shadow states vary enough: a badly
      // conditioned fit extrapolates wildly, so refuse it (the maps and smoothing remain).
      const Eigen::VectorXd column_norms = a.colwise().norm().transpose().cwiseMax(1e-300);
      const Eigen::JacobiSVD<Eigen::MatrixXd> svd(a * column_norms.cwiseInverse().asDiagonal());
      const double condition = svd.singularValues()(0) / std::max(1e-300, svd.singularValues()(unknowns - 1));
      model.condition_number = std::max(model.condition_number, condition);
      if (condition > 1e3) {
        model.reason = std::string(fitted ? "sun, sky and indirect light" : "sun and sky") +
                       " are not separable from these samples (condition number " +
                       std::to_string(condition).substr(0, 8) + "): too few distinct normals or shadow states";
        return model;
      }
      x = qr.solve(b);
      k = k_column >= 0 ? x[k_column] : k_fixed;
      q = q_column >= 0 ? x[q_column] : (tied ? fixed_scale[c] * k : q_fixed);
      if (!(x.allFinite() && x[0] >= -1e-6 && x[1] >= -1e-6 && k > 0.0)) {
        model.reason = "the fit is not physical (negative sun or sky)";
        return model;
      }
      if (!(q >= 0.0)) {
        model.reason = "the fit is not physical (negative indirect light)";
        return model;
      }
      if (round + 1 < rounds) {
        for (std::size_t r = 0; r < rows.size(); ++r) {
          const Sample& s = samples[rows[r]];
          const double h_s = SkyTerm(s.normal, s.sky_view, s.sky_moment, gradient_s[c]);
          const double a_s = s.source_sun * std::max(0.0f, s.normal.dot(model.sun_dir_source));
          const double i_s = std::isfinite(s.source_indirect[c]) ? s.source_indirect[c] : 0.0;
          denominator[r] = std::max(h_s, x[0] * a_s + h_s + q * i_s);
        }
      }
    }
    model.sun_source[c] = static_cast<float>(std::max(0.0, x[0]));
    model.sun_target[c] = static_cast<float>(std::max(0.0, x[1]));
    model.sky_target[c] = static_cast<float>(k);
    model.indirect_scale[c] = static_cast<float>(q);
    // The residual as without indirect light (relative to ratio * h_s).
    for (std::size_t r = 0; r < rows.size(); ++r) {
      const Sample& s = samples[rows[r]];
      const double h_s = SkyTerm(s.normal, s.sky_view, s.sky_moment, gradient_s[c]);
      const double e =
          (a.row(static_cast<Eigen::Index>(r)).dot(x) - b(static_cast<Eigen::Index>(r))) * denominator[r] / h_s;
      squared += e * e;
    }
  }
  model.valid = true;
  double total = 0.0, ratio_squared = 0.0;
  for (std::size_t r : rows) {
    total += counts[r];
    // The model's ratio against the measured one, relative: how fits of different kinds compare.
    const Sample& s = samples[r];
    const Eigen::Vector3f ratio = model.Ratio(s.normal.normalized(), s.source_sun, s.target_sun, s.sky_view,
                                              s.sky_moment, s.source_indirect, s.target_indirect);
    const Eigen::Vector3f measured = s.target_rgb.cwiseQuotient(s.source_rgb);
    if (ratio.allFinite()) ratio_squared += counts[r] * (ratio - measured).cwiseQuotient(measured).squaredNorm();
  }
  model.rms_relative_residual = std::sqrt(squared / (3.0 * total));
  model.rms_ratio_error = std::sqrt(ratio_squared / (3.0 * total));
  return model;
}

void FillBySmoothing(RatioMap& map, float sigma) {
  std::vector<Eigen::Vector3f> centres(map.ratio.size());
  for (int j = 0; j < map.bins; ++j) {
    for (int i = 0; i < map.bins; ++i) {
      centres[static_cast<std::size_t>(j * map.bins + i)] =
          DirectionFromOctahedral({(i + 0.5f) / map.bins, (j + 0.5f) / map.bins});
    }
  }
  std::vector<Eigen::Vector3f> filled = map.ratio;
  for (std::size_t e = 0; e < map.ratio.size(); ++e) {
    if (map.source[e] != 0) continue;
    Eigen::Vector3f sum = Eigen::Vector3f::Zero();
    float weight = 0.0f;
    for (std::size_t m = 0; m < map.ratio.size(); ++m) {
      if (map.source[m] != 1) continue;
      const float angle = std::acos(std::clamp(centres[e].dot(centres[m]), -1.0f, 1.0f));
      const float w = static_cast<float>(map.count[m]) * std::exp(-0.5f * angle * angle / (sigma * sigma));
      sum += w * map.ratio[m];
      weight += w;
    }
    if (weight > 1e-6f) {
      filled[e] = sum / weight;
      map.source[e] = 2;
    }
  }
  map.ratio = std::move(filled);
}

}  // namespace

IrmSet BuildIrms(std::span<const Sample> samples, const Eigen::Vector3f& sun_dir_source,
                 const Eigen::Vector3f& sun_dir_target, const IrmOptions& options,
                 const Eigen::Vector3f& sky_gradient_source, const Eigen::Vector3f& sky_gradient_target,
                 const Eigen::Vector3f& source_sky_radiance, const Eigen::Vector3f& target_sky_radiance) {
  if (!sky_gradient_source.allFinite() || !sky_gradient_target.allFinite() ||
      (Eigen::Vector3f::Ones() + sky_gradient_source).minCoeff() <= 0.0f ||
      (Eigen::Vector3f::Ones() + sky_gradient_target).minCoeff() <= 0.0f) {
    throw InvalidArgumentError("IRMs: a sky gradient must be finite and above -1 (a sky brighter than black)");
  }
  ThrowIfInvalid(options, "IRM options");
  IrmSet set;
  set.lit_threshold = options.lit_threshold;
  set.shadow_threshold = options.shadow_threshold;
  const std::size_t bin_count = static_cast<std::size_t>(options.bins * options.bins);
  std::array<std::vector<std::vector<Eigen::Vector3f>>, 4> per_bin;
  std::array<std::vector<std::vector<std::size_t>>, 4> bin_samples;  // indices into samples, as per_bin
  std::array<std::vector<Eigen::Vector3f>, 4> normal_sum;
  std::array<std::vector<double>, 4> sky_sum;     // of the samples' sky views (NaN once one is unknown)
  std::array<std::vector<double>, 4> moment_sum;  // of their zenith moments (likewise)
  std::array<std::vector<Eigen::Vector3d>, 4> indirect_source_sum, indirect_target_sum;  // of I_s, I_t
  for (int k = 0; k < 4; ++k) {
    indirect_source_sum[static_cast<std::size_t>(k)].assign(bin_count, Eigen::Vector3d::Zero());
    indirect_target_sum[static_cast<std::size_t>(k)].assign(bin_count, Eigen::Vector3d::Zero());
    set.maps[static_cast<std::size_t>(k)].bins = options.bins;
    set.maps[static_cast<std::size_t>(k)].ratio.assign(bin_count, Eigen::Vector3f::Constant(kNaN));
    set.maps[static_cast<std::size_t>(k)].count.assign(bin_count, 0);
    set.maps[static_cast<std::size_t>(k)].source.assign(bin_count, 0);
    set.maps[static_cast<std::size_t>(k)].mean_normal.assign(bin_count, Eigen::Vector3f::Constant(kNaN));
    set.maps[static_cast<std::size_t>(k)].mean_sky_view.assign(bin_count, kNaN);
    set.maps[static_cast<std::size_t>(k)].mean_sky_moment.assign(bin_count, kNaN);
    set.maps[static_cast<std::size_t>(k)].model_ratio.assign(bin_count, Eigen::Vector3f::Constant(kNaN));
    bin_samples[static_cast<std::size_t>(k)].resize(bin_count);
    sky_sum[static_cast<std::size_t>(k)].assign(bin_count, 0.0);
    moment_sum[static_cast<std::size_t>(k)].assign(bin_count, 0.0);
    per_bin[static_cast<std::size_t>(k)].resize(bin_count);
    normal_sum[static_cast<std::size_t>(k)].assign(bin_count, Eigen::Vector3f::Zero());
  }
  bool any_shadow = false;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const Sample& s = samples[i];
    if (!Finite(s.normal) || !Finite(s.source_rgb) || !Finite(s.target_rgb) ||
        s.source_rgb.minCoeff() < options.min_source_radiance || s.target_rgb.minCoeff() < 0.0f) {
      ++set.samples_too_dark;
      continue;
    }
    const State source = Classify(s.source_sun, options);
    const State target = Classify(s.target_sun, options);
    if (source == State::kPenumbra || target == State::kPenumbra) {
      ++set.samples_in_penumbra;
      continue;
    }
    const MapKind kind = KindOf(source, target);
    any_shadow = any_shadow || kind != MapKind::kLitToLit;
    RatioMap& map = set.maps[static_cast<std::size_t>(kind)];
    const auto bin = static_cast<std::size_t>(map.BinOf(s.normal.normalized()));
    per_bin[static_cast<std::size_t>(kind)][bin].push_back(s.target_rgb.cwiseQuotient(s.source_rgb));
    bin_samples[static_cast<std::size_t>(kind)][bin].push_back(i);
    normal_sum[static_cast<std::size_t>(kind)][bin] += s.normal.normalized();
    sky_sum[static_cast<std::size_t>(kind)][bin] += s.sky_view;  // NaN stays NaN: unknown
    moment_sum[static_cast<std::size_t>(kind)][bin] += s.sky_moment;
    indirect_source_sum[static_cast<std::size_t>(kind)][bin] += s.source_indirect.cast<double>();
    indirect_target_sum[static_cast<std::size_t>(kind)][bin] += s.target_indirect.cast<double>();
    ++set.samples_used;
  }
  for (int k = 0; k < 4; ++k) {
    RatioMap& map = set.maps[static_cast<std::size_t>(k)];
    for (std::size_t b = 0; b < bin_count; ++b) {
      auto& values = per_bin[static_cast<std::size_t>(k)][b];
      map.count[b] = static_cast<int>(values.size());
      if (static_cast<int>(values.size()) >= options.min_samples_per_bin) {
        map.ratio[b] = TrimmedMean(values, options.trim_fraction);
        map.source[b] = 1;
        map.mean_normal[b] = normal_sum[static_cast<std::size_t>(k)][b].normalized();
        map.mean_sky_view[b] = static_cast<float>(sky_sum[static_cast<std::size_t>(k)][b] / values.size());
        map.mean_sky_moment[b] = static_cast<float>(moment_sum[static_cast<std::size_t>(k)][b] / values.size());
      }
    }
  }
  set.single_map = !any_shadow && options.single_map_without_shadow;
  set.model_correction = options.model_correction;
  // One row per measured bin: its mean normal, its robust ratio, its pure sun states.
  std::vector<Sample> bin_rows;
  std::vector<double> bin_counts;
  for (int k = 0; k < 4; ++k) {
    const RatioMap& map = set.maps[static_cast<std::size_t>(k)];
    const auto kind = static_cast<MapKind>(k);
    for (std::size_t b = 0; b < bin_count; ++b) {
      if (map.source[b] != 1) continue;
      Sample row;
      row.normal = normal_sum[static_cast<std::size_t>(k)][b].normalized();
      row.sky_view = map.mean_sky_view[b];
      row.sky_moment = map.mean_sky_moment[b];
      row.source_rgb = Eigen::Vector3f::Ones();
      row.target_rgb = map.ratio[b];
      const double in_bin = map.count[b];
      row.source_indirect = (indirect_source_sum[static_cast<std::size_t>(k)][b] / in_bin).cast<float>();
      row.target_indirect = (indirect_target_sum[static_cast<std::size_t>(k)][b] / in_bin).cast<float>();
      row.source_sun = (kind == MapKind::kLitToLit || kind == MapKind::kLitToShadow) ? 1.0f : 0.0f;
      row.target_sun = (kind == MapKind::kLitToLit || kind == MapKind::kShadowToLit) ? 1.0f : 0.0f;
      bin_rows.push_back(row);
      bin_counts.push_back(map.count[b]);
    }
  }
  std::vector<Sample> usable_samples;
  for (const Sample& s : samples) {
    if (Finite(s.normal) && Finite(s.source_rgb) && Finite(s.target_rgb) &&
        s.source_rgb.minCoeff() >= options.min_source_radiance && s.target_rgb.minCoeff() >= 0.0f &&
        Classify(s.source_sun, options) != State::kPenumbra && Classify(s.target_sun, options) != State::kPenumbra) {
      usable_samples.push_back(s);
    }
  }
  const std::vector<double> ones(usable_samples.size(), 1.0);
  const bool any_indirect = std::any_of(usable_samples.begin(), usable_samples.end(), [](const Sample& s) {
    return (s.source_indirect.array() > 0.0f).any() || (s.target_indirect.array() > 0.0f).any();
  });
  std::string indirect_reason = "no indirect light gathered";
  // Both photographs' sky radiances at the horizon (each in its own units), when measured.
  const bool source_sky = source_sky_radiance.allFinite() && source_sky_radiance.minCoeff() > 0.0f;
  const bool target_sky = target_sky_radiance.allFinite() && target_sky_radiance.minCoeff() > 0.0f;
  const Eigen::Vector3f measured_k_t = target_sky_radiance.cwiseQuotient(source_sky_radiance);
  // The model fitted to the samples with indirect light treated as `mode` (FitModel).
  auto fit = [&](IndirectFit mode, const Eigen::Vector3f& scale = Eigen::Vector3f::Zero(),
                 const Eigen::Vector3f& k_t = Eigen::Vector3f::Constant(kNaN)) {
    return FitModel(usable_samples, ones, sun_dir_source, sun_dir_target, sky_gradient_source, sky_gradient_target,
                    mode, scale, k_t);
  };
  // The per-sample fit without indirect light and with K_t free: what each fit with the term is
  // judged against, and a fallback below. Computed once, when first asked for.
  std::optional<SunSkyModel> free_fit;
  auto free_model = [&]() -> const SunSkyModel& {
    if (!free_fit) free_fit = fit(IndirectFit::kNone);
    return *free_fit;
  };
  // The bin means' fit without indirect light: the fallback below, and what a fit of the bins
  // with the term is judged against. Computed once, when first asked for.
  std::optional<SunSkyModel> bin_fit;
  auto bin_model = [&]() -> const SunSkyModel& {
    if (!bin_fit) {
      bin_fit =
          FitModel(bin_rows, bin_counts, sun_dir_source, sun_dir_target, sky_gradient_source, sky_gradient_target);
    }
    return *bin_fit;
  };
  // Keeps set.model (fitted with the term; `label` says how) only when it explains the samples
  // better than `without`: its ratio error below `margin` times that one's. Else says why.
  auto keep_if_better = [&](const SunSkyModel& without, const std::string& label, double margin,
                            const std::string& verdict) {
    const std::string how = label.empty() ? "" : " (" + label + ")";
    if (!set.model.valid) {
      indirect_reason = "indirect light left out" + how + ": " + set.model.reason;
    } else if (without.valid && !(set.model.rms_ratio_error < margin * without.rms_ratio_error)) {
      indirect_reason = "indirect light left out" + how + ": the samples fit better without it (rms ratio error " +
                        std::to_string(without.rms_ratio_error) + " against " +
                        std::to_string(set.model.rms_ratio_error) + ")" + verdict;
      set.model.valid = false;
    }
  };
  // q fitted: one more unknown always fits the samples at least as well, so the term must earn
  // its place, a tenth less ratio error than the same samples' fit without it (`relume bench
  // --stage irm` with no sky views, a scene without interreflection, fitted a small q and
  // gathered every vertex for nothing).
  auto fit_q = [&](const std::string& why) {
    set.model = fit(IndirectFit::kFitted);
    keep_if_better(free_model(), why + ", so q was fitted", 0.9, "");
  };
  if (any_indirect) {
    // Indirect light varies from vertex to vertex within a bin (the ground beside a sunlit wall,
    // the open ground), which bin means wash out: fitted to the samples. With both photographs'
    // sky radiances at the horizon (a_s, a_t) the model's unit is known, pi a_s (K_s = 1), and
    // with it K_t = a_t / a_s and q = 1 / (pi a_s): only the suns are fitted. That model is kept
    // when it explains the samples better than the same without indirect light (data rendered
    // without interreflection, such as the simulator's by default). Fitting q as well gave
    // 0.3-1.1 times this value on random courtyards rendered by Blender with 4 bounces, and relit
    // shadows 5.6 % off at the median against 4.8 % with q from the sky (docs/irm.md). With the
    // source's sky alone q is still known and K_t fitted; with the target's alone q = K_t /
    // (pi a_t) follows K_t; without either K_t and q are fitted.
    const float pi = std::numbers::pi_v<float>;
    if (source_sky && target_sky) {
      set.model = fit(IndirectFit::kFixed, (pi * source_sky_radiance).cwiseInverse(), measured_k_t);
      keep_if_better(fit(IndirectFit::kFixed, Eigen::Vector3f::Zero(), measured_k_t), "", 1.0,
                     ": no interreflection in these photographs");
    } else if (source_sky) {
      // Only the source's sky: q = 1 / (pi a_s) is still known (the model's unit), K_t fitted.
      const Eigen::Vector3f q_source = (pi * source_sky_radiance).cwiseInverse();
      set.model = fit(IndirectFit::kFixed, q_source);
      if (!set.model.valid && !free_model().valid) {
        // Neither fit holds per sample (scene 11 of the IRM suites: a target sun of -0.6 with
        // and without the term, over 4002 samples in 4 bins), while the bins' robust means fit
        // a valid model. The same model on the bin rows, with the same known q (no unknown
        // added), kept when it explains the bins better than they are without it: rendered
        // with bounces, ratio error 0.0008-0.0014 against 0.0079 (shadow 16.3 -> 2.2 %, floor
        // 1.8 %; lit 4.6 -> 0.7 %); rendered without, 0.012 against 0.0010 (left out).
        const std::string per_sample = set.model.reason;
        set.model = FitModel(bin_rows, bin_counts, sun_dir_source, sun_dir_target, sky_gradient_source,
                             sky_gradient_target, IndirectFit::kFixed, q_source);
        keep_if_better(bin_model(), "no sky in the target photograph, K_t fitted to the bins: per sample " + per_sample,
                       1.0, ": no interreflection in these photographs");
      } else {
        keep_if_better(free_model(), "no sky in the target photograph, K_t fitted", 1.0, "");
      }
    } else if (target_sky) {
      // Only the target's sky: the model's unit pi a_s is unknown, but q = 1 / (pi a_s) =
      // K_t / (pi a_t), so q follows the fitted K_t. When that fit fails (the first pass's
      // radiance of unseen surfaces comes from a model fitted without indirect light, which can
      // be far off), q is fitted free, as without either sky.
      set.model = fit(IndirectFit::kTied, (pi * target_sky_radiance).cwiseInverse());
      if (set.model.valid) {
        keep_if_better(free_model(), "no sky in the source photograph, q tied to K_t", 1.0, "");
      } else {
        fit_q("no sky in the source photograph, and q tied to K_t failed: " + set.model.reason);
      }
    } else {
      fit_q("no sky in either photograph to set its scale");
    }
  }
  if (!set.model.valid) {
    set.model = bin_model();
    if (!set.model.valid || set.model.rms_relative_residual > 0.01) {
      // Bin means smear the ratio across a bin; with exact data the samples themselves fit
      // better. Keep whichever explains the data best.
      const SunSkyModel& per_sample = free_model();
      if (per_sample.valid &&
          (!set.model.valid || per_sample.rms_relative_residual < set.model.rms_relative_residual)) {
        set.model = per_sample;
      }
    }
    if (!set.model.valid && source_sky && target_sky) {
      // The free fit failed. Under interreflection it can go negative (light the model has no
      // term for pushes K_t or a sun below zero: 4 of 20 scenes of the IRM suite with bounces).
      // The sky ratio the photographs' own sky pixels measure leaves only the suns to fit; the
      // indirect light is then gathered from this model (relight.h) and the fit made again.
      SunSkyModel fixed = fit(IndirectFit::kNone, Eigen::Vector3f::Zero(), measured_k_t);
      if (fixed.valid) {
        indirect_reason += "; the sky ratio K_t from the photographs' skies (the free fit: " + set.model.reason + ")";
        set.model = fixed;
      }
    }
    set.model.indirect_reason = indirect_reason;
  }

  // The model correction's reference per measured bin: the model's ratio at the bin's own
  // samples, averaged as their ratios were. The ratio is far from linear in a sample's sky view
  // (a shadowed surface's 1 / v), so the model at the bin's mean sky view is not what the bin's
  // mean ratio measured when the bin mixes open ground with ground beside a wall.
  if (set.model.valid) {
    std::vector<Eigen::Vector3f> at_samples;
    for (int k = 0; k < 4; ++k) {
      RatioMap& map = set.maps[static_cast<std::size_t>(k)];
      const auto kind = static_cast<MapKind>(k);
      const float fs = (kind == MapKind::kLitToLit || kind == MapKind::kLitToShadow) ? 1.0f : 0.0f;
      const float ft = (kind == MapKind::kLitToLit || kind == MapKind::kShadowToLit) ? 1.0f : 0.0f;
      for (std::size_t b = 0; b < bin_count; ++b) {
        if (map.source[b] != 1) continue;
        at_samples.clear();
        for (std::size_t i : bin_samples[static_cast<std::size_t>(k)][b]) {
          const Sample& s = samples[i];
          const Eigen::Vector3f r = set.model.Ratio(s.normal.normalized(), fs, ft, s.sky_view, s.sky_moment,
                                                    s.source_indirect, s.target_indirect);
          if (Finite(r) && r.minCoeff() > 1e-6f) at_samples.push_back(r);
        }
        if (at_samples.size() == bin_samples[static_cast<std::size_t>(k)][b].size()) {
          map.model_ratio[b] = TrimmedMean(at_samples, options.trim_fraction);
        }
      }
    }
  }

  const int map_count = set.single_map ? 1 : 4;
  for (int k = 0; k < map_count; ++k) {
    RatioMap& map = set.maps[static_cast<std::size_t>(k)];
    if (options.fill == FillMethod::kSunSkyModel && set.model.valid) {
      const auto kind = static_cast<MapKind>(k);
      const float fs = (kind == MapKind::kLitToLit || kind == MapKind::kLitToShadow) ? 1.0f : 0.0f;
      const float ft = (kind == MapKind::kLitToLit || kind == MapKind::kShadowToLit) ? 1.0f : 0.0f;
      for (std::size_t b = 0; b < bin_count; ++b) {
        if (map.source[b] != 0) continue;
        const int i = static_cast<int>(b) % options.bins;
        const int j = static_cast<int>(b) / options.bins;
        const Eigen::Vector3f centre = DirectionFromOctahedral({(i + 0.5f) / options.bins, (j + 0.5f) / options.bins});
        const Eigen::Vector3f ratio = set.model.Ratio(centre, fs, ft);
        if (Finite(ratio)) {
          map.ratio[b] = ratio;
          map.source[b] = 3;
          map.mean_normal[b] = centre;
          if (ratio.minCoeff() > 1e-6f) map.model_ratio[b] = ratio;  // the model at its centre, open plane
        }
      }
    } else if (options.fill != FillMethod::kNone) {
      FillBySmoothing(map, options.smoothing_sigma_rad);
    }
  }

  // The share of each region's light that is indirect, by the model, over the samples used.
  if (set.model.valid && (set.model.indirect_scale.array() > 0.0f).any()) {
    IndirectShare& share = set.indirect_share;
    for (const Sample& s : samples) {
      const State source = Classify(s.source_sun, options), target = Classify(s.target_sun, options);
      if (!Finite(s.normal) || source == State::kPenumbra || target == State::kPenumbra) continue;
      Eigen::Vector3f e_s, e_t, i_s, i_t;
      const Eigen::Vector3f n = s.normal.normalized();
      set.model.Irradiance(n, s.source_sun, s.target_sun, s.sky_view, s.sky_moment, s.source_indirect,
                           s.target_indirect, &e_s, &e_t);
      set.model.Irradiance(n, 0.0f, 0.0f, 0.0f, 0.0f, s.source_indirect, s.target_indirect, &i_s, &i_t);
      if (!(e_s.minCoeff() > 0.0f && e_t.minCoeff() > 0.0f)) continue;
      const double f_s = i_s.cwiseQuotient(e_s).mean(), f_t = i_t.cwiseQuotient(e_t).mean();
      const bool lit_s = source == State::kLit && n.dot(set.model.sun_dir_source) > 0.0f;
      const bool lit_t = target == State::kLit && n.dot(set.model.sun_dir_target) > 0.0f;
      (lit_s ? share.source_lit : share.source_shadow) += f_s;
      ++(lit_s ? share.source_lit_samples : share.source_shadow_samples);
      (lit_t ? share.target_lit : share.target_shadow) += f_t;
      ++(lit_t ? share.target_lit_samples : share.target_shadow_samples);
    }
    auto mean = [](double& sum, int count) { sum = count > 0 ? sum / count : 0.0; };
    mean(share.source_lit, share.source_lit_samples);
    mean(share.source_shadow, share.source_shadow_samples);
    mean(share.target_lit, share.target_lit_samples);
    mean(share.target_shadow, share.target_shadow_samples);
  }

  std::ostringstream summary;
  if (set.single_map) {
    summary << "one IRM (lit to lit): no sample is in cast shadow in either photograph";
  } else {
    summary << "four IRMs";
  }
  summary << "; " << set.samples_used << " samples";
  for (int k = 0; k < map_count; ++k) {
    summary << ", " << ToString(static_cast<MapKind>(k)) << " " << set.maps[static_cast<std::size_t>(k)].measured_bins()
            << " bins";
  }
  summary << "; " << set.samples_in_penumbra << " in penumbra, " << set.samples_too_dark << " too dark";
  summary << "; sun+sky model "
          << (set.model.valid ? "fitted (rms " + std::to_string(set.model.rms_relative_residual) + ", ratio error " +
                                    std::to_string(set.model.rms_ratio_error) + ")"
                              : "not used: " + set.model.reason);
  if (set.model.valid) {
    if ((set.model.indirect_scale.array() > 0.0f).any()) {
      const IndirectShare& share = set.indirect_share;
      summary << "; indirect light (share of the model's irradiance) source lit " << std::lround(100 * share.source_lit)
              << " %, shadow " << std::lround(100 * share.source_shadow) << " %; target lit "
              << std::lround(100 * share.target_lit) << " %, shadow " << std::lround(100 * share.target_shadow) << " %";
    } else if (!set.model.indirect_reason.empty()) {
      summary << "; " << set.model.indirect_reason;
    }
  }
  set.summary = summary.str();
  return set;
}

namespace {
// A map's own pure sun states: what the model correction evaluates the model at.
float MapSourceSun(MapKind kind) {
  return (kind == MapKind::kLitToLit || kind == MapKind::kLitToShadow) ? 1.0f : 0.0f;
}
float MapTargetSun(MapKind kind) {
  return (kind == MapKind::kLitToLit || kind == MapKind::kShadowToLit) ? 1.0f : 0.0f;
}

// IrmSet::Ratio's choice between the maps, given `at(kind)`, one map's (corrected) value for
// the normal: shared by IrmSet::Ratio and RatioTable so that both decide alike.
template <typename MapAt, typename ModelAt>
Eigen::Vector3f CombineMaps(const IrmSet& set, const MapAt& at, const ModelAt& model_at, float source_sun,
                            float target_sun) {
  if (set.single_map) {
    // One map holds lit-to-lit ratios only; a pixel in shadow or penumbra at either time (cast
    // shadows outside the overlap the planner saw) gets the model, which has the sun fractions,
    // or no ratio without a valid model (2026-12-02, bench/irm_suite.cc: such pixels relit with
    // the lit map were 90 % off).
    const bool lit = source_sun >= set.lit_threshold && target_sun >= set.lit_threshold;
    if (!lit) return model_at();
    const Eigen::Vector3f r = at(MapKind::kLitToLit);
    return Finite(r) ? r : model_at();
  }
  // Pure states read their own map; penumbrae blend exactly through the shadow maps (see the
  // top of irm.h).
  const bool source_lit = source_sun >= set.lit_threshold, source_shadow = source_sun <= set.shadow_threshold;
  const bool target_lit = target_sun >= set.lit_threshold, target_shadow = target_sun <= set.shadow_threshold;
  if ((source_lit || source_shadow) && (target_lit || target_shadow)) {
    const MapKind kind = source_lit ? (target_lit ? MapKind::kLitToLit : MapKind::kLitToShadow)
                                    : (target_lit ? MapKind::kShadowToLit : MapKind::kShadowToShadow);
    const Eigen::Vector3f r = at(kind);
    if (Finite(r)) return r;
  }
  const Eigen::Vector3f r_ss = at(MapKind::kShadowToShadow);
  const Eigen::Vector3f r_ls = at(MapKind::kLitToShadow);
  const Eigen::Vector3f r_sl = at(MapKind::kShadowToLit);
  if (Finite(r_ss) && Finite(r_ls) && Finite(r_sl) && r_ss.minCoeff() > 0.0f && r_ls.minCoeff() > 0.0f) {
    const float fs = std::clamp(source_sun, 0.0f, 1.0f);
    const float ft = std::clamp(target_sun, 0.0f, 1.0f);
    Eigen::Vector3f r;
    for (int c = 0; c < 3; ++c) {
      const float numerator = ft * (r_sl[c] / r_ss[c] - 1.0f) + 1.0f;
      const float denominator = fs * (1.0f / r_ls[c] - 1.0f / r_ss[c]) + 1.0f / r_ss[c];
      r[c] = denominator > 1e-6f ? numerator / denominator : kNaN;
    }
    if (Finite(r)) return r;
  }
  return model_at();
}
}  // namespace

Eigen::Vector3f IrmSet::Ratio(const Eigen::Vector3f& normal, float source_sun, float target_sun, float sky_view,
                              float sky_moment, const Eigen::Vector3f& indirect_source,
                              const Eigen::Vector3f& indirect_target) const {
  auto at = [&](MapKind kind) {
    const RatioMap& map = maps[static_cast<std::size_t>(kind)];
    if (!model_correction || !model.valid) return map.Interpolate(normal);
    // The map's own pure states: the correction compares normals, not sun fractions.
    const float fs = MapSourceSun(kind), ft = MapTargetSun(kind);
    const Eigen::Vector3f at_normal =
        model.Ratio(normal, fs, ft, sky_view, sky_moment, indirect_source, indirect_target);
    return map.Interpolate(normal, [&](std::size_t b) -> Eigen::Vector3f {
      if (!Finite(at_normal)) return Eigen::Vector3f::Constant(kNaN);
      return at_normal.cwiseQuotient(map.model_ratio[b]);
    });
  };
  auto model_at = [&] {
    return model.Ratio(normal, source_sun, target_sun, sky_view, sky_moment, indirect_source, indirect_target);
  };
  return CombineMaps(*this, at, model_at, source_sun, target_sun);
}

RatioTable::RatioTable(const IrmSet& set)
    : set_(&set), bins_(set.maps[0].bins), correct_(set.model_correction && set.model.valid) {
  sun_source_.head<3>() = set.model.sun_source.array();
  sun_target_.head<3>() = set.model.sun_target.array();
  sky_target_.head<3>() = set.model.sky_target.array();
  indirect_scale_.head<3>() = set.model.indirect_scale.array();
  sky_gradient_source_.head<3>() = set.model.sky_gradient_source.array();
  sky_gradient_target_.head<3>() = set.model.sky_gradient_target.array();
  const std::size_t bin_count = static_cast<std::size_t>(bins_) * static_cast<std::size_t>(bins_);
  for (int k = 0; k < 4; ++k) {
    const RatioMap& map = set.maps[static_cast<std::size_t>(k)];
    RELUME_CHECK_MSG(map.bins == bins_ && map.ratio.size() == bin_count && map.source.size() == bin_count,
                     "RatioTable: the maps of an IrmSet share one bin count");
    std::vector<Bin>& bins = maps_[static_cast<std::size_t>(k)];
    bins.resize(bin_count);
    for (std::size_t b = 0; b < bin_count; ++b) {
      Bin& bin = bins[b];
      bin.ratio.head<3>() = map.ratio[b].array();
      if (!Finite(map.ratio[b])) continue;
      bin.flags = kFinite | (map.source[b] == 1 ? kMeasured : 0);
      // As RatioMap::Interpolate's correction: only bins with a model reference.
      if (!correct_ || b >= map.model_ratio.size() || !Finite(map.model_ratio[b])) continue;
      const Eigen::Vector3f& at_bin = map.model_ratio[b];
      bin.ratio_over_model.head<3>() = map.ratio[b].cwiseQuotient(at_bin).array();
      bin.flags |= kCorrected;
    }
  }
}

RatioTable::NormalTerms RatioTable::Prepare(const Eigen::Vector3f& normal) const {
  NormalTerms terms;
  const SunSkyModel& model = set_->model;
  terms.cos_source = std::max(0.0f, normal.dot(model.sun_dir_source));
  terms.cos_target = std::max(0.0f, normal.dot(model.sun_dir_target));
  terms.open_sky = SkyFactor(normal);
  // The four bins around the normal and their weights: the same arithmetic as
  // RatioMap::Interpolate, so that the same bins and weights come out.
  const Eigen::Vector2f uv =
      OctahedralFromDirection(normal) * static_cast<float>(bins_) - Eigen::Vector2f::Constant(0.5f);
  const int i0 = static_cast<int>(std::floor(uv.x())), j0 = static_cast<int>(std::floor(uv.y()));
  const float fx = uv.x() - static_cast<float>(i0), fy = uv.y() - static_cast<float>(j0);
  std::array<std::size_t, 4> corner{};
  std::array<float, 4> weight{};
  for (int dj = 0; dj <= 1; ++dj) {
    for (int di = 0; di <= 1; ++di) {
      const int i = std::clamp(i0 + di, 0, bins_ - 1), j = std::clamp(j0 + dj, 0, bins_ - 1);
      const auto q = static_cast<std::size_t>(2 * dj + di);
      corner[q] = static_cast<std::size_t>(j * bins_ + i);
      weight[q] = std::max(1e-4f, (di ? fx : 1.0f - fx) * (dj ? fy : 1.0f - fy));
    }
  }
  for (std::size_t k = 0; k < 4; ++k) {
    const std::vector<Bin>& bins = maps_[k];
    MapTerms& m = terms.maps[k];
    // Measured bins first: filled values (smoothing, model) only where no measured neighbour is.
    for (const std::uint8_t needed : {std::uint8_t{kFinite | kMeasured}, std::uint8_t{kFinite}}) {
      Eigen::Array4f plain = Eigen::Array4f::Zero(), fixed = Eigen::Array4f::Zero(), corrected = Eigen::Array4f::Zero();
      float total = 0.0f;
      for (std::size_t q = 0; q < 4; ++q) {
        const Bin& bin = bins[corner[q]];
        if ((bin.flags & needed) != needed) continue;
        plain += weight[q] * bin.ratio;
        if (bin.flags & kCorrected) {
          corrected += weight[q] * bin.ratio_over_model;
        } else {
          fixed += weight[q] * bin.ratio;
        }
        total += weight[q];
      }
      if (total > 0.0f) {
        m = {plain / total, fixed / total, corrected / total, true};
        break;
      }
    }
    // No neighbour holds a value: RatioMap::Interpolate then reads the normal's own bin, which
    // is one of them, so there is no value either (`any` stays false).
  }
  return terms;
}

Eigen::Array4f RatioTable::ModelRatio(const NormalTerms& terms, float source_sun, float target_sun, float sky_view,
                                      float sky_moment, const Eigen::Array4f& indirect_source,
                                      const Eigen::Array4f& indirect_target) const {
  if (!set_->model.valid) return Eigen::Array4f::Constant(kNaN);
  const float a_s = source_sun * terms.cos_source;
  const float a_t = target_sun * terms.cos_target;
  // Lane by lane the operations of SunSkyModel::Ratio (and SkyTerm), so the same values.
  Eigen::Array4f h_s, h_t;
  if (std::isfinite(sky_view) && std::isfinite(sky_moment)) {
    h_s = sky_view + sky_gradient_source_ * sky_moment;
    h_t = sky_view + sky_gradient_target_ * sky_moment;
  } else {
    h_s = h_t = Eigen::Array4f::Constant(std::isfinite(sky_view) ? sky_view : terms.open_sky);
  }
  // SunSkyModel::Irradiance: a NaN indirect irradiance counts as none.
  const Eigen::Array4f i_s = indirect_source.isFinite().select(indirect_scale_ * indirect_source, 0.0f);
  const Eigen::Array4f i_t = indirect_target.isFinite().select(indirect_scale_ * indirect_target, 0.0f);
  const Eigen::Array4f source = sun_source_ * a_s + h_s + i_s;
  const Eigen::Array4f target = sun_target_ * a_t + sky_target_ * h_t + i_t;
  return (source > 1e-6f).select(target / source, kNaN);
}

namespace {
bool Finite3(const Eigen::Array4f& v) {
  return v.head<3>().allFinite();
}
Eigen::Vector3f Rgb(const Eigen::Array4f& v) {
  return v.head<3>().matrix();
}
}  // namespace

Eigen::Vector3f RatioTable::Ratio(const NormalTerms& terms, float source_sun, float target_sun, float sky_view,
                                  float sky_moment, const Eigen::Vector3f& indirect_source,
                                  const Eigen::Vector3f& indirect_target) const {
  Eigen::Array4f i_s = Eigen::Array4f::Zero(), i_t = Eigen::Array4f::Zero();
  i_s.head<3>() = indirect_source.array();
  i_t.head<3>() = indirect_target.array();
  auto at = [&](MapKind kind) -> Eigen::Vector3f {
    const MapTerms& m = terms.maps[static_cast<std::size_t>(kind)];
    if (!m.any) return Eigen::Vector3f::Constant(kNaN);
    if (!correct_) return Rgb(m.plain);
    const Eigen::Array4f at_normal =
        ModelRatio(terms, MapSourceSun(kind), MapTargetSun(kind), sky_view, sky_moment, i_s, i_t);
    return Finite3(at_normal) ? Rgb(m.fixed + at_normal * m.corrected) : Rgb(m.plain);
  };
  auto model_at = [&] { return Rgb(ModelRatio(terms, source_sun, target_sun, sky_view, sky_moment, i_s, i_t)); };
  return CombineMaps(*set_, at, model_at, source_sun, target_sun);
}

}  // namespace relume::irm
