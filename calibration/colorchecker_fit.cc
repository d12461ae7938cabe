#include "calibration/colorchecker_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

#include "core/error.h"

namespace relume::calibration {
namespace {

bool Fail(std::string* why, const std::string& reason) {
  if (why) *why = reason;
  return false;
}

double Deg(double rad) {
  return rad * 180.0 / std::numbers::pi;
}
double Rad(double deg) {
  return deg * std::numbers::pi / 180.0;
}

// Hue angle in degrees [0, 360); 0 for a neutral colour (as the standard defines).
double HueDeg(double b, double a) {
  if (a == 0.0 && b == 0.0) return 0.0;
  double h = Deg(std::atan2(b, a));
  return h < 0.0 ? h + 360.0 : h;
}

// Pools adjacent violators so y is non-decreasing along x (isotonic regression, equal weights).
int MakeNonDecreasing(std::vector<double>& y) {
  int fixes = 0;
  std::vector<double> value;
  std::vector<int> count;
  for (double v : y) {
    value.push_back(v);
    count.push_back(1);
    while (value.size() > 1 && value[value.size() - 2] > value.back()) {
      const double merged = (value[value.size() - 2] * count[count.size() - 2] + value.back() * count.back()) /
                            (count[count.size() - 2] + count.back());
      count[count.size() - 2] += count.back();
      value.pop_back();
      count.pop_back();
      value.back() = merged;
      ++fixes;
    }
  }
  std::size_t k = 0;
  for (std::size_t b = 0; b < value.size(); ++b) {
    for (int i = 0; i < count[b]; ++i) y[k++] = value[b];
  }
  return fixes;
}

}  // namespace

double DeltaE2000(const Lab& lab1, const Lab& lab2) {
  const double L1 = lab1[0], a1 = lab1[1], b1 = lab1[2];
  const double L2 = lab2[0], a2 = lab2[1], b2 = lab2[2];
  const double c1 = std::hypot(a1, b1), c2 = std::hypot(a2, b2);
  const double c_mean = 0.5 * (c1 + c2);
  const double c7 = std::pow(c_mean, 7.0);
  const double g = 0.5 * (1.0 - std::sqrt(c7 / (c7 + std::pow(25.0, 7.0))));
  const double a1p = (1.0 + g) * a1, a2p = (1.0 + g) * a2;
  const double c1p = std::hypot(a1p, b1), c2p = std::hypot(a2p, b2);
  const double h1p = HueDeg(b1, a1p), h2p = HueDeg(b2, a2p);
  const double dLp = L2 - L1;
  const double dCp = c2p - c1p;
  double dhp = 0.0;
  if (c1p * c2p != 0.0) {
    dhp = h2p - h1p;
    if (dhp > 180.0) dhp -= 360.0;
    if (dhp < -180.0) dhp += 360.0;
  }
  const double dHp = 2.0 * std::sqrt(c1p * c2p) * std::sin(Rad(dhp / 2.0));
  const double Lp_mean = 0.5 * (L1 + L2);
  const double Cp_mean = 0.5 * (c1p + c2p);
  double hp_mean = h1p + h2p;
  if (c1p * c2p != 0.0) {
    if (std::abs(h1p - h2p) <= 180.0) {
      hp_mean = 0.5 * (h1p + h2p);
    } else if (h1p + h2p < 360.0) {
      hp_mean = 0.5 * (h1p + h2p + 360.0);
    } else {
      hp_mean = 0.5 * (h1p + h2p - 360.0);
    }
  }
  const double t = 1.0 - 0.17 * std::cos(Rad(hp_mean - 30.0)) + 0.24 * std::cos(Rad(2.0 * hp_mean)) +
                   0.32 * std::cos(Rad(3.0 * hp_mean + 6.0)) - 0.20 * std::cos(Rad(4.0 * hp_mean - 63.0));
  const double d_theta = 30.0 * std::exp(-std::pow((hp_mean - 275.0) / 25.0, 2.0));
  const double cp7 = std::pow(Cp_mean, 7.0);
  const double rc = 2.0 * std::sqrt(cp7 / (cp7 + std::pow(25.0, 7.0)));
  const double l50 = (Lp_mean - 50.0) * (Lp_mean - 50.0);
  const double sl = 1.0 + 0.015 * l50 / std::sqrt(20.0 + l50);
  const double sc = 1.0 + 0.045 * Cp_mean;
  const double sh = 1.0 + 0.015 * Cp_mean * t;
  const double rt = -std::sin(Rad(2.0 * d_theta)) * rc;
  const double tl = dLp / sl, tc = dCp / sc, th = dHp / sh;
  return std::sqrt(tl * tl + tc * tc + th * th + rt * tc * th);
}

double PiecewiseLinearGain::Apply(int channel, double value) const {
  const auto& xs = x[channel];
  const auto& ys = y[channel];
  if (xs.empty()) return value;
  // Knots include (0, 0) at the front.
  if (value <= xs.front()) {
    const double slope = xs.size() > 1 ? (ys[1] - ys[0]) / (xs[1] - xs[0]) : 1.0;
    return ys.front() + slope * (value - xs.front());
  }
  for (std::size_t i = 1; i < xs.size(); ++i) {
    if (value <= xs[i]) return ys[i - 1] + (ys[i] - ys[i - 1]) * (value - xs[i - 1]) / (xs[i] - xs[i - 1]);
  }
  const std::size_t n = xs.size();
  const double slope = (ys[n - 1] - ys[n - 2]) / (xs[n - 1] - xs[n - 2]);
  return ys[n - 1] + slope * (value - xs[n - 1]);
}

bool ColorFitOptions::IsValid(std::string* why) const {
  if (!(ridge >= 0.0) || !std::isfinite(ridge)) return Fail(why, "ridge must be finite and >= 0");
  if (!(max_condition > 1.0)) return Fail(why, "max_condition must be > 1");
  if (!(max_mean_delta_e > 0.0)) return Fail(why, "max_mean_delta_e must be > 0");
  return true;
}

std::string ColorFitSummary::BriefReport() const {
  std::ostringstream s;
  s << (usable ? (low_confidence ? "usable, LOW CONFIDENCE" : "usable") : "NOT usable") << ", patches " << patches_used
    << " (neutrals " << neutrals_used << "), condition " << condition << ", residual " << residual_rms
    << ", Delta E 2000 mean " << mean_delta_e << " max " << max_delta_e;
  if (!reason.empty()) s << " (" << reason << ")";
  return s.str();
}

Eigen::Vector3d ColorFit::Correct(const Eigen::Vector3d& measured) const {
  Eigen::Vector3d g;
  for (int c = 0; c < 3; ++c) g[c] = gain.Apply(c, measured[c]);
  return ccm * g;
}

ColorFit FitColorChecker(const std::vector<PatchSample>& patches, const ColorCheckerReference& reference,
                         const ColorFitOptions& options) {
  ThrowIfInvalid(options, "colour fit options");
  if (patches.size() != 24 || reference.patches.size() != 24) {
    throw InvalidArgumentError("colour fit needs 24 patches and a 24-patch reference");
  }
  ColorFit fit;
  ColorFitSummary& s = fit.summary;
  std::vector<std::string> notes;
  fit.patches.resize(24);
  for (int k = 0; k < 24; ++k) {
    fit.patches[k].status = patches[k].status;
    fit.patches[k].measured = Eigen::Vector3d(patches[k].median[0], patches[k].median[1], patches[k].median[2]);
    fit.patches[k].used = patches[k].status == PatchStatus::kOk && fit.patches[k].measured.allFinite();
    if (!fit.patches[k].used) {
      notes.push_back(reference.patches[k].name + " " + ToString(patches[k].status));
    }
  }
  // (a) Gain from the neutral patches.
  if (options.fit_gain) {
    std::vector<int> neutrals;
    for (int k : reference.NeutralIndices()) {
      if (fit.patches[k].used && fit.patches[k].measured.minCoeff() > 0.0) neutrals.push_back(k);
    }
    s.neutrals_used = static_cast<int>(neutrals.size());
    if (neutrals.empty()) {
      s.reason = "no usable neutral patch: the gain cannot be fitted";
      return fit;
    }
    int fixes = 0;
    for (int c = 0; c < 3; ++c) {
      std::vector<std::pair<double, double>> knots = {{0.0, 0.0}};
      for (int k : neutrals) knots.push_back({fit.patches[k].measured[c], reference.patches[k].linear_rgb[c]});
      std::sort(knots.begin(), knots.end());
      std::vector<double> xs, ys;
      for (const auto& [kx, ky] : knots) {
        if (!xs.empty() && kx <= xs.back() + 1e-9) continue;  // equal measurements: keep the first
        xs.push_back(kx);
        ys.push_back(ky);
      }
      fixes += MakeNonDecreasing(ys);
      fit.gain.x[c] = xs;
      fit.gain.y[c] = ys;
    }
    if (fixes > 0) {
      s.low_confidence = true;
      notes.push_back("neutral patches out of brightness order (" + std::to_string(fixes) +
                      " pooled): uneven light on the chart?");
    }
  }
  std::vector<int> used;
  for (int k = 0; k < 24; ++k) {
    if (fit.patches[k].used) used.push_back(k);
  }
  s.patches_used = static_cast<int>(used.size());
  if (used.size() < 3) {
    s.reason = "only " + std::to_string(used.size()) + " usable patches";
    return fit;
  }
  // (b) CCM: rows of X are gain-corrected patches, rows of R the reference linear RGB.
  Eigen::MatrixXd X(used.size(), 3), R(used.size(), 3);
  for (std::size_t i = 0; i < used.size(); ++i) {
    const int k = used[i];
    for (int c = 0; c < 3; ++c) X(i, c) = fit.gain.Apply(c, fit.patches[k].measured[c]);
    R.row(i) = reference.patches[k].linear_rgb.transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(X);
  const double smax = svd.singularValues()(0), smin = svd.singularValues()(2);
  s.condition = smin > 0.0 ? smax / smin : std::numeric_limits<double>::infinity();
  if (options.fit_matrix) {
    const double mu = options.ridge * X.squaredNorm() / static_cast<double>(used.size());
    const Eigen::Matrix3d A = X.transpose() * X + mu * Eigen::Matrix3d::Identity();
    // White patch (or the brightest usable neutral) for the constraint.
    int white = -1;
    for (int k : reference.NeutralIndices()) {
      if (fit.patches[k].used) {
        white = k;
        break;
      }
    }
    for (int row = 0; row < 3; ++row) {
      const Eigen::Vector3d b = X.transpose() * R.col(row) + mu * Eigen::Vector3d::Unit(row);
      if (options.white_preserving && white >= 0) {
        Eigen::Vector3d w;
        for (int c = 0; c < 3; ++c) w[c] = fit.gain.Apply(c, fit.patches[white].measured[c]);
        Eigen::Matrix4d kkt = Eigen::Matrix4d::Zero();
        kkt.topLeftCorner<3, 3>() = A;
        kkt.block<3, 1>(0, 3) = w;
        kkt.block<1, 3>(3, 0) = w.transpose();
        Eigen::Vector4d rhs;
        rhs << b, reference.patches[white].linear_rgb[row];
        const Eigen::Vector4d m = kkt.fullPivLu().solve(rhs);
        fit.ccm.row(row) = m.head<3>().transpose();
      } else {
        fit.ccm.row(row) = A.ldlt().solve(b).transpose();
      }
    }
    if (!fit.ccm.allFinite()) {
      fit.ccm = Eigen::Matrix3d::Identity();
      s.low_confidence = true;
      notes.push_back("the colour matrix could not be solved; identity used");
    }
  }
  if (s.condition > options.max_condition) {
    s.low_confidence = true;
    notes.push_back("patch colours nearly collinear (condition " + std::to_string(s.condition) +
                    "): the matrix is held near identity by the ridge term");
  }
  double sq = 0.0, sum_de = 0.0;
  s.patch_delta_e.assign(24, std::numeric_limits<double>::quiet_NaN());
  for (int k = 0; k < 24; ++k) {
    PatchFit& p = fit.patches[k];
    p.corrected = fit.Correct(p.measured);
    p.corrected_lab = LabD50FromLinearRgb(p.corrected.cwiseMax(0.0));
    if (!p.used) continue;
    p.delta_e = DeltaE2000(p.corrected_lab, reference.patches[k].lab_d50);
    s.patch_delta_e[static_cast<std::size_t>(k)] = p.delta_e;
    sum_de += p.delta_e;
    s.max_delta_e = std::max(s.max_delta_e, p.delta_e);
    sq += (p.corrected - reference.patches[k].linear_rgb).squaredNorm();
  }
  s.mean_delta_e = sum_de / static_cast<double>(used.size());
  s.residual_rms = std::sqrt(sq / (3.0 * static_cast<double>(used.size())));
  if (s.mean_delta_e > options.max_mean_delta_e) {
    s.low_confidence = true;
    notes.push_back("mean Delta E 2000 " + std::to_string(s.mean_delta_e) +
                    " is high: uneven light (shadow) on the chart, wrong corners, or a non-linear input");
  }
  s.usable = true;
  for (std::size_t i = 0; i < notes.size(); ++i) s.reason += (i ? "; " : "") + notes[i];
  return fit;
}

}  // namespace relume::calibration
