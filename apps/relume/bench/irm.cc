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

std::string IrmErrors::Describe() const {
  return "lit " + Format(lit) + " (" + std::to_string(n_lit) + " px), shadow " + Format(shadow) + " (" +
         std::to_string(n_shadow) + " px), penumbra " + Format(penumbra) + " (" + std::to_string(n_penumbra) + " px)";
}

IrmErrors CompareRelit(const IrmScene& s, const irm::RelightResult& result) {
  IrmErrors e;
  for (int y = 0; y < result.status.rows; ++y) {
    for (int x = 0; x < result.status.cols; ++x) {
      if (result.status.at<std::uint8_t>(y, x) != irm::kRelit) continue;
      const cv::Vec3f r = result.relit.pixels.at<cv::Vec3f>(y, x);
      const cv::Vec3f t = s.truth.pixels.at<cv::Vec3f>(y, x);
      double e2 = 0.0;
      for (int c = 0; c < 3; ++c) e2 += std::pow((r[c] - t[c]) / t[c], 2) / 3;
      const float fs = s.truth_source_sun.at<float>(y, x), ft = s.truth_target_sun.at<float>(y, x);
      const bool pure_s = !(fs > 0.0f && fs < 1.0f), pure_t = !(ft > 0.0f && ft < 1.0f);  // NaN: attached shadow
      e.all += e2;
      ++e.n_all;
      if (!pure_s || !pure_t) {
        e.penumbra += e2;
        ++e.n_penumbra;
      } else if (fs >= 1.0f && ft >= 1.0f) {
        e.lit += e2;
        ++e.n_lit;
      } else {
        e.shadow += e2;
        ++e.n_shadow;
      }
    }
  }
  auto rms = [](double sum, int n) { return n ? std::sqrt(sum / n) : 0.0; };
  e.all = rms(e.all, e.n_all);
  e.lit = rms(e.lit, e.n_lit);
  e.shadow = rms(e.shadow, e.n_shadow);
  e.penumbra = rms(e.penumbra, e.n_penumbra);
  return e;
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
    const IrmErrors e = CompareRelit(s, result);
    rows.push_back({"irm", "IRM relight (sun + sky model)",
                    std::to_string(k.bins) + " bins, " + std::to_string(k.sun_samples) + " sun-disk samples, " +
                        std::to_string(k.sky_samples) + " sky samples, " +
                        (k.model_correction ? "" : "no model correction, ") + std::to_string(width) + "x" +
                        std::to_string(height),
                    seconds, mp / seconds, "MP/s", e.all, "relit relative RMS, all relit pixels",
                    e.Describe() + (result.irms.single_map ? ", one IRM" : ", four IRMs")});
  }
}

}  // namespace relume::app::bench
