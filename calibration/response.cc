#include "calibration/response.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numeric>
#include <opencv2/core.hpp>
#include <random>
#include <sstream>

#include "calibration/bracket.h"
#include "core/error.h"

namespace relume::calibration {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

// Sampled code values: codes[(sample * frames + frame) * channels + channel], frames sorted
// by exposure (shortest first).
struct Samples {
  int count = 0;
  int frames = 0;
  int channels = 0;
  std::vector<std::uint8_t> codes;
  std::uint8_t at(int sample, int frame, int channel) const {
    return codes[(static_cast<std::size_t>(sample) * frames + frame) * channels + channel];
  }
};

// Picks pixels spread over the brightness range and over the image, preferring flat ones.
// Brightness is the sum over all frames of the channel mean: it grows with scene radiance for
// any monotonic response, so bins of it cover the code range in every frame, including pixels
// black in the middle frame (bright in long ones) and saturated ones (mid-grey in short ones).
Samples SelectSamples(const std::vector<const cv::Mat*>& sorted, int wanted, std::uint64_t seed) {
  const int rows = sorted[0]->rows;
  const int cols = sorted[0]->cols;
  const int channels = sorted[0]->channels();
  const int frames = static_cast<int>(sorted.size());
  // Candidate grid: at most ~250k pixels, away from the border.
  const int stride = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(rows) * cols / 250000.0)));
  struct Candidate {
    int x, y, score, roughness;
  };
  std::vector<Candidate> candidates;
  auto score_at = [&](int x, int y) {
    int s = 0;
    for (const cv::Mat* m : sorted) {
      const std::uint8_t* p = m->ptr<std::uint8_t>(y) + static_cast<std::size_t>(x) * channels;
      for (int c = 0; c < channels; ++c) s += p[c];
    }
    return s / channels;
  };
  for (int y = 1; y + 1 < rows; y += stride) {
    for (int x = 1; x + 1 < cols; x += stride) {
      const int s = score_at(x, y);
      const int rough = std::max({std::abs(score_at(x - 1, y) - s), std::abs(score_at(x + 1, y) - s),
                                  std::abs(score_at(x, y - 1) - s), std::abs(score_at(x, y + 1) - s)});
      candidates.push_back({x, y, s, rough});
    }
  }
  Samples samples;
  samples.frames = frames;
  samples.channels = channels;
  if (candidates.empty()) return samples;
  std::mt19937_64 rng(seed);
  std::shuffle(candidates.begin(), candidates.end(), rng);
  // Flat first: roughness up to 2 codes per frame counts as flat (noise and quantisation).
  std::stable_partition(candidates.begin(), candidates.end(),
                        [&](const Candidate& c) { return c.roughness <= 2 * frames; });
  const int max_score = 255 * frames;
  const int bins = std::clamp(wanted / 4, 1, 64);
  std::vector<std::vector<int>> by_bin(bins);
  for (int i = 0; i < static_cast<int>(candidates.size()); ++i) {
    by_bin[std::min(bins - 1, candidates[i].score * bins / (max_score + 1))].push_back(i);
  }
  std::vector<int> chosen;
  std::vector<std::size_t> next(bins, 0);
  bool any = true;
  while (static_cast<int>(chosen.size()) < wanted && any) {
    any = false;
    for (int b = 0; b < bins && static_cast<int>(chosen.size()) < wanted; ++b) {
      if (next[b] < by_bin[b].size()) {
        chosen.push_back(by_bin[b][next[b]++]);
        any = true;
      }
    }
  }
  samples.count = static_cast<int>(chosen.size());
  samples.codes.resize(static_cast<std::size_t>(samples.count) * frames * channels);
  for (int s = 0; s < samples.count; ++s) {
    const Candidate& c = candidates[chosen[s]];
    for (int f = 0; f < frames; ++f) {
      const std::uint8_t* p = sorted[f]->ptr<std::uint8_t>(c.y) + static_cast<std::size_t>(c.x) * channels;
      for (int ch = 0; ch < channels; ++ch) {
        samples.codes[(static_cast<std::size_t>(s) * frames + f) * channels + ch] = p[ch];
      }
    }
  }
  return samples;
}

// Makes the curve non-decreasing (running maximum); returns how many codes changed.
int MakeMonotonic(std::vector<double>& curve) {
  int fixes = 0;
  for (std::size_t z = 1; z < curve.size(); ++z) {
    if (curve[z] < curve[z - 1]) {
      curve[z] = curve[z - 1];
      ++fixes;
    }
  }
  return fixes;
}

