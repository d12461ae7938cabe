#include "processing/sh_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "core/error.h"

namespace relume::processing {
namespace {

using Gram = Eigen::Matrix<double, kShCount, kShCount>;
constexpr double kInvPi = 1.0 / std::numbers::pi;

bool Fail(std::string* why, const char* reason) {
  if (why) *why = reason;
  return false;
}

double ConditionFromGram(const Gram& gram, int order) {
  const int n = ShCountForOrder(order);
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(gram.topLeftCorner(n, n));
  const double lo = eig.eigenvalues()(0), hi = eig.eigenvalues()(n - 1);
  if (!(hi > 0.0) || !(lo > hi * 1e-24)) return std::numeric_limits<double>::infinity();
  return std::sqrt(hi / lo);
}

Gram BasisGram(const std::vector<ShObservation>& observations) {
  Gram gram = Gram::Zero();
  for (const ShObservation& o : observations) {
    const ShVector y = ShBasis(o.normal);
    gram.selfadjointView<Eigen::Lower>().rankUpdate(y);
  }
  return gram.selfadjointView<Eigen::Lower>();
}

// Picks the order the normals support and fills the conditioning fields of the summary.
int ChooseOrder(const std::vector<ShObservation>& observations, const ShFitOptions& options, ShFitSummary* summary) {
  const Gram gram = BasisGram(observations);
  const int n = static_cast<int>(observations.size());
  summary->observation_count = n;
  summary->normal_solid_angle_sr = NormalSolidAngleSr(observations);
  summary->condition_number_order2 = ConditionFromGram(gram, 2);
  std::string why;  // "order 2 not supported (...); order 1 not supported (...)"
  for (int order = options.max_order; order >= 0; --order) {
    const double condition = order == 2 ? summary->condition_number_order2 : ConditionFromGram(gram, order);
    const bool enough = n >= options.min_observations_per_coefficient * ShCountForOrder(order);
    const bool well_conditioned = order == 0 ? condition < 1e12 : condition <= options.max_condition_number;
    const bool covered = order < 2 || summary->normal_solid_angle_sr >= options.min_solid_angle_order2_sr;
    if (enough && well_conditioned && covered) {
      summary->order_used = order;
      summary->condition_number = condition;
      summary->order_reduced = order < options.max_order;
      if (summary->order_reduced) summary->message = "order reduced to " + std::to_string(order) + ": " + why;
      return order;
    }
    std::ostringstream reason;
    reason << (why.empty() ? "" : "; ") << "order " << order << " not supported (";
    if (!enough)
      reason << n << " observations < " << options.min_observations_per_coefficient * ShCountForOrder(order);
    else if (!well_conditioned)
      reason << "condition number " << condition << " > " << options.max_condition_number;
    else
      reason << "normals cover " << summary->normal_solid_angle_sr << " sr < " << options.min_solid_angle_order2_sr;
    reason << ")";
    why += reason.str();
  }
  summary->message = "no order supported: " + why;
  return -1;
}

// Least squares for channel c given per-observation albedo.
ShRgb SolveKnownAlbedo(const std::vector<ShObservation>& observations, const std::vector<ShVector>& kernels,
                       int order) {
  const int n = ShCountForOrder(order);
  ShRgb light = ShRgb::Zero();
  for (int c = 0; c < 3; ++c) {
    Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (size_t i = 0; i < observations.size(); ++i) {
      const double a = observations[i].albedo(c) * kInvPi;
      const Eigen::VectorXd row = kernels[i].head(n) * a;
      normal.selfadjointView<Eigen::Lower>().rankUpdate(row);
      rhs += row * observations[i].radiance(c);
    }
    light.col(c).head(n) = normal.selfadjointView<Eigen::Lower>().ldlt().solve(rhs);
  }
  return light;
}

double RelativeResidual(const std::vector<ShObservation>& observations, const std::vector<ShVector>& kernels,
                        const ShRgb& light, const std::vector<Eigen::Vector3d>* segment_albedo) {
  double residual = 0.0, total = 0.0;
  for (size_t i = 0; i < observations.size(); ++i) {
    const Eigen::Vector3d albedo = segment_albedo ? (*segment_albedo)[observations[i].segment] : observations[i].albedo;
    const Eigen::Vector3d model = albedo.cwiseProduct(light.transpose() * kernels[i]) * kInvPi;
    residual += (observations[i].radiance - model).squaredNorm();
    total += observations[i].radiance.squaredNorm();
  }
  return total > 0.0 ? std::sqrt(residual / total) : 0.0;
}

std::vector<ShVector> Kernels(const std::vector<ShObservation>& observations) {
  std::vector<ShVector> kernels;
  kernels.reserve(observations.size());
  for (const ShObservation& o : observations) kernels.push_back(ShIrradianceBasis(o.normal));
  return kernels;
}

// The joint problem's conditioning at a solution of the unknown-albedo fit (sh_fit.h,
// ShFitSummary::albedo_light_condition_number). Per channel, the Gauss-Newton matrix of
// I_i = a_s(i) k_i.L / pi over the light's n coefficients and every used segment's albedo but
// the reference's (fixed: that removes the scale both share) is, with G_s = sum_i k_i k_i^T
// and the common 1/pi^2 dropped:
//   H_LL = sum_s a_s^2 G_s,  H_L,a_s = a_s G_s L,  H_a_s,a_s = L^T G_s L.
// Scaled to a unit diagonal (Jacobi), its condition number is the worst channel's
// sqrt(largest / smallest eigenvalue); infinite when a direction of the light can be traded
// for the albedos without changing any pixel (a flat segment: its albedo absorbs whatever
// irradiance its one normal receives).
double AlbedoLightCondition(const std::vector<Gram>& gram, const std::vector<bool>& used, int reference,
                            const std::vector<Eigen::Vector3d>& albedo, const ShRgb& light, int order) {
  const int n = ShCountForOrder(order);
  std::vector<int> free_segments;
  for (int s = 0; s < static_cast<int>(used.size()); ++s) {
    if (used[s] && s != reference) free_segments.push_back(s);
  }
  const int m = n + static_cast<int>(free_segments.size());
  double worst = 0.0;
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd l = light.col(c).head(n);
    Eigen::MatrixXd h = Eigen::MatrixXd::Zero(m, m);
    for (int s = 0; s < static_cast<int>(used.size()); ++s) {
      if (used[s]) h.topLeftCorner(n, n) += albedo[s](c) * albedo[s](c) * gram[s].topLeftCorner(n, n);
    }
    for (int j = 0; j < static_cast<int>(free_segments.size()); ++j) {
      const int s = free_segments[j];
      const Eigen::VectorXd gl = gram[s].topLeftCorner(n, n) * l;
      h.block(0, n + j, n, 1) = albedo[s](c) * gl;
      h.block(n + j, 0, 1, n) = albedo[s](c) * gl.transpose();
      h(n + j, n + j) = l.dot(gl);
    }
    Eigen::VectorXd scale(m);
    for (int i = 0; i < m; ++i) {
      if (!(h(i, i) > 0.0) || !std::isfinite(h(i, i))) return std::numeric_limits<double>::infinity();
      scale(i) = 1.0 / std::sqrt(h(i, i));
    }
    const Eigen::MatrixXd scaled = scale.asDiagonal() * h * scale.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled, Eigen::EigenvaluesOnly);
    const double lo = eig.eigenvalues()(0), hi = eig.eigenvalues()(m - 1);
    if (!(lo > hi * 1e-24)) return std::numeric_limits<double>::infinity();
    worst = std::max(worst, std::sqrt(hi / lo));
  }
  return worst;
}

}  // namespace

