// `irm`: IRM relighting (processing/irm/relight.h) on the analytic outdoor scene with an
// occluded sky, across bins per map, sun-disk samples (penumbra) and sky samples. Error:
// relative RMS of the relit source against its truth under the target light over all relit
// pixels (headline), and per lit / shadow / penumbra region (notes). Time: one relight, all
// three stages (per-vertex rays, IRM build, per-pixel relight), 2 threads.
#include "apps/relume/bench/irm.h"

#include <cmath>

#include "apps/relume/bench/bench.h"

namespace relume::app::bench {

namespace it = irm::testing;

IrmScene::IrmScene(int width, int height, const it::Light& source_light_in, const it::Light& target_light_in,
                   int render_sky_samples, bool with_neighbour)
    : source_light(source_light_in), target_light(target_light_in) {
  if (with_neighbour) {
    mesh = it::OutdoorScene(16).mesh;
  } else {
    mesh.Append(MakeQuad({-30, -30, 0}, {60, 0, 0}, {0, 60, 0}, 20));
    mesh.Append(MakeBox({-6, -3, 0}, {6, 3, 8}, 8));
    mesh.albedo.assign(mesh.vertex_count(), Eigen::Vector3f(0.4f, 0.4f, 0.4f));
  }
  caster = std::make_unique<RayCaster>(mesh);
  const PinholeIntrinsics k = PinholeIntrinsics::FromHorizontalFov(width, height, 1.1);
  if (with_neighbour) {
    source_camera = PinholeCamera::LookAt(k, {-14, -30, 10}, {2, 0, 5});
    target_camera = PinholeCamera::LookAt(k, {10, -32, 12}, {0, 0, 4});
  } else {  // from the south, low enough not to see the ground behind the building
    source_camera = target_camera = PinholeCamera::LookAt(k, {0, -30, 6}, {0, 0, 4});
  }
  const int n = render_sky_samples;
  source = it::Render(*caster, source_camera, source_light, &truth_source_sun, 32, n);
  target = it::Render(*caster, target_camera, target_light, nullptr, 32, n);
  truth = it::Render(*caster, source_camera, target_light, &truth_target_sun, 32, n);
}

std::string Describe(const metrics::SunRegionErrors& e) {
  return "lit " + Format(e.lit) + " (" + std::to_string(e.lit_pixels) + " px), shadow " + Format(e.shadow) + " (" +
         std::to_string(e.shadow_pixels) + " px), penumbra " + Format(e.penumbra) + " (" +
         std::to_string(e.penumbra_pixels) + " px), scale " + Format(e.scale);
}

metrics::SunRegionErrors CompareRelit(const IrmScene& s, const irm::RelightResult& result) {
  cv::Mat use;
  cv::compare(result.status, cv::Scalar(irm::kRelit), use, cv::CMP_EQ);
  return metrics::CompareSunRegions(result.relit.pixels, s.truth.pixels, s.truth_source_sun, s.truth_target_sun, use,
                                    metrics::Scale::kFitted);
}

void BenchIrm(bool quick, std::vector<Row>& rows) {
  const int width = quick ? 200 : 400, height = quick ? 140 : 280;
  // Morning sun from the east (the neighbour shadows the building), afternoon from the south-west.
  const IrmScene s(width, height, {it::SunFromAzimuthElevationDeg(95, 25), {900, 850, 780}, {28, 33, 45}},
                   {it::SunFromAzimuthElevationDeg(230, 50), {1000, 980, 950}, {20, 26, 40}}, quick ? 144 : 400);
  struct Knobs {
    int bins, sun_samples, sky_samples;
    bool model_correction = true;  // off: a bin's ratio as measured, so the bin count shows
  };
  const std::vector<Knobs> settings =
      quick ? std::vector<Knobs>{{32, 16, 144}, {16, 16, 144}, {32, 4, 144}, {32, 16, 0}, {32, 16, 144, false}}
            : std::vector<Knobs>{{32, 16, 144}, {16, 16, 144},        {24, 16, 144},        {64, 16, 144},
                                 {32, 4, 144},  {32, 64, 144},        {32, 16, 0},          {32, 16, 36},
                                 {32, 16, 400}, {16, 16, 144, false}, {32, 16, 144, false}, {64, 16, 144, false}};
  const double mp = width * height / 1e6;
  for (const Knobs& k : settings) {
    irm::RelightOptions options;
    options.irm.bins = k.bins;
    options.sun_samples = k.sun_samples;
    options.sky_samples = k.sky_samples;
    options.irm.model_correction = k.model_correction;
    irm::RelightResult result;
    const double seconds = BestSeconds(
        quick ? 1 : 2, [&] { result = irm::RelightImage(*s.caster, s.SourceView(), s.TargetView(), options); });
    const metrics::SunRegionErrors e = CompareRelit(s, result);
    rows.push_back(
        {"irm", "IRM relight (sun + sky model)",
         std::to_string(k.bins) + " bins, " + std::to_string(k.sun_samples) + " sun-disk samples, " +
             std::to_string(k.sky_samples) + " sky samples, " + (k.model_correction ? "" : "no model correction, ") +
             std::to_string(width) + "x" + std::to_string(height),
         seconds, mp / seconds, "MP/s", e.all, "relit relative RMS, all relit pixels",
         Describe(e) + (result.irms.single_map ? ", one IRM" : ", four IRMs") +
             (result.irms.vertex_indirect_source.empty() ? ", indirect light not used" : ", indirect light used") +
             " (" + std::to_string(result.summary.indirect_s).substr(0, 5) + " s)"});
  }
}

}  // namespace relume::app::bench