struct ChannelSolve {
  std::vector<double> inverse;  // relative exposure per code
  double residual = 0.0;
  double condition = 0.0;
  int samples_used = 0;
  int iterations = 0;
  bool converged = false;
  int monotonic_fixes = 0;
  std::optional<double> prior_disagreement;  // Debevec only
  std::string problem;                       // non-empty: unusable
};

constexpr int kMinDistinctCodes = 4;

// Samples with at least two frames inside the weighted range constrain the curve's shape.
std::vector<int> InformativeSamples(const Samples& samples, int channel, const std::vector<double>& weight) {
  std::vector<int> useful;
  for (int s = 0; s < samples.count; ++s) {
    int good = 0;
    for (int f = 0; f < samples.frames; ++f) good += weight[samples.at(s, f, channel)] > 0.0 ? 1 : 0;
    if (good >= 2) useful.push_back(s);
  }
  return useful;
}

// Of the informative samples, the fraction that are brighter in the longest exposure than in the
// shortest. A real bracket brightens nearly every one (a sample clipped at both ends is not
// informative); identical frames give 0, and frames with shuffled exposure labels far less
// than one half. The solvers would fit a curve to either (a step, with a small residual).
double BrighteningFraction(const Samples& samples, int channel, const std::vector<int>& informative) {
  if (informative.empty()) return 1.0;
  int brighter = 0;
  for (const int s : informative) brighter += samples.at(s, samples.frames - 1, channel) > samples.at(s, 0, channel);
  return static_cast<double>(brighter) / static_cast<double>(informative.size());
}
constexpr double kMinBrighteningFraction = 0.5;

// Debevec & Malik 1997: unknowns g(z) = ln X(z) and ln E_i per sample; equations
// w(z_ij) [g(z_ij) - ln E_i - ln t_j] = 0, lambda w(z) D g(z) = 0 (D: the smoothness operator),
// g(mid) = 0. The sample unknowns are eliminated (Schur complement: each ln E_i couples only to
// its own codes), so the solve is a dense levels x levels system whatever the sample count.
struct DebevecData {
  Eigen::MatrixXd normal;  // data part of the reduced normal equations
  Eigen::VectorXd rhs;
};

DebevecData ReducedDataEquations(const Samples& samples, int channel, const std::vector<int>& useful,
                                 const std::vector<double>& log_t, const std::vector<double>& weight) {
  const int n = static_cast<int>(weight.size());
  DebevecData data{Eigen::MatrixXd::Zero(n, n), Eigen::VectorXd::Zero(n)};
  Eigen::MatrixXd& S = data.normal;
  Eigen::VectorXd& rhs = data.rhs;
  std::vector<int> z(samples.frames);
  std::vector<double> w2(samples.frames);
  for (int s : useful) {
    // Rows for this sample: w (g_z - e) = w ln t. Normal-equation blocks: A_gg, A_ge, d = sum w^2.
    double d = 0.0, be = 0.0;
    for (int f = 0; f < samples.frames; ++f) {
      z[f] = samples.at(s, f, channel);
      w2[f] = weight[z[f]] * weight[z[f]];
      d += w2[f];
      S(z[f], z[f]) += w2[f];
      rhs(z[f]) += w2[f] * log_t[f];
      be -= w2[f] * log_t[f];
    }
    // Eliminate e: S -= a a^T / d, rhs -= a * be / d, with a_z = -sum w^2 over frames at code z.
    for (int f = 0; f < samples.frames; ++f) {
      if (w2[f] == 0.0) continue;
      for (int k = 0; k < samples.frames; ++k) {
        if (w2[k] == 0.0) continue;
        S(z[f], z[k]) -= w2[f] * w2[k] / d;
      }
      rhs(z[f]) -= (-w2[f]) * be / d;
    }
  }
  return data;
}

// Three-point stencil of the smoothness operator at code c (1 <= c <= levels - 2), applied to
// g(c - 1), g(c), g(c + 1). kLogCode: the second derivative in v = ln z on the non-uniform grid
// (exact, so zero for every power law), times 1/c^2 so that it is in units of codes^-2 like
// kCode's [1, -2, 1]; at c = 1 (code 0 has no logarithm) the same operator by central
// differences: g'' + g'/z.
std::array<double, 3> SmoothnessStencil(ResponseSmoothness smoothness, int c) {
  if (smoothness == ResponseSmoothness::kCode) return {1.0, -2.0, 1.0};
  if (c == 1) return {1.0 - 0.5, -2.0, 1.0 + 0.5};
  const double h1 = std::log(static_cast<double>(c) / (c - 1));
  const double h2 = std::log(static_cast<double>(c + 1) / c);
  const double scale = 2.0 / (static_cast<double>(c) * c * (h1 + h2));
  const double lo = scale / h1, hi = scale / h2;
  return {lo, -lo - hi, hi};
}