std::vector<ShObservation> GatherObservations(const RadianceImage& radiance, const cv::Mat& normal_in_camera,
                                              const cv::Mat& albedo, const cv::Mat& labels,
                                              const std::vector<cv::Point>& points) {
  if (radiance.pixels.type() != CV_32FC3) throw InvalidArgumentError("SH observations: radiance must be RGB float");
  const cv::Size size = radiance.pixels.size();
  if (normal_in_camera.type() != CV_32FC3 || normal_in_camera.size() != size) {
    throw InvalidArgumentError("SH observations: normals must be CV_32FC3 of the radiance image's size");
  }
  if (!albedo.empty() && (albedo.type() != CV_32FC3 || albedo.size() != size)) {
    throw InvalidArgumentError("SH observations: albedo must be CV_32FC3 of the radiance image's size");
  }
  if (!labels.empty() && (labels.type() != CV_32SC1 || labels.size() != size)) {
    throw InvalidArgumentError("SH observations: labels must be CV_32SC1 of the radiance image's size");
  }
  std::vector<ShObservation> out;
  out.reserve(points.size());
  for (const cv::Point& p : points) {
    if (p.x < 0 || p.y < 0 || p.x >= size.width || p.y >= size.height) continue;
    const cv::Vec3f n = normal_in_camera.at<cv::Vec3f>(p);
    const cv::Vec3f c = radiance.pixels.at<cv::Vec3f>(p);
    if (!std::isfinite(n[0] + n[1] + n[2]) || !std::isfinite(c[0] + c[1] + c[2])) continue;
    if (c[0] < 0 || c[1] < 0 || c[2] < 0) continue;
    ShObservation o;
    o.normal = Eigen::Vector3d(n[0], n[1], n[2]).normalized();
    o.radiance = Eigen::Vector3d(c[0], c[1], c[2]);
    if (!albedo.empty()) {
      const cv::Vec3f a = albedo.at<cv::Vec3f>(p);
      if (!std::isfinite(a[0] + a[1] + a[2])) continue;
      o.albedo = Eigen::Vector3d(a[0], a[1], a[2]);
    }
    if (!labels.empty()) {
      o.segment = labels.at<int>(p);
      if (o.segment < 0) continue;
    }
    out.push_back(o);
  }
  return out;
}

