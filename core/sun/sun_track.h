// The sun's position along a time series, far faster than one SPA evaluation per instant.
//
// Everything that depends only on TT (the Earth's orbit, nutation, aberration: the sun's
// geocentric apparent right ascension and declination, its distance, the equation of the
// equinoxes) changes slowly. SunTrack evaluates those with the full SPA at "nodes" spaced
// node_spacing_hours apart in TT, and interpolates them at each instant with a cubic through
// the four nearest nodes. What changes fast (sidereal time, hence hour angle, and the
// topocentric/refraction/azimuth step) is computed exactly at every instant.
//
// The interpolation error is below 1e-7 deg at the default 6 h spacing (measured in
// sun_track_test.cc against per-call SPA), far below the SPA's own 0.0003 deg. Nodes are
// cached, so instants may come in any order; sequential series reuse the same four nodes.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/site.h"
#include "core/sun/spa.h"
#include "core/sun/sun_position.h"
#include "core/time.h"

namespace relume {

struct SunTrackOptions {
  SunOptions sun;
  // Spacing of the exact SPA evaluations in hours of TT: the speed/accuracy knob.
  double node_spacing_hours = 6.0;
  bool IsValid(std::string* why) const;
};

class SunTrack {
 public:
  // Throws InvalidArgumentError for an invalid site or options.
  explicit SunTrack(const Site& site, const SunTrackOptions& options = {});

  SunPosition At(UtcTime time);
  // Positions at start, start + step, ..., written to `out` (one per element).
  void Series(UtcTime start, Nanoseconds step, std::span<SunPosition> out);
  std::vector<SunPosition> Series(UtcTime start, Nanoseconds step, std::size_t count);

  const Site& site() const { return site_; }
  // Exact SPA evaluations so far (for tests and benchmarks).
  std::int64_t nodes_evaluated() const { return nodes_evaluated_; }

 private:
  struct Node {
    double right_ascension_deg;
    double declination_deg;
    double distance_au;
    double equation_of_equinoxes_deg;
  };
  const Node& NodeAt(std::int64_t index);

  Site site_;
  SunTrackOptions options_;
  spa::SiteTerms site_terms_;
  double spacing_days_;
  std::unordered_map<std::int64_t, Node> nodes_;
  std::int64_t window_index_ = INT64_MIN;  // first node of the cached four
  const Node* window_[4] = {nullptr, nullptr, nullptr, nullptr};
  std::int64_t nodes_evaluated_ = 0;
};

}  // namespace relume