// Smoothness rows, with a small weight floor so codes never observed are extrapolated
// smoothly, and g(mid) = 0.
void AddSmoothness(Eigen::MatrixXd& S, const std::vector<double>& weight, double lambda,
                   ResponseSmoothness smoothness) {
  const int n = static_cast<int>(weight.size());
  for (int c = 1; c + 1 < n; ++c) {
    const double lw = lambda * std::max(weight[c], 0.05);
    const int idx[3] = {c - 1, c, c + 1};
    const std::array<double, 3> coef = SmoothnessStencil(smoothness, c);
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) S(idx[a], idx[b]) += lw * lw * coef[a] * coef[b];
    }
  }
  S(n / 2, n / 2) += 1.0;
}

// RMS of the data equations, with each sample's optimal ln E.
double DataResidual(const Samples& samples, int channel, const std::vector<int>& useful,
                    const std::vector<double>& log_t, const std::vector<double>& weight, const Eigen::VectorXd& g) {
  double sum = 0.0;
  int rows = 0;
  for (int s : useful) {
    double num = 0.0, den = 0.0;
    for (int f = 0; f < samples.frames; ++f) {
      const int zf = samples.at(s, f, channel);
      const double ww = weight[zf] * weight[zf];
      num += ww * (g(zf) - log_t[f]);
      den += ww;
    }
    const double e = num / den;
    for (int f = 0; f < samples.frames; ++f) {
      const int zf = samples.at(s, f, channel);
      const double r = weight[zf] * (g(zf) - e - log_t[f]);
      sum += r * r;
      rows += weight[zf] > 0.0 ? 1 : 0;
    }
  }
  return std::sqrt(sum / std::max(rows, 1));
}

// g -> X(z) = exp(g(z) - g(mid)), made non-decreasing; X(0) = 0 (black stands for no light).
std::vector<double> InverseFromLog(const Eigen::VectorXd& g, int* monotonic_fixes) {
  const int n = static_cast<int>(g.size());
  std::vector<double> log_curve(g.data(), g.data() + n);
  const int fixes = MakeMonotonic(log_curve);
  if (monotonic_fixes) *monotonic_fixes = fixes;
  std::vector<double> inverse(n, 0.0);
  for (int c = 1; c < n; ++c) inverse[c] = std::exp(log_curve[c] - log_curve[n / 2]);
  return inverse;
}

// Largest relative difference between two inverse responses over codes with weight >= 0.15,
// where both are defined by data if the data can define them at all.
double LargestRelativeDifference(const std::vector<double>& a, const std::vector<double>& b,
                                 const std::vector<double>& weight) {
  double worst = 0.0;
  for (std::size_t z = 0; z < a.size(); ++z) {
    if (weight[z] < 0.15 || !(a[z] > 0.0) || !(b[z] > 0.0)) continue;
    worst = std::max(worst, std::abs(a[z] / b[z] - 1.0));
  }
  return worst;
}

ResponseSmoothness OtherSmoothness(ResponseSmoothness smoothness) {
  return smoothness == ResponseSmoothness::kCode ? ResponseSmoothness::kLogCode : ResponseSmoothness::kCode;
}

