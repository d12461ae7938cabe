// Sun position throughput: one SPA call per instant against the time-series path (SunTrack),
// and the ERFA reference for scale. Run: build/core/sun_benchmark
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>

#include "core/sun/erfa_sun_reference.h"
#include "core/sun/sun_position.h"
#include "core/sun/sun_track.h"

namespace relume {
namespace {

const Site kSite = Site::FromDegrees(37.9715, 23.7267, 156);
const UtcTime kStart = ParseIso8601("2024-06-21T00:00:00Z").utc;

// Per-call SPA over a day at 1 s steps.
void BM_SpaPerCall(benchmark::State& state) {
  SunOptions options;
  options.delta_t_s = 69.2;
  std::int64_t i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(ComputeSunPosition(kSite, kStart + std::chrono::seconds(i % 86400), options));
    ++i;
  }
  state.SetItemsProcessed(state.iterations());
  state.SetLabel("positions/s = items_per_second");
}
BENCHMARK(BM_SpaPerCall);

// The time-series path over the same day at 1 s steps; arg = node spacing in hours.
void BM_SunTrackDaySeries(benchmark::State& state) {
  SunTrackOptions options;
  options.sun.delta_t_s = 69.2;
  options.node_spacing_hours = static_cast<double>(state.range(0));
  std::vector<SunPosition> out(86400);
  for (auto _ : state) {
    SunTrack track(kSite, options);  // a fresh track: node evaluations are included
    track.Series(kStart, std::chrono::seconds(1), std::span<SunPosition>(out));
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * 86400);
  // Error against per-call SPA (every 60th instant), beside the speed.
  double max_error_deg = 0.0;
  for (std::size_t i = 0; i < out.size(); i += 60) {
    const SunPosition exact = ComputeSunPosition(kSite, kStart + std::chrono::seconds(i), options.sun);
    max_error_deg =
        std::max({max_error_deg, std::abs(RadToDeg(out[i].elevation_rad - exact.elevation_rad)),
                  std::abs(RadToDeg(out[i].azimuth_rad - exact.azimuth_rad)) * std::cos(exact.elevation_rad)});
  }
  state.counters["max_err_deg"] = max_error_deg;
}
BENCHMARK(BM_SunTrackDaySeries)->Arg(1)->Arg(6)->Arg(24)->Arg(48)->Unit(benchmark::kMillisecond);

void BM_ErfaReference(benchmark::State& state) {
  JulianDate jd = JulianDateFromUtc(kStart);
  for (auto _ : state) {
    benchmark::DoNotOptimize(testing::ErfaTopocentricSun(kSite, jd, 69.2));
    jd.fraction += 1.0 / 86400.0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ErfaReference);

}  // namespace
}  // namespace relume

BENCHMARK_MAIN();