bool ShFitOptions::IsValid(std::string* why) const {
  if (max_order < 0 || max_order > 2) return Fail(why, "max_order must be 0, 1 or 2");
  if (!(max_condition_number >= 1.0)) return Fail(why, "max_condition_number must be >= 1");
  if (!(min_solid_angle_order2_sr >= 0.0) || min_solid_angle_order2_sr > 4.0 * std::numbers::pi) {
    return Fail(why, "min_solid_angle_order2_sr must be in [0, 4 pi]");
  }
  if (min_observations_per_coefficient < 1) return Fail(why, "min_observations_per_coefficient must be >= 1");
  return true;
}

bool ShAlbedoFitOptions::IsValid(std::string* why) const {
  if (!fit.IsValid(why)) return false;
  if (max_iterations < 1) return Fail(why, "max_iterations must be >= 1");
  if (!(tolerance > 0.0)) return Fail(why, "tolerance must be > 0");
  if (min_observations_per_segment < 1) return Fail(why, "min_observations_per_segment must be >= 1");
  if (!(reference_albedo.minCoeff() > 0.0) || !reference_albedo.allFinite()) {
    return Fail(why, "reference_albedo must be positive in every channel");
  }
  return true;
}

std::string ShFitSummary::BriefReport() const {
  std::ostringstream out;
  out << (usable ? "usable" : "NOT usable") << ", order " << order_used << (order_reduced ? " (reduced)" : "") << ", "
      << observation_count << " observations, condition " << condition_number << ", normals cover "
      << normal_solid_angle_sr << " sr, residual " << relative_rms_residual << ", " << iterations << " iteration(s), "
      << (converged ? "converged" : "not converged");
  if (!message.empty()) out << ": " << message;
  return out.str();
}

double NormalSolidAngleSr(const std::vector<ShObservation>& observations) {
  constexpr int kBands = 16, kSectors = 32;  // equal area: uniform in z and in azimuth
  std::array<bool, kBands * kSectors> occupied{};
  for (const ShObservation& o : observations) {
    const double z = std::clamp(o.normal.z(), -1.0, 1.0);
    const int band = std::min(kBands - 1, static_cast<int>((z + 1.0) * 0.5 * kBands));
    double phi = std::atan2(o.normal.y(), o.normal.x());
    if (phi < 0) phi += 2.0 * std::numbers::pi;
    const int sector = std::min(kSectors - 1, static_cast<int>(phi / (2.0 * std::numbers::pi) * kSectors));
    occupied[band * kSectors + sector] = true;
  }
  const auto cells = std::count(occupied.begin(), occupied.end(), true);
  return 4.0 * std::numbers::pi * static_cast<double>(cells) / (kBands * kSectors);
}