ChannelSolve SolveDebevec(const Samples& samples, int channel, const std::vector<double>& log_t,
                          const std::vector<double>& weight, const ResponseOptions& options) {
  ChannelSolve out;
  const std::vector<int> useful = InformativeSamples(samples, channel, weight);
  out.samples_used = static_cast<int>(useful.size());
  if (out.samples_used < 2) {
    out.problem = "fewer than 2 sampled pixels are well exposed in two frames";
    return out;
  }
  const DebevecData data = ReducedDataEquations(samples, channel, useful, log_t, weight);
  Eigen::MatrixXd S = data.normal;
  AddSmoothness(S, weight, options.lambda, options.smoothness);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(S, Eigen::EigenvaluesOnly);
  const double lmin = eig.eigenvalues().minCoeff();
  const double lmax = eig.eigenvalues().maxCoeff();
  out.condition = lmin > 0.0 ? std::sqrt(lmax / lmin) : std::numeric_limits<double>::infinity();
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
  const Eigen::VectorXd g = ldlt.solve(data.rhs);
  if (ldlt.info() != Eigen::Success || !g.allFinite()) {
    out.problem = "the least-squares system is singular";
    return out;
  }
  out.residual = DataResidual(samples, channel, useful, log_t, weight, g);
  out.inverse = InverseFromLog(g, &out.monotonic_fixes);
  // The same data under the other smoothness term: where the two curves differ, the data do
  // not decide between them (periodic ambiguity of sparse brackets), the prior does.
  Eigen::MatrixXd S_other = data.normal;
  AddSmoothness(S_other, weight, options.lambda, OtherSmoothness(options.smoothness));
  const Eigen::LDLT<Eigen::MatrixXd> ldlt_other(S_other);
  const Eigen::VectorXd g_other = ldlt_other.solve(data.rhs);
  out.prior_disagreement =
      ldlt_other.info() == Eigen::Success && g_other.allFinite()
          ? std::optional<double>(LargestRelativeDifference(out.inverse, InverseFromLog(g_other, nullptr), weight))
          : std::nullopt;
  out.iterations = 1;
  out.converged = true;
  return out;
}

// Fills codes never observed by linear interpolation between observed neighbours, and by
// the nearest end slope beyond them.
void FillUnobserved(std::vector<double>& curve, const std::vector<bool>& observed) {
  const int n = static_cast<int>(curve.size());
  std::vector<int> known;
  for (int z = 0; z < n; ++z) {
    if (observed[z]) known.push_back(z);
  }
  if (known.empty()) return;
  for (std::size_t k = 0; k + 1 < known.size(); ++k) {
    const int a = known[k], b = known[k + 1];
    for (int z = a + 1; z < b; ++z) curve[z] = curve[a] + (curve[b] - curve[a]) * (z - a) / (b - a);
  }
  const int lo = known.front(), hi = known.back();
  for (int z = 0; z < lo; ++z) curve[z] = curve[lo] * z / std::max(lo, 1);
  double slope = 0.0;
  if (known.size() >= 2) {
    const int prev = known[known.size() - 2];
    slope = (curve[hi] - curve[prev]) / (hi - prev);
  }
  for (int z = hi + 1; z < n; ++z) curve[z] = curve[hi] + std::max(slope, 0.0) * (z - hi);
}

// Robertson, Borman & Stevenson 2003: alternate the exposure estimates E_i (weighted least
// squares given the curve) and the curve I(m) (mean of E_i t_j over observations of code m).
ChannelSolve SolveRobertson(const Samples& samples, int channel, const std::vector<double>& t,
                            const std::vector<double>& weight, const ResponseOptions& options) {
  ChannelSolve out;
  const int n = static_cast<int>(weight.size());
  const std::vector<int> useful = InformativeSamples(samples, channel, weight);
  out.samples_used = static_cast<int>(useful.size());
  if (out.samples_used < 2) {
    out.problem = "fewer than 2 sampled pixels are well exposed in two frames";
    return out;
  }
  const int mid = n / 2;
  std::vector<double> curve(n);
  for (int z = 0; z < n; ++z) curve[z] = static_cast<double>(z) / mid;
  std::vector<double> exposure(samples.count, 0.0);
  std::vector<double> sum(n), count(n);
  std::vector<bool> observed(n);
  for (out.iterations = 1; out.iterations <= options.robertson_max_iterations; ++out.iterations) {
    for (int s : useful) {
      double num = 0.0, den = 0.0;
      for (int f = 0; f < samples.frames; ++f) {
        const int z = samples.at(s, f, channel);
        num += weight[z] * t[f] * curve[z];
        den += weight[z] * t[f] * t[f];
      }
      exposure[s] = den > 0.0 ? num / den : 0.0;
    }
    std::fill(sum.begin(), sum.end(), 0.0);
    std::fill(count.begin(), count.end(), 0.0);
    for (int s : useful) {
      for (int f = 0; f < samples.frames; ++f) {
        const int z = samples.at(s, f, channel);
        sum[z] += exposure[s] * t[f];
        count[z] += 1.0;
      }
    }
    std::vector<double> next(n, 0.0);
    for (int z = 0; z < n; ++z) {
      observed[z] = count[z] > 0.0;
      if (observed[z]) next[z] = sum[z] / count[z];
    }
    FillUnobserved(next, observed);
    if (!(next[mid] > 0.0)) {
      out.problem = "the mid code was never observed with a positive exposure";
      return out;
    }
    const double scale = 1.0 / next[mid];
    double change = 0.0;
    for (int z = 0; z < n; ++z) {
      next[z] *= scale;
      if (weight[z] > 0.0) change = std::max(change, std::abs(next[z] - curve[z]) / std::max(curve[z], 1e-6));
    }
    curve.swap(next);
    if (change < options.robertson_tolerance) {
      out.converged = true;
      break;
    }
  }
  out.iterations = std::min(out.iterations, options.robertson_max_iterations);
  double total = 0.0, wsum = 0.0;
  for (int s : useful) {
    for (int f = 0; f < samples.frames; ++f) {
      const int z = samples.at(s, f, channel);
      const double predicted = exposure[s] * t[f];
      if (predicted <= 0.0 || weight[z] == 0.0) continue;
      const double r = (curve[z] - predicted) / predicted;
      total += weight[z] * r * r;
      wsum += weight[z];
    }
  }
  out.residual = wsum > 0.0 ? std::sqrt(total / wsum) : 0.0;
  out.monotonic_fixes = MakeMonotonic(curve);
  curve[0] = 0.0;
  out.inverse = curve;
  return out;
}

}  // namespace

