#include "processing/radiosity/reflectance.h"

#include <gtest/gtest.h>

#include <cstdio>

#include "processing/radiosity/test_room.h"

namespace relume::radiosity {
namespace {

TEST(ReflectanceRoomTest, Probe) {
  testing::TestRoom room = testing::MakeTestRoom(6);
  HierarchyOptions ho;
  ho.max_patch_edge_m = 0.6;
  PatchHierarchy h(room.mesh, ho);
  RayCaster caster(room.mesh);
  auto photos = testing::RenderPhotographs(room, h, caster);
  ReflectanceOptions options;
  options.max_iterations = 3;
  {
    RadiosityOptions ro;
    RadiositySolver sv(h, caster, ro);
    auto alb = h.LeafAlbedo();
    DirectLight d = ComputeDirectLight(h, caster, photos[0].lighting, options.direct);
    RadiositySolution sol;
    auto sm = sv.Solve(alb, d.irradiance, h.LeafEmission(), &sol);
    double e = 0;
    int c = 0;
    for (int p = 0; p < h.LeafCount(); ++p) {
      if (!photos[0].radiance[p].allFinite()) continue;
      Rgb est = M_PI * photos[0].radiance[p];
      Rgb mine = alb[p].cwiseProduct(d.irradiance[p] + sol.indirect_irradiance[p]);
      e += ((mine - est).cwiseAbs().array() / est.array().max(1e-9)).mean();
      ++c;
      if (p % 200 == 0)
        std::printf("p %d est %.4f mine %.4f E %.4f I %.4f\n", p, est[0], mine[0], d.irradiance[p][0],
                    sol.indirect_irradiance[p][0]);
    }
    std::printf("consistency rel err %.4f %s\n", e / c, sm.BriefReport().c_str());
  }
  ReflectanceResult r = EstimateReflectance(h, caster, photos, options);
  std::printf("patches %d iterations %d converged %d reason %s time %.2f\n", h.LeafCount(), r.iterations, r.converged,
              r.reason.c_str(), r.time_s);
  for (size_t i = 0; i < r.max_change.size(); ++i)
    std::printf(" it %zu max %.4f mean %.5f\n", i, r.max_change[i], r.mean_change[i]);
  auto before = testing::CompareAlbedo(h, r.initial_albedo, r.estimated);
  auto after = testing::CompareAlbedo(h, r.albedo, r.estimated);
  for (size_t m = 0; m < before.size(); ++m)
    std::printf("mat %zu n %d before err %.4f spread %.4f after err %.4f spread %.4f range %.4f\n", m,
                before[m].patches, before[m].mean_abs_error, before[m].spread, after[m].mean_abs_error, after[m].spread,
                after[m].range);
  std::printf("%s\n", r.last_solves[0].BriefReport().c_str());
}

}  // namespace
}  // namespace relume::radiosity