double ShConditionNumber(const std::vector<ShObservation>& observations, int order) {
  RELUME_CHECK(order >= 0 && order <= 2);
  return ConditionFromGram(BasisGram(observations), order);
}

std::vector<ShObservation> WithSegmentAlbedo(const std::vector<ShObservation>& observations,
                                             const std::vector<Eigen::Vector3d>& segment_albedo) {
  std::vector<ShObservation> used;
  used.reserve(observations.size());
  for (const ShObservation& o : observations) {
    if (o.segment < 0 || o.segment >= static_cast<int>(segment_albedo.size())) {
      throw InvalidArgumentError("an observation's segment " + std::to_string(o.segment) + " has no albedo (" +
                                 std::to_string(segment_albedo.size()) + " given)");
    }
    const Eigen::Vector3d& a = segment_albedo[static_cast<std::size_t>(o.segment)];
    if (!(a.minCoeff() > 0.0)) continue;
    used.push_back(o);
    used.back().albedo = a;
  }
  return used;
}

ShFitResult FitShKnownAlbedo(const std::vector<ShObservation>& observations, const ShFitOptions& options) {
  ThrowIfInvalid(options, "SH fit");
  ShFitResult result;
  const int order = ChooseOrder(observations, options, &result.summary);
  if (order < 0) return result;
  const std::vector<ShVector> kernels = Kernels(observations);
  result.light = SolveKnownAlbedo(observations, kernels, order);
  result.summary.usable = result.light.allFinite();
  if (!result.summary.usable) {
    result.light.setZero();
    result.summary.message += "least squares gave non-finite coefficients (zero albedo?)";
    return result;
  }
  result.summary.iterations = 1;
  result.summary.converged = true;
  result.summary.relative_rms_residual = RelativeResidual(observations, kernels, result.light, nullptr);
  if (result.summary.message.empty()) result.summary.message = "linear least squares";
  return result;
}