const char* ToString(ResponseMethod method) {
  switch (method) {
    case ResponseMethod::kDebevec: return "debevec";
    case ResponseMethod::kRobertson: return "robertson";
  }
  return "unknown";
}

ResponseMethod ResponseMethodFromString(const std::string& name) {
  if (name == "debevec") return ResponseMethod::kDebevec;
  if (name == "robertson") return ResponseMethod::kRobertson;
  throw InvalidArgumentError("response method '" + name + "' is unknown; use debevec or robertson");
}

const char* ToString(ResponseSmoothness smoothness) {
  switch (smoothness) {
    case ResponseSmoothness::kCode: return "code";
    case ResponseSmoothness::kLogCode: return "log-code";
  }
  return "unknown";
}

ResponseSmoothness ResponseSmoothnessFromString(const std::string& name) {
  if (name == "code") return ResponseSmoothness::kCode;
  if (name == "log-code") return ResponseSmoothness::kLogCode;
  throw InvalidArgumentError("response smoothness '" + name + "' is unknown; use code or log-code");
}

CameraResponse CameraResponse::Linear(int channels, int levels, int black_level, int white_level) {
  RELUME_CHECK(channels > 0 && levels > 1 && black_level < white_level);
  CameraResponse r;
  r.levels = levels;
  r.sensor_linear = true;
  r.inverse.assign(channels, std::vector<double>(levels));
  for (int c = 0; c < channels; ++c) {
    for (int z = 0; z < levels; ++z) {
      r.inverse[c][z] = std::max(0.0, static_cast<double>(z - black_level) / (white_level - black_level));
    }
  }
  return r;
}

bool CameraResponse::IsValid(std::string* why) const {
  if (levels < 2) return Fail(why, "a response needs at least 2 levels");
  if (inverse.empty() || (inverse.size() != 1 && inverse.size() != 3)) {
    return Fail(why, "a response needs 1 or 3 channels");
  }
  for (const auto& curve : inverse) {
    if (static_cast<int>(curve.size()) != levels) return Fail(why, "a response curve has the wrong length");
    for (int z = 0; z < levels; ++z) {
      if (!std::isfinite(curve[z]) || curve[z] < 0.0) return Fail(why, "a response value is negative or not finite");
      if (z > 0 && curve[z] < curve[z - 1]) return Fail(why, "a response curve decreases");
    }
  }
  return true;
}

bool ResponseOptions::IsValid(std::string* why) const {
  if (sample_count < 8) return Fail(why, "sample_count must be >= 8");
  if (!(lambda >= 0.0) || !std::isfinite(lambda)) return Fail(why, "lambda must be finite and >= 0");
  if (smoothness != ResponseSmoothness::kCode && smoothness != ResponseSmoothness::kLogCode) {
    return Fail(why, "smoothness must be kCode or kLogCode");
  }
  if (!(max_prior_disagreement > 0.0) || !std::isfinite(max_prior_disagreement)) {
    return Fail(why, "max_prior_disagreement must be finite and > 0");
  }
  if (robertson_max_iterations < 1) return Fail(why, "robertson_max_iterations must be >= 1");
  if (!(robertson_tolerance > 0.0)) return Fail(why, "robertson_tolerance must be > 0");
  if (black_margin < 0 || saturation_margin < 0 || black_margin + saturation_margin > 200) {
    return Fail(why, "black_margin and saturation_margin must be >= 0 and leave codes in between");
  }
  return true;
}

