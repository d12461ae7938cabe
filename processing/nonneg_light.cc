#include "processing/nonneg_light.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "core/error.h"

namespace relume::processing {
namespace {

constexpr double kInvPi = 1.0 / std::numbers::pi;

bool Fail(std::string* why, const char* reason) {
  if (why) *why = reason;
  return false;
}

struct NnlsOutcome {
  Eigen::VectorXd x;
  int iterations = 0;
  bool converged = false;
};

// The normal equations' columns A^T a_j + ridge e_j of the design matrix A, each computed when a
// direction first enters a passive set and kept, shared by the three channels' solves.
class GramColumns {
 public:
  GramColumns(const Eigen::MatrixXd& a, double ridge)
      : a_(a), ridge_(ridge * a.colwise().squaredNorm().mean()), column_(static_cast<std::size_t>(a.cols())) {}
  const Eigen::VectorXd& col(int j) {
    Eigen::VectorXd& c = column_[static_cast<std::size_t>(j)];
    if (c.size() == 0) {
      c.noalias() = a_.transpose() * a_.col(j);
      c(j) += ridge_;
    }
    return c;
  }

 private:
  const Eigen::MatrixXd& a_;
  double ridge_;
  std::vector<Eigen::VectorXd> column_;
};

// The unconstrained solution of the normal equations on the directions `set`.
Eigen::VectorXd SolveOn(GramColumns& gram, const Eigen::VectorXd& b, const std::vector<int>& set) {
  const int m = static_cast<int>(set.size());
  Eigen::MatrixXd g(m, m);
  Eigen::VectorXd rhs(m);
  for (int c = 0; c < m; ++c) {
    const int j = set[static_cast<std::size_t>(c)];
    const Eigen::VectorXd& column = gram.col(j);
    rhs(c) = b(j);
    for (int r = 0; r < m; ++r) g(r, c) = column(set[static_cast<std::size_t>(r)]);
  }
  return g.ldlt().solve(rhs);
}

std::vector<int> Members(const std::vector<bool>& passive) {
  std::vector<int> set;
  for (int j = 0; j < static_cast<int>(passive.size()); ++j) {
    if (passive[static_cast<std::size_t>(j)]) set.push_back(j);
  }
  return set;
}

// Lawson & Hanson's active-set NNLS on the normal equations: min x^T G x / 2 - b^T x, x >= 0
// (G = A^T A + ridge, b = A^T y). A direction enters the passive set when its gradient is the
// largest positive; the passive set's unconstrained solution is taken when positive, else the
// step stops at the first weight to reach zero, which leaves the set. G's columns are computed
// only for directions that enter a passive set (GramColumns), once for the three channels. On
// the quick SH suites (12 scenes, 512 directions; fit + refit of two frames and the relighting)
// this takes 0.070 s per lamp-lit scene and 0.130 s under smooth lights, against 0.159 and
// 0.181 s forming all of G by one rank update (measured 2026-12-07).
// warm_start: directions to start from (another channel's or a previous fit's solution),
// dropped while their unconstrained solution is not positive (Bro & de Jong 1997), so the
// active-set steps begin near the answer.
NnlsOutcome SolveNnls(GramColumns& gram, const Eigen::VectorXd& b, const Eigen::VectorXd* warm_start) {
  const int n = static_cast<int>(b.size());
  NnlsOutcome out;
  out.x = Eigen::VectorXd::Zero(n);
  std::vector<bool> passive(static_cast<std::size_t>(n), false);
  if (warm_start) {
    for (int j = 0; j < n; ++j) passive[static_cast<std::size_t>(j)] = (*warm_start)(j) > 0.0;
    for (;;) {
      const std::vector<int> set = Members(passive);
      if (set.empty()) break;
      const Eigen::VectorXd z = SolveOn(gram, b, set);
      if (z.minCoeff() > 0.0) {
        for (std::size_t r = 0; r < set.size(); ++r) out.x(set[r]) = z(static_cast<Eigen::Index>(r));
        break;
      }
      for (std::size_t r = 0; r < set.size(); ++r) {
        if (z(static_cast<Eigen::Index>(r)) <= 0.0) passive[static_cast<std::size_t>(set[r])] = false;
      }
    }
  }
  const double tolerance = 1e-10 * std::max(1e-300, b.cwiseAbs().maxCoeff());
  const int max_iterations = 3 * n;
  for (; out.iterations < max_iterations; ++out.iterations) {
    Eigen::VectorXd w = b;
    for (int j = 0; j < n; ++j) {
      if (out.x(j) != 0.0) w -= gram.col(j) * out.x(j);
    }
    int enter = -1;
    double best = tolerance;
    for (int j = 0; j < n; ++j) {
      if (!passive[static_cast<std::size_t>(j)] && w(j) > best) {
        best = w(j);
        enter = j;
      }
    }
    if (enter < 0) {
      out.converged = true;
      return out;
    }
    passive[static_cast<std::size_t>(enter)] = true;
    for (int inner = 0; inner < n; ++inner) {
      const std::vector<int> set = Members(passive);
      const int m = static_cast<int>(set.size());
      const Eigen::VectorXd z = SolveOn(gram, b, set);
      if (z.minCoeff() > 0.0) {
        for (int r = 0; r < m; ++r) out.x(set[static_cast<std::size_t>(r)]) = z(r);
        break;
      }
      // Step from x toward z until the first passive weight reaches zero.
      double alpha = 1.0;
      for (int r = 0; r < m; ++r) {
        const int j = set[static_cast<std::size_t>(r)];
        if (z(r) <= 0.0) alpha = std::min(alpha, out.x(j) / (out.x(j) - z(r)));
      }
      for (int r = 0; r < m; ++r) {
        const int j = set[static_cast<std::size_t>(r)];
        out.x(j) += alpha * (z(r) - out.x(j));
        if (out.x(j) <= 1e-15 * std::max(1.0, std::abs(z(r)))) {
          out.x(j) = 0.0;
          passive[static_cast<std::size_t>(j)] = false;
        }
      }
    }
  }
  return out;
}

}  // namespace

bool NonNegativeLightOptions::IsValid(std::string* why) const {
  if (direction_count < 6 || direction_count > 4096) return Fail(why, "direction_count must be in [6, 4096]");
  if (min_observations < 1) return Fail(why, "min_observations must be >= 1");
  if (!(ridge >= 0.0 && ridge < 1.0)) return Fail(why, "ridge must be in [0, 1)");
  if (outlier_rounds < 0 || outlier_rounds > 10) return Fail(why, "outlier_rounds must be in [0, 10]");
  if (!(outlier_mads > 0.0)) return Fail(why, "outlier_mads must be > 0");
  if (!(min_outlier_residual >= 0.0)) return Fail(why, "min_outlier_residual must be >= 0");
  return true;
}

std::vector<Eigen::Vector3d> FibonacciDirections(int count) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(static_cast<std::size_t>(std::max(0, count)));
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / count;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = golden * i;
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

Eigen::Vector3d NonNegativeLight::Irradiance(const Eigen::Vector3d& n) const {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (std::size_t j = 0; j < directions.size(); ++j) e += irradiance[j] * std::max(0.0, n.dot(directions[j]));
  return e;
}

ShRgb NonNegativeLight::ToSh() const {
  ShRgb sh = ShRgb::Zero();
  for (std::size_t j = 0; j < directions.size(); ++j) sh += ShBasis(directions[j]) * irradiance[j].transpose();
  return sh;
}

namespace {

// One fit on the observations `use` marks (all when empty).
// grid_weights: in, the previous fit's weights on the grid to start from (empty: none); out, this
// fit's (K x 3).
NonNegativeLightResult FitOnce(const std::vector<ShObservation>& observations, const std::vector<bool>& use,
                               const std::vector<Eigen::Vector3d>& grid, const NonNegativeLightOptions& options,
                               Eigen::MatrixXd* grid_weights) {
  NonNegativeLightResult result;
  NonNegativeLightSummary& summary = result.summary;
  std::vector<int> rows;
  for (int i = 0; i < static_cast<int>(observations.size()); ++i) {
    // An albedo of 0 in a channel says nothing about that channel's light.
    const bool lit = observations[static_cast<std::size_t>(i)].albedo.minCoeff() > 0.0;
    if (lit && (use.empty() || use[static_cast<std::size_t>(i)])) rows.push_back(i);
  }
  const int n = static_cast<int>(rows.size()), k = static_cast<int>(grid.size());
  // In irradiance units, E_i = pi I_i / albedo_i per channel, each row weighted by the
  // observation's mean albedo / pi: the radiance-space least squares up to the albedo's tint,
  // with one design matrix (and one set of normal-equation columns) for the three channels.
  // design(i, j) = weight_i max(0, n_i . d_j).
  Eigen::MatrixXd design(n, k);
  Eigen::MatrixXd target(n, 3);
  for (int i = 0; i < n; ++i) {
    const ShObservation& o = observations[static_cast<std::size_t>(rows[static_cast<std::size_t>(i)])];
    const double weight = o.albedo.mean() * kInvPi;
    target.row(i) = (std::numbers::pi * o.radiance.cwiseQuotient(o.albedo)).transpose() * weight;
    for (int j = 0; j < k; ++j) design(i, j) = weight * std::max(0.0, o.normal.dot(grid[static_cast<std::size_t>(j)]));
  }
  GramColumns gram(design, options.ridge);
  const Eigen::MatrixXd rhs = design.transpose() * target;
  Eigen::MatrixXd weights(k, 3);
  summary.converged = true;
  for (int c = 0; c < 3; ++c) {
    // Each channel starts from the one before (the first from the previous fit's): the channels
    // of one light share most of their directions.
    Eigen::VectorXd start;
    if (c > 0)
      start = weights.col(c - 1);
    else if (grid_weights->rows() == k)
      start = grid_weights->col(0);
    const NnlsOutcome solved = SolveNnls(gram, rhs.col(c), start.size() > 0 ? &start : nullptr);
    weights.col(c) = solved.x;
    summary.iterations += solved.iterations;
    summary.converged = summary.converged && solved.converged;
  }
  for (int j = 0; j < k; ++j) {
    if (weights.row(j).maxCoeff() > 0.0) {
      result.light.directions.push_back(grid[static_cast<std::size_t>(j)]);
      result.light.irradiance.push_back(weights.row(j).transpose());
    }
  }
  summary.active_direction_count = static_cast<int>(result.light.directions.size());
  *grid_weights = weights;
  return result;
}

// The light's radiance a E(n) / pi at each observation.
std::vector<Eigen::Vector3d> Predict(const std::vector<ShObservation>& observations, const NonNegativeLight& light) {
  std::vector<Eigen::Vector3d> model;
  model.reserve(observations.size());
  for (const ShObservation& o : observations)
    model.push_back(o.albedo.cwiseProduct(light.Irradiance(o.normal)) * kInvPi);
  return model;
}

// |I - model| per observation, summed over channels, relative to the observations' mean |I|.
std::vector<double> Residuals(const std::vector<ShObservation>& observations,
                              const std::vector<Eigen::Vector3d>& model) {
  std::vector<double> out;
  out.reserve(observations.size());
  double level = 0.0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    out.push_back((observations[i].radiance - model[i]).cwiseAbs().sum());
    level += observations[i].radiance.cwiseAbs().sum();
  }
  level /= static_cast<double>(std::max<std::size_t>(1, observations.size()));
  if (level > 0.0) {
    for (double& r : out) r /= level;
  }
  return out;
}

double Median(std::vector<double> values) {
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace

NonNegativeLightResult FitNonNegativeLight(const std::vector<ShObservation>& observations,
                                           const NonNegativeLightOptions& options) {
  ThrowIfInvalid(options, "non-negative light fit");
  const int n = static_cast<int>(observations.size());
  if (n < options.min_observations) {
    NonNegativeLightResult result;
    result.summary.observation_count = n;
    result.summary.message = std::to_string(n) + " observations < " + std::to_string(options.min_observations);
    return result;
  }
  const std::vector<Eigen::Vector3d> grid = FibonacciDirections(options.direction_count);
  Eigen::MatrixXd grid_weights;
  NonNegativeLightResult result = FitOnce(observations, {}, grid, options, &grid_weights);
  int iterations = result.summary.iterations;
  int left_out = 0;                    // by the last refit
  std::vector<Eigen::Vector3d> model;  // Predict(result.light), or empty when not yet evaluated
  for (int round = 0; round < options.outlier_rounds && !result.light.directions.empty(); ++round) {
    model = Predict(observations, result.light);
    const std::vector<double> residual = Residuals(observations, model);
    const double median = Median(residual);
    std::vector<double> deviation;
    deviation.reserve(residual.size());
    for (double r : residual) deviation.push_back(std::abs(r - median));
    const double threshold =
        std::max(options.min_outlier_residual, median + options.outlier_mads * 1.4826 * Median(deviation));
    std::vector<bool> use(residual.size());
    int outliers = 0;
    for (std::size_t i = 0; i < residual.size(); ++i) {
      use[i] = residual[i] <= threshold;
      outliers += use[i] ? 0 : 1;
    }
    if (outliers == 0 || n - outliers < options.min_observations) break;
    result = FitOnce(observations, use, grid, options, &grid_weights);
    model.clear();
    iterations += result.summary.iterations;
    left_out = outliers;
  }
  NonNegativeLightSummary& summary = result.summary;
  summary.observation_count = n;
  summary.outlier_count = left_out;
  summary.iterations = iterations;
  // The residual over every observation, outliers included (the light is evaluated once more
  // only if a refit changed it).
  if (model.empty()) model = Predict(observations, result.light);
  double residual = 0.0, total = 0.0;
  for (std::size_t i = 0; i < observations.size(); ++i) {
    residual += (observations[i].radiance - model[i]).squaredNorm();
    total += observations[i].radiance.squaredNorm();
  }
  summary.relative_rms_residual = total > 0.0 ? std::sqrt(residual / total) : 0.0;
  if (summary.active_direction_count == 0) {
    summary.message = "no light: every channel's best non-negative fit is zero";
    return result;
  }
  summary.usable = true;
  if (!summary.converged) summary.message = "the active-set solver stopped at its iteration limit";
  return result;
}

NonNegativeLightResult FitNonNegativeLightKnownSegments(const std::vector<ShObservation>& observations,
                                                        const std::vector<Eigen::Vector3d>& segment_albedo,
                                                        const NonNegativeLightOptions& options) {
  return FitNonNegativeLight(WithSegmentAlbedo(observations, segment_albedo), options);
}

NonNegativeSegmentFitResult FitNonNegativeLightSegments(const std::vector<ShObservation>& observations,
                                                        std::vector<Eigen::Vector3d> segment_albedo,
                                                        int reference_segment, int rounds,
                                                        const NonNegativeLightOptions& options) {
  const int segments = static_cast<int>(segment_albedo.size());
  if (reference_segment < 0 || reference_segment >= segments ||
      !(segment_albedo[static_cast<std::size_t>(reference_segment)].minCoeff() > 0.0)) {
    throw InvalidArgumentError("non-negative light fit: the reference segment must have a positive albedo");
  }
  if (rounds < 1) throw InvalidArgumentError("non-negative light fit: rounds must be >= 1");
  std::vector<ShObservation> used = WithSegmentAlbedo(observations, segment_albedo);
  const Eigen::Vector3d reference = segment_albedo[static_cast<std::size_t>(reference_segment)];
  NonNegativeSegmentFitResult result;
  for (int round = 0; round < rounds; ++round) {
    for (ShObservation& o : used) o.albedo = segment_albedo[static_cast<std::size_t>(o.segment)];
    result.fit = FitNonNegativeLight(used, options);
    if (!result.fit.summary.usable) break;
    // Albedo step, then the reference's albedo restored (the light takes the inverse scale).
    std::vector<Eigen::Vector3d> ie(static_cast<std::size_t>(segments), Eigen::Vector3d::Zero()),
        ee(static_cast<std::size_t>(segments), Eigen::Vector3d::Zero());
    for (const ShObservation& o : used) {
      const Eigen::Vector3d e = result.fit.light.Irradiance(o.normal) * kInvPi;
      ie[static_cast<std::size_t>(o.segment)] += o.radiance.cwiseProduct(e);
      ee[static_cast<std::size_t>(o.segment)] += e.cwiseProduct(e);
    }
    std::vector<Eigen::Vector3d> next = segment_albedo;
    for (int s = 0; s < segments; ++s) {
      const std::size_t i = static_cast<std::size_t>(s);
      if (!(segment_albedo[i].minCoeff() > 0.0) || !(ee[i].minCoeff() > 0.0)) continue;
      next[i] = ie[i].cwiseQuotient(ee[i]);
    }
    const Eigen::Vector3d& got = next[static_cast<std::size_t>(reference_segment)];
    if (!(got.minCoeff() > 0.0) || !got.allFinite()) break;  // keep the albedos the light was fitted with
    const Eigen::Vector3d scale = reference.cwiseQuotient(got);
    for (Eigen::Vector3d& a : next) a = a.cwiseProduct(scale).cwiseMax(0.0);
    for (Eigen::Vector3d& w : result.fit.light.irradiance) w = w.cwiseQuotient(scale);
    segment_albedo = std::move(next);
  }
  result.segment_albedo = std::move(segment_albedo);
  return result;
}

std::string NonNegativeLightSummary::BriefReport() const {
  std::ostringstream out;
  out << (usable ? "usable" : "NOT usable") << ", " << observation_count << " observations (" << outlier_count
      << " left out as outliers), " << active_direction_count << " active direction(s), residual "
      << relative_rms_residual << ", " << iterations << " active-set step(s), "
      << (converged ? "converged" : "not converged");
  if (!message.empty()) out << ": " << message;
  return out.str();
}

}  // namespace relume::processing