ShAlbedoFitResult FitShUnknownAlbedo(const std::vector<ShObservation>& observations,
                                     const ShAlbedoFitOptions& options) {
  ThrowIfInvalid(options, "SH fit with unknown albedo");
  ShAlbedoFitResult result;
  ShFitSummary& summary = result.summary;

  // Segments with enough observations take part; the rest are left out.
  int segments = 0;
  for (const ShObservation& o : observations) {
    if (o.segment < 0)
      throw InvalidArgumentError("SH fit with unknown albedo: observation with a negative segment label");
    segments = std::max(segments, o.segment + 1);
  }
  std::vector<int> counts(segments, 0);
  for (const ShObservation& o : observations) ++counts[o.segment];
  result.segment_used.assign(segments, false);
  result.segment_albedo.assign(segments, Eigen::Vector3d::Zero());
  std::vector<ShObservation> used;
  for (const ShObservation& o : observations) {
    if (counts[o.segment] >= options.min_observations_per_segment) used.push_back(o);
  }
  for (int s = 0; s < segments; ++s) result.segment_used[s] = counts[s] >= options.min_observations_per_segment;
  int reference = options.reference_segment;
  if (reference < 0) {
    reference = static_cast<int>(std::max_element(counts.begin(), counts.end()) - counts.begin());
  }
  if (reference >= segments || !result.segment_used[reference]) {
    summary.message = segments == 0 ? "no observations"
                                    : "reference segment " + std::to_string(reference) + " has too few observations";
    return result;
  }
  result.reference_segment = reference;

  const int order = ChooseOrder(used, options.fit, &summary);
  if (order < 0) return result;
  const int n = ShCountForOrder(order);
  const std::string order_note = summary.message;

  // Per-segment sufficient statistics: Gram matrices of the kernels and moments with each
  // channel, so that every alternation costs O(segments), not O(observations).
  const std::vector<ShVector> kernels = Kernels(used);
  std::vector<Gram> gram(segments, Gram::Zero());
  std::vector<ShRgb> moment(segments, ShRgb::Zero());
  std::vector<Eigen::Vector3d> mean(segments, Eigen::Vector3d::Zero());
  for (size_t i = 0; i < used.size(); ++i) {
    const int s = used[i].segment;
    gram[s].selfadjointView<Eigen::Lower>().rankUpdate(kernels[i]);
    moment[s] += kernels[i] * used[i].radiance.transpose();
    mean[s] += used[i].radiance / counts[s];
  }
  for (Gram& g : gram) g = g.selfadjointView<Eigen::Lower>();

  // Initial albedo: the segment's mean colour (Ogura & Saito), rescaled to the reference.
  std::vector<Eigen::Vector3d>& albedo = result.segment_albedo;
  for (int s = 0; s < segments; ++s) albedo[s] = result.segment_used[s] ? mean[s] : Eigen::Vector3d::Zero();
  if (!(albedo[reference].minCoeff() > 0.0)) {
    summary.message = "reference segment is black in some channel: its albedo cannot fix the scale";
    return result;
  }
  const Eigen::Vector3d first_scale = options.reference_albedo.cwiseQuotient(albedo[reference]);
  for (Eigen::Vector3d& a : albedo) a = a.cwiseProduct(first_scale);

  ShRgb light = ShRgb::Zero();
  std::string stop;
  for (int iteration = 1; iteration <= options.max_iterations; ++iteration) {
    // Illumination step.
    ShRgb next = ShRgb::Zero();
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd normal = Eigen::MatrixXd::Zero(n, n);
      Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
      for (int s = 0; s < segments; ++s) {
        if (!result.segment_used[s]) continue;
        const double a = albedo[s](c) * kInvPi;
        normal += a * a * gram[s].topLeftCorner(n, n);
        rhs += a * moment[s].col(c).head(n);
      }
      next.col(c).head(n) = normal.ldlt().solve(rhs);
    }
    // Albedo step: a = sum I E / sum E^2 per segment and channel, E = kernel . L / pi.
    for (int s = 0; s < segments; ++s) {
      if (!result.segment_used[s]) continue;
      for (int c = 0; c < 3; ++c) {
        const Eigen::VectorXd l = next.col(c).head(n);
        const double e2 = l.dot(gram[s].topLeftCorner(n, n) * l) * kInvPi * kInvPi;
        const double ie = moment[s].col(c).head(n).dot(l) * kInvPi;
        albedo[s](c) = e2 > 0.0 ? ie / e2 : 0.0;
      }
    }
    // Scale: the reference segment keeps reference_albedo.
    if (!(albedo[reference].minCoeff() > 0.0) || !next.allFinite()) {
      stop = "degenerate at iteration " + std::to_string(iteration) + ": the reference segment lost its irradiance";
      summary.iterations = iteration;
      break;
    }
    const Eigen::Vector3d scale = options.reference_albedo.cwiseQuotient(albedo[reference]);
    for (Eigen::Vector3d& a : albedo) a = a.cwiseProduct(scale);
    next = next * scale.cwiseInverse().asDiagonal();
    const double change = (next - light).norm() / std::max(next.norm(), 1e-300);
    light = next;
    summary.iterations = iteration;
    if (change < options.tolerance) {
      summary.converged = true;
      std::ostringstream s;
      s << "converged: coefficient change " << change << " < " << options.tolerance << " after " << iteration
        << " iteration(s)";
      stop = s.str();
      break;
    }
    if (iteration == options.max_iterations) {
      std::ostringstream s;
      s << "stopped at max_iterations " << iteration << " with coefficient change " << change;
      stop = s.str();
    }
  }
  result.light = light;
  summary.usable = summary.converged || summary.iterations == options.max_iterations;
  if (!summary.usable) result.light.setZero();
  std::ostringstream message;
  message << stop << "; scale fixed by segment " << reference << " albedo = (" << options.reference_albedo.transpose()
          << ")";
  if (!order_note.empty()) message << "; " << order_note;
  summary.message = message.str();
  summary.relative_rms_residual = RelativeResidual(used, kernels, result.light, &result.segment_albedo);
  if (summary.usable) {
    summary.albedo_light_condition_number =
        AlbedoLightCondition(gram, result.segment_used, reference, result.segment_albedo, result.light, order);
  }
  return result;
}

}  // namespace relume::processing