std::string ResponseSummary::BriefReport() const {
  std::ostringstream s;
  s << ToString(method) << ": " << (usable ? "usable" : "NOT usable") << ", "
    << (converged ? "converged" : "not converged") << ", iterations " << iterations << ", residual " << residual
    << ", condition " << condition << ", samples " << samples_used << ", frames " << frames_used;
  if (monotonic_fixes > 0) s << ", monotonic fixes " << monotonic_fixes;
  if (prior_disagreement) s << ", prior disagreement " << *prior_disagreement;
  if (low_confidence) s << ", LOW CONFIDENCE";
  if (!reason.empty()) s << " (" << reason << ")";
  return s.str();
}

std::vector<double> HatWeights(int levels, int black_margin, int saturation_margin) {
  std::vector<double> w(levels, 0.0);
  const double lo = black_margin + 1;
  const double hi = levels - 2 - saturation_margin;
  const double half = (hi - lo) / 2.0;
  for (int z = 0; z < levels; ++z) {
    if (z < lo || z > hi) continue;
    w[z] = std::max(0.0, (std::min(z - lo, hi - z) + 1.0) / (half + 1.0));
  }
  return w;
}

namespace {
void AppendReason(ResponseSummary& summary, const std::string& note) {
  summary.reason += (summary.reason.empty() ? "" : "; ") + note;
}

// Flags a usable curve that the bracket does not determine well, and says why.
void NoteLowConfidence(const ResponseOptions& options, ResponseSummary& summary) {
  if (summary.samples_used < 32) {
    summary.low_confidence = true;
    AppendReason(summary, "only " + std::to_string(summary.samples_used) + " informative samples: low confidence");
  }
  if (summary.prior_disagreement && *summary.prior_disagreement > options.max_prior_disagreement) {
    summary.low_confidence = true;
    std::ostringstream note;
    note.precision(2);
    note << "low confidence: the two smoothness priors give curves up to " << 100.0 * *summary.prior_disagreement
         << " % apart, so the curve rests on the prior rather than on the data (exposures too far apart: "
            "more frames, at most 2 stops apart, or irregular ratios would determine it)";
    AppendReason(summary, note.str());
  }
}
}  // namespace

