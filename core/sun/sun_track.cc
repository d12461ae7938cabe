#include "core/sun/sun_track.h"

#include <cmath>

#include "core/error.h"
#include "core/sun/delta_t.h"

namespace relume {

namespace {
constexpr double kJ2000 = 2451545.0;
constexpr std::size_t kMaxCachedNodes = 4096;  // about 3 years at 6 h spacing

double AngleDifferenceDeg(double b, double a) {
  double d = std::fmod(b - a, 360.0);
  if (d > 180.0) d -= 360.0;
  if (d <= -180.0) d += 360.0;
  return d;
}
}  // namespace

bool SunTrackOptions::IsValid(std::string* why) const {
  if (!sun.IsValid(why)) return false;
  if (!(node_spacing_hours > 0.0 && node_spacing_hours <= 48.0)) {
    if (why) *why = "node spacing must be within (0, 48] hours";
    return false;
  }
  return true;
}

SunTrack::SunTrack(const Site& site, const SunTrackOptions& options)
    : site_(site), options_(options), spacing_days_(options.node_spacing_hours / 24.0) {
  std::string why;
  if (!site.IsValid(&why)) throw InvalidArgumentError("sun track: invalid site: " + why);
  ThrowIfInvalid(options, "sun track options");
  site_terms_ = spa::MakeSiteTerms(site);
}

const SunTrack::Node& SunTrack::NodeAt(std::int64_t index) {
  auto it = nodes_.find(index);
  if (it != nodes_.end()) return it->second;
  if (nodes_.size() >= kMaxCachedNodes) {
    nodes_.clear();
    window_index_ = INT64_MIN;
  }
  const spa::GeocentricSun sun = spa::ComputeGeocentricSun(kJ2000 + static_cast<double>(index) * spacing_days_);
  ++nodes_evaluated_;
  return nodes_
      .emplace(index,
               Node{sun.right_ascension_deg, sun.declination_deg, sun.distance_au, sun.equation_of_equinoxes_deg})
      .first->second;
}

SunPosition SunTrack::At(UtcTime time) {
  JulianDate jd_ut1 = JulianDateFromUtc(time);
  jd_ut1.fraction += options_.sun.dut1_s / 86400.0;
  const double delta_t_s = std::isnan(options_.sun.delta_t_s)
                               ? DeltaTModelSeconds(2000.0 + (jd_ut1.Value() - kJ2000) / 365.25)
                               : options_.sun.delta_t_s;
  // Position on the node grid, from the two-part date to keep precision.
  const double days_tt = (jd_ut1.day - kJ2000) + jd_ut1.fraction + delta_t_s / 86400.0;
  const double s = days_tt / spacing_days_;
  const double floor_s = std::floor(s);
  const std::int64_t k = static_cast<std::int64_t>(floor_s);
  const double t = s - floor_s;

  if (k - 1 != window_index_) {
    // Fetch all four first: a fetch may clear the cache and invalidate earlier pointers.
    for (int i = 0; i < 4; ++i) NodeAt(k - 1 + i);
    for (int i = 0; i < 4; ++i) window_[i] = &NodeAt(k - 1 + i);
    window_index_ = k - 1;
  }
  // Cubic Lagrange weights for nodes at -1, 0, 1, 2 and 0 <= t < 1.
  const double w[4] = {-t * (t - 1.0) * (t - 2.0) / 6.0, (t + 1.0) * (t - 1.0) * (t - 2.0) / 2.0,
                       -(t + 1.0) * t * (t - 2.0) / 2.0, (t + 1.0) * t * (t - 1.0) / 6.0};
  const double ra_reference = window_[1]->right_ascension_deg;
  double ra = 0.0, dec = 0.0, distance = 0.0, equinoxes = 0.0;
  for (int i = 0; i < 4; ++i) {
    ra += w[i] * AngleDifferenceDeg(window_[i]->right_ascension_deg, ra_reference);
    dec += w[i] * window_[i]->declination_deg;
    distance += w[i] * window_[i]->distance_au;
    equinoxes += w[i] * window_[i]->equation_of_equinoxes_deg;
  }
  ra += ra_reference;

  const double sidereal_deg = spa::GreenwichMeanSiderealTimeDeg(jd_ut1) + equinoxes;
  SunPosition position =
      spa::Topocentric(site_terms_, spa::WrapDegrees360(ra), dec, distance, sidereal_deg, options_.sun);
  position.delta_t_s = delta_t_s;
  return position;
}

void SunTrack::Series(UtcTime start, Nanoseconds step, std::span<SunPosition> out) {
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = At(start + step * static_cast<std::int64_t>(i));
}

std::vector<SunPosition> SunTrack::Series(UtcTime start, Nanoseconds step, std::size_t count) {
  std::vector<SunPosition> out(count);
  Series(start, step, std::span<SunPosition>(out));
  return out;
}

}  // namespace relume