ResponseResult RecoverResponse(const std::vector<CameraImage>& frames, const std::vector<double>& exposure_times_s,
                               const ResponseOptions& options) {
  ThrowIfInvalid(options, "response options");
  CheckBracket(frames, exposure_times_s);
  if (frames.size() < 2) {
    throw InvalidArgumentError("response recovery needs at least 2 frames with different exposures (got 1)");
  }
  const CameraImage& first = frames.front();
  if (first.pixels.depth() != CV_8U || (first.layout != ColorLayout::kRgb && first.layout != ColorLayout::kMono)) {
    throw InvalidArgumentError(
        "response recovery needs 8-bit RGB or mono frames; sensor-linear raw frames need no response "
        "(use CameraResponse::Linear)");
  }
  const std::vector<int> order = OrderByExposure(exposure_times_s);
  std::vector<const cv::Mat*> sorted;
  std::vector<double> t, log_t;
  for (int i : order) {
    sorted.push_back(&frames[i].pixels);
    t.push_back(exposure_times_s[i]);
    log_t.push_back(std::log(exposure_times_s[i]));
  }
  ResponseResult result;
  ResponseSummary& summary = result.summary;
  summary.method = options.method;
  summary.frames_used = static_cast<int>(frames.size());
  if (t.back() / t.front() < 1.0 + 1e-6) {
    summary.reason = "all exposure times are equal: the response cannot be recovered from one exposure level";
    return result;
  }
  const int sample_count =
      options.method == ResponseMethod::kRobertson ? options.sample_count * 20 : options.sample_count;
  const Samples samples = SelectSamples(sorted, sample_count, options.seed);
  const std::vector<double> weight = HatWeights(256, options.black_margin, options.saturation_margin);
  result.response.levels = 256;
  summary.usable = true;
  summary.converged = true;
  summary.samples_used = samples.count;
  for (int c = 0; c < first.pixels.channels(); ++c) {
    // A curve needs codes across its range: samples that all sit at one or two codes (a flat
    // scene, or every frame clipped to the same value) cannot define it, however many there are.
    std::vector<bool> seen(256, false);
    int distinct = 0;
    const std::vector<int> informative = InformativeSamples(samples, c, weight);
    for (const int sample : informative) {
      for (int f = 0; f < samples.frames; ++f) {
        const int z = samples.at(sample, f, c);
        if (weight[z] > 0.0 && !seen[z]) {
          seen[z] = true;
          ++distinct;
        }
      }
    }
    if (distinct < kMinDistinctCodes) {
      summary.usable = false;
      summary.converged = false;
      summary.reason = "channel " + std::to_string(c) + ": the well-exposed samples (" + std::to_string(samples.count) +
                       " drawn) cover only " + std::to_string(distinct) +
                       " distinct code(s), too few to define a response (a flat scene?)";
      result.response.inverse.clear();
      return result;
    }
    if (const double brighter = BrighteningFraction(samples, c, informative); brighter < kMinBrighteningFraction) {
      std::ostringstream why;
      why.precision(3);
      why << "channel " << c << ": the frames do not change with exposure: only " << 100.0 * brighter << " % of "
          << informative.size() << " well-exposed samples are brighter at " << t.back() << " s than at " << t.front()
          << " s (the same image given several times, or wrong exposure times?)";
      summary.usable = false;
      summary.converged = false;
      summary.reason = why.str();
      result.response.inverse.clear();
      return result;
    }
    const ChannelSolve solve = options.method == ResponseMethod::kDebevec
                                   ? SolveDebevec(samples, c, log_t, weight, options)
                                   : SolveRobertson(samples, c, t, weight, options);
    if (!solve.problem.empty()) {
      summary.usable = false;
      summary.converged = false;
      summary.reason = "channel " + std::to_string(c) + ": " + solve.problem;
      result.response.inverse.clear();
      return result;
    }
    result.response.inverse.push_back(solve.inverse);
    summary.iterations = std::max(summary.iterations, solve.iterations);
    summary.residual = std::max(summary.residual, solve.residual);
    summary.condition = std::max(summary.condition, solve.condition);
    summary.samples_used = std::min(summary.samples_used, solve.samples_used);
    summary.monotonic_fixes += solve.monotonic_fixes;
    summary.converged = summary.converged && solve.converged;
    if (solve.prior_disagreement) {
      summary.prior_disagreement = std::max(summary.prior_disagreement.value_or(0.0), *solve.prior_disagreement);
    }
  }
  if (!summary.converged) summary.reason = "Robertson reached the iteration limit before the tolerance";
  NoteLowConfidence(options, summary);
  return result;
}

std::vector<double> ExposureTimesFromEv(const std::vector<double>& ev, double reference_time_s) {
  std::vector<double> t;
  for (double e : ev) {
    if (!std::isfinite(e)) throw InvalidArgumentError("EV value is not a finite number");
    t.push_back(reference_time_s * std::exp2(e));
  }
  return t;
}

ScaleFit FitScaleFactor(const cv::Mat& values, const cv::Mat& reference, const cv::Mat& mask) {
  RELUME_CHECK(values.size() == reference.size() && values.type() == reference.type());
  RELUME_CHECK(values.depth() == CV_32F);
  RELUME_CHECK(mask.empty() || (mask.type() == CV_8UC1 && mask.size() == values.size()));
  const int channels = values.channels();
  ScaleFitter fitter;
  for (int y = 0; y < values.rows; ++y) {
    const float* v = values.ptr<float>(y);
    const float* r = reference.ptr<float>(y);
    const std::uint8_t* m = mask.empty() ? nullptr : mask.ptr<std::uint8_t>(y);
    for (int x = 0; x < values.cols; ++x) {
      if (m && !m[x]) continue;
      for (int c = 0; c < channels; ++c) fitter.Add(v[x * channels + c], r[x * channels + c]);
    }
  }
  return fitter.Fit(10);
}

namespace {
// Linearised frame (X(z) / t) on a subsampled grid, plus a mask of pixels whose codes are
// well inside the hat in every channel.
void LineariseSubsampled(const CameraImage& frame, double t, const CameraResponse& response,
                         const std::vector<double>& weight, int stride, cv::Mat* radiance, cv::Mat* mask) {
  const int channels = frame.pixels.channels();
  const int rows = (frame.height() + stride - 1) / stride, cols = (frame.width() + stride - 1) / stride;
  *radiance = cv::Mat(rows, cols, CV_MAKETYPE(CV_32F, channels));
  *mask = cv::Mat::zeros(rows, cols, CV_8UC1);
  for (int y = 0; y < rows; ++y) {
    const std::uint8_t* p = frame.pixels.ptr<std::uint8_t>(y * stride);
    float* out = radiance->ptr<float>(y);
    std::uint8_t* m = mask->ptr<std::uint8_t>(y);
    for (int x = 0; x < cols; ++x) {
      bool good = true;
      for (int c = 0; c < channels; ++c) {
        const int z = p[static_cast<std::size_t>(x) * stride * channels + c];
        out[x * channels + c] = static_cast<float>(response.inverse[c][z] / t);
        good = good && weight[z] >= 0.2;
      }
      m[x] = good ? 255 : 0;
    }
  }
}
}  // namespace

std::vector<double> RefineExposureScales(const std::vector<CameraImage>& frames,
                                         const std::vector<double>& nominal_exposure_times_s,
                                         const CameraResponse& response, const ResponseOptions& options,
                                         std::string* notes) {
  CheckBracket(frames, nominal_exposure_times_s);
  std::string why;
  if (!response.IsValid(&why)) throw InvalidArgumentError("response: " + why);
  RELUME_CHECK(response.channels() == frames[0].pixels.channels() && response.levels == 256);
  const std::vector<int> order = OrderByExposure(nominal_exposure_times_s);
  const int n = static_cast<int>(order.size());
  const std::vector<double> weight = HatWeights(256, options.black_margin, options.saturation_margin);
  const int stride = std::max(1, static_cast<int>(std::sqrt(frames[0].pixels.total() / 200000.0)));
  std::vector<cv::Mat> radiance(n), mask(n);
  for (int k = 0; k < n; ++k) {
    LineariseSubsampled(frames[order[k]], nominal_exposure_times_s[order[k]], response, weight, stride, &radiance[k],
                        &mask[k]);
  }
  std::vector<double> refined = nominal_exposure_times_s;
  std::vector<double> scale(n, 1.0);
  const int ref = n / 2;
  // Chain outward from the middle frame: frame k is matched to its already-refined neighbour.
  auto match = [&](int k, int toward) {
    cv::Mat both;
    cv::bitwise_and(mask[k], mask[toward], both);
    cv::Mat reference = radiance[toward] * scale[toward];
    const ScaleFit fit = FitScaleFactor(radiance[k], reference, both);
    if (fit.usable) {
      scale[k] = fit.scale;
    } else {
      scale[k] = scale[toward];
      if (notes) *notes += "frame " + std::to_string(order[k]) + " kept its nominal ratio: " + fit.reason + "; ";
    }
  };
  for (int k = ref + 1; k < n; ++k) match(k, k - 1);
  for (int k = ref - 1; k >= 0; --k) match(k, k + 1);
  for (int k = 0; k < n; ++k) refined[order[k]] = nominal_exposure_times_s[order[k]] / scale[k];
  return refined;
}

EvCalibration RecoverResponseFromEv(const std::vector<CameraImage>& frames, const std::vector<double>& ev,
                                    const ResponseOptions& options) {
  EvCalibration out;
  out.exposure_times_s = ExposureTimesFromEv(ev);
  out.result = RecoverResponse(frames, out.exposure_times_s, options);
  if (!out.result.summary.usable) return out;
  std::string notes;
  const std::vector<double> nominal = out.exposure_times_s;
  std::vector<double> refined = RefineExposureScales(frames, nominal, out.result.response, options, &notes);
  // Response and exposure ratios are jointly defined only up to an exponent (X^g with t^g fits
  // the same frames), so the refined times are anchored: the span shortest..longest keeps its
  // nominal EV span, and only the deviations from a power law are taken from the data.
  const auto [lo, hi] = std::minmax_element(nominal.begin(), nominal.end());
  const auto [rlo, rhi] = std::minmax_element(refined.begin(), refined.end());
  const double ref = nominal[std::distance(nominal.begin(), lo)];
  if (*hi > *lo && *rhi > *rlo) {
    const double exponent = std::log(*hi / *lo) / std::log(*rhi / *rlo);
    const double refined_ref = refined[std::distance(nominal.begin(), lo)];
    for (double& t : refined) t = ref * std::pow(t / refined_ref, exponent);
  }
  out.exposure_times_s = refined;
  out.result = RecoverResponse(frames, out.exposure_times_s, options);
  if (!notes.empty()) out.result.summary.reason += (out.result.summary.reason.empty() ? "" : "; ") + notes;
  return out;
}

}  // namespace relume::calibration
